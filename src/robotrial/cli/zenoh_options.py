"""The options that put the bus on ROS 2's rmw_zenoh: `--zenoh`, `--zenoh-router`,
`--zenoh-listen`, `--ros-domain-id` (shared by `serve` and `sim`)."""

from __future__ import annotations

import argparse
import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robotrial.ros.bus import Bus
    from robotrial.ros.zenoh_bridge import ZenohBridge


def add_zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--zenoh",
        action="store_true",
        help="also be ROS 2 nodes on Zenoh (rmw_zenoh, Jazzy and later): ros2 topic list, "
        "echo, pub and service call see the topics and services with no bridge",
    )
    parser.add_argument(
        "--zenoh-router",
        default="tcp/127.0.0.1:7447",
        metavar="ENDPOINT",
        help="with --zenoh: the Zenoh router to join (default tcp/127.0.0.1:7447, where "
        "`ros2 run rmw_zenoh_cpp rmw_zenohd` listens)",
    )
    parser.add_argument(
        "--zenoh-listen",
        metavar="ENDPOINT",
        help="with --zenoh: be the router ROS 2 nodes connect to (e.g. tcp/127.0.0.1:7447) "
        "instead of joining one",
    )
    parser.add_argument(
        "--ros-domain-id",
        type=int,
        default=int(os.environ.get("ROS_DOMAIN_ID", "0") or 0),
        help="with --zenoh: the ROS domain (default $ROS_DOMAIN_ID or 0)",
    )


def zenoh_bridge(args: argparse.Namespace, bus: Bus) -> ZenohBridge | None:
    """The bridge the options ask for (None without --zenoh); ValueError or OSError
    naming what is wrong."""
    if not args.zenoh:
        return None
    if not 0 <= args.ros_domain_id <= 232:
        raise ValueError(f"--ros-domain-id must be 0 to 232, got {args.ros_domain_id}")
    from robotrial.ros.zenoh_bridge import ZenohBridge

    try:
        if args.zenoh_listen:
            return ZenohBridge(
                bus,
                connect=[],
                listen=[args.zenoh_listen],
                mode="router",
                domain_id=args.ros_domain_id,
            )
        return ZenohBridge(bus, connect=[args.zenoh_router], domain_id=args.ros_domain_id)
    except ImportError as exc:
        raise ValueError(str(exc)) from None
