"""`robotrial rosbridge`: a standalone rosbridge v2 server on an empty bus (layer 5)."""

from __future__ import annotations

import argparse

from robotrial.cli.access import access_from, add_access_arguments

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
    add_access_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.console import console
    from robotrial.ros.rosbridge import serve

    try:
        access = access_from(args)
    except ValueError as exc:
        console.print(f"[red]error:[/red] {exc}")
        return 2
    dialect = "ros1" if args.ros_version == "1" else "ros2"
    print(f"rosbridge v2 on ws://{args.host}:{args.port}/ (also /rosbridge); Ctrl-C stops")
    serve(args.host, args.port, dialect=dialect, access=access)
    return 0
