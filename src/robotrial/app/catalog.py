"""What the web server offers: the built-in robots and worlds, their kinds, the default
pairings, and their browser files (RDTF for robots, scene glTF for worlds, MJCF for the
browser's physics), built once and cached. Layer 5: calls the description layer, knows
nothing of HTTP.

A name from a request is only ever compared with the built-in lists; it never becomes
part of a file path. The server's own robot and world may be files (`serve --robot
FILE --world FILE`): they join the lists under the names their descriptions give.
"""

from __future__ import annotations

import base64
import hashlib
import json
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from robotrial.app.uploads import unique_name
from robotrial.geometry import Pose
from robotrial.model import ROBOT_SUFFIXES, library, load_robot, load_world
from robotrial.model.anatomy import tool_choices, with_tool
from robotrial.model.robot import RobotModel
from robotrial.model.stand import stand
from robotrial.model.world import World

Kind = Literal["arm", "mobile"]
WORLD_SUFFIXES = (".yaml", ".yml")

# The world a robot of each kind opens in when none is asked for (if it exists).
PREFERRED_WORLD: dict[Kind, str] = {"arm": "desk", "mobile": "room_a"}


class UnknownName(LookupError):
    """A robot or world name that is not built in."""


@dataclass(frozen=True)
class Asset:
    """A built file: its bytes and a strong ETag (a hash of the bytes)."""

    data: bytes
    etag: str


def robot_kind(model: RobotModel) -> Kind:
    """A robot with a drive (a wheeled base) is mobile; anything else is an arm."""
    return "mobile" if model.metadata.get("drive") else "arm"


def world_kind(world: World) -> Kind:
    """A world with walls is a room for mobile robots; one without is a tabletop scene."""
    return "mobile" if world.walls else "arm"


def _pose_entry(pose: Pose) -> dict[str, list[float]]:
    return {"xyz": list(pose.xyz), "quat": list(pose.quat)}


def _default_spawn(world: World) -> Pose:
    """The spawn pose named "default", else the first one, else the origin."""
    if "default" in world.spawns or not world.spawns:
        return world.spawn("default")
    return next(iter(world.spawns.values()))


