"""`robotrial warm`: do at set-up time what the planner would otherwise do on its first
request (layer 5): compile its kernels into numba's cache and compute each built-in
arm's spheres (both covers) and self-collision pairs into robotrial's cache
(robotrial.cache), so that the first Move Robot! after `make run` answers at once.
"""

from __future__ import annotations

import argparse
import time

HELP = "compile the planner and compute the built-in arms' collision models ahead of use"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--robot",
        action="append",
        default=[],
        help="an arm to prepare (built-in name or file); repeat; default: every built-in arm",
    )


def run(args: argparse.Namespace) -> int:
    from robotrial.app.catalog import robot_kind
    from robotrial.cache import cache_dir
    from robotrial.console import console, progress
    from robotrial.model import library, load_robot, load_world
    from robotrial.planning.task import TaskPlanner, robot_spheres

    names = args.robot or library.robot_names()
    done = []
    with progress("preparing the planner", len(names)) as advance:
        for name in names:
            t0 = time.perf_counter()
            robot = load_robot(name)
            if robot_kind(robot) != "arm":
                # a mobile manipulator's arm: its covers (the carry trial plans with them)
                if (robot.metadata.get("groups") or {}).get("arm"):
                    robot_spheres(TaskPlanner(robot).kin, fine=True)
                    done.append(f"{name} ({time.perf_counter() - t0:.1f} s)")
                advance()
                continue
            world = load_world(library.DEFAULT_WORLD) if name == library.DEFAULT_ROBOT else None
            planner = TaskPlanner(robot, world)
            robot_spheres(planner.kin, fine=True)  # the fine covers too, kept on disk
            if name == library.DEFAULT_ROBOT or args.robot:
                planner.warm()  # plans once: every kernel of a request compiles
            done.append(f"{name} ({time.perf_counter() - t0:.1f} s)")
            advance()
    console.print(f"planner ready for {', '.join(done) or 'no arm'}; cache in {cache_dir()}")
    return 0
