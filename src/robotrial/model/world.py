"""World: what a room IS (floor, walls, obstacles, movable objects, lights, spawn poses).

Layer 1: imports only `robotrial.geometry`, `robotrial.model.robot` and
`robotrial.model.home` (checks on a drawn floor plan). A world is read
from YAML; the format is documented in docs/worlds.md. Compiling it to MJCF, glTF or an
occupancy grid lives in other modules.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
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


def _where(path: str, item: str) -> str:
    return f"{path}: {item}" if path else item


def _floats(value: Any, n: int, what: str) -> tuple[float, ...]:
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{what}: expected {n} numbers, got {value!r}") from exc
    if arr.size != n or not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: expected {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def _pose(d: Any, what: str) -> Pose:
    """A pose as {xyz: [...], rpy: [...]} or {xyz, quat: [x, y, z, w]} or [x, y, yaw]."""
    if d is None:
        return Pose()
    if isinstance(d, list | tuple):
        if len(d) == 3:
            x, y, yaw = _floats(d, 3, what)
            return Pose.from_xy_yaw(x, y, yaw)
        raise ModelError(f"{what}: a pose list is [x, y, yaw], got {d!r}")
    if not isinstance(d, dict):
        raise ModelError(f"{what}: expected a mapping with xyz and rpy, got {d!r}")
    xyz = _floats(d.get("xyz", (0, 0, 0)), 3, f"{what}.xyz")
    if "quat" in d:
        return Pose(xyz, _floats(d["quat"], 4, f"{what}.quat"))
    return Pose.from_xyz_rpy(xyz, _floats(d.get("rpy", (0, 0, 0)), 3, f"{what}.rpy"))


def _shape(d: dict, what: str, base: Path | None) -> Shape:
    kind = d.get("shape", "box")
    if kind == "box":
        size = _floats(d.get("size"), 3, f"{what}.size")
        if min(size) <= 0:
            raise ModelError(f"{what}.size: every edge must be positive, got {size}")
        return Box(size)
    if kind == "cylinder":
        r, h = float(d.get("radius", 0)), float(d.get("length", d.get("height", 0)))
        if r <= 0 or h <= 0:
            raise ModelError(f"{what}: cylinder needs positive radius and length")
        return Cylinder(r, h)
    if kind == "sphere":
        r = float(d.get("radius", 0))
        if r <= 0:
            raise ModelError(f"{what}: sphere needs a positive radius")
        return Sphere(r)
    if kind == "mesh":
        fn = str(d.get("file", ""))
        if not fn:
            raise ModelError(f"{what}: mesh needs a file")
        p = Path(fn)
        if not p.is_absolute() and base is not None:
            p = base / p
        return Mesh(str(p), _floats(d.get("scale", (1, 1, 1)), 3, f"{what}.scale"))
    raise ModelError(f"{what}.shape: unknown shape {kind!r} (box, cylinder, sphere, mesh)")


def _body(d: Any, what: str, kind: str, base: Path | None) -> Obstacle:
    if not isinstance(d, dict):
        raise ModelError(f"{what}: expected a mapping, got {d!r}")
    rgba = _floats(d.get("rgba", DEFAULT_RGBA), 4, f"{what}.rgba")
    mass = float(d.get("mass", 0.0))
    if kind == "object" and mass <= 0:
        raise ModelError(f"{what}: a movable object needs a positive mass")
    return Obstacle(
        name=str(d.get("name", what.rsplit(".", 1)[-1])),
        geometry=_shape(d, what, base),
        pose=_pose(d.get("pose"), f"{what}.pose"),
        rgba=rgba,  # type: ignore[arg-type]
        mass=mass,
        kind=str(d.get("kind", kind)),
    )


def _wall(d: Any, what: str, defaults: dict) -> Obstacle:
    """A wall from a segment: {from: [x, y], to: [x, y], thickness, height}."""
    if not isinstance(d, dict) or "from" not in d or "to" not in d:
        raise ModelError(f"{what}: a wall needs 'from' and 'to' points")
    a = np.array(_floats(d["from"], 2, f"{what}.from"))
    b = np.array(_floats(d["to"], 2, f"{what}.to"))
    length = float(np.linalg.norm(b - a))
    if length <= 0:
        raise ModelError(f"{what}: wall has zero length")
    t = float(d.get("thickness", defaults.get("thickness", 0.1)))
    h = float(d.get("height", defaults.get("height", 1.0)))
    mid = (a + b) / 2
    yaw = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
    rgba = _floats(d.get("rgba", defaults.get("rgba", DEFAULT_RGBA)), 4, f"{what}.rgba")
    return Obstacle(
        name=str(d.get("name", what.rsplit(".", 1)[-1])),
        geometry=Box((length, t, h)),
        pose=Pose.from_xy_yaw(mid[0], mid[1], yaw, h / 2),
        rgba=rgba,  # type: ignore[arg-type]
        kind="wall",
    )


def world_from_dict(d: Any, source: str = "", base: Path | None = None) -> World:
    """Build a World from parsed YAML, with errors that name the failing entry."""
    if not isinstance(d, dict):
        raise ModelError(_where(source, "a world file must be a mapping"))
    try:
        fl = d.get("floor", {}) or {}
        floor = Floor(
            size=_floats(fl.get("size", (10, 10)), 2, "floor.size"),  # type: ignore[arg-type]
            center=_floats(fl.get("center", (0, 0)), 2, "floor.center"),  # type: ignore[arg-type]
            height=float(fl.get("height", 0.0)),
            rgba=_floats(fl.get("rgba", Floor.rgba), 4, "floor.rgba"),  # type: ignore[arg-type]
            friction=float(fl.get("friction", 1.0)),
        )
        wall_defaults = d.get("wall_defaults", {}) or {}
        walls = tuple(
            _wall(w, f"walls[{i}]", wall_defaults) for i, w in enumerate(d.get("walls", []) or [])
        )
        obstacles = tuple(
            _body(o, f"obstacles[{i}]", "obstacle", base)
            for i, o in enumerate(d.get("obstacles", []) or [])
        )
        objects = tuple(
            _body(o, f"objects[{i}]", "object", base)
            for i, o in enumerate(d.get("objects", []) or [])
        )
        lights = tuple(
            Light(
                name=str(li.get("name", f"light{i}")),
                type=str(li.get("type", "directional")),
                pose=_pose(li.get("pose"), f"lights[{i}].pose"),
                direction=_floats(li.get("direction", (0, 0, -1)), 3, f"lights[{i}].direction"),  # type: ignore[arg-type]
                intensity=float(li.get("intensity", 1.0)),
                color=_floats(li.get("color", (1, 1, 1)), 3, f"lights[{i}].color"),  # type: ignore[arg-type]
            )
            for i, li in enumerate(d.get("lights", []) or [])
        )
        spawns = {str(k): _pose(v, f"spawns.{k}") for k, v in (d.get("spawns", {}) or {}).items()}
        interior = None
        if d.get("interior") is not None:
            lo = _floats(d["interior"][0], 2, "interior[0]")
            hi = _floats(d["interior"][1], 2, "interior[1]")
            interior = (lo, hi)
        rooms = tuple(_room(r, f"rooms[{i}]") for i, r in enumerate(d.get("rooms", []) or []))
        if d.get("home") is not None:
            check_home(d["home"])
    except ModelError as exc:
        raise ModelError(_where(source, str(exc))) from None
    names = [b.name for b in walls + obstacles + objects]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ModelError(_where(source, f"duplicate body names {dup}"))
    for i, r in enumerate(rooms):
        if r.place_on and r.place_on not in names:
            raise ModelError(
                _where(source, f"rooms[{i}].place.surface: no body {r.place_on!r} in the world")
            )
    return World(
        name=str(d.get("name", Path(source).stem if source else "world")),
        floor=floor,
        walls=walls,
        obstacles=obstacles,
        objects=objects,
        lights=lights,
        spawns=spawns,
        interior=interior,  # type: ignore[arg-type]
        rooms=rooms,
        description=str(d.get("description", "")),
        source=source,
    )


def _room(d: Any, what: str) -> Room:
    if not isinstance(d, dict) or "name" not in d:
        raise ModelError(f"{what}: a room is a mapping with a name, min and max")
    lo = _floats(d.get("min"), 2, f"{what}.min")
    hi = _floats(d.get("max"), 2, f"{what}.max")
    if not (lo[0] < hi[0] and lo[1] < hi[1]):
        raise ModelError(f"{what}.min must be below and left of max, got {lo} and {hi}")
    place = d.get("place")
    if place is None:
        return Room(str(d["name"]), (lo, hi))  # type: ignore[arg-type]
    if not isinstance(place, dict) or "surface" not in place or "xy" not in place:
        raise ModelError(f"{what}.place: give surface (a furniture name) and xy")
    xy = _floats(place["xy"], 2, f"{what}.place.xy")
    return Room(str(d["name"]), (lo, hi), str(place["surface"]), xy)  # type: ignore[arg-type]


def load_world_file(path: str | Path) -> World:
    """Read a world YAML file."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise ModelError(f"{p}: cannot read world file ({exc.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f" line {mark.line + 1}" if mark is not None else ""
        raise ModelError(f"{p}:{line} is not valid YAML: {exc}") from None
    return world_from_dict(data, source=str(p), base=p.parent)


def load_world_text(text: str, source: str = "world.yaml") -> World:
    """A world from YAML text sent by someone else (the page's home editor): confined,
    so a mesh that refers to a file is refused, and every mistake names its entry."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f" line {mark.line + 1}" if mark is not None else ""
        raise ModelError(f"{source}:{line} is not valid YAML: {exc}") from None
    if isinstance(data, dict):
        for group in ("obstacles", "objects"):
            for i, body in enumerate(data.get(group) or []):
                if isinstance(body, dict) and ("file" in body or body.get("shape") == "mesh"):
                    raise ModelError(
                        f"{source}: {group}[{i}]: a world sent to the server cannot refer to "
                        "files; use box, cylinder or sphere"
                    )
    return world_from_dict(data, source=source, base=None)
