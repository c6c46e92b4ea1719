"""`robotrial explore`: a robot maps a home it has never seen, on its own (layer 5).

    robotrial explore --world apartment [--seed 0] [--mode frontier|route] [--plot DIR]

The robot starts at the world's `default` spawn and explores by frontiers
(`robotrial.onboard.explore`) with its pose-graph SLAM until no reachable frontier is
left (or, with `--mode route`, drives the carry trial's given route). Prints the share
of the reachable free area mapped, the ATE of SLAM's path, the time, the path length and
the contacts (JSON with --json); with --plot, a PNG of the map and the paths in DIR.
A world is a built-in name, a World YAML file, or a generated home `home:SEED` /
`home:SEED:ROOMS`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from robotrial.console import add_json_flag, console, print_json, print_table, progress

HELP = "explore a home with frontiers and SLAM until nothing reachable is left; score the map"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--world",
        default="apartment",
        help="built-in world, World YAML file, or a generated home home:SEED[:ROOMS]",
    )
    parser.add_argument("--seed", type=int, default=0, help="simulation seed (sensor noise)")
    parser.add_argument(
        "--mode",
        choices=("frontier", "route"),
        default="frontier",
        help="frontier: explore on its own; route: the carry trial's given route",
    )
    parser.add_argument("--time-limit", type=float, default=900.0, help="simulated seconds")
    parser.add_argument("--plot", metavar="DIR", help="write explore_WORLD_MODE.png there")
    add_json_flag(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.trials.explore import ExploreSetup, plot_explore, run_explore

    try:
        setup = ExploreSetup(world=args.world, mode=args.mode, time_limit=args.time_limit)
        with progress(
            f"explore {args.world}", total=round(args.time_limit), enabled=not args.json
        ) as advance:
            last = [0.0]

            def on_progress(t: float) -> None:
                advance(t - last[0])
                last[0] = t

            result = run_explore(setup, args.seed, on_progress)
    except (ValueError, KeyError, FileNotFoundError) as exc:
        console.print(f"[red]robotrial explore: {exc}")
        return 2
    summary = result.summary()
    if args.plot:
        name = args.world.replace(":", "_").replace("/", "_")
        png = plot_explore(Path(args.plot) / f"explore_{name}_{args.mode}.png", [result])
        summary["plot"] = str(png)
    if args.json:
        print_json(summary)
        return 0
    print_table(
        f"explore {args.world} ({args.mode}, seed {args.seed})",
        ["mapped", "ATE (cm)", "time (s)", "path (m)", "contacts", "goals", "stopped"],
        [
            [
                f"{100 * result.coverage:.1f} % of {result.reachable_area:.1f} m2",
                f"{100 * result.ate:.1f}",
                f"{result.sim_time:.0f}",
                f"{result.path_length:.1f}",
                result.contacts,
                len(result.goals),
                result.stopped,
            ]
        ],
    )
    if args.plot:
        console.print(f"plot: {summary['plot']}")
    return 0
