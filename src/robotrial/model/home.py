"""The `home` section of a world: the floor plan a household drew in the page's home
editor (rooms as closed outlines, doorways on their walls, furniture and objects), kept
next to the walls and bodies built from it (docs/worlds.md, "Homes").

Layer 1: plain geometry on the parsed YAML. The world loader calls `check_home` so a
home sent to the server, or run headless, is refused with the item named when its
doorway is off every wall, narrower than the wall is thick, or its furniture overlaps.
`world_yaml` writes the World YAML of a home as the editor does (web/src/home/model.ts),
for homes made in Python (`robotrial.model.homegen`).
"""

from __future__ import annotations

import math
from typing import Any

from robotrial.model.checked import floats, number
from robotrial.model.robot import ModelError

DOOR_TOLERANCE = 0.01
"""How far (m) beyond half the wall thickness a doorway's centre may sit from a wall."""
MAX_HOME_ITEMS = {"rooms": 50, "doorways": 100, "furniture": 300}
"""The most entries of each list of a home (docs/worlds.md, "Limits")."""
MAX_CORNERS = 64
"""The most corners of one room."""


def _point(value: Any, what: str) -> tuple[float, float]:
    x, y = floats(value, 2, what)
    return x, y


def _number(value: Any, what: str) -> float:
    return number(value, what, above=0)


def _home_list(home: dict, group: str) -> list[dict]:
    """The list `group` of a home, each entry a mapping, at most MAX_HOME_ITEMS long."""
    items = home.get(group) or []
    if not isinstance(items, list):
        raise ModelError(f"home.{group}: expected a list, got {type(items).__name__}")
    if len(items) > MAX_HOME_ITEMS[group]:
        raise ModelError(
            f"home.{group}: {len(items)} entries; a home holds at most {MAX_HOME_ITEMS[group]}"
        )
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            raise ModelError(f"home.{group}[{i}]: expected a mapping, got {type(item).__name__}")
    return items


def _label(items: Any, i: int, group: str) -> str:
    name = items[i].get("name") if isinstance(items[i], dict) else None
    return f"home.{group}[{i}]" + (f" ({name})" if name else "")


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _segments_cross(
    a: tuple[float, float], b: tuple[float, float], c: tuple[float, float], d: tuple[float, float]
) -> bool:
    """True when segments ab and cd cross at a point inside both."""
    d1, d2 = _cross(c, d, a), _cross(c, d, b)
    d3, d4 = _cross(a, b, c), _cross(a, b, d)
    return d1 * d2 < 0 and d3 * d4 < 0


