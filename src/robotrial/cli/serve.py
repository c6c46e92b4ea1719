"""`robotrial serve`: the web page and its files on a local port (uvicorn)."""

from __future__ import annotations

import argparse

from robotrial.cli.access import access_from, add_access_arguments
from robotrial.model.library import DEFAULT_ROBOT, DEFAULT_WORLD

HELP = "serve the web page: a robot in a world, in the browser"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this computer only; "
        "0.0.0.0 opens it to the network)",
    )
    parser.add_argument("--port", type=int, default=8000, help="TCP port (default 8000)")
    parser.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        help="robot the page opens on: a built-in name or a .urdf, .xacro or .glb file "
        f"(default {DEFAULT_ROBOT})",
    )
    parser.add_argument(
        "--world",
        default=DEFAULT_WORLD,
        help=f"world the page opens on: a built-in name or a YAML file (default {DEFAULT_WORLD})",
    )
    parser.add_argument(
        "--foxglove-port",
        type=int,
        default=8765,
        metavar="PORT",
        help="also serve the topics over the Foxglove WebSocket protocol, for Foxglove and "
        "Lichtblick (default 8765, on --host; 0: off)",
    )
    add_access_arguments(parser)


def run(args: argparse.Namespace) -> int:
    import uvicorn

    from robotrial.app.server import ROSBRIDGE_PATH, create_app
    from robotrial.console import console
    from robotrial.model.robot import ModelError
    from robotrial.ros.bus import Bus

    try:
        if not 0 <= args.foxglove_port <= 65535:
            raise ValueError(f"--foxglove-port must be 0 (off) to 65535, got {args.foxglove_port}")
        access = access_from(args)
        app = create_app(
            args.robot,
            args.world,
            bus=Bus(),
            live=True,
            planner=True,
            access=access,
            foxglove_port=args.foxglove_port or None,
        )
    except (ModelError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        return 2
    shown = "127.0.0.1" if args.host in ("0.0.0.0", "::") else args.host
    host = f"[{shown}]" if ":" in shown else shown
    key = f"?token={access.token}" if access.token else ""
    foxglove = f"; Foxglove at ws://{host}:{args.foxglove_port}/{key}" if args.foxglove_port else ""
    print(
        f"robotrial: open http://{host}:{args.port}/{key} ({args.robot} in {args.world}); "
        f"rosbridge at ws://{host}:{args.port}{ROSBRIDGE_PATH}{foxglove}; Ctrl+C stops",
        flush=True,
    )
    uvicorn.run(app, host=args.host, port=args.port, log_level="warning")
    return 0
