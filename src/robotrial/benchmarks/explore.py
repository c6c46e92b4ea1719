"""`robotrial bench explore`: frontier exploration beside the given route (layer 5).

For each world (the apartment and generated homes `home:SEED:ROOMS`, 2-6 rooms), the
robot maps it twice in the same run: on its own by frontiers (`robotrial explore`) and
along the carry trial's given route (the apartment's drawn route; for a generated home
a tour of its rooms made from its plan, which the frontier mode is never told). Each
row: the share of the reachable free area mapped, the ATE of SLAM's path, the simulated
time, the path length, the contacts, the goals driven and why it stopped; with --plot,
one PNG per world with both maps.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

from robotrial.console import add_json_flag, emit, print_table, progress

HELP = "frontier exploration beside the given route: share mapped, ATE, time, path, contacts"

WORLDS = ("apartment", "home:0:2", "home:1:3", "home:2:4", "home:3:5", "home:4:6")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--worlds", nargs="+", default=list(WORLDS), help="worlds (names, files, home:SEED:ROOMS)"
    )
    parser.add_argument("--seed", type=int, default=0, help="simulation seed")
    parser.add_argument(
        "--modes", nargs="+", choices=("frontier", "route"), default=["frontier", "route"]
    )
    parser.add_argument("--time-limit", type=float, default=900.0, help="simulated seconds a run")
    parser.add_argument("--plot", metavar="DIR", help="write explore_WORLD.png there")
    parser.add_argument("-o", "--output", metavar="JSON", help="write the results there")
    add_json_flag(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.trials.explore import ExploreSetup, plot_explore, run_explore

    result: dict = {
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d"),
        "load_average": list(os.getloadavg()),
        "rows": [],
    }
    jobs = [(w, m) for w in args.worlds for m in args.modes]
    with progress("bench explore", total=len(jobs), enabled=not args.json) as advance:
        for world in args.worlds:
            runs = []
            for mode in args.modes:
                setup = ExploreSetup(world=world, mode=mode, time_limit=args.time_limit)
                try:
                    r = run_explore(setup, args.seed)
                except ValueError as exc:
                    result["rows"].append({"world": world, "mode": mode, "error": str(exc)})
                    advance()
                    continue
                runs.append(r)
                row = r.summary()
                row["load_average"] = os.getloadavg()[0]
                result["rows"].append(row)
                advance()
            if args.plot and runs:
                name = world.replace(":", "_").replace("/", "_")
                plot_explore(Path(args.plot) / f"explore_{name}.png", runs)
    if emit(result, args, load_after=True):
        return 0
    print_table(
        f"bench explore (seed {args.seed}, load {result['load_average'][0]:.1f})",
        ["world", "mode", "mapped %", "ATE cm", "time s", "path m", "contacts", "goals", "stopped"],
        [
            [r["world"], r["mode"], "-", "-", "-", "-", "-", "-", r["error"]]
            if "error" in r
            else [
                r["world"],
                r["mode"],
                f"{100 * r['coverage']:.1f}",
                f"{100 * r['ate_m']:.1f}",
                f"{r['sim_time']:.0f}",
                f"{r['path_length']:.1f}",
                r["contacts"],
                r["goals"],
                r["stopped"],
            ]
            for r in result["rows"]
        ],
    )
    return 0
