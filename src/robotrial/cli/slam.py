"""`robotrial slam`: build a map with GMapping-, Hector- or pose-graph SLAM from a recording or
the live simulator, and score it against the world's ground truth (layer 5).

    robotrial slam --method gmapping --bag run.mcap -o room_c
    robotrial slam --method hector --live --world room_a --duration 60 -o room_a_hector
    robotrial slam --method graph --bag apartment.mcap --world apartment -o apartment_graph
    robotrial slam --method hector --log intel.clf --relations intel.relations -o intel

writes room_c.pgm + room_c.yaml (map_server), room_c.tum (the trajectory) and room_c.png
(the map with the trajectory over the ground truth), and prints the scores (or --json).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from robotrial.console import add_json_flag, console, print_json, print_table, progress

HELP = "SLAM (gmapping, hector, graph) from a recording, a CARMEN log or live: maps, scores"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--method", choices=("gmapping", "hector", "graph"), default="gmapping")
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--bag", metavar="FILE", help="a recording (.mcap or ROS 1 .bag)")
    src.add_argument("--live", action="store_true", help="drive the simulator and map live")
    src.add_argument("--log", metavar="FILE", help="a real-robot CARMEN log (.clf, .log)")
    parser.add_argument("--relations", metavar="FILE", help="--log: relations to score against")
    parser.add_argument(
        "--order",
        choices=("file", "time"),
        default="file",
        help="--log: scans in the file's order (as taken) or sorted by time stamp",
    )
    parser.add_argument(
        "--drift-odometry",
        type=int,
        metavar="SEED",
        help="--log: replace the log's odometry by a raw-odometry version of its motions "
        "(5 %% in distance and turn, a heading bias of 0.002 rad/m; seeded), for a log whose "
        "poses are a corrected trajectory",
    )
    parser.add_argument("-o", "--output", default="map", help="output stem (STEM.pgm, .yaml, ...)")
    parser.add_argument(
        "--world",
        help="world to score against (default: the output stem when it names a built-in "
        "world, e.g. -o room_c; with --live: room_c)",
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a ROS parameter of the method, e.g. particles=30 or map_resolution=0.05",
    )
    parser.add_argument("--duration", type=float, default=120.0, help="--live: simulated s")
    parser.add_argument(
        "--drive",
        choices=("route", "square"),
        default="route",
        help="--live: the world's route across the room (built-in rooms), or a square",
    )
    parser.add_argument(
        "--route",
        help="--live: a named route of robotrial.trials.slam.ROUTES instead of the world's "
        "own, e.g. apartment_tour (every room of the apartment and back)",
    )
    parser.add_argument("--side", type=float, default=2.0, help="--live: square side (m)")
    parser.add_argument("--speed", type=float, default=0.3, help="--live: speed (m/s)")
    parser.add_argument("--seed", type=int, default=0, help="--live: sensor noise seed")
    add_json_flag(parser)


def _params(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--param {item!r}: expected NAME=VALUE")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _world(args: argparse.Namespace):
    from robotrial.model import load_world
    from robotrial.model.library import world_names

    name = args.world
    if name is None:
        stem = Path(args.output).name
        name = stem if stem in world_names() else ("room_c" if args.live else None)
    return load_world(name) if name else None


def run(args: argparse.Namespace) -> int:
    from robotrial.model import ModelError
    from robotrial.slam.gmapping import OdometryRequired
    from robotrial.trials import slam as trial

    try:
        params = _params(args.param)
        world = _world(args)
        trial.make_slam(args.method, params)
    except (ValueError, KeyError, ModelError) as exc:
        console.print(f"[red]robotrial slam: {exc}")
        return 2
    if args.relations and not args.log:
        console.print("[red]robotrial slam: --relations scores a --log run; give --log FILE")
        return 2
    if args.drift_odometry is not None and not args.log:
        console.print(
            "[red]robotrial slam: --drift-odometry drifts a --log's odometry; give --log FILE"
        )
        return 2
    if args.log:
        from robotrial.cli.slam_log import run_log

        return run_log(args, params)
    try:
        if args.bag:
            run_, rec = _offline(args, params, trial)
        else:
            run_, rec = _live(args, params, world, trial)
    except (OdometryRequired, ValueError, FileNotFoundError) as exc:
        console.print(f"[red]robotrial slam: {exc}")
        return 2
    size = trial.room_size(world) if world is not None and world.name.startswith("room_") else None
    result = {"method": args.method, "source": rec.source, "world": world.name if world else None}
    result.update(trial.score(run_, rec, world, size))
    result["files"] = trial.write_outputs(run_, rec, world, args.output)
    if args.json:
        print_json(result)
        return 0
    rows = []
    for k, v in result.items():
        if isinstance(v, dict):
            rows.extend((f"{k}.{kk}", vv) for kk, vv in v.items())
        else:
            rows.append((k, v))
    print_table(f"robotrial slam: {args.method}", ["quantity", "value"], rows)
    return 0


def _offline(args, params, trial):
    rec = trial.load_recording(args.bag)
    with progress(
        f"{args.method} over {Path(args.bag).name}", len(rec.scans), not args.json
    ) as adv:
        run_ = trial.run_slam(args.method, rec, params, on_scan=lambda i: adv())
    return run_, rec


def _route(args, world, trial):
    """The waypoints to drive live: --route by name, else the world's own route."""
    if args.drive != "route":
        return None
    if args.route is None:
        return trial.ROUTES.get(world.name)
    if trial.route_world(args.route) != world.name:
        raise ValueError(
            f"--route {args.route} drives in {trial.route_world(args.route)}, not {world.name}"
        )
    return trial.ROUTES[args.route]


def _live(args, params, world, trial):
    import numpy as np

    from robotrial.ros.slam_node import SlamNode

    slam = trial.make_slam(args.method, params)
    nodes: list[SlamNode] = []
    last = [0.0]
    wall0 = time.perf_counter()
    with progress(
        f"{args.method} live in {world.name}", round(args.duration, 1), not args.json
    ) as adv:

        def on_step(t: float) -> None:
            if t - last[0] >= 0.5:
                adv(round(t - last[0], 1))
                last[0] = round(t, 1)

        rec = trial.record_drive(
            world,
            None,
            args.duration,
            args.side,
            args.speed,
            args.seed,
            on_step=on_step,
            extra_nodes=lambda bus: nodes.append(SlamNode(bus, slam)),
            route=_route(args, world, trial),
        )
    wall = time.perf_counter() - wall0
    times = np.asarray(nodes[0].scan_times)
    run_ = trial.finish_run(args.method, slam, times, wall, rec.duration)
    return run_, rec
