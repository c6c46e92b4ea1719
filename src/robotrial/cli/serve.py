"""`robotrial serve`: the web page and its files on a local port (uvicorn)."""

from __future__ import annotations

import argparse

from robotrial.cli.access import access_from, add_access_arguments
from robotrial.cli.zenoh_options import add_zenoh_arguments, zenoh_bridge
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
    add_zenoh_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.app.server import ROSBRIDGE_PATH, create_app
    from robotrial.cli.serving import run_server
    from robotrial.console import console
    from robotrial.model.robot import ModelError
    from robotrial.ros.bus import Bus

    bus = Bus()
    try:
        if not 0 <= args.foxglove_port <= 65535:
            raise ValueError(f"--foxglove-port must be 0 (off) to 65535, got {args.foxglove_port}")
        if args.foxglove_port and not _port_free(args.host, args.foxglove_port):
            print(
                f"robotrial: Foxglove is off: port {args.foxglove_port} is in use (another "
                "server?); choose another with --foxglove-port PORT, or 0 to turn it off",
                flush=True,
            )
            args.foxglove_port = 0
        access = access_from(args)
        app = create_app(
            args.robot,
            args.world,
            bus=bus,
            live=True,
            planner=True,
            access=access,
            foxglove_port=args.foxglove_port or None,
        )
        zenoh = zenoh_bridge(args, bus)
    except (ModelError, ValueError, OSError) as exc:
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
    if zenoh is not None:
        print(f"robotrial: ROS 2 (rmw_zenoh) on Zenoh, domain {zenoh.domain_id}", flush=True)
    run_server(app, args.host, args.port, on_stop=zenoh.destroy if zenoh is not None else None)
    return 0


def _port_free(host: str, port: int) -> bool:
    """Whether a server could listen on host:port now."""
    import socket

    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True
