"""The kinds of trial a sweep can run, each a function of (configuration, seed) (layer 5).

A kind names its configuration keys with their defaults and runs one trial from plain
JSON values, so a run can be sent to another process or another machine, stored, and
run again from its row. `KINDS` is the table: a new kind is a function and an entry.

- `nav`: the navigation trial (`robotrial nav`): AMCL, the global planner and DWA in the
  simulator, from the world's start to its goal; success and simulated time.
- `plan`: one arm planning query (`robotrial plan`, Table 2): the g2rViewer desk task or
  a scene around an arm; success, planning time and path length.
- `slam`: a drive along the world's route, mapped by GMapping, Hector or the pose
  graph; map accuracy, trajectory error and time per scan, the map files beside the
  database.
- `g2r`: the g2rViewer desk experiment: the desk arm plans (the PlanTask service) from one
  side of obstacle C to the other (or with no obstacle), the motion runs in MuJoCo, and
  the hand's path under physics is compared with the planned one; a plot of both.
- `carry`: the whole platform in one task (`robotrial trials carry`): map with SLAM,
  navigate on that map, pick an object, carry it to a room and place it; success, the
  failed phase and each phase's time, the MCAP, JSON and plot beside the database.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from robotrial.nav import DEFAULT_PLANNER


@dataclass(frozen=True)
class Outcome:
    """What one run gives: success (None for measurements without a pass mark), the
    figures, and the files it wrote (name -> path)."""

    success: bool | None
    figures: dict[str, Any]
    files: dict[str, str]


@dataclass(frozen=True)
class TrialKind:
    """A kind of trial: its configuration keys with defaults, the figure a report ranks
    runs by, and the function that runs one."""

    name: str
    defaults: dict[str, Any]
    figure: str
    run: Callable[[dict[str, Any], int, Path], Outcome]

    def config(self, given: dict[str, Any]) -> dict[str, Any]:
        """The full configuration: the defaults updated by `given`; unknown keys refused."""
        unknown = sorted(set(given) - set(self.defaults))
        if unknown:
            raise ValueError(
                f"trial kind {self.name!r} has no setting {', '.join(unknown)}; "
                f"its settings: {', '.join(self.defaults)}"
            )
        return {**self.defaults, **given}


def _nav(config: dict[str, Any], seed: int, out: Path) -> Outcome:
    from robotrial.model import load_world
    from robotrial.trials.nav import NavTrialSetup, run_once

    goal = config["goal"]
    if goal is None:
        world = load_world(config["world"])
        if "goal" not in world.spawns:
            raise ValueError(f"world {world.name!r} has no `goal` spawn; set goal=X,Y,YAW")
        p = world.spawn("goal")
        goal = (float(p.xyz[0]), float(p.xyz[1]), float(p.yaw))
    setup = NavTrialSetup(
        world=config["world"],
        goal=tuple(goal),
        start=config["start"],
        robot=config["robot"],
        speed=float(config["speed"]),
        planner=config["planner"],
        time_limit=config["time_limit"],
    )
    r = run_once(setup, seed)
    return Outcome(r.success, r.summary(), {})


@cache
def _planning_problem(robot: str, scene: str, planner: str):
    """The problem and its checker, after one short untimed query: the first call in a
    process compiles the planner (or loads numba's cache), which is not planning time."""
    from robotrial.model import load_robot, load_world
    from robotrial.planning import Problem, planner_class
    from robotrial.planning.problems import SCENES, desk_task, scene_problem

    if scene == "desk":
        prob = desk_task(load_robot(robot), load_world("desk"))
    elif scene in SCENES:
        prob = scene_problem(load_robot(robot), scene)
    else:
        raise ValueError(f"unknown planning scene {scene!r}; choose desk or {', '.join(SCENES)}")
    checker = prob.checker()
    planner_class(planner)().solve(Problem(prob.start, prob.goal[None], 0.05, 12345), checker)
    return prob, checker


def _plan(config: dict[str, Any], seed: int, out: Path) -> Outcome:
    from robotrial.planning import Problem, planner_class

    prob, checker = _planning_problem(config["robot"], config["scene"], config["planner"])
    planner = planner_class(config["planner"])()
    res = planner.solve(
        Problem(prob.start, prob.goal[None], float(config["time_limit"]), seed), checker
    )
    figures = {
        "status": res.status,
        "planning_time": res.planning_time,
        "path_length": res.stats.get("path_length") if res.success else None,
        "waypoints": len(res.path),
    }
    return Outcome(res.success, figures, {})


def _slam(config: dict[str, Any], seed: int, out: Path) -> Outcome:
    from robotrial.model import load_world
    from robotrial.trials import slam

    world = load_world(config["world"])
    route = slam.ROUTES.get(world.name)
    rec = slam.record_drive(
        world,
        None,
        float(config["duration"]),
        speed=float(config["speed"]),
        seed=seed,
        route=route,
    )
    run = slam.run_slam(config["method"], rec)
    size = slam.room_size(world) if world.name.startswith("room_") else None
    figures = slam.score(run, rec, world, size)
    out.mkdir(parents=True, exist_ok=True)
    files = slam.write_outputs(run, rec, world, out / f"{world.name}_{config['method']}")
    return Outcome(None, figures, files)


def _g2r(config: dict[str, Any], seed: int, out: Path) -> Outcome:
    from robotrial.trials.g2r import desk_run

    return desk_run(bool(config["obstacle"]), str(config["planner"]), seed, out)


def _carry(config: dict[str, Any], seed: int, out: Path) -> Outcome:
    from robotrial.trials.carry import CarrySetup, run_carry

    setup = CarrySetup(**config)
    run_dir = out / f"carry_{setup.object}_{setup.to}"
    r = run_carry(setup, seed, run_dir)
    files = {k: str(run_dir / f"carry_{seed}.{k}") for k in ("mcap", "json", "png")}
    return Outcome(r.success, r.summary(), files)


KINDS: dict[str, TrialKind] = {
    "nav": TrialKind(
        "nav",
        {
            "world": "room_a",
            "goal": None,
            "start": "default",
            "robot": "mobile_manipulator",
            "speed": 0.3,
            "planner": DEFAULT_PLANNER,
            "time_limit": None,
        },
        "time",
        _nav,
    ),
    "plan": TrialKind(
        "plan",
        {"robot": "desk_arm", "scene": "desk", "planner": "rrt_connect", "time_limit": 5.0},
        "planning_time",
        _plan,
    ),
    "g2r": TrialKind("g2r", {"obstacle": True, "planner": "rrt_connect"}, "ee_deviation", _g2r),
    "carry": TrialKind(
        "carry",
        {
            "world": "apartment",
            "object": "cup",
            "to": "bedroom",
            "slam": "graph",
            "speed": 0.5,
            "mapping": "route",
        },
        "sim_time",
        _carry,
    ),
    "slam": TrialKind(
        "slam",
        {"world": "room_a", "method": "gmapping", "duration": 120.0, "speed": 0.3},
        "ate.rmse",
        _slam,
    ),
}


def trial_kind(name: str) -> TrialKind:
    """The kind called `name`, or an error that lists the kinds."""
    if name not in KINDS:
        raise ValueError(f"unknown trial kind {name!r}; choose one of {', '.join(KINDS)}")
    return KINDS[name]
