"""The carry task, as the robot runs it: map, search, navigate, pick, carry, place
(layer 4).

What the robot is told is a plan of the home and an order in words: where it starts on
the plan, the rooms as rectangles of the plan, a route to map the home along or none, to
explore it on its own (`Plan`), and "bring the cup from the living room to the bedroom,
here" (`CarryOrder`: the object's kind, the room it is in, the room to take it to and the
point there to set it down).
Nothing in either says where an object or a piece of furniture stands. The plan's frame
is the home's; the robot's map starts where it starts, so the plan's points enter the
map frame through the start pose.

`CarryTask.tick()` advances the task by one control period; a skill's failure ends it
with the phase it happened in, the skill's cause and its reason.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robotrial.nav.amcl import compose, inverse
from robotrial.onboard.skills import SkillFailed, Skills

PHASES = ("mapping", "search", "navigation", "pick", "carry", "place")

Rect = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class Plan:
    """What the robot knows of the home before it starts: its start pose on the plan
    (x, y, yaw), the rooms (name -> ((xmin, ymin), (xmax, ymax)) on the plan) and the
    route to map the home along (plan x, y; empty: the robot explores on its own)."""

    start: tuple[float, float, float]
    rooms: dict[str, Rect]
    route: tuple[tuple[float, float], ...]

    def to_map(self, x: float, y: float) -> np.ndarray:
        """A plan point in the robot's map frame (which starts at the start pose)."""
        return compose(inverse(np.asarray(self.start, dtype=float)), np.array([x, y, 0.0]))[:2]

    def room_in_map(self, name: str) -> Rect:
        """A room's rectangle in the map frame (the box around its corners when the
        start is turned)."""
        if name not in self.rooms:
            have = ", ".join(self.rooms) or "none"
            raise KeyError(f"the plan has no room {name!r}; its rooms: {have}")
        return self.rect_in_map(self.rooms[name])

    def rect_in_map(self, rect: Rect) -> Rect:
        """A rectangle of the plan in the map frame (the box around its corners)."""
        (x0, y0), (x1, y1) = rect
        corners = np.array([self.to_map(x, y) for x in (x0, x1) for y in (y0, y1)])
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        return (float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1]))


@dataclass(frozen=True)
class CarryOrder:
    """Bring the `object` (a kind of the catalogue) from room `find_in` to room `to` and
    set it down at `place` (plan x, y); `on`, when the order names it, the furniture the
    object should be on, with its outline on the plan ("the cup on the kitchen table")."""

    object: str
    find_in: str
    to: str
    place: tuple[float, float]
    on: tuple[str, Rect] | None = None


@dataclass
class Outcome:
    """How far the task got: each phase's start and length (simulated s) and wall time,
    and, when it failed, the phase, the cause and the reason."""

    phases: list[dict[str, Any]] = field(default_factory=list)
    done: bool = False
    phase: str = ""
    cause: str = ""
    reason: str = ""


class CarryTask:
    """The carry task over a robot's skills."""

    def __init__(self, skills: Skills, plan: Plan, order: CarryOrder, speed: float) -> None:
        self.skills = skills
        self.plan = plan
        self.order = order
        self.speed = float(speed)
        self.kind = skills.catalogue.kind(order.object)
        for room in (order.find_in, order.to):
            plan.room_in_map(room)
        self.outcome = Outcome()
        self._phase: dict[str, Any] | None = None
        self._steps: Iterator[None] = self._run()

    @property
    def phase(self) -> str:
        return self._phase["phase"] if self._phase else ""

    @property
    def finished(self) -> bool:
        return self.outcome.done or bool(self.outcome.cause)

    def tick(self) -> None:
        """One control period of the task."""
        if self.finished:
            return
        try:
            next(self._steps)
        except StopIteration:
            self._end_phase()
            self.outcome.done = True
        except SkillFailed as exc:
            self.fail(exc.cause, exc.reason)

    def fail(self, cause: str, reason: str) -> None:
        """End the task in the current phase (also for what the world says: a contact, the
        time limit)."""
        if self.finished:
            return
        self.outcome.phase = self.phase or PHASES[0]
        self.outcome.cause, self.outcome.reason = cause, reason
        self._end_phase()

    def _begin(self, name: str) -> None:
        self._end_phase()
        self._phase = {"phase": name, "start": self.skills.robot.now, "wall": time.perf_counter()}
        self.skills.log.phase = name

    def _end_phase(self) -> None:
        if self._phase is None:
            return
        p = self._phase
        self.outcome.phases.append(
            {
                "phase": p["phase"],
                "start": round(p["start"], 2),
                "time": round(self.skills.robot.now - p["start"], 2),
                "wall_time": round(time.perf_counter() - p["wall"], 2),
            }
        )
        self._phase = None

    def _run(self) -> Iterator[None]:
        s, plan, order = self.skills, self.plan, self.order
        self._begin("mapping")
        route = [tuple(plan.to_map(x, y)) for x, y in plan.route]
        yield from s.explore(route, self.speed)  # type: ignore[arg-type]
        yield from s.start_navigation()
        self._begin("search")
        on = None if order.on is None else (order.on[0], plan.rect_in_map(order.on[1]))
        bounds = plan.room_in_map(order.find_in)
        seen = yield from s.search(self.kind, order.find_in, bounds, on)
        self._begin("navigation")
        seen = yield from s.approach(seen, bounds)
        self._begin("pick")
        yield from s.pick(seen)
        self._begin("carry")
        point = plan.to_map(*order.place)
        height = yield from s.carry_to(point, plan.room_in_map(order.to))
        self._begin("place")
        yield from s.place(point, height)
