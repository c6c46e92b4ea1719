"""Random homes: floor plans of 2-6 rooms joined by doorways, with furniture along the
walls, for trying navigation, exploration and chores in homes nobody tuned to (layer 1).

    from robotrial.model.homegen import generate_home, home_plan
    world = generate_home(7)              # a World with its `home` section
    world = generate_home(7, rooms=4)     # four rooms
    plan = home_plan(7)                   # the `home` section alone (the editor's format)

The same seed gives the same home. A home is a rectangle (about 9-18 m2 a room, wider
than deep) cut into rooms: each cut splits the largest room across its longer side,
leaving no room narrower than `HomeSpec.min_side`. Rooms that share a stretch of wall
are neighbours; a random spanning tree of neighbours gets doorways (every room is
reached), and each other pair one with probability `extra_door`. A doorway is 0.8-1.0 m
wide (5 cm steps, as the editor snaps), at least `door_margin` from the ends of the
shared stretch. Furniture (the editor's presets: tables, counters, shelves, beds, sofas,
round tables) stands along the walls, 3-10 cm off them, never in front of a doorway
(`door_clear` m deep), never closer than `furniture_gap` to another piece, and never on
the middle of the first room, where the robot starts. Objects (cups, books, cans) lie on
some of the tables. With `HomeSpec.extras`, last and from a random stream of their own
(the rest of the home stays the one drawn without them): a side table in each room with
no top at table height, and a jar on a top of each room (docs/worlds.md says why). The
World YAML is written as the page's home editor writes it
(`robotrial.model.home.world_yaml`), so a generated home opens in the editor and runs
everywhere a drawn one does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robotrial.model.home import check_home, place_in, world_yaml
from robotrial.model.world import World, load_world_text

# name, width along the wall, depth, height (m); "round table" is a cylinder
FURNITURE = (
    ("table", 1.2, 0.8, 0.75),
    ("counter", 2.0, 0.6, 0.9),
    ("shelf", 0.8, 0.35, 1.8),
    ("bed", 2.0, 1.6, 0.5),
    ("sofa", 2.0, 0.9, 0.8),
    ("round table", 1.0, 1.0, 0.75),
)
OBJECTS = (("cup", 0.08), ("book", 0.06), ("can", 0.07))
SIDE_TABLE = ("side table", 0.6, 0.45, 0.6)  # as FURNITURE
JAR = ("jar", 0.05)  # a spice jar or a small pot, as OBJECTS
OBJECT_GAP = 0.15  # m an added object keeps from every other object and its room's place
EXTRAS_STREAM = 1  # the extras' random stream: default_rng([seed, 35, EXTRAS_STREAM])
DOCK_WALL = 0.7  # m a dock drawn anywhere keeps from its room's walls
DOCK_CLEAR = 0.75  # m and from every piece of furniture


@dataclass(frozen=True)
class HomeSpec:
    """What a generated home may be (lengths in m): rooms between `rooms` (inclusive),
    each `room_area` m2 on average and no side under `min_side`; doorways `doorway` wide,
    at least `door_margin` from the ends of their wall, and an extra doorway between
    other neighbours with probability `extra_door`; up to `furniture_per_room` pieces a
    room, kept `furniture_gap` apart and out of `door_clear` in front of doorways; walls
    `thickness` thick and `height` high. The robot's dock (the `default` spawn) is the
    middle of the first room, kept free of furniture, or with `dock_anywhere` a free spot
    of a random room, drawn after the furniture. Each piece at table height carries an
    object with probability `object_chance`. With `extras`, drawn last from a random
    stream of their own (so the rest of the home is the one drawn without them): a side
    table in each room with no top at table height, and a jar on a top of each room (see
    `_extras`)."""

    rooms: tuple[int, int] = (2, 6)
    room_area: tuple[float, float] = (9.0, 18.0)
    min_side: float = 2.6
    doorway: tuple[float, float] = (0.8, 1.0)
    door_margin: float = 0.3
    extra_door: float = 0.25
    furniture_per_room: int = 3
    furniture_gap: float = 0.8
    door_clear: float = 1.3
    thickness: float = 0.1
    height: float = 2.0
    dock_anywhere: bool = False
    object_chance: float = 0.5
    extras: bool = False

    def __post_init__(self) -> None:
        lo, hi = self.rooms
        if not 1 <= lo <= hi:
            raise ValueError(
                f"home generator: rooms must be (low, high) with 1 <= low <= high, got {self.rooms}"
            )
        if not 0 < self.doorway[0] <= self.doorway[1]:
            raise ValueError(
                f"home generator: doorway must be (low, high) widths, got {self.doorway}"
            )
        if not self.min_side > 0:
            raise ValueError(f"home generator: min_side must be positive, got {self.min_side}")


def _snap(v: float, step: float = 0.05) -> float:
    return round(round(v / step) * step, 3)


def _split(rng: np.random.Generator, n: int, spec: HomeSpec) -> list[list[float]]:
    """`n` rectangles (x0, y0, x1, y1) that tile a home-sized rectangle."""
    for attempt in range(50):
        area = float(rng.uniform(*spec.room_area, size=n).sum()) * (1.1**attempt)
        aspect = float(rng.uniform(1.0, 1.7))
        w = max(_snap(np.sqrt(area * aspect)), spec.min_side)
        h = max(_snap(area / w), spec.min_side)
        rects = [[0.0, 0.0, w, h]]
        while len(rects) < n:
            order = sorted(range(len(rects)), key=lambda i: -_area(rects[i]))
            for i in order:
                x0, y0, x1, y1 = rects[i]
                along_x = (x1 - x0) >= (y1 - y0)
                lo, hi = (x0, x1) if along_x else (y0, y1)
                if hi - lo < 2 * spec.min_side:
                    continue
                cut = _snap(lo + (hi - lo) * float(rng.uniform(0.38, 0.62)))
                cut = min(max(cut, lo + spec.min_side), hi - spec.min_side)
                cut = _snap(cut)
                if cut - lo < spec.min_side - 1e-9 or hi - cut < spec.min_side - 1e-9:
                    continue
                if along_x:
                    rects[i : i + 1] = [[x0, y0, cut, y1], [cut, y0, x1, y1]]
                else:
                    rects[i : i + 1] = [[x0, y0, x1, cut], [x0, cut, x1, y1]]
                break
            else:
                break
        if len(rects) == n:
            return rects
    raise ValueError(f"home generator: could not cut {n} rooms")


def _area(r: list[float]) -> float:
    return (r[2] - r[0]) * (r[3] - r[1])


def _shared(a: list[float], b: list[float]) -> tuple[str, float, float, float] | None:
    """The wall stretch two rooms share: ('x', x, y_lo, y_hi) for one along y at x, or
    ('y', y, x_lo, x_hi); None if they only touch at a corner or not at all."""
    for axis, (ai, bi, lo, hi) in (("x", (2, 0, 1, 3)), ("y", (3, 1, 0, 2))):
        for first, second in ((a, b), (b, a)):
            if abs(first[ai] - second[bi]) < 1e-9:
                s0, s1 = max(first[lo], second[lo]), min(first[hi], second[hi])
                if s1 - s0 > 1e-9:
                    return axis, first[ai], s0, s1
    return None


def _doorways(rng: np.random.Generator, rects: list[list[float]], spec: HomeSpec) -> list[dict]:
    widths = np.round(np.arange(spec.doorway[0], spec.doorway[1] + 1e-9, 0.05), 3)
    pairs = []
    for i in range(len(rects)):
        for j in range(i):
            s = _shared(rects[i], rects[j])
            if s is not None and s[3] - s[2] >= widths[0] + 2 * spec.door_margin:
                pairs.append((i, j, s))
    order = rng.permutation(len(pairs))
    group = list(range(len(rects)))

    def root(k: int) -> int:
        while group[k] != k:
            k = group[k]
        return k

    doors = []
    for k in order:
        i, j, (axis, at, s0, s1) = pairs[k]
        joins = root(i) != root(j)
        if not joins and rng.random() >= spec.extra_door:
            continue
        group[root(i)] = root(j)
        room_for = s1 - s0 - 2 * spec.door_margin
        width = float(rng.choice(widths[widths <= room_for + 1e-9]))
        lo, hi = s0 + spec.door_margin + width / 2, s1 - spec.door_margin - width / 2
        centre = min(max(_snap(float(rng.uniform(lo, hi))), _snap(lo + 0.025)), _snap(hi - 0.025))
        point = [at, centre] if axis == "x" else [centre, at]
        doors.append({"name": f"Doorway {len(doors) + 1}", "at": point, "width": width})
    if len({root(k) for k in range(len(rects))}) > 1:
        raise ValueError("home generator: the rooms are not all joined")
    return doors


def _boxes_apart(a: tuple[float, ...], b: tuple[float, ...], gap: float) -> bool:
    """Whether two rectangles (x0, y0, x1, y1) keep `gap` m between them."""
    dx = max(a[0] - b[2], b[0] - a[2], 0.0)
    dy = max(a[1] - b[3], b[1] - a[3], 0.0)
    return max(dx, dy) >= gap if dx == 0 or dy == 0 else np.hypot(dx, dy) >= gap


def _furnish(
    rng: np.random.Generator, rects: list[list[float]], doors: list[dict], spec: HomeSpec
) -> tuple[list[dict], list[dict]]:
    half = spec.thickness / 2
    keep_out = _keep_out(rects, doors, spec)
    furniture: list[dict] = []
    placed: list[tuple[float, ...]] = []
    counts: dict[str, int] = {}
    for r in rects:
        wanted = int(rng.integers(0, spec.furniture_per_room + 1))
        for _ in range(12 * wanted):
            if wanted == 0:
                break
            name, width, depth, height = FURNITURE[int(rng.integers(len(FURNITURE)))]
            spot = _wall_spot(rng, r, width, depth, half)
            if spot is None or not _free(spot[2], keep_out, placed, spec.furniture_gap):
                continue
            c, size, box = spot
            counts[name] = counts.get(name, 0) + 1
            label = name if counts[name] == 1 else f"{name} {counts[name]}"
            shape = "cylinder" if name == "round table" else "box"
            furniture.append(
                {"name": label, "shape": shape, "at": list(c), "size": list(size), "height": height}
            )
            placed.append(box)
            wanted -= 1
    objects: list[dict] = []
    seen: dict[str, int] = {}
    for f in furniture:
        if not 0.4 <= f["height"] <= 1.0 or rng.random() < 1.0 - spec.object_chance:
            continue
        name, size = OBJECTS[int(rng.integers(len(OBJECTS)))]
        at = _on_top(rng, f)
        seen[name] = seen.get(name, 0) + 1
        label = name if seen[name] == 1 else f"{name} {seen[name]}"
        objects.append({"name": label, "at": at, "size": size})
    return furniture, objects


def _keep_out(rects: list[list[float]], doors: list[dict], spec: HomeSpec) -> list[tuple]:
    """Where no furniture stands: `door_clear` deep in front of each doorway (its swing and
    the way through it), and the middle of the first room when the robot starts there."""
    keep_out = []
    for d in doors:
        (x, y), w = d["at"], d["width"]
        reach = w / 2 + 0.35
        on_x = any(abs(x - r[0]) < 1e-9 or abs(x - r[2]) < 1e-9 for r in rects) and not any(
            abs(y - r[1]) < 1e-9 or abs(y - r[3]) < 1e-9 for r in rects
        )
        if on_x:  # a wall along y
            keep_out.append((x - spec.door_clear, y - reach, x + spec.door_clear, y + reach))
        else:
            keep_out.append((x - reach, y - spec.door_clear, x + reach, y + spec.door_clear))
    x0, y0, x1, y1 = rects[0]
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    if not spec.dock_anywhere:
        keep_out.append((cx - 0.9, cy - 0.7, cx + 0.9, cy + 0.7))  # where the robot starts
    return keep_out


def _wall_spot(
    rng: np.random.Generator, r: list[float], width: float, depth: float, half: float
) -> tuple[tuple[float, float], tuple[float, float], tuple[float, ...]] | None:
    """A random spot for a piece `width` along a wall of room `r` and `depth` deep, 3-10 cm
    off the wall: (centre, footprint size, box), or None when it does not fit that wall
    (longer than the wall, or deeper than 35 % of the room across)."""
    side = int(rng.integers(4))  # south, east, north, west
    along = (r[2] - r[0]) if side in (0, 2) else (r[3] - r[1])
    across = (r[3] - r[1]) if side in (0, 2) else (r[2] - r[0])
    if width > along - 0.2 or depth > 0.35 * across:
        return None
    off = half + float(rng.uniform(0.03, 0.10))
    s = float(rng.uniform(half + 0.05 + width / 2, along - half - 0.05 - width / 2))
    if side == 0:
        c, size = (r[0] + s, r[1] + off + depth / 2), (width, depth)
    elif side == 2:
        c, size = (r[0] + s, r[3] - off - depth / 2), (width, depth)
    elif side == 1:
        c, size = (r[2] - off - depth / 2, r[1] + s), (depth, width)
    else:
        c, size = (r[0] + off + depth / 2, r[1] + s), (depth, width)
    c = (_snap(c[0], 0.01), _snap(c[1], 0.01))
    box = (c[0] - size[0] / 2, c[1] - size[1] / 2, c[0] + size[0] / 2, c[1] + size[1] / 2)
    return c, size, box


def _free(box: tuple[float, ...], keep_out: list[tuple], placed: list[tuple], gap: float) -> bool:
    """Whether a piece's `box` stays out of every keep-out area and `gap` m from every
    placed piece."""
    if not all(_boxes_apart(box, k, 0.0) and not _overlaps(box, k) for k in keep_out):
        return False
    return all(_boxes_apart(box, p, gap) for p in placed)


def _on_top(rng: np.random.Generator, f: dict) -> list[float]:
    """A random spot on furniture `f`'s top, 0.15 m or more in from its edges."""
    inset = np.array(f["size"]) / 2 - 0.15
    at = np.array(f["at"]) + rng.uniform(-1, 1, 2) * np.maximum(inset, 0.0) * (
        0.7 if f["shape"] == "cylinder" else 1.0
    )
    return [_snap(at[0], 0.01), _snap(at[1], 0.01)]


