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

Then random goals (`robotrial.trials.nav_goals`): `--goals` reachable goals (position
and heading, drawn in the free space, each called reachable by the footprint planner
before driving) in the apartment and in `--homes` generated homes (seeds `--home-seed`
on), each driven from the world's spawn at 1.0 m/s with the default stack, and the
first `--baseline-goals` of each world also with the old default (Dijkstra + DWA) in
the same run: reached within 0.15 m without contact, contacts, runs stuck after every
recovery, the median time and the median of each goal's time over the footprint's least
time along its plan; and how many drawn goals the planner refused (unreachable).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from robotrial.cli.nav import CONTROLLERS, PLANNERS, add_planner_argument
from robotrial.console import add_json_flag, emit, print_table, progress

HELP = (
    "Table 1 of the platform paper (rooms A, B, C; apartment), planner times, and random "
    "reachable goals in the apartment and in generated homes beside the old default stack"
)

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
    parser.add_argument(
        "--no-table", action="store_true", help="leave out Table 1 (only the random goals)"
    )
    parser.add_argument(
        "--goals",
        type=int,
        default=100,
        help="random reachable goals per world, driven with the default stack (0: none) "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--homes", type=int, default=10, help="generated homes besides the apartment"
    )
    parser.add_argument(
        "--home-seed",
        type=int,
        default=1000,
        help="seed of the first generated home (the next ones follow)",
    )
    parser.add_argument(
        "--no-apartment", action="store_true", help="random goals in generated homes only"
    )
    parser.add_argument("--goal-seed", type=int, default=0, help="seed of the goals drawn")
    parser.add_argument(
        "--baseline-goals",
        type=int,
        default=20,
        help="how many of each world's goals the old default stack (dijkstra/dwa) drives too "
        "(default: %(default)s)",
    )
    parser.add_argument("--jobs", type=int, default=1, help="processes driving random goals")
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    parser.add_argument("--plot", metavar="DIR", help="write a PNG of the paths per row here")
    add_json_flag(parser)


def _goal(world, goal) -> tuple[float, float, float]:
    if isinstance(goal, str):
        p = world.spawn(goal)
        return float(p.xyz[0]), float(p.xyz[1]), float(p.yaw)
    return goal


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
    from robotrial.model import load_robot
    from robotrial.nav import default_controller
    from robotrial.sim.controllers import DriveLimits
    from robotrial.trials.nav import PAPER_TABLE1, footprint_of_robot

    if args.runs < 1 or args.goals < 0 or args.homes < 0 or args.jobs < 1:
        print("robotrial bench nav: --runs and --jobs must be at least 1, --goals and --homes >= 0")
        return 2
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
    footprint = footprint_of_robot("mobile_manipulator")
    drive = load_robot("mobile_manipulator").metadata.get("drive", {}) or {}
    limits = DriveLimits.from_metadata(drive)
    result: dict = {
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d"),
        "load_average": list(os.getloadavg()),
    }
    if not args.no_table:
        rows, timing = _table(args, methods, footprint, limits)
        result.update(
            runs_per_row=args.runs,
            methods=[f"{p}/{c}" for p, c in methods],
            rows=rows,
            planning=timing,
            paper=PAPER_TABLE1,
        )
    if args.goals:
        result["goals"] = _random_goals(args)
    if emit(result, args, load_after=True):
        return 0
    if "rows" in result:
        _print_table(result["rows"], result["planning"])
    if "goals" in result:
        _print_goals(result["goals"])
    return 0


def _table(args, methods, footprint, limits) -> tuple[list[dict], dict]:
    """Table 1 (rooms A-C, the apartment's routes): rows per route, speed and method,
    and the planners' times per call."""
    from robotrial.model import load_world
    from robotrial.model.gridmap import world_map
    from robotrial.trials.nav import (
        NavTrialSetup,
        footprint_time,
        plot_paths,
        run_once,
        shortest_time,
        start_pose,
        summarize,
    )

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
                length, best = shortest_time(setup, nav_map, footprint, start)
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
    return rows, timing


def _print_table(rows: list[dict], timing: dict) -> None:
    from robotrial.trials.nav import PAPER_TABLE1

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


