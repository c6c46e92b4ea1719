"""The options that say where a robot description comes from, shared by the commands
that read one: `--robot` (a built-in name or a file), search paths for package:// and
xacro arguments."""

from __future__ import annotations

import argparse

from robotrial.model import load_robot
from robotrial.model.robot import ModelError, RobotModel


def add_robot_source_arguments(
    parser: argparse.ArgumentParser, default: str | None = None, robot: bool = True
) -> None:
    """`--robot` (required without a `default`; left out with `robot=False`, for a
    command that adds its own), `--package-path` and `--xacro-arg`."""
    if robot:
        parser.add_argument(
            "--robot",
            default=default,
            required=default is None,
            help="built-in robot name, .urdf, .xacro or .glb file"
            + (f" (default {default})" if default else ""),
        )
    parser.add_argument(
        "--package-path",
        "-p",
        action="append",
        default=[],
        metavar="P",
        help="folder searched for package:// URIs (repeatable; before ROS_PACKAGE_PATH)",
    )
    parser.add_argument(
        "--xacro-arg",
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="argument for a .xacro file (repeatable)",
    )


def xacro_arguments(items: list[str]) -> dict[str, str]:
    """NAME:=VALUE items as a mapping, refusing malformed ones."""
    out = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name.strip():
            raise ModelError(f"--xacro-arg {item!r}: expected NAME:=VALUE")
        out[name.strip()] = value
    return out


def load_robot_from_args(args: argparse.Namespace) -> RobotModel:
    """The robot named by `args.robot` with the search paths and xacro arguments given."""
    xargs = xacro_arguments(args.xacro_arg)
    if not xargs:
        return load_robot(args.robot, package_paths=args.package_path)
    if not str(args.robot).endswith(".xacro"):
        raise ModelError(f"--xacro-arg given, but {args.robot} is not a .xacro file")
    from robotrial.model.urdf import load_urdf

    return load_urdf(args.robot, package_paths=args.package_path, xacro_args=xargs)