def _distance_to_segment(
    p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> float:
    ax, ay = b[0] - a[0], b[1] - a[1]
    length2 = ax * ax + ay * ay
    t = (
        0.0
        if length2 == 0
        else max(0.0, min(1.0, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / length2))
    )
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


def room_edges(home: dict) -> list[tuple[str, tuple[float, float], tuple[float, float]]]:
    """Every wall edge of every room: (label, start, end)."""
    edges = []
    for i, room in enumerate(home.get("rooms") or []):
        corners = [_point(c, f"home.rooms[{i}].corners") for c in room.get("corners", [])]
        label = _label(home["rooms"], i, "rooms")
        for k, start in enumerate(corners):
            edges.append((f"{label} edge {k + 1}", start, corners[(k + 1) % len(corners)]))
    return edges


def _footprint(item: dict, what: str) -> tuple[str, tuple[float, float], tuple[float, float]]:
    """('box', centre, (width, depth)) or ('cylinder', centre, (diameter, diameter))."""
    centre = _point(item.get("at"), f"{what}.at")
    shape = item.get("shape", "box")
    if shape not in ("box", "cylinder"):
        raise ModelError(f"{what}.shape: expected box or cylinder, got {shape!r}")
    size = item.get("size")
    if not isinstance(size, list | tuple) or len(size) != 2:
        raise ModelError(f"{what}.size: expected [width, depth] in metres, got {size!r}")
    w = _number(size[0], f"{what}.size[0]")
    d = _number(size[1], f"{what}.size[1]")
    _number(item.get("height"), f"{what}.height")
    return shape, centre, (w, d)


def _overlap(a: tuple, b: tuple) -> bool:
    """Whether two footprints overlap by more than 1 mm (touching is allowed)."""
    (sa, ca, za), (sb, cb, zb) = a, b
    eps = 1e-3
    if sa == "cylinder" and sb == "cylinder":
        return math.hypot(ca[0] - cb[0], ca[1] - cb[1]) < (za[0] + zb[0]) / 2 - eps
    if sa == "cylinder" or sb == "cylinder":
        (circle, box) = (a, b) if sa == "cylinder" else (b, a)
        r = circle[2][0] / 2
        hx, hy = box[2][0] / 2, box[2][1] / 2
        dx = max(abs(circle[1][0] - box[1][0]) - hx, 0.0)
        dy = max(abs(circle[1][1] - box[1][1]) - hy, 0.0)
        return math.hypot(dx, dy) < r - eps
    return (
        abs(ca[0] - cb[0]) < (za[0] + zb[0]) / 2 - eps
        and abs(ca[1] - cb[1]) < (za[1] + zb[1]) / 2 - eps
    )


def check_home(home: Any) -> None:
    """Refuse a home whose rooms are not closed outlines, whose doorway does not sit on a
    wall or does not fit it, or whose furniture overlaps; the message names the item."""
    if not isinstance(home, dict):
        raise ModelError(f"home: expected a mapping with rooms, got {home!r}")
    thickness = _number(home.get("thickness", 0.1), "home.thickness")
    rooms = _home_list(home, "rooms")
    if not rooms:
        raise ModelError("home.rooms: a home needs at least one room")
    for i, room in enumerate(rooms):
        label = _label(rooms, i, "rooms")
        corners = room.get("corners")
        if not isinstance(corners, list) or len(corners) < 3:
            raise ModelError(f"{label}: not closed; a room needs at least 3 corners")
        if len(corners) > MAX_CORNERS:
            raise ModelError(f"{label}: {len(corners)} corners; a room has at most {MAX_CORNERS}")
        pts = [_point(c, f"{label}.corners[{k}]") for k, c in enumerate(corners)]
        n = len(pts)
        for k in range(n):
            if pts[k] == pts[(k + 1) % n]:
                raise ModelError(f"{label}: edge {k + 1} has zero length")
        for k in range(n):
            for m in range(k + 2, n):
                if k == 0 and m == n - 1:
                    continue
                if _segments_cross(pts[k], pts[(k + 1) % n], pts[m], pts[(m + 1) % n]):
                    raise ModelError(f"{label}: edges {k + 1} and {m + 1} cross")
    edges = room_edges(home)
    doorways = _home_list(home, "doorways")
    for i, door in enumerate(doorways):
        label = _label(doorways, i, "doorways")
        at = _point(door.get("at"), f"{label}.at")
        width = _number(door.get("width"), f"{label}.width")
        gap, edge, a, b = min(
            ((_distance_to_segment(at, a, b), name, a, b) for name, a, b in edges),
            key=lambda e: e[0],
        )
        if gap > thickness / 2 + DOOR_TOLERANCE:
            raise ModelError(
                f"{label}: does not sit on a wall; the nearest wall ({edge}) is {gap:.2f} m away"
            )
        if width < thickness:
            raise ModelError(
                f"{label}: {width:.2f} m wide is narrower than the wall is thick "
                f"({thickness:.2f} m)"
            )
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        if width > length:
            raise ModelError(
                f"{label}: {width:.2f} m wide is wider than its wall ({edge}, {length:.2f} m)"
            )
    furniture = _home_list(home, "furniture")
    prints = [_footprint(f, _label(furniture, i, "furniture")) for i, f in enumerate(furniture)]
    for i in range(len(prints)):
        for j in range(i):
            if _overlap(prints[i], prints[j]):
                first, second = _label(furniture, i, "furniture"), _label(furniture, j, "furniture")
                raise ModelError(f"{first} overlaps {second}")


# --- what a home becomes: the World YAML the page's home editor writes ---------------

OBJECT_MASS = 0.2
"""kg of an object of a home (a small movable box), as the editor writes it."""
PLACE_INSET = 0.12
"""How far in from a table's edge (m) a chore sets things down."""


def body_name(text: str) -> str:
    """A body name for the world file: "Round table" -> "round_table"."""
    import re

    return re.sub(r"^_+|_+$", "", re.sub(r"[^a-z0-9]+", "_", text.lower())) or "item"


def _round(v: float) -> float:
    return round(v * 1000) / 1000


def home_walls(home: dict) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The walls (from, to): every room edge, edges on one line merged (a shared wall is
    one wall), stretched by half the thickness at their ends (closed corners), doorways
    cut out."""
    lines: dict[tuple, dict] = {}
    for _, a, b in room_edges(home):
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        if length == 0:
            continue
        u = ((b[0] - a[0]) / length, (b[1] - a[1]) / length)
        if u[0] < -1e-9 or (abs(u[0]) <= 1e-9 and u[1] < 0):
            u = (-u[0], -u[1])
        n = (-u[1], u[0])
        c = n[0] * a[0] + n[1] * a[1]
        key = (f"{u[0]:.5f}", f"{u[1]:.5f}", f"{c:.4f}")
        line = lines.setdefault(key, {"u": u, "n": n, "c": c, "spans": []})
        s0, s1 = u[0] * a[0] + u[1] * a[1], u[0] * b[0] + u[1] * b[1]
        line["spans"].append([min(s0, s1), max(s0, s1)])
    half = float(home.get("thickness", 0.1)) / 2
    out = []
    for line in lines.values():
        merged: list[list[float]] = []
        for s0, s1 in sorted(line["spans"]):
            if merged and s0 <= merged[-1][1] + 1e-6:
                merged[-1][1] = max(merged[-1][1], s1)
            else:
                merged.append([s0, s1])
        pieces = [(s0 - half, s1 + half) for s0, s1 in merged]
        u, n, c = line["u"], line["n"], line["c"]
        for door in home.get("doorways") or []:
            at, width = door["at"], float(door["width"])
            if abs(n[0] * at[0] + n[1] * at[1] - c) > half + DOOR_TOLERANCE:
                continue
            s = u[0] * at[0] + u[1] * at[1]
            cut = (s - width / 2, s + width / 2)
            kept = []
            for p0, p1 in pieces:
                if cut[1] <= p0 or cut[0] >= p1 or s < p0 or s > p1:
                    kept.append((p0, p1))
                    continue
                if cut[0] - p0 > 1e-6:
                    kept.append((p0, cut[0]))
                if p1 - cut[1] > 1e-6:
                    kept.append((cut[1], p1))
            pieces = kept
        for s0, s1 in pieces:
            at = [(_round(c * n[0] + s * u[0]), _round(c * n[1] + s * u[1])) for s in (s0, s1)]
            out.append((at[0], at[1]))
    return out


def _number_text(v: float) -> str:
    """Millimetres, as the editor prints them: 1, 0.5, 2.25."""
    r = _round(float(v))
    return str(int(r)) if r.is_integer() else repr(r)


def _bounds(points) -> tuple[tuple[float, float], tuple[float, float]]:
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return (min(xs), min(ys)), (max(xs), max(ys))


def _under(home: dict, p) -> dict | None:
    """The furniture an object at `p` lies on, if any."""
    for f in home.get("furniture") or []:
        (fx, fy), (w, d) = f["at"], f["size"]
        if f.get("shape", "box") == "cylinder":
            if math.hypot(p[0] - fx, p[1] - fy) <= w / 2:
                return f
        elif abs(p[0] - fx) <= w / 2 and abs(p[1] - fy) <= d / 2:
            return f
    return None


def place_in(home: dict, room: dict) -> tuple[str, tuple[float, float]] | None:
    """Where a chore sets things down in a room: on the piece of furniture at table
    height (0.4-1.0 m) with the largest top among those standing in the room,
    PLACE_INSET in from its edge nearest the room's middle; None when there is none."""
    (x0, y0), (x1, y1) = _bounds(room["corners"])
    tables = [
        f
        for f in home.get("furniture") or []
        if x0 <= f["at"][0] <= x1 and y0 <= f["at"][1] <= y1 and 0.4 <= f["height"] <= 1.0
    ]
    if not tables:
        return None
    f = max(tables, key=lambda t: t["size"][0] * t["size"][1])
    mx, my = (x0 + x1) / 2, (y0 + y1) / 2
    fx, fy = f["at"]
    if f.get("shape", "box") == "cylinder":
        d = math.hypot(mx - fx, my - fy)
        r = min(d, max(0.0, f["size"][0] / 2 - PLACE_INSET))
        at = (fx + (mx - fx) * r / d, fy + (my - fy) * r / d) if d > 0 else (fx, fy)
    else:

        def clamp(v: float, c: float, half: float) -> float:
            room_ = max(0.0, half - PLACE_INSET)
            return min(c + room_, max(c - room_, v))

        at = (clamp(mx, fx, f["size"][0] / 2), clamp(my, fy, f["size"][1] / 2))
    return body_name(f["name"]), at


def world_yaml(home: dict, name: str = "my_home") -> str:
    """The World YAML of a home (docs/worlds.md), with the plan itself as `home:`, as the
    page's home editor writes it. Call it on a home that `check_home` accepts."""
    import json

    num = _number_text
    xy = lambda p: f"[{num(p[0])}, {num(p[1])}]"  # noqa: E731
    text = json.dumps
    rooms = home["rooms"]
    (lx, ly), (hx, hy) = _bounds([c for r in rooms for c in r["corners"]])
    t = float(home.get("thickness", 0.1))
    plural = "" if len(rooms) == 1 else "s"
    lines = [
        "# A home drawn in the robotrial page (docs/web.md, My home).",
        f"name: {text(name)}",
        f"description: {text(f'A home with {len(rooms)} room{plural}')}",
        f"floor: {{size: {xy((hx - lx + 2, hy - ly + 2))}, "
        f"center: {xy(((lx + hx) / 2, (ly + hy) / 2))}}}",
        f"interior: [{xy((lx + t / 2, ly + t / 2))}, {xy((hx - t / 2, hy - t / 2))}]",
        f"wall_defaults: {{thickness: {num(t)}, height: {num(home.get('height', 2.0))}}}",
        "walls:",
    ]
    for i, (a, b) in enumerate(home_walls(home)):
        lines.append(f"  - {{name: wall{i + 1}, from: {xy(a)}, to: {xy(b)}}}")
    furniture = home.get("furniture") or []
    lines.append("obstacles:" if furniture else "obstacles: []")
    for f in furniture:
        pose = f"pose: {{xyz: [{num(f['at'][0])}, {num(f['at'][1])}, {num(f['height'] / 2)}]}}"
        if f.get("shape", "box") == "box":
            shape = (
                f"shape: box, size: [{num(f['size'][0])}, {num(f['size'][1])}, {num(f['height'])}]"
            )
        else:
            shape = f"shape: cylinder, radius: {num(f['size'][0] / 2)}, length: {num(f['height'])}"
        lines.append(
            f"  - {{name: {text(body_name(f['name']))}, kind: furniture, {shape}, {pose}}}"
        )
    objects = home.get("objects") or []
    lines.append("objects:" if objects else "objects: []")
    for o in objects:
        below = _under(home, o["at"])
        base = below["height"] if below else 0.0
        s = num(o["size"])
        pose = f"pose: {{xyz: [{num(o['at'][0])}, {num(o['at'][1])}, {num(base + o['size'] / 2)}]}}"
        lines.append(
            f"  - {{name: {text(body_name(o['name']))}, shape: box, size: [{s}, {s}, {s}], "
            f"mass: {OBJECT_MASS}, {pose}}}"
        )
    spawn = home.get("spawn")
    if spawn is None:
        (rx0, ry0), (rx1, ry1) = _bounds(rooms[0]["corners"])
        spawn = (_round((rx0 + rx1) / 2), _round((ry0 + ry1) / 2))
    lines += ["spawns:", f"  default: [{num(spawn[0])}, {num(spawn[1])}, 0.0]", "rooms:"]
    for room in rooms:
        lo, hi = _bounds(room["corners"])
        place = place_in(home, room)
        where = f", place: {{surface: {text(place[0])}, xy: {xy(place[1])}}}" if place else ""
        lines.append(f"  - {{name: {text(room['name'])}, min: {xy(lo)}, max: {xy(hi)}{where}}}")
    lines += [f"home: {json.dumps(home, separators=(',', ':'))}", ""]
    return "\n".join(lines)
