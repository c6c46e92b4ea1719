"""`robotrial bench nav`: the platform paper's Table 1, re-run and timed (layer 5).

Rooms A, B and C (start `default` (1, 1), goal (6.8, 6.6, 0)), `--runs` runs each (10 in
the paper; seeds vary sensor noise, odometry slip and the initial pose guess) at 0.3
m/s (the paper's speed) and at the base's top speed 1.0 m/s, plus the apartment
(`default` -> `kitchen`, through the doorway between the two lower rooms; with
`--apartment`, from the living room to every other room: kitchen, corridor, bedroom,
study). `--methods` runs each row with several global planner / local controller pairs
(e.g. `dijkstra/dwa hybrid/pursuit`). Each row: successes, collisions, mean/min/max time
of the successes and two yardsticks with the ratio of the mean to each, beside the
paper's figures: "shortest", the shortest collision-free path of the centre (keeping
the footprint's inscribed radius) over the top speed; and "footprint", the least time
in which the base, within its own speed, yaw rate and acceleration limits, follows a
Hybrid-A* plan for its rectangle from rest to rest (turns on the spot included, or
curves where the rectangle, 3 cm clear, takes one instead) and then turns on the spot
to the goal's heading (`footprint_time`). Then each global planner's time per call
(Dijkstra, A*, Hybrid-A*) on each map and the DWA's step time, measured on the maps
apart from the trials.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robotrial.cli.nav import CONTROLLERS, PLANNERS, add_planner_argument
from robotrial.console import add_json_flag, print_json, print_table, progress

if TYPE_CHECKING:
    from robotrial.model.gridmap import NavMap
    from robotrial.nav.costmap import Footprint
    from robotrial.sim.controllers import DriveLimits

HELP = "Table 1 of the platform paper (rooms A, B, C; apartment) at 0.3 and 1.0 m/s; planner times"

ROOMS = {
    "room_a": ("default", (6.8, 6.6, 0.0)),
    "room_b": ("default", (6.8, 6.6, 0.0)),
    "room_c": ("default", (6.8, 6.6, 0.0)),
    "apartment": ("default", "kitchen"),
}
# the apartment's routes from the living room to every other room (`--apartment`)
APARTMENT_ROUTES = ("kitchen", "corridor", "bedroom", "study")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs", type=int, default=10, help="runs per room and speed")
    parser.add_argument(
        "--speeds", type=float, nargs="+", default=[0.3, 1.0], help="top speeds (m/s)"
    )
    parser.add_argument(
        "--worlds", nargs="+", default=list(ROOMS), choices=list(ROOMS), help="which worlds"
    )
    add_planner_argument(parser)
    parser.add_argument(
        "--methods",
        nargs="+",
        metavar="PLANNER/CONTROLLER",
        help="run every row with each of these (e.g. dijkstra/dwa hybrid/profile); "
        "default: --planner with its default controller (profile for hybrid, else dwa)",
    )
    parser.add_argument(
        "--apartment",
        action="store_true",
        help="in the apartment, drive from the living room to every other room",
    )
    parser.add_argument("--repeats", type=int, default=30, help="planner timing repetitions")
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    parser.add_argument("--plot", metavar="DIR", help="write a PNG of the paths per row here")
    add_json_flag(parser)


def _goal(world, goal) -> tuple[float, float, float]:
    if isinstance(goal, str):
        p = world.spawn(goal)
        return float(p.xyz[0]), float(p.xyz[1]), float(p.yaw)
    return goal


def footprint_time(
    nav_map: NavMap,
    footprint: Footprint,
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    speed: float,
    limits: DriveLimits,
) -> tuple[float | None, float | None]:
    """The footprint-aware yardstick (s): the least time in which a base with `limits`
    (top speed capped at `speed`) follows a Hybrid-A* plan from `start` to `goal` from
    rest to rest (the cheaper of the cheapest plan and the navigator's own, each with
    curves where the rectangle takes them), and turns to the goal's heading; and the same
    for the plans exactly as planned (every turn on the spot kept). None where
    Hybrid-A* finds no way for the rectangle."""
    from robotrial.nav.costmap import Costmap, coarsen
    from robotrial.nav.hybrid import HybridAStar, HybridConfig
    from robotrial.nav.planners import NoPath
    from robotrial.nav.profile import ProfileConfig, minimum_time

    occupied, unknown, res = coarsen(nav_map.occupied, nav_map.unknown, nav_map.resolution, 0.05)
    cm = Costmap(occupied, nav_map.origin, res, footprint, unknown=unknown)
    base = ProfileConfig(
        max_speed=min(speed, limits.max_speed),
        max_yaw_rate=limits.max_yaw_rate,
        max_accel=limits.max_accel,
        max_yaw_accel=limits.max_yaw_accel,
    )
    curves, planned = np.inf, np.inf
    # the cheapest plan, and the navigator's own (heuristic weight 1.1)
    for config in (HybridConfig(heuristic_weight=1.0), HybridConfig()):
        try:
            poses = HybridAStar(config).plan_poses(cm, start, goal[:2])
        except NoPath:
            continue
        curves = min(curves, minimum_time(poses, base, goal[2], cm, config.margin))
        planned = min(planned, minimum_time(poses, base, goal[2]))
    if not np.isfinite(planned):
        return None, None
    return min(curves, planned), planned


def planner_times(nav_map, footprint, start, goal, repeats: int) -> dict:
    """Median wall time (ms) of one global plan (Dijkstra, A*) and one DWA step."""
    from robotrial.nav.costmap import Costmap
    from robotrial.nav.dwa import DWAConfig, DWAPlanner
    from robotrial.nav.hybrid import HybridAStar
    from robotrial.nav.planners import AStar, Dijkstra

    cm = Costmap(nav_map.occupied, nav_map.origin, nav_map.resolution, footprint)
    out = {}
    path = None
    for planner, s in ((HybridAStar(), start), (Dijkstra(), start[:2]), (AStar(), start[:2])):
        path = planner.plan(cm, s, goal[:2])
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            planner.plan(cm, s, goal[:2])
            times.append(time.perf_counter() - t0)
        out[f"{planner.name}_ms"] = 1e3 * float(np.median(times))
    dwa = DWAPlanner(footprint, DWAConfig(max_speed=1.0, max_yaw_rate=1.6))
    times = []
    for i in range(repeats):
        k = min(len(path) - 1, (i * 7) % len(path))
        x, y = path[k]
        local = cm.window((x, y), 5.0)
        t0 = time.perf_counter()
        dwa.compute((x, y, 0.5), (0.5, 0.0), path, local)
        times.append(time.perf_counter() - t0)
    out["dwa_step_ms"] = 1e3 * float(np.median(times))
    return out


def run(args: argparse.Namespace) -> int:
    from robotrial.model import load_robot, load_world
    from robotrial.model.gridmap import world_map
    from robotrial.nav.navigator import default_controller
    from robotrial.sim.controllers import DriveLimits
    from robotrial.trials.nav import (
        PAPER_TABLE1,
        NavTrialSetup,
        footprint_of_robot,
        plot_paths,
        run_once,
        shortest_time,
        start_pose,
        summarize,
    )

    if args.runs < 1:
        print("robotrial bench nav: --runs must be at least 1")
        return 2
    footprint = footprint_of_robot("mobile_manipulator")
    drive = load_robot("mobile_manipulator").metadata.get("drive", {}) or {}
    limits = DriveLimits.from_metadata(drive)
    methods = [
        m.split("/") if "/" in m else [m, default_controller(m)]
        for m in args.methods or [args.planner]
    ]
    for planner, controller in methods:
        if planner not in PLANNERS or controller not in CONTROLLERS:
            print(
                f"robotrial bench nav: unknown method {planner}/{controller}: planners "
                f"{', '.join(PLANNERS)}; controllers {', '.join(CONTROLLERS)}"
            )
            return 2
    routes = [(name, ROOMS[name][0], ROOMS[name][1]) for name in args.worlds]
    if args.apartment:
        routes = [r for r in routes if r[0] != "apartment"]
        routes += [("apartment", "default", room) for room in APARTMENT_ROUTES]
    rows, timing = [], {}
    total = len(routes) * len(args.speeds) * len(methods) * args.runs
    with progress("bench nav", total=total, enabled=not args.json) as advance:
        for name, start_name, goal_spec in routes:
            world = load_world(name)
            nav_map = world_map(world)
            goal = _goal(world, goal_spec)
            start = start_pose(world, start_name)
            label = name if isinstance(goal_spec, tuple) else f"{name}:{goal_spec}"
            timing[label] = planner_times(nav_map, footprint, start, goal, args.repeats)
            timing[label]["map_cells"] = int(nav_map.occupied.size)
            for speed, (planner, controller) in ((v, m) for v in args.speeds for m in methods):
                setup = NavTrialSetup(
                    world=name,
                    goal=goal,
                    start=start_name,
                    speed=speed,
                    planner=planner,
                    controller=controller,
                )
                method = f"{planner}/{controller}"
                length, best = shortest_time(setup, nav_map, footprint, world)
                fp_best, fp_planned = footprint_time(nav_map, footprint, start, goal, speed, limits)
                results = []
                for i in range(args.runs):
                    results.append(run_once(setup, i, nav_map, world))
                    advance()
                s = summarize(results, best)
                s.update(world=label, speed=speed, method=method, shortest_length=length)
                s["footprint_time"] = fp_best
                s["footprint_planned_time"] = fp_planned
                s["footprint_ratio"] = (
                    s["mean_time"] / fp_best if s["mean_time"] and fp_best else None
                )
                s["failures"] = [r.summary() for r in results if not r.success]
                s["wall_time"] = float(sum(r.wall_time for r in results))
                rows.append(s)
                if args.plot:
                    plot_paths(
                        Path(args.plot)
                        / f"nav_{label.replace(':', '_')}_{planner}_{controller}_{speed:g}.png",
                        nav_map,
                        results,
                        start,
                        goal,
                        title=f"{label}, {method}: {s['successes']}/{s['runs']} at {speed:g} m/s",
                    )
    result = {
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d"),
        "runs_per_row": args.runs,
        "methods": [f"{p}/{c}" for p, c in methods],
        "rows": rows,
        "planning": timing,
        "paper": PAPER_TABLE1,
    }
    if args.output:
        Path(args.output).write_text(json.dumps(result, indent=2, default=float))
    if args.json:
        print_json(result)
        return 0
    fmt = lambda v, d=2: "-" if v is None else f"{v:.{d}f}"  # noqa: E731
    table = []
    for s in rows:
        paper = PAPER_TABLE1.get(s["world"]) if abs(s["speed"] - 0.3) < 1e-9 else None
        table.append(
            (
                s["world"],
                s["method"],
                s["speed"],
                f"{s['successes']}/{s['runs']}",
                s["collisions"],
                fmt(s["mean_time"]),
                fmt(s["min_time"]),
                fmt(s["max_time"]),
                fmt(s["shortest_time"]),
                fmt(s["ratio"]),
                fmt(s["footprint_time"]),
                fmt(s["footprint_ratio"]),
                f"{paper['successes']}/{paper['runs']}, {paper['mean_time']}" if paper else "-",
            )
        )
    print_table(
        "navigation trials (times in simulated s, successes only)",
        [
            "world",
            "method",
            "m/s",
            "success",
            "collisions",
            "mean",
            "min",
            "max",
            "shortest",
            "ratio",
            "footprint",
            "fp ratio",
            "paper (success, mean)",
        ],
        table,
    )
    print_table(
        "planning time per call (ms, median)",
        ["world", "cells", "Dijkstra", "A*", "Hybrid-A*", "DWA step"],
        [
            (
                w,
                t["map_cells"],
                fmt(t["dijkstra_ms"]),
                fmt(t["astar_ms"]),
                fmt(t["hybrid_ms"]),
                fmt(t["dwa_step_ms"]),
            )
            for w, t in timing.items()
        ],
    )
    return 0
