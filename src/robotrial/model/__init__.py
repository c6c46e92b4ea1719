"""Robot and world descriptions (layer 1): load a robot or a world by name or by file.

`load_robot` and `load_world` accept a built-in name (see `robotrial.model.library`) or
a path; robots come from URDF, xacro or RDTF files.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from robotrial.model.robot import ModelError, RobotModel
from robotrial.model.world import World, load_world_file

ROBOT_SUFFIXES = (".urdf", ".xacro", ".glb", ".gltf")


def load_robot(
    source: str | Path, package_paths: Sequence[str | Path] = (), confined: Path | None = None
) -> RobotModel:
    """A robot from a built-in name, or a URDF, xacro (.urdf.xacro, .xacro) or RDTF (.glb)
    file. `confined`: the folder the file and all it names must stay in (uploads)."""
    from robotrial.model import library

    text = str(source)
    p = Path(text)
    if p.suffix.lower() not in ROBOT_SUFFIXES and not p.exists():
        return library.load_builtin_robot(text)
    if not p.exists():
        raise ModelError(f"{p}: no such file")
    if p.suffix.lower() in (".glb", ".gltf"):
        from robotrial.model.rdtf import read_rdtf

        return read_rdtf(p)
    from robotrial.model.urdf import load_urdf

    return load_urdf(p, package_paths=package_paths, confined=confined)


def load_world(source: str | Path) -> World:
    """A world from a built-in name or a YAML file."""
    from robotrial.model import library

    p = Path(str(source))
    if p.suffix.lower() in (".yaml", ".yml") or p.exists():
        return load_world_file(p)
    return library.load_builtin_world(str(source))


__all__ = ["ModelError", "RobotModel", "World", "load_robot", "load_world"]
