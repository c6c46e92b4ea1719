"""`robotrial rosbridge`: a standalone rosbridge v2 server without the web app (layer 5).

With `--robot` (an arm), the planning node answers /robotrial/plan_task on its bus for
that robot, standing in `--world` if given.
"""

from __future__ import annotations

import argparse

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
        "--robot",
        default="",
        help="an arm (built-in name or URDF/xacro/RDTF file): offer /robotrial/plan_task for it",
    )
    parser.add_argument("--world", default="", help="the world the arm stands in (optional)")


def run(args: argparse.Namespace) -> int:
    from robotrial.ros.bus import Bus
    from robotrial.ros.rosbridge import serve

    bus = Bus()
    node = None
    if args.robot:
        from robotrial.model import ModelError, load_robot, load_world
        from robotrial.ros.planning_node import PLAN_TASK, PlanningNode

        try:
            robot = load_robot(args.robot)
            world = load_world(args.world) if args.world else None
        except (ModelError, KeyError, FileNotFoundError) as exc:
            raise SystemExit(f"robotrial rosbridge: {exc}") from None
        node = PlanningNode(bus, robot, world)
        print(f"planning for {robot.name} on {PLAN_TASK}; compiling the planner...", flush=True)
        node.planner.warm()
    elif args.world:
        raise SystemExit("robotrial rosbridge: --world needs --robot")
    dialect = "ros1" if args.ros_version == "1" else "ros2"
    print(f"rosbridge v2 on ws://{args.host}:{args.port}/ (also /rosbridge); Ctrl-C stops")
    try:
        serve(args.host, args.port, bus, dialect=dialect)
    finally:
        if node is not None:
            node.destroy()
    return 0
