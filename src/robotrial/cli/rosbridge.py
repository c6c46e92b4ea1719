"""`robotrial rosbridge`: a standalone rosbridge v2 server (layer 5).

    robotrial rosbridge --port 9090                          # an empty bus
    robotrial rosbridge --robot desk_arm --world desk        # with /robotrial/plan_task

With `--robot`, the arm planner answers `/robotrial/plan_task` for that robot (standing
in `--world`, if given), as `robotrial serve` does for the page.
"""

from __future__ import annotations

import argparse

from robotrial.cli.access import access_from, add_access_arguments
from robotrial.cli.robot_source import add_tool_argument, with_tool_from_args

HELP = "serve the rosbridge v2 protocol (WebSocket) without the web app"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on")
    parser.add_argument("--port", type=int, default=9090, help="port (rosbridge's is 9090)")
    parser.add_argument(
        "--ros-version",
        choices=("1", "2"),
        default="2",
        help="spelling of type names and time fields when a client does not choose one",
    )
    parser.add_argument(
        "--robot", help="offer /robotrial/plan_task for this robot (built-in name or file)"
    )
    parser.add_argument("--world", help="the world the robot stands in (with --robot)")
    add_tool_argument(parser)
    add_access_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.cli.serving import run_server
    from robotrial.console import console
    from robotrial.model import ModelError, load_robot, load_world
    from robotrial.ros.bus import Bus
    from robotrial.ros.rosbridge import standalone_app

    bus = Bus()
    try:
        access = access_from(args)
        if (args.world or args.tool) and not args.robot:
            raise ValueError("--world and --tool need --robot (the robot they are for)")
        if args.robot:
            from robotrial.ros.planning_node import PLAN_TASK, PlanningNode

            world = load_world(args.world) if args.world else None
            node = PlanningNode(bus, with_tool_from_args(load_robot(args.robot), args), world)
            console.print(
                f"{PLAN_TASK} plans for {args.robot}"
                + (f" in {args.world}" if world else "")
                + "; compiling the planner..."
            )
            node.planner.warm()
    except (ModelError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        return 2
    dialect = "ros1" if args.ros_version == "1" else "ros2"
    print(f"rosbridge v2 on ws://{args.host}:{args.port}/ (also /rosbridge); Ctrl-C stops")
    run_server(standalone_app(bus, dialect=dialect, access=access), args.host, args.port)
    return 0
