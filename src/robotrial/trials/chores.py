"""Chores in a buyer's verdict: "take the cup to the bedroom", run as carry trials
(layer 5).

A chore is an (object, destination room) pair, written `cup:bedroom`; the object may
name the furniture it should be on, `cup@kitchen_table:bedroom` (the robot looks there
first and says whether it was there). Each runs as the
carry trial (`trials/carry.py`: map, search, navigate, pick, carry, place, with the
robot side seeing only through its sensors) over a few seeds; the verdict keeps the
success rate, the simulated time of the successful runs, and the phase each failure
stopped in with its cause and reason. What the carry trial needs from the world (a
movable object of that name, a room with a `place`; a mapping route, which it makes for
a home without one) is checked by the trial itself; a chore it refuses is reported with
the trial's reason, not raised.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.model.robot import RobotModel
from robotrial.model.world import World


def parse_chore(text: str) -> tuple[str, str]:
    """`object:room` (or `object@furniture:room`) to (object, room); a clear error for
    anything else."""
    obj, sep, room = str(text).partition(":")
    if not sep or not obj.strip() or not room.strip():
        raise ValueError(f"chore {text!r}: write it as OBJECT:ROOM, e.g. cup:bedroom")
    split_object(obj, text)
    return obj.strip(), room.strip()


def split_object(obj: str, chore: str = "") -> tuple[str, str]:
    """A chore's object, `cup` or `cup@kitchen_table` (the furniture it should be on), to
    (object, furniture or "")."""
    name, at, on = obj.partition("@")
    if at and (not name.strip() or not on.strip()):
        raise ValueError(
            f"chore {chore or obj!r}: name the furniture after the object, e.g. "
            "cup@kitchen_table:bedroom"
        )
    return name.strip(), on.strip()


def room_of(world: World, obj: Any) -> str:
    """The name of the first room of `world` that holds `obj`'s centre, or "" when none."""
    x, y = obj.pose.xyz[:2]
    return next((r.name for r in world.rooms if r.contains(x, y)), "")


def home_chores(world: World, n: int = 3) -> list[tuple[str, str]]:
    """Up to `n` chores a world offers: each movable object standing in a room, to
    another room with a place to set it down; one chore per object before any object
    gets a second (objects and rooms in the world's order)."""
    options: list[list[tuple[str, str]]] = []
    for ob in world.objects:
        inside = room_of(world, ob)
        if inside:
            to = [r.name for r in world.rooms if r.place is not None and r.name != inside]
            options.append([(ob.name, room) for room in to])
    out: list[tuple[str, str]] = []
    for k in range(max((len(o) for o in options), default=0)):
        out += [o[k] for o in options if k < len(o)]
    return out[:n]


PHASE_SHARES = {
    "mapping": "exploring",
    "search": "searching",
    "navigation": "navigating",
    "carry": "navigating",
    "pick": "manipulating",
    "place": "manipulating",
}


def time_shares(phases: Sequence[dict[str, Any]]) -> dict[str, float]:
    """A run's simulated time (s) spent exploring, navigating, searching and
    manipulating, from its phases (`PHASE_SHARES`: the carry phase, driving to the place
    with the object held, counts as navigating)."""
    shares = dict.fromkeys(("exploring", "navigating", "searching", "manipulating"), 0.0)
    for p in phases:
        what = PHASE_SHARES.get(p["phase"])
        if what is not None:
            shares[what] = round(shares[what] + float(p["time"]), 2)
    return shares


@dataclass
class ChoreVerdict:
    """One chore over its seeds: successes of runs, mean simulated time (s) of the
    successful runs and its mean share exploring, navigating, searching, manipulating
    (`shares`, s; `time_shares`), the failed phases by count, each run's outcome, or why
    the trial refused it (`refused`)."""

    object: str
    room: str
    runs: int = 0
    successes: int = 0
    mean_time: float | None = None
    failed_phases: dict[str, int] = field(default_factory=dict)
    outcomes: list[dict[str, Any]] = field(default_factory=list)
    refused: str = ""
    wall_time: float = 0.0
    shares: dict[str, float] | None = None

    @property
    def name(self) -> str:
        return f"{self.object}:{self.room}"

    @property
    def done(self) -> bool:
        """Done when every run succeeded (a chore that fails now and then is not done)."""
        return self.runs > 0 and self.successes == self.runs

    @property
    def rate(self) -> float:
        return self.successes / self.runs if self.runs else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "chore": self.name,
            "object": self.object,
            "room": self.room,
            "runs": self.runs,
            "successes": self.successes,
            "success_rate": round(self.rate, 3),
            "done": self.done,
            "mean_time": None if self.mean_time is None else round(self.mean_time, 2),
            "shares": self.shares,
            "failed_phases": self.failed_phases,
            "outcomes": self.outcomes,
            "refused": self.refused,
            "wall_time": round(self.wall_time, 2),
        }


