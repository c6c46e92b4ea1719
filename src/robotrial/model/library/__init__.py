"""The built-in robots (URDF/xacro under robots/) and worlds (YAML under worlds/)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from robotrial.model.robot import ModelError, RobotModel
from robotrial.model.world import World, load_world_file

HERE = Path(__file__).parent
ROBOTS_DIR = HERE / "robots"
WORLDS_DIR = HERE / "worlds"

DEFAULT_ROBOT = "desk_arm"
DEFAULT_WORLD = "desk"


def robot_names() -> list[str]:
    """Built-in robot names: each is robots/NAME/NAME.urdf or robots/NAME/NAME.urdf.xacro."""
    return sorted(p.name for p in ROBOTS_DIR.iterdir() if p.is_dir() and _robot_file(p.name))


def world_names() -> list[str]:
    return sorted(p.stem for p in WORLDS_DIR.glob("*.yaml"))


def _robot_file(name: str) -> Path | None:
    folder = ROBOTS_DIR / name
    for fn in (f"{name}.urdf.xacro", f"{name}.urdf"):
        if (folder / fn).is_file():
            return folder / fn
    return None


def robot_path(name: str) -> Path:
    """The description file of a built-in robot."""
    path = _robot_file(name) if "/" not in name and name else None
    if path is None:
        raise ModelError(f"unknown robot {name!r}; built-in robots are {robot_names()}")
    return path


def world_path(name: str) -> Path:
    path = WORLDS_DIR / f"{name}.yaml"
    if "/" in name or not path.is_file():
        raise ModelError(f"unknown world {name!r}; built-in worlds are {world_names()}")
    return path


@cache
def load_builtin_robot(name: str) -> RobotModel:
    from robotrial.model.urdf import load_urdf

    return load_urdf(robot_path(name))


@cache
def load_builtin_world(name: str) -> World:
    return load_world_file(world_path(name))