def _drive_one(job: tuple) -> dict:
    from robotrial.trials.nav_goals import drive_goal

    return drive_goal(*job)


def _random_goals(args) -> dict:
    """Random reachable goals in the apartment and in generated homes, driven with the
    default stack, and the first `--baseline-goals` of each world with the old one."""
    from concurrent.futures import ProcessPoolExecutor

    from robotrial.nav import DEFAULT_PLANNER, OLD_DEFAULT_PLANNER
    from robotrial.trials.nav_goals import draw_goals, goal_table

    worlds = ["apartment"] * (not args.no_apartment) + [
        f"home:{s}" for s in range(args.home_seed, args.home_seed + args.homes)
    ]
    draws = [draw_goals(w, args.goals, args.goal_seed) for w in worlds]
    jobs = []
    for d in draws:
        for i, g in enumerate(d.goals):
            jobs.append((d.world, tuple(g), DEFAULT_PLANNER, args.goal_seed + i, 1.0))
            if i < args.baseline_goals:
                jobs.append((d.world, tuple(g), OLD_DEFAULT_PLANNER, args.goal_seed + i, 1.0))
    rows: list[dict] = []
    with progress("bench nav: random goals", total=len(jobs), enabled=not args.json) as advance:
        if args.jobs == 1:
            for job in jobs:
                rows.append(_drive_one(job))
                advance()
        else:
            with ProcessPoolExecutor(args.jobs) as pool:
                for row in pool.map(_drive_one, jobs, chunksize=1):
                    rows.append(row)
                    advance()
    if args.plot:
        _plot_goals(Path(args.plot), rows)
    return {
        "goal_seed": args.goal_seed,
        "worlds": worlds,
        "refused": {
            d.world: [{"goal": [round(v, 3) for v in g], "reason": r} for g, r in d.refused]
            for d in draws
        },
        "table": goal_table(rows),
        "rows": rows,
    }


def _plot_goals(folder: Path, rows: list[dict]) -> None:
    """Per world: the map, each goal as an arrow (green reached, red not)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from robotrial.trials.nav_goals import goal_world

    folder.mkdir(parents=True, exist_ok=True)
    for world in sorted({r["world"] for r in rows}):
        w, m = goal_world(world)
        for method in sorted({r["method"] for r in rows if r["world"] == world}):
            mine = [r for r in rows if r["world"] == world and r["method"] == method]
            h, wd = m.occupied.shape
            fig, ax = plt.subplots(figsize=(7, 7 * h / max(wd, 1)))
            ax.imshow(~m.occupied, origin="lower", extent=m.extent, cmap="gray", vmin=0, vmax=1)
            s = w.spawn("default")
            ax.plot(s.xyz[0], s.xyz[1], "bo")
            for r in mine:
                x, y, yaw = r["goal"]
                ax.arrow(
                    x,
                    y,
                    0.3 * np.cos(yaw),
                    0.3 * np.sin(yaw),
                    width=0.04,
                    color="tab:green" if r["success"] else "tab:red",
                )
            ok = sum(r["success"] for r in mine)
            ax.set_title(f"{world}, {method}: {ok}/{len(mine)} reached")
            fig.tight_layout()
            fig.savefig(
                folder / f"goals_{world.replace(':', '_')}_{method.replace('/', '_')}.png", dpi=90
            )
            plt.close(fig)


def _print_goals(goals: dict) -> None:
    fmt = lambda v, d=2: "-" if v is None else f"{v:.{d}f}"  # noqa: E731
    print_table(
        "random reachable goals (from the spawn, 1.0 m/s; reached within 0.15 m without contact)",
        [
            "world",
            "method",
            "reached",
            "contacts",
            "stuck",
            "median (s)",
            "footprint (s)",
            "median ratio",
            "refused drawn",
        ],
        [
            (
                t["world"],
                t["method"],
                f"{t['reached']}/{t['goals']} ({100 * t['share']:.0f} %)",
                t["contacts"],
                t["stuck"],
                fmt(t["median_time"]),
                fmt(t["median_footprint_time"]),
                fmt(t["median_ratio"]),
                len(goals["refused"].get(t["world"], [])),
            )
            for t in goals["table"]
        ],
    )