def _dock(
    rng: np.random.Generator, rects: list[list[float]], furniture: list[dict]
) -> tuple[float, float]:
    """A free spot of a random room for the robot's dock: DOCK_WALL from the room's
    walls and DOCK_CLEAR from every piece of furniture (the first room's middle when
    none is found)."""
    boxes = []
    for f in furniture:
        (x, y), (w, d) = f["at"], f["size"]
        boxes.append((x - w / 2, y - d / 2, x + w / 2, y + d / 2))
    for _ in range(200):
        x0, y0, x1, y1 = rects[int(rng.integers(len(rects)))]
        p = (
            _snap(float(rng.uniform(x0 + DOCK_WALL, x1 - DOCK_WALL))),
            _snap(float(rng.uniform(y0 + DOCK_WALL, y1 - DOCK_WALL))),
        )
        spot = (p[0], p[1], p[0], p[1])
        if all(_boxes_apart(spot, b, DOCK_CLEAR) for b in boxes):
            return p
    x0, y0, x1, y1 = rects[0]
    return ((x0 + x1) / 2, (y0 + y1) / 2)


def _extras(
    seed: int,
    rects: list[list[float]],
    doors: list[dict],
    furniture: list[dict],
    objects: list[dict],
    spawn: tuple[float, float] | None,
    spec: HomeSpec,
) -> tuple[list[dict], list[dict]]:
    """The home's furniture and objects with the extras added after them, drawn from
    their own random stream: a side table (SIDE_TABLE) against a wall of each room with no
    top at table height, kept as the generator keeps any piece (out of the doorways'
    keep-out, `furniture_gap` from every piece, and DOCK_CLEAR from the dock when it is
    drawn anywhere); then a jar (JAR) on a random top at table height of each room,
    0.15 m or more in from the top's edges and OBJECT_GAP from every other object and
    from the room's place. A room where none fits in 50 draws gets none."""
    rng = np.random.default_rng([int(seed), 35, EXTRAS_STREAM])
    furniture, objects = list(furniture), list(objects)
    keep_out = _keep_out(rects, doors, spec)
    placed = []
    for f in furniture:
        (x, y), (w, d) = f["at"], f["size"]
        placed.append((x - w / 2, y - d / 2, x + w / 2, y + d / 2))
    dock = None if spawn is None else (spawn[0], spawn[1], spawn[0], spawn[1])

    def tops(r: list[float]) -> list[dict]:
        return [
            f
            for f in furniture
            if r[0] <= f["at"][0] <= r[2] and r[1] <= f["at"][1] <= r[3]
            if 0.4 <= f["height"] <= 1.0
        ]

    name, width, depth, height = SIDE_TABLE
    tables = 0
    for r in rects:
        if tops(r):
            continue
        for _ in range(50):
            spot = _wall_spot(rng, r, width, depth, spec.thickness / 2)
            if spot is None or not _free(spot[2], keep_out, placed, spec.furniture_gap):
                continue
            if dock is not None and not _boxes_apart(spot[2], dock, DOCK_CLEAR):
                continue
            tables += 1
            label = name if tables == 1 else f"{name} {tables}"
            furniture.append(
                {
                    "name": label,
                    "shape": "box",
                    "at": list(spot[0]),
                    "size": list(spot[1]),
                    "height": height,
                }
            )
            placed.append(spot[2])
            break
    name, size = JAR
    jars = 0
    for r in rects:
        on = tops(r)
        if not on:
            continue
        corners = [[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]]
        place = place_in({"furniture": furniture}, {"corners": corners})
        taken = [o["at"] for o in objects] + ([list(place[1])] if place else [])
        for _ in range(50):
            at = _on_top(rng, on[int(rng.integers(len(on)))])
            if all(np.hypot(at[0] - t[0], at[1] - t[1]) >= OBJECT_GAP for t in taken):
                jars += 1
                label = name if jars == 1 else f"{name} {jars}"
                objects.append({"name": label, "at": at, "size": size})
                break
    return furniture, objects


