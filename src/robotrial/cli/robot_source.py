"""The options that say where a robot description comes from, shared by the commands
that read one: `--robot` (a built-in name or a file), search paths for package:// and
xacro arguments, and for the commands that plan, `--tool` (another link as the tool)."""

from __future__ import annotations

import argparse

from robotrial.model import load_robot
from robotrial.model.anatomy import with_tool
from robotrial.model.robot import ModelError, RobotModel


def add_robot_source_arguments(
    parser: argparse.ArgumentParser,
    default: str | None = None,
    robot: bool = True,
    tool: bool = False,
) -> None:
    """`--robot` (required without a `default`; left out with `robot=False`, for a
    command that adds its own), `--package-path` and `--xacro-arg`; with `tool`, also
    `--tool`."""
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
    if tool:
        add_tool_argument(parser)
    parser.add_argument(
        "--xacro-arg",
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="argument for a .xacro file (repeatable)",
    )


def add_tool_argument(parser: argparse.ArgumentParser) -> None:
    """`--tool LINK`: another link as the arm's tool (model/anatomy.py `with_tool`)."""
    parser.add_argument(
        "--tool",
        default="",
        metavar="LINK",
        help="the link the goal is for, and the arm the joints that move it "
        "(default: the description's tool, or the one found in its tree)",
    )


def with_tool_from_args(model: RobotModel, args: argparse.Namespace) -> RobotModel:
    """`model` with the `--tool` link as its tool, when one is given."""
    return with_tool(model, args.tool) if getattr(args, "tool", "") else model


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
        return with_tool_from_args(load_robot(args.robot, package_paths=args.package_path), args)
    if not str(args.robot).endswith(".xacro"):
        raise ModelError(f"--xacro-arg given, but {args.robot} is not a .xacro file")
    from robotrial.model.urdf import load_urdf

    model = load_urdf(args.robot, package_paths=args.package_path, xacro_args=xargs)
    return with_tool_from_args(model, args)
