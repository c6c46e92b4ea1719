"""`robotrial bench verdict`: the buyer's verdict timed, and checked by driving (layer 5).

For each robot, `check_home` on the world (default: the apartment; no chores) `--repeats`
times: the wall time of the whole verdict and of each part (footprint, rooms, parking
poses, reach), and the process's CPU time (what the wall time would be on an idle core:
the verdict runs on one), against the 10 s target. Then the verdict is checked by driving: the
navigation trial (AMCL in MuJoCo, Hybrid-A*, the speed profile) from the dock to each room's
goal, `--runs` seeds each; every room the verdict calls reachable must be reached and
every other must not. In the apartment, the same is done with the study's doorway
narrowed to 0.6 m (the study must then be red, and not reached). With `--chore
OBJECT:ROOM`, the chores run too (`--seeds` each), timed apart.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

from robotrial.console import add_json_flag, emit, print_table, progress

HELP = "the home verdict's time per part (target 10 s) and its rooms checked by driving"
TARGET = 10.0  # s, the whole verdict without chores


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", default="apartment", help="world name or World YAML")
    parser.add_argument(
        "--robots", nargs="+", default=["mobile_manipulator"], help="robots to judge"
    )
    parser.add_argument("--repeats", type=int, default=3, help="verdicts timed per robot")
    parser.add_argument("--runs", type=int, default=1, help="drives per room (seeds)")
    parser.add_argument("--chore", action="append", default=[], metavar="OBJECT:ROOM")
    parser.add_argument("--seeds", type=int, default=3, help="runs per chore")
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    add_json_flag(parser)


def narrowed_apartment(apartment):
    """The apartment with doorway D2 (corridor to study) narrowed from 1.0 m to 0.6 m."""
    from robotrial.model.world import load_world_text

    text = Path(apartment.source).read_text()
    wall = "{name: corridor_north_c, from: [7.0, 5.4]"
    if wall not in text:
        raise ValueError(f"{apartment.source}: no wall {wall!r} to move")
    text = text.replace(wall, "{name: corridor_north_c, from: [6.6, 5.4]")
    text = text.replace("name: apartment\n", "name: apartment_narrow_study\n")
    return load_world_text(text, source="apartment_narrow_study.yaml")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from robotrial.model import load_world
    from robotrial.trials.chores import run_chores
    from robotrial.trials.verdict import check_home, drive_to_rooms

    world = load_world(args.world)
    results: dict = {
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "world": world.name,
        "target_s": TARGET,
        "robots": {},
    }
    agree = True
    for robot in args.robots:
        timings = []
        with progress(f"verdict {robot}", args.repeats, enabled=not args.json) as advance:
            for _ in range(args.repeats):
                verdict = check_home(world, robot)
                timings.append(
                    {"total": verdict.seconds, "cpu": verdict.cpu_seconds, **verdict.timings}
                )
                advance()
        drives, not_driven = [], ""
        with progress(f"driving {robot}", args.runs, enabled=not args.json) as advance:
            for seed in range(args.runs):
                try:
                    rows = drive_to_rooms(verdict.base, world, robot, seed=seed)
                except ValueError as exc:  # e.g. no LiDAR: the navigation trial needs one
                    not_driven = str(exc)
                    break
                drives.extend({**row, "seed": seed, "world": world.name} for row in rows)
                advance()
        if world.name == "apartment" and not not_driven:
            # the same home with the study's doorway narrowed to 0.6 m: the study turns red,
            # and driving there must fail
            narrow = narrowed_apartment(world)
            closed = check_home(narrow, robot).base
            for seed in range(args.runs):
                drives.extend(
                    {**row, "seed": seed, "world": narrow.name}
                    for row in drive_to_rooms(closed, narrow, robot, seed=seed)
                )
        agree &= all(d["agrees"] for d in drives)
        parts = {k: float(np.median([t[k] for t in timings])) for k in timings[0]}
        entry = {
            "summary": verdict.summary,
            "median_s": {k: round(v, 3) for k, v in parts.items()},
            "runs_s": [round(t["total"], 3) for t in timings],
            "within_target": parts["total"] <= TARGET,
            "cpu_within_target": parts["cpu"] <= TARGET,
            "drives": drives,
            "not_driven": not_driven,
        }
        if args.chore:
            from robotrial.trials.chores import parse_chore

            t = time.perf_counter()
            chores = run_chores(world, robot, [parse_chore(c) for c in args.chore], args.seeds)
            entry["chores"] = [c.to_dict() for c in chores]
            entry["chores_s"] = round(time.perf_counter() - t, 1)
        results["robots"][robot] = entry
    results["driving_agrees"] = agree
    if emit(results, args):
        return 0 if agree else 1
    print_table(
        f"verdict time in {world.name} (median of {args.repeats}, s; target {TARGET:g} s)",
        [
            "robot",
            "total",
            "CPU",
            "footprint",
            "rooms",
            "parking poses",
            "reach",
            "within target (wall, CPU)",
        ],
        [
            [
                r,
                e["median_s"]["total"],
                e["median_s"]["cpu"],
                e["median_s"].get("footprint"),
                e["median_s"].get("base"),
                e["median_s"].get("parking"),
                e["median_s"].get("reach"),
                f"{'yes' if e['within_target'] else 'no'}, "
                f"{'yes' if e['cpu_within_target'] else 'no'}",
            ]
            for r, e in results["robots"].items()
        ],
    )
    print_table(
        "rooms: the verdict against driving (navigation trial, Hybrid-A* + speed profile)",
        ["robot", "world", "room", "verdict", "driven", "agrees", "time (s)", "message"],
        [
            [
                r,
                d["world"],
                d["room"],
                d["verdict"],
                d["driven"],
                d["agrees"],
                d["time"],
                d["message"][:40],
            ]
            for r, e in results["robots"].items()
            for d in e["drives"]
        ],
    )
    for r, e in results["robots"].items():
        if e["not_driven"]:
            print(f"{r} not driven: {e['not_driven']}")
        for c in e.get("chores", []):
            print(
                f"{r} {c['chore']}: {c['successes']} of {c['runs']} "
                f"{c['refused'] or c['failed_phases'] or ''} ({c['wall_time']:.0f} s)"
            )
    print("driving agrees with the verdict" if agree else "DRIVING DISAGREES with the verdict")
    return 0 if agree else 1