def _overlaps(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def home_plan(seed: int, rooms: int | None = None, spec: HomeSpec = HomeSpec()) -> dict:
    """The `home` section (the editor's format, docs/worlds.md) of the home `seed`, with
    `rooms` rooms (None: drawn from `spec.rooms`)."""
    rng = np.random.default_rng([int(seed), 35])
    n = int(rng.integers(spec.rooms[0], spec.rooms[1] + 1)) if rooms is None else int(rooms)
    if not 1 <= n <= 12:
        raise ValueError(f"home generator: rooms must be 1 .. 12, got {rooms}")
    rects = _split(rng, n, spec)
    doors = _doorways(rng, rects, spec)
    furniture, objects = _furnish(rng, rects, doors, spec)
    spawn = _dock(rng, rects, furniture) if spec.dock_anywhere else None
    if spec.extras:
        furniture, objects = _extras(seed, rects, doors, furniture, objects, spawn, spec)
    home = {
        "version": 1,
        "thickness": spec.thickness,
        "height": spec.height,
        "rooms": [
            {"name": f"Room {i + 1}", "corners": [[a, b], [c, b], [c, d], [a, d]]}
            for i, (a, b, c, d) in enumerate(rects)
        ],
        "doorways": doors,
        "furniture": furniture,
        "objects": objects,
        "spawn": None if spawn is None else list(spawn),
    }
    check_home(home)
    return home


def home_yaml(seed: int, rooms: int | None = None, spec: HomeSpec = HomeSpec()) -> str:
    """The World YAML of the home `seed`, as the page's home editor writes it."""
    return world_yaml(home_plan(seed, rooms, spec), name=f"home_{seed}")


def generate_home(seed: int, rooms: int | None = None, spec: HomeSpec = HomeSpec()) -> World:
    """The home `seed` (2-6 rooms unless `rooms` says, see the module docstring) as a
    World: walls, furniture, objects, rooms (with where chores set things down), the
    `default` spawn in the middle of the first room, and the plan as `home`."""
    return load_world_text(home_yaml(seed, rooms, spec), source=f"home_{seed}.yaml")
