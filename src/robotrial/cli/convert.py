"""`robotrial convert --robot R -o OUT` (or `--world W`): a robot or a world into RDTF
(.glb) or MJCF (.xml).

Layer 5. R is a built-in robot name or a URDF / xacro / RDTF file; W a built-in world
name or a world YAML file. OUT's suffix picks the format: `.glb` writes
RDTF for a robot (docs/rdtf.md) or the browser's glTF scene for a world; `.xml` writes
MJCF with its mesh files next to it. Prints what it wrote (size, links, joints and the
repairs the loader made); `--json` prints the same as one object. Errors are one line on
stderr and exit status 1.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path
from typing import Any

from robotrial.cli.robot_source import add_robot_source_arguments, load_robot_from_args
from robotrial.console import add_json_flag, print_json

HELP = "convert a robot (URDF, xacro, RDTF) or a world to RDTF/glTF (.glb) or MJCF (.xml)"
FORMATS = {".glb": "glb", ".xml": "mjcf"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--robot", help="built-in robot name, .urdf, .xacro or .glb file")
    source.add_argument("--world", help="built-in world name or .yaml file")
    parser.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help="file to write: .glb (RDTF, or glTF scene for a world) or .xml (MJCF)",
    )
    add_robot_source_arguments(parser, robot=False)
    parser.add_argument(
        "--base",
        choices=("fixed", "free", "planar"),
        default="fixed",
        help="MJCF only: how the robot's root is joined to the world (default fixed)",
    )
    add_json_flag(parser)


def _size(n: int) -> str:
    for unit in ("bytes", "kB", "MB"):
        if n < 1000 or unit == "MB":
            return f"{n} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000  # type: ignore[assignment]
    return str(n)


def _convert_robot(args: argparse.Namespace, out: Path, fmt: str) -> dict[str, Any]:
    model = load_robot_from_args(args)
    result: dict[str, Any] = {
        "input": str(args.robot),
        "kind": "robot",
        "name": model.name,
        "links": len(model.links),
        "joints": len(model.joints),
        "actuated_joints": len(model.actuated_joints),
        "sensors": len(model.sensors),
        "repairs": list(model.repairs),
    }
    if fmt == "glb":
        from robotrial.model.rdtf import write_rdtf

        write_rdtf(model, out)
        result["format"] = "RDTF"
    else:
        from robotrial.model.mjcf import to_mjcf

        doc = to_mjcf(model, base=args.base)
        doc.save(out.parent, out.name)
        result["format"] = "MJCF"
        result["mesh_files"] = sorted(doc.assets)
        result["notes"] = list(doc.notes)
    return result


def _convert_world(args: argparse.Namespace, out: Path, fmt: str) -> dict[str, Any]:
    from robotrial.model import load_world

    world = load_world(args.world)
    result: dict[str, Any] = {
        "input": str(args.world),
        "kind": "world",
        "name": world.name,
        "walls": len(world.walls),
        "obstacles": len(world.obstacles),
        "objects": len(world.objects),
        "lights": len(world.lights),
    }
    if fmt == "glb":
        from robotrial.model.scene_gltf import write_world_glb

        write_world_glb(world, out)
        result["format"] = "glTF"
    else:
        from robotrial.model.mjcf import to_mjcf

        doc = to_mjcf(world=world)
        doc.save(out.parent, out.name)
        result["format"] = "MJCF"
        result["mesh_files"] = sorted(doc.assets)
        result["notes"] = list(doc.notes)
    return result


def _print(result: dict[str, Any]) -> None:
    size = _size(result["bytes"])
    head = f"wrote {result['output']} ({result['format']}, {size})"
    if result["kind"] == "robot":
        print(
            f"{head}: robot {result['name']!r}, {result['links']} links, "
            f"{result['joints']} joints ({result['actuated_joints']} actuated), "
            f"{result['sensors']} sensors, {len(result['repairs'])} repairs"
        )
    else:
        print(
            f"{head}: world {result['name']!r}, {result['walls']} walls, "
            f"{result['obstacles']} obstacles, {result['objects']} objects, "
            f"{result['lights']} lights"
        )
    for line in result.get("repairs", []):
        print(f"  repaired: {line}")
    for line in result.get("notes", []):
        print(f"  note: {line}")
    for line in result["warnings"]:
        print(f"  warning: {line}")


def run(args: argparse.Namespace) -> int:
    from robotrial.model.robot import ModelError

    out = Path(args.output)
    fmt = FORMATS.get(out.suffix.lower())
    try:
        if fmt is None:
            raise ModelError(f"{out}: the output must end in .glb (RDTF/glTF) or .xml (MJCF)")
        if not out.parent.is_dir():
            raise ModelError(f"{out}: folder {str(out.parent)!r} does not exist")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            convert = _convert_world if args.world is not None else _convert_robot
            result = convert(args, out, fmt)
    except (ModelError, OSError, ValueError) as exc:
        # ModelError says what and where; an OSError names the file it failed on
        message = " ".join(str(exc).split())
        print(f"robotrial convert: error: {message}", file=sys.stderr)
        return 1
    result["output"] = str(out)
    result["bytes"] = out.stat().st_size
    repairs = set(result.get("repairs", []))
    # loader warnings repeat the repairs; keep only what they do not already say
    result["warnings"] = [
        str(w.message)
        for w in caught
        if not any(r in str(w.message) or str(w.message) in r for r in repairs)
    ]
    if args.json:
        print_json(result)
    else:
        _print(result)
    return 0