def _world_ref(world: World) -> str | World:
    """What the carry trial is given: the built-in name when the trial knows its route,
    else the file the world came from, else the World itself (a home sent as YAML); the
    trial makes a mapping route for a world without one."""
    from robotrial.trials.carry import ROUTES

    if world.name in ROUTES:
        return world.name
    if world.source and Path(world.source).exists():
        return world.source
    return world


def _unable(robot: str | RobotModel) -> str:
    """Why this robot cannot do any chore (the carry trial maps the home with a LiDAR and
    carries with an arm and a gripper; it loads the robot by name or file), or ""."""
    from robotrial.model import load_robot
    from robotrial.trials.reach import arm_joints

    if isinstance(robot, RobotModel):
        return (
            f"robot {robot.name!r} is not a built-in robot or a file: the carry trial loads "
            "the robot it runs by name"
        )
    model = load_robot(robot)
    missing = [
        what
        for what, has in (
            ("LiDAR to map the home", any(s.type == "lidar" for s in model.sensors)),
            ("arm", bool(arm_joints(model))),
            ("gripper", bool((model.metadata or {}).get("gripper"))),
        )
        if not has
    ]
    if not missing:
        return ""
    listed = ", no ".join(missing[:-1]) + (" and no " if len(missing) > 1 else "") + missing[-1]
    return f"robot {robot!r} has no {listed}: it cannot do chores"


def run_chores(
    world: World,
    robot: str | RobotModel,
    chores: Sequence[tuple[str, str]],
    seeds: int = 3,
    progress: Callable[[float, str], None] | None = None,
) -> list[ChoreVerdict]:
    """Each chore as `seeds` carry trials (seeds 0 .. seeds - 1)."""
    from robotrial.trials.carry import PHASES, CarrySetup, run_carry

    if seeds < 1:
        raise ValueError(f"chores: seeds must be at least 1, got {seeds}")
    unable = _unable(robot)
    out = []
    total = max(1, len(chores) * seeds)
    for i, (obj, room) in enumerate(chores):
        v = ChoreVerdict(obj, room)
        t0 = time.perf_counter()
        times = []
        for seed in range(seeds if not unable else 0):
            name = robot if isinstance(robot, str) else robot.name
            thing, on = split_object(obj)
            setup = CarrySetup(world=_world_ref(world), object=thing, to=room, robot=name, on=on)
            done, label = i * seeds + seed, f"chore {obj}:{room}, seed {seed}"

            def phase(name: str, _sim_time: float, done: int = done, label: str = label) -> None:
                if progress is not None:
                    k = PHASES.index(name) if name in PHASES else 0
                    progress((done + (k + 0.5) / len(PHASES)) / total, f"{label}: {name}")

            if progress is not None:
                progress(done / total, label)
            try:
                r = run_carry(setup, seed, None, phase)
            except (ValueError, KeyError, OSError) as exc:
                v.refused = str(exc.args[0]) if isinstance(exc, KeyError) else str(exc)
                break
            v.runs += 1
            v.outcomes.append(
                {
                    "seed": seed,
                    "success": r.success,
                    "failed_phase": r.failed_phase,
                    "cause": r.cause,
                    "reason": r.reason,
                    "sim_time": round(r.sim_time, 2),
                    "shares": time_shares(r.phases),
                    "found": r.found,
                }
            )
            if r.success:
                v.successes += 1
                times.append(r.sim_time)
            else:
                v.failed_phases[r.failed_phase] = v.failed_phases.get(r.failed_phase, 0) + 1
        v.refused = v.refused or unable
        v.mean_time = float(np.mean(times)) if times else None
        done = [o["shares"] for o in v.outcomes if o["success"]]
        if done:
            v.shares = {k: round(float(np.mean([d[k] for d in done])), 2) for k in done[0]}
        v.wall_time = time.perf_counter() - t0
        out.append(v)
    return out
