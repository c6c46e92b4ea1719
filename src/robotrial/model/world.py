"""World: what a room IS (floor, walls, obstacles, movable objects, lights, spawn poses).

Layer 1: imports only `robotrial.geometry`, `robotrial.model.robot` and
`robotrial.model.home` (checks on a drawn floor plan). A world is read
from YAML; the format is documented in docs/worlds.md. Compiling it to MJCF, glTF or an
occupancy grid lives in other modules.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
from robotrial.model.checked import floats, mapping, number, shown, text
from robotrial.model.home import check_home
from robotrial.model.robot import ModelError

DEFAULT_RGBA = (0.75, 0.72, 0.68, 1.0)


@dataclass(frozen=True)
class Obstacle:
    """A body in the world. Static unless `mass` > 0 (then it is a movable object)."""

    name: str
    geometry: Shape
    pose: Pose = Pose()
    rgba: tuple[float, float, float, float] = DEFAULT_RGBA
    mass: float = 0.0
    kind: str = "obstacle"  # "wall", "obstacle", "furniture" or "object"


@dataclass(frozen=True)
class Light:
    name: str
    type: str = "directional"  # "directional" or "point"
    pose: Pose = Pose((0.0, 0.0, 3.0))
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    intensity: float = 1.0
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class Floor:
    """A flat floor at z = `height`, a rectangle `size` (x, y) centred at `center` (x, y)."""

    size: tuple[float, float] = (10.0, 10.0)
    center: tuple[float, float] = (0.0, 0.0)
    height: float = 0.0
    rgba: tuple[float, float, float, float] = (0.85, 0.85, 0.82, 1.0)
    friction: float = 1.0


@dataclass(frozen=True)
class Room:
    """A named rectangle of the floor plan ((xmin, ymin), (xmax, ymax)) and, when things
    may be set down there, a place: the point (x, y) on top of the furniture `place_on`."""

    name: str
    bounds: tuple[tuple[float, float], tuple[float, float]]
    place_on: str = ""
    place: tuple[float, float] | None = None

    def contains(self, x: float, y: float) -> bool:
        (x0, y0), (x1, y1) = self.bounds
        return x0 <= x <= x1 and y0 <= y <= y1


@dataclass(frozen=True)
class World:
    """A room or a scene. `interior` is the free rectangle ((xmin, ymin), (xmax, ymax))
    that the walls enclose, used to score maps; `spawns` are named robot poses; `rooms`
    name parts of the floor plan."""

    name: str
    floor: Floor = Floor()
    walls: tuple[Obstacle, ...] = ()
    obstacles: tuple[Obstacle, ...] = ()
    objects: tuple[Obstacle, ...] = ()
    lights: tuple[Light, ...] = ()
    spawns: Mapping[str, Pose] = field(default_factory=dict)
    interior: tuple[tuple[float, float], tuple[float, float]] | None = None
    description: str = ""
    source: str = ""
    rooms: tuple[Room, ...] = ()

    @property
    def static_bodies(self) -> tuple[Obstacle, ...]:
        """Walls and obstacles: everything that never moves."""
        return self.walls + self.obstacles

    def spawn(self, name: str = "default") -> Pose:
        if name in self.spawns:
            return self.spawns[name]
        if name == "default" and not self.spawns:
            return Pose()
        raise KeyError(
            f"world {self.name!r} has no spawn pose {name!r}; it has {sorted(self.spawns)}"
        )

    def room(self, name: str) -> Room:
        for r in self.rooms:
            if r.name == name:
                return r
        have = ", ".join(r.name for r in self.rooms) or "none"
        raise KeyError(f"world {self.name!r} has no room {name!r}; its rooms: {have}")

    def body(self, name: str) -> Obstacle:
        """A wall, obstacle or object by name."""
        for b in self.static_bodies + self.objects:
            if b.name == name:
                return b
        raise KeyError(f"world {self.name!r} has no body {name!r}")


# --- YAML ---------------------------------------------------------------------------

MAX_ITEMS = {
    "walls": 2000,
    "obstacles": 2000,
    "objects": 500,
    "lights": 32,
    "rooms": 200,
    "spawns": 100,
}
"""The most entries of each list a world may hold (docs/worlds.md, "Limits")."""
MAX_YAML_NODES = 100_000
"""The most YAML nodes (values, lists, mappings) in a world sent to the server."""
MAX_YAML_DEPTH = 16
"""The deepest nesting of lists and mappings in a world sent to the server."""
MAX_TEXT = 4000
"""The longest string value in a world sent to the server (characters)."""


def _where(path: str, item: str) -> str:
    return f"{path}: {item}" if path else item


def _items(d: dict, key: str) -> list:
    """The list `key` of a world (empty when absent), refused past MAX_ITEMS."""
    value = d.get(key)
    if value is None:
        return []
    if not isinstance(value, list):
        raise ModelError(f"{key}: expected a list, got {shown(value)}")
    if len(value) > MAX_ITEMS[key]:
        raise ModelError(f"{key}: {len(value)} entries; a world holds at most {MAX_ITEMS[key]}")
    return value


def _pose(d: Any, what: str) -> Pose:
    """A pose as {xyz: [...], rpy: [...]} or {xyz, quat: [x, y, z, w]} or [x, y, yaw]."""
    if d is None:
        return Pose()
    if isinstance(d, list | tuple):
        if len(d) == 3:
            x, y, yaw = floats(d, 3, what)
            return Pose.from_xy_yaw(x, y, yaw)
        raise ModelError(f"{what}: a pose list is [x, y, yaw], got {shown(d)}")
    if not isinstance(d, dict):
        raise ModelError(f"{what}: expected a mapping with xyz and rpy, got {shown(d)}")
    xyz = floats(d.get("xyz", [0, 0, 0]), 3, f"{what}.xyz")
    if "quat" in d:
        quat = floats(d["quat"], 4, f"{what}.quat")
        if np.linalg.norm(quat) < 1e-9:
            raise ModelError(f"{what}.quat: a quaternion must not be all zeros")
        return Pose(xyz, quat)
    return Pose.from_xyz_rpy(xyz, floats(d.get("rpy", [0, 0, 0]), 3, f"{what}.rpy"))


def _shape(d: dict, what: str, base: Path | None) -> Shape:
    kind = d.get("shape", "box")
    if kind == "box":
        size = floats(d.get("size"), 3, f"{what}.size")
        if min(size) <= 0:
            raise ModelError(f"{what}.size: every edge must be positive, got {list(size)}")
        return Box(size)
    if kind == "cylinder":
        r = number(d.get("radius"), f"{what}.radius", above=0)
        h = number(d.get("length", d.get("height")), f"{what}.length", above=0)
        return Cylinder(r, h)
    if kind == "sphere":
        return Sphere(number(d.get("radius"), f"{what}.radius", above=0))
    if kind == "mesh":
        fn = text(d.get("file"), f"{what}.file")
        if not fn:
            raise ModelError(f"{what}: mesh needs a file")
        p = Path(fn)
        if not p.is_absolute() and base is not None:
            p = base / p
        return Mesh(str(p), floats(d.get("scale", [1, 1, 1]), 3, f"{what}.scale"))
    raise ModelError(f"{what}.shape: unknown shape {shown(kind)} (box, cylinder, sphere, mesh)")


def _body(d: Any, what: str, kind: str, base: Path | None) -> Obstacle:
    if not isinstance(d, dict):
        raise ModelError(f"{what}: expected a mapping, got {shown(d)}")
    rgba = floats(d.get("rgba", list(DEFAULT_RGBA)), 4, f"{what}.rgba")
    mass = number(d.get("mass", 0.0), f"{what}.mass", least=0)
    if kind == "object" and mass <= 0:
        raise ModelError(f"{what}: a movable object needs a positive mass")
    return Obstacle(
        name=text(d.get("name"), f"{what}.name", what.rsplit(".", 1)[-1]),
        geometry=_shape(d, what, base),
        pose=_pose(d.get("pose"), f"{what}.pose"),
        rgba=rgba,  # type: ignore[arg-type]
        mass=mass,
        kind=text(d.get("kind"), f"{what}.kind", kind),
    )


def _wall(d: Any, what: str, defaults: dict) -> Obstacle:
    """A wall from a segment: {from: [x, y], to: [x, y], thickness, height}."""
    if not isinstance(d, dict) or "from" not in d or "to" not in d:
        raise ModelError(f"{what}: a wall needs 'from' and 'to' points")
    a = np.array(floats(d["from"], 2, f"{what}.from"))
    b = np.array(floats(d["to"], 2, f"{what}.to"))
    length = float(np.linalg.norm(b - a))
    if length <= 0:
        raise ModelError(f"{what}: wall has zero length")
    t = number(d.get("thickness", defaults.get("thickness", 0.1)), f"{what}.thickness", above=0)
    h = number(d.get("height", defaults.get("height", 1.0)), f"{what}.height", above=0)
    mid = (a + b) / 2
    yaw = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
    rgba = floats(d.get("rgba", defaults.get("rgba", list(DEFAULT_RGBA))), 4, f"{what}.rgba")
    return Obstacle(
        name=text(d.get("name"), f"{what}.name", what.rsplit(".", 1)[-1]),
        geometry=Box((length, t, h)),
        pose=Pose.from_xy_yaw(mid[0], mid[1], yaw, h / 2),
        rgba=rgba,  # type: ignore[arg-type]
        kind="wall",
    )


def _light(d: Any, what: str) -> Light:
    d = mapping(d, what)
    kind = text(d.get("type"), f"{what}.type", "directional")
    if kind not in ("directional", "point"):
        raise ModelError(f"{what}.type: expected directional or point, got {shown(kind)}")
    return Light(
        name=text(d.get("name"), f"{what}.name", what.replace("lights[", "light").rstrip("]")),
        type=kind,
        pose=_pose(d.get("pose"), f"{what}.pose"),
        direction=floats(d.get("direction", [0, 0, -1]), 3, f"{what}.direction"),  # type: ignore[arg-type]
        intensity=number(d.get("intensity", 1.0), f"{what}.intensity", least=0),
        color=floats(d.get("color", [1, 1, 1]), 3, f"{what}.color"),  # type: ignore[arg-type]
    )


def world_from_dict(d: Any, source: str = "", base: Path | None = None) -> World:
    """Build a World from parsed YAML, with errors that name the failing entry."""
    if not isinstance(d, dict):
        raise ModelError(_where(source, "a world file must be a mapping"))
    try:
        fl = mapping(d.get("floor"), "floor")
        floor = Floor(
            size=floats(fl.get("size", [10, 10]), 2, "floor.size"),  # type: ignore[arg-type]
            center=floats(fl.get("center", [0, 0]), 2, "floor.center"),  # type: ignore[arg-type]
            height=number(fl.get("height", 0.0), "floor.height"),
            rgba=floats(fl.get("rgba", list(Floor.rgba)), 4, "floor.rgba"),  # type: ignore[arg-type]
            friction=number(fl.get("friction", 1.0), "floor.friction", least=0),
        )
        if min(floor.size) <= 0:
            raise ModelError(f"floor.size: both sides must be positive, got {list(floor.size)}")
        wall_defaults = mapping(d.get("wall_defaults"), "wall_defaults")
        walls = tuple(
            _wall(w, f"walls[{i}]", wall_defaults) for i, w in enumerate(_items(d, "walls"))
        )
        obstacles = tuple(
            _body(o, f"obstacles[{i}]", "obstacle", base)
            for i, o in enumerate(_items(d, "obstacles"))
        )
        objects = tuple(
            _body(o, f"objects[{i}]", "object", base) for i, o in enumerate(_items(d, "objects"))
        )
        lights = tuple(_light(li, f"lights[{i}]") for i, li in enumerate(_items(d, "lights")))
        spawns_in = mapping(d.get("spawns"), "spawns")
        if len(spawns_in) > MAX_ITEMS["spawns"]:
            raise ModelError(f"spawns: {len(spawns_in)} poses; a world holds at most 100")
        spawns = {str(k): _pose(v, f"spawns.{k}") for k, v in spawns_in.items()}
        interior = None
        if d.get("interior") is not None:
            corners = d["interior"]
            if not isinstance(corners, list) or len(corners) != 2:
                raise ModelError(
                    f"interior: expected [[xmin, ymin], [xmax, ymax]], got {shown(corners)}"
                )
            interior = (
                floats(corners[0], 2, "interior[0]"),
                floats(corners[1], 2, "interior[1]"),
            )
        rooms = tuple(_room(r, f"rooms[{i}]") for i, r in enumerate(_items(d, "rooms")))
        if d.get("home") is not None:
            check_home(d["home"])
        name = text(d.get("name"), "name", Path(source).stem if source else "world")
        description = text(d.get("description"), "description")
    except ModelError as exc:
        raise ModelError(_where(source, str(exc))) from None
    counts = Counter(b.name for b in walls + obstacles + objects)
    dup = sorted(n for n, c in counts.items() if c > 1)
    if dup:
        raise ModelError(_where(source, f"duplicate body names {dup[:10]}"))
    for i, r in enumerate(rooms):
        if r.place_on and r.place_on not in counts:
            raise ModelError(
                _where(source, f"rooms[{i}].place.surface: no body {r.place_on!r} in the world")
            )
    return World(
        name=name,
        floor=floor,
        walls=walls,
        obstacles=obstacles,
        objects=objects,
        lights=lights,
        spawns=spawns,
        interior=interior,  # type: ignore[arg-type]
        rooms=rooms,
        description=description,
        source=source,
    )


def _room(d: Any, what: str) -> Room:
    if not isinstance(d, dict) or "name" not in d:
        raise ModelError(f"{what}: a room is a mapping with a name, min and max")
    name = text(d["name"], f"{what}.name")
    lo = floats(d.get("min"), 2, f"{what}.min")
    hi = floats(d.get("max"), 2, f"{what}.max")
    if not (lo[0] < hi[0] and lo[1] < hi[1]):
        raise ModelError(f"{what}.min must be below and left of max, got {list(lo)} and {list(hi)}")
    place = d.get("place")
    if place is None:
        return Room(name, (lo, hi))  # type: ignore[arg-type]
    if not isinstance(place, dict) or "surface" not in place or "xy" not in place:
        raise ModelError(f"{what}.place: give surface (a furniture name) and xy")
    xy = floats(place["xy"], 2, f"{what}.place.xy")
    return Room(name, (lo, hi), text(place["surface"], f"{what}.place.surface"), xy)  # type: ignore[arg-type]


def _yaml_error(exc: yaml.YAMLError, source: str) -> ModelError:
    mark = getattr(exc, "problem_mark", None)
    line = f" line {mark.line + 1}" if mark is not None else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return ModelError(f"{source}:{line} is not valid YAML: {problem}")


def _within_budget(text: str, source: str) -> None:
    """Refuse YAML sent by someone else before building anything from it: aliases
    (`*name`, which can make a few bytes into gigabytes), more than MAX_YAML_NODES
    nodes, nesting deeper than MAX_YAML_DEPTH, strings longer than MAX_TEXT."""
    depth = nodes = 0
    for event in yaml.parse(text, Loader=_Loader):
        line = f"line {event.start_mark.line + 1}" if event.start_mark else "somewhere"
        if isinstance(event, yaml.AliasEvent):
            raise ModelError(
                f"{source}: {line}: YAML aliases (*{event.anchor}) are not taken in a world "
                "sent to the server; write the values out"
            )
        if isinstance(event, yaml.MappingStartEvent | yaml.SequenceStartEvent):
            depth += 1
            nodes += 1
            if depth > MAX_YAML_DEPTH:
                raise ModelError(f"{source}: {line}: nested deeper than {MAX_YAML_DEPTH} levels")
        elif isinstance(event, yaml.MappingEndEvent | yaml.SequenceEndEvent):
            depth -= 1
        elif isinstance(event, yaml.ScalarEvent):
            nodes += 1
            if len(event.value) > MAX_TEXT:
                raise ModelError(
                    f"{source}: {line}: a value of {len(event.value)} characters; "
                    f"at most {MAX_TEXT}"
                )
        if nodes > MAX_YAML_NODES:
            raise ModelError(f"{source}: more than {MAX_YAML_NODES} values; too large a world")


_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def load_world_file(path: str | Path) -> World:
    """Read a world YAML file."""
    p = Path(path)
    try:
        text = p.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        why = getattr(exc, "strerror", None) or "not a text file"
        raise ModelError(f"{p}: cannot read world file ({why})") from None
    try:
        data = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise _yaml_error(exc, str(p)) from None
    return world_from_dict(data, source=str(p), base=p.parent)


def load_world_text(text: str, source: str = "world.yaml") -> World:
    """A world from YAML text sent by someone else (the page's home editor): within the
    YAML budget (`_within_budget`), confined, so a mesh that refers to a file is
    refused, and every mistake names its entry."""
    try:
        _within_budget(text, source)
        data = yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise _yaml_error(exc, source) from None
    if isinstance(data, dict):
        for group in ("obstacles", "objects"):
            bodies = data.get(group)
            for i, body in enumerate(bodies if isinstance(bodies, list) else []):
                if isinstance(body, dict) and ("file" in body or body.get("shape") == "mesh"):
                    raise ModelError(
                        f"{source}: {group}[{i}]: a world sent to the server cannot refer to "
                        "files; use box, cylinder or sphere"
                    )
    return world_from_dict(data, source=source, base=None)
