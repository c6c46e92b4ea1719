"""Random goals: the navigation trial to goals nobody chose, in the apartment and in
generated homes (layer 5).

A world is named `apartment` (any built-in or file) or `home:SEED` (the home
`robotrial.model.homegen.generate_home(SEED)`; `home:SEED:ROOMS` with that many rooms).
`draw_goals` draws poses in the free space of the world's interior
(`robotrial.nav.goals.sample_goals`: the rectangle keeps 10 cm from everything) and asks
the footprint planner, from the world's `default` spawn, whether each is reachable; it
keeps the first `count` reachable ones and the refusals with their reasons.
`drive_goal` runs the navigation trial to one goal with one stack and times the
footprint's least time along its plan beside it (`footprint_time`). `goal_table` sums
rows up per world and stack: reached within the trial's 0.15 m, contacts, the median
time and the median of each goal's time over its yardstick, and the runs that ended
"stuck" on a goal the planner called reachable.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

from robotrial.model import load_robot, load_world
from robotrial.model.gridmap import NavMap, world_map
from robotrial.model.world import World
from robotrial.nav import default_controller
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.goals import check_goal, sample_goals
from robotrial.sim.controllers import DriveLimits
from robotrial.trials.nav import (
    NavTrialSetup,
    footprint_of_robot,
    footprint_time,
    run_once,
    start_pose,
)

ROBOT = "mobile_manipulator"


@cache
def goal_world(name: str) -> tuple[World, NavMap]:
    """The world `name` (a built-in, a file, `home:SEED` or `home:SEED:ROOMS`) and its
    ground-truth map."""
    return named_world(name), world_map(named_world(name))


@cache
def named_world(name: str) -> World:
    """The world `name`: a built-in, a file, or a generated home `home:SEED` (`home:SEED:
    ROOMS` with that many rooms). Raises ValueError for a malformed home name."""
    if not name.startswith("home:"):
        return load_world(name)
    from robotrial.model.homegen import generate_home

    parts = name.split(":")[1:]
    try:
        numbers = [int(p) for p in parts]
    except ValueError:
        numbers = []
    if len(numbers) not in (1, 2):
        raise ValueError(f"world {name!r}: a generated home is home:SEED or home:SEED:ROOMS")
    return generate_home(numbers[0], numbers[1] if len(numbers) == 2 else None)


@cache
def _footprint() -> Footprint:
    return footprint_of_robot(ROBOT)


@dataclass(frozen=True)
class GoalDraw:
    """Reachable goals (N, 3) from the world's spawn, and the goals drawn that the
    footprint planner refused, each with its reason."""

    world: str
    start: tuple[float, float, float]
    goals: np.ndarray
    refused: list[tuple[tuple[float, float, float], str]]


def draw_goals(name: str, count: int, seed: int = 0) -> GoalDraw:
    """The first `count` reachable goals drawn in world `name` with `seed` (and the
    refused ones drawn before them)."""
    world, nav_map = goal_world(name)
    cm = Costmap(
        nav_map.occupied, nav_map.origin, nav_map.resolution, _footprint(), unknown=nav_map.unknown
    )
    start = start_pose(world, "default")
    rng = np.random.default_rng([seed, 35])
    kept: list[np.ndarray] = []
    refused: list[tuple[tuple[float, float, float], str]] = []
    while len(kept) < count:
        batch = sample_goals(cm, max(8, 2 * (count - len(kept))), rng, region=world.interior)
        for g in batch:
            verdict = check_goal(cm, tuple(g), start)
            if verdict.ok:
                kept.append(g)
            elif verdict.kind != "here":
                refused.append((tuple(float(v) for v in g), verdict.reason))
            if len(kept) == count:
                break
        if len(refused) > 20 * count + 100:
            raise ValueError(f"{name}: too few reachable goals ({len(kept)} of {count})")
    return GoalDraw(name, start, np.array(kept).reshape(-1, 3), refused)


def drive_goal(
    name: str, goal: tuple[float, float, float], planner: str, seed: int, speed: float = 1.0
) -> dict:
    """One run of the navigation trial in world `name` from its spawn to `goal` with
    the global planner `planner` (and its default controller), and the footprint
    yardstick for it: a row of `goal_table`."""
    world, nav_map = goal_world(name)
    limits = DriveLimits.from_metadata(load_robot(ROBOT).metadata.get("drive", {}) or {})
    setup = NavTrialSetup(
        world=world.name,
        goal=tuple(float(v) for v in goal),
        speed=speed,
        planner=planner,
        controller=default_controller(planner),
        robot=ROBOT,
    )
    r = run_once(setup, seed, nav_map, world)
    start = start_pose(world, "default")
    best, _ = footprint_time(nav_map, _footprint(), start, setup.goal, speed, limits)
    return {
        "world": name,
        "method": f"{planner}/{setup.controller}",
        "goal": [round(float(v), 3) for v in goal],
        "seed": seed,
        "success": r.success,
        "collision": r.collision,
        "time": round(r.time, 3),
        "footprint_time": None if best is None else round(best, 3),
        "ratio": round(r.time / best, 3) if r.success and best else None,
        "final_error": round(r.final_error, 3),
        "status": r.status,
        "message": r.message,
        "recoveries": r.recoveries,
        "wall_time": round(r.wall_time, 2),
    }


def goal_table(rows: list[dict]) -> list[dict]:
    """Per world and stack: goals, reached (within the trial's radius, no contact),
    contacts, the median time of the reached ones (s), their median footprint
    yardstick (s) and the median of time over yardstick per goal, and how many ended
    stuck after every recovery."""
    out = []
    keys = sorted({(r["world"], r["method"]) for r in rows}, key=lambda k: (k[0], k[1]))
    for world, method in keys:
        mine = [r for r in rows if r["world"] == world and r["method"] == method]
        ok = [r for r in mine if r["success"]]
        med = lambda v: float(np.median(v)) if v else None  # noqa: E731
        out.append(
            {
                "world": world,
                "method": method,
                "goals": len(mine),
                "reached": len(ok),
                "share": len(ok) / len(mine) if mine else None,
                "contacts": sum(bool(r["collision"]) for r in mine),
                "median_time": med([r["time"] for r in ok]),
                "median_footprint_time": med(
                    [r["footprint_time"] for r in ok if r["footprint_time"]]
                ),
                "median_ratio": med([r["ratio"] for r in ok if r["ratio"] is not None]),
                "stuck": sum(r["message"].startswith("stuck") for r in mine),
                "failures": [
                    {k: r[k] for k in ("goal", "seed", "message", "final_error")}
                    for r in mine
                    if not r["success"]
                ],
            }
        )
    return out