class Catalog:
    """The built-in robots and worlds, with cached browser files.

    Thread-safe: the server calls it from its worker threads; each file is built at
    most once even when several requests ask for it at the same time.
    """

    def __init__(self, robot: str = library.DEFAULT_ROBOT, world: str = library.DEFAULT_WORLD):
        """`robot` and `world`: built-in names, or files (a robot description, a world
        YAML), which join the lists. UnknownName for a name that is neither; ModelError
        for a file that does not load."""
        self._lock = threading.Lock()
        self._building: dict[str, threading.Lock] = {}
        self._assets: dict[str, Asset] = {}
        self._uploaded: dict[str, RobotModel] = {}
        self._added_worlds: dict[str, World] = {}
        self._stands: dict[tuple[str, str], Pose] = {}
        self.default_robot = self._robot_file(robot) if _is_file(robot, ROBOT_SUFFIXES) else robot
        self.default_world = self._world_file(world) if _is_file(world, WORLD_SUFFIXES) else world
        self.check_robot(self.default_robot)
        self.check_world(self.default_world)

    def _robot_file(self, path: str) -> str:
        """Load a robot description file into the list; its name there."""
        model = load_robot(path)
        name = unique_name(model.name or Path(path).stem, set(library.robot_names()))
        self.add_robot(name, model)
        return name

    def _world_file(self, path: str) -> str:
        """Load a world YAML file into the list; its name there."""
        return self.add_world(load_world(path))

    # --- names ---------------------------------------------------------------------

    def robot_names(self) -> list[str]:
        """The built-in robots, then the uploaded ones."""
        with self._lock:
            uploaded = list(self._uploaded)
        return library.robot_names() + uploaded

    def add_robot(self, name: str, model: RobotModel, glb: bytes | None = None) -> None:
        """Offer an uploaded robot under `name` (a name not yet taken); `glb`: its RDTF
        bytes when already built."""
        with self._lock:
            if name in self._uploaded or name in library.robot_names():
                raise ValueError(f"robot name {name!r} is taken")
            self._uploaded[name] = model
            if glb is not None:
                self._assets[f"robot/{name}"] = _asset(glb)

    def is_uploaded(self, name: str) -> bool:
        with self._lock:
            return name in self._uploaded

    def set_tool(self, name: str, link: str) -> RobotModel:
        """Make `link` the tool of the uploaded robot `name` (anatomy.with_tool): its
        files are built again on the next request. ModelError for a link that cannot be
        the tool; UnknownName for a robot that is not uploaded."""
        with self._lock:
            model = self._uploaded.get(name)
        if model is None:
            raise UnknownName(f"robot {name!r} is not one of the robots uploaded here")
        changed = with_tool(model, link)
        with self._lock:
            self._uploaded[name] = changed
            mine = [
                k for k in self._assets if k == f"robot/{name}" or k.startswith(f"mjcf/{name}/")
            ]
            for key in mine:
                del self._assets[key]
        return changed

    def world_names(self) -> list[str]:
        """The built-in worlds, then the ones sent to the server."""
        with self._lock:
            added = list(self._added_worlds)
        return library.world_names() + added

    def add_world(self, world: World) -> str:
        """Offer a world sent to the server; returns its catalog name (the world's name,
        with a number added when that name is taken)."""
        with self._lock:
            taken = set(library.world_names()) | set(self._added_worlds)
            name = unique_name(world.name or "home", taken)
            self._added_worlds[name] = world
        return name

    def check_robot(self, name: str) -> str:
        """`name` if it is a built-in robot, else UnknownName listing the ones there are."""
        names = self.robot_names()
        if name not in names:
            raise UnknownName(f"unknown robot {name!r}; built-in robots are {', '.join(names)}")
        return name

    def check_world(self, name: str) -> str:
        names = self.world_names()
        if name not in names:
            raise UnknownName(f"unknown world {name!r}; built-in worlds are {', '.join(names)}")
        return name

    # --- descriptions ----------------------------------------------------------------

    def robot(self, name: str) -> RobotModel:
        with self._lock:
            uploaded = self._uploaded.get(name)
        return uploaded or library.load_builtin_robot(self.check_robot(name))

    def world(self, name: str) -> World:
        with self._lock:
            added = self._added_worlds.get(name)
        return added or library.load_builtin_world(self.check_world(name))

    def stand(self, robot: str, world: str) -> Pose:
        """Where the robot's root stands relative to the world's spawn (model/stand.py:
        lifted onto the floor when its legs reach below it), kept per pair."""
        key = (robot, world)
        with self._lock:
            kept = self._stands.get(key)
        if kept is None:
            kept = stand(self.robot(robot), self.world(world), _default_spawn(self.world(world)))
            with self._lock:
                self._stands[key] = kept
        return kept

    def default_pair(self) -> dict[str, str]:
        return {"robot": self.default_robot, "world": self.default_world}

    def world_for(self, kind: Kind) -> str:
        """The world a robot of `kind` opens in: the server's default world if it suits,
        else the preferred one, else the first that suits, else the default world."""
        worlds = {w["name"]: w["kind"] for w in self.worlds()}
        if worlds.get(self.default_world) == kind:
            return self.default_world
        if worlds.get(PREFERRED_WORLD[kind]) == kind:
            return PREFERRED_WORLD[kind]
        return next((n for n, k in worlds.items() if k == kind), self.default_world)

    def robots(self) -> list[dict]:
        """One entry per built-in robot: name, kind, joint count and the world it opens in."""
        out = []
        for name in self.robot_names():
            model = self.robot(name)
            kind = robot_kind(model)
            out.append(
                {
                    "name": name,
                    "title": model.name or name,
                    "kind": kind,
                    "joints": len(model.actuated_joints),
                    "world": self.world_for(kind),
                    "uploaded": self.is_uploaded(name),
                    "tool": model.end_effector,
                    "tools": tool_choices(model) if kind == "arm" else [],
                    "stand": _pose_entry(self.stand(name, self.world_for(kind))),
                }
            )
        return out

    def worlds(self) -> list[dict]:
        """One entry per built-in world: name, kind, description and the robot's spawn pose."""
        out = []
        for name in self.world_names():
            world = self.world(name)
            spawn = _default_spawn(world)
            out.append(
                {
                    "name": name,
                    "kind": world_kind(world),
                    "description": world.description,
                    "spawn": _pose_entry(spawn),
                }
            )
        return out

    # --- files -----------------------------------------------------------------------

    def robot_glb(self, name: str) -> Asset:
        """The robot as RDTF (glTF binary)."""
        model = self.robot(name)
        from robotrial.model.rdtf import write_rdtf

        return self._cached(f"robot/{name}", lambda: write_rdtf(model, None))

    def world_glb(self, name: str) -> Asset:
        """The world as a glTF binary scene."""
        world = self.world(name)
        from robotrial.model.scene_gltf import write_world_glb

        return self._cached(f"world/{name}", lambda: write_world_glb(world))

    def mjcf_bundle(self, robot: str, world: str) -> Asset:
        """The robot standing in the world as MJCF for the browser's MuJoCo (mujoco-js), as
        JSON: {name, xml, assets: {file: base64}, notes}. Every joint gets a position
        servo (docs/mjcf.md), the controller the page's joint tracker drives."""
        model = self.robot(robot)
        scene = self.world(world)

        def build() -> bytes:
            from robotrial.model.mjcf import to_mjcf

            doc = to_mjcf(model, scene, actuators="position")
            assets = {n: base64.b64encode(b).decode("ascii") for n, b in doc.assets.items()}
            body = {"name": doc.name, "xml": doc.xml, "assets": assets, "notes": list(doc.notes)}
            return json.dumps(body).encode()

        return self._cached(f"mjcf/{robot}/{world}", build)

    def warm(self) -> None:
        """Build the default robot's and world's files now, so the first page is quick."""
        self.robot_glb(self.default_robot)
        self.world_glb(self.default_world)

    def _cached(self, key: str, build: Callable[[], bytes]) -> Asset:
        with self._lock:
            if key in self._assets:
                return self._assets[key]
            gate = self._building.setdefault(key, threading.Lock())
        with gate:
            with self._lock:
                if key in self._assets:
                    return self._assets[key]
            asset = _asset(build())
            with self._lock:
                self._assets[key] = asset
            return asset


def _is_file(text: str, suffixes: tuple[str, ...]) -> bool:
    """Whether a robot or world option names a file (by its suffix, or because it is
    one) rather than a built-in."""
    return text.lower().endswith(suffixes) or Path(text).is_file()


def _asset(data: bytes) -> Asset:
    return Asset(data, '"' + hashlib.sha256(data).hexdigest()[:32] + '"')
