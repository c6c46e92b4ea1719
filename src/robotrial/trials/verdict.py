"""Will this robot fit in my home? A buyer's verdict (layer 5).

The API the web server and the CLI call:

- `check_home(world, robot_name, *, chores=(), seeds=3, progress=None) -> HomeVerdict`:
  the whole verdict for one robot (a name, a robot file or a RobotModel);
  `progress(fraction, what)` is told how far it got.
- `HomeVerdict.to_dict()`: JSON-safe figures: `summary` (one line), `base` (the rooms,
  as `BaseVerdict.to_dict`), `reach` (furniture surfaces with heat maps, heights),
  `chores` (None when none were asked).
- `compare(verdicts) -> dict`: two (or more) robots side by side, row by row, with the
  rows whose values differ marked.
- `to_html(verdicts) -> str`: one printable page (one column per robot);
  `pictures(verdict) -> dict[str, bytes]`: the PNG pictures (floor plan, reach maps,
  heights); `write_page(verdicts, path)`: the page as PDF or PNG; `plot(base, world)`: the
  rooms' floor plan alone (trials/verdict_page.py).

The parts:

1. Base (`check_base`). For each room of a world (its `rooms` rectangles), Hybrid-A* with
   the robot's real rectangular footprint plans from the dock (the `default` spawn) to
   the room's most open spot: the room is reachable when a plan exists. Along the plan,
   the narrowest clearance the base passes (twice the distance from its centre line to
   the nearest obstacle) is the passage that room asks for, judged against the
   footprint: green when the base could also turn on the spot there (wider than its
   turning circle), amber when it passes but cannot turn, red when no plan gets there.
2. Arm (trials/reach.py): how much of each furniture top the hand reaches with the base
   parked where it can get to, as heat maps; the lowest and highest heights it reaches.
3. Chores (trials/chores.py): (object, room) pairs run as carry trials over seeds.

`drive_to_rooms(base, world, robot)` checks the rooms part by driving (the navigation
trial); `robotrial bench verdict` runs it on the apartment.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from robotrial.model.anatomy import base_links, has_wheels
from robotrial.model.gridmap import NavMap, world_map
from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.hybrid import HybridAStar
from robotrial.nav.planners import NoPath, StartBlocked
from robotrial.nav.tour import open_spot
from robotrial.trials.chores import ChoreVerdict
from robotrial.trials.reach import ReachVerdict


@dataclass
class RoomVerdict:
    """One room: reachable from the dock, the narrowest passage on the way (m), the
    colour (green, amber, red), the route's length (m) and the planner's time (ms)."""

    room: str
    reachable: bool
    colour: str
    passage: float | None
    route_length: float | None
    plan_ms: float
    reason: str = ""
    route: np.ndarray | None = field(default=None, repr=False)  # (N, 2) points
    goal: tuple[float, float] | None = None  # the room's most open spot, planned to


@dataclass
class BaseVerdict:
    world: str
    robot: str
    footprint: tuple[float, float]
    turning_diameter: float
    dock: tuple[float, float, float]
    rooms: list[RoomVerdict]
    seconds: float

    @property
    def summary(self) -> str:
        fits = sum(r.reachable for r in self.rooms)
        amber = [r.room for r in self.rooms if r.colour == "amber"]
        red = [r.room for r in self.rooms if r.colour == "red"]
        out = f"fits: {fits} of {len(self.rooms)} rooms"
        if red:
            out += f"; cannot reach {', '.join(red)}"
        if amber:
            out += f"; tight (cannot turn on the way): {', '.join(amber)}"
        return out

    def to_dict(self) -> dict[str, Any]:
        out = {**asdict(self), "summary": self.summary}
        for room in out["rooms"]:
            room.pop("route")
        return out


def check_base(
    world: World, footprint: Footprint, robot: str = "", grid: NavMap | None = None
) -> BaseVerdict:
    """Reachability of every room from the dock for `footprint` (see the module doc);
    `grid` is the world's navigation grid when the caller has it already."""
    t0 = time.perf_counter()
    if not world.rooms:
        raise ValueError(f"world {world.name!r} names no rooms: give `rooms` in its YAML")
    grid = grid if grid is not None else world_map(world)
    origin, res = np.asarray(grid.origin, dtype=float), grid.resolution
    clearance = ndimage.distance_transform_edt(~grid.occupied) * res
    costmap = Costmap(grid.occupied, tuple(origin), res, footprint)
    dock_pose = world.spawn("default")
    dock = (float(dock_pose.xyz[0]), float(dock_pose.xyz[1]), float(dock_pose.yaw))
    turning = float(np.hypot(footprint.length, footprint.width))
    planner = HybridAStar()
    rooms = []
    for room in world.rooms:
        goal = open_spot(clearance, origin, res, room.bounds)
        t = time.perf_counter()
        try:
            route = planner.plan(costmap, dock, goal)  # points about a cell apart
        except (NoPath, StartBlocked) as exc:
            ms = 1e3 * (time.perf_counter() - t)
            rooms.append(RoomVerdict(room.name, False, "red", None, None, ms, str(exc), goal=goal))
            continue
        ms = 1e3 * (time.perf_counter() - t)
        cells = np.floor((route - origin) / res).astype(int)
        rows, cols = clearance.shape
        cells[:, 0] = np.clip(cells[:, 0], 0, cols - 1)
        cells[:, 1] = np.clip(cells[:, 1], 0, rows - 1)
        passage = float(2 * clearance[cells[:, 1], cells[:, 0]].min())
        length = float(np.sum(np.linalg.norm(np.diff(route, axis=0), axis=1)))
        colour = "green" if passage >= turning else "amber"
        rooms.append(
            RoomVerdict(room.name, True, colour, passage, length, ms, route=route, goal=goal)
        )
    return BaseVerdict(
        world.name,
        robot,
        (footprint.length, footprint.width),
        turning,
        dock,
        rooms,
        time.perf_counter() - t0,
    )


class VerdictError(ValueError):
    """A verdict that cannot be given as asked (the message names the robot or world)."""


@dataclass
class HomeVerdict:
    """The verdict for one robot in one home: the base part, the arm part, the chores
    (None when none were asked), the wall time (s) and the time of each part."""

    world: str
    robot: str
    base: BaseVerdict
    reach: ReachVerdict
    chores: list[ChoreVerdict] | None
    seconds: float
    timings: dict[str, float] = field(default_factory=dict)
    home: World | None = field(default=None, repr=False)
    cpu_seconds: float = 0.0  # this process's CPU time: the wall time on an idle core

    @property
    def summary(self) -> str:
        """One line: "fits: 4 of 5 rooms (not study); reaches: ...; chores: 2 of 3"."""
        rooms = self.base.rooms
        red = [r.room for r in rooms if not r.reachable]
        out = f"fits: {sum(r.reachable for r in rooms)} of {len(rooms)} rooms"
        if red:
            out += f" (not {', '.join(red)})"
        out += f"; {self.reach.summary}"
        if self.chores is not None:
            out += f"; chores: {sum(c.done for c in self.chores)} of {len(self.chores)}"
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "world": self.world,
            "robot": self.robot,
            "summary": self.summary,
            "base": self.base.to_dict(),
            "reach": self.reach.to_dict(),
            "chores": None if self.chores is None else [c.to_dict() for c in self.chores],
            "seconds": round(self.seconds, 3),
            "cpu_seconds": round(self.cpu_seconds, 3),
            "timings": {k: round(v, 3) for k, v in self.timings.items()},
        }


def has_base(robot: RobotModel) -> bool:
    """Whether the robot drives about: its description gives a `drive`, or its tree has
    wheels (model/anatomy.py), as a base of the user's own does."""
    return bool((robot.metadata or {}).get("drive")) or has_wheels(robot)


def check_home(
    world: World | str,
    robot_name: str | RobotModel,
    *,
    chores: Sequence[tuple[str, str] | str] = (),
    seeds: int = 3,
    progress: Callable[[float, str], None] | None = None,
) -> HomeVerdict:
    """The buyer's verdict for one robot (a built-in name, a robot file or a RobotModel,
    e.g. one uploaded to the server) in a home (a World, a built-in name or a World
    YAML): rooms, reach, and the `chores` ("cup:bedroom" or ("cup", "bedroom")) as carry
    trials over `seeds` seeds. Raises VerdictError for a robot without a mobile base or a
    home it cannot judge; ModelError, KeyError or FileNotFoundError for a robot or world
    that does not load."""
    from robotrial.model import load_robot, load_world
    from robotrial.model.library import robot_names
    from robotrial.nav.reachable import reachable_poses
    from robotrial.trials.chores import parse_chore, run_chores
    from robotrial.trials.nav import footprint_of_robot
    from robotrial.trials.reach import arm_joints, check_reach

    t0, cpu0 = time.perf_counter(), time.process_time()
    tell = progress or (lambda fraction, what: None)
    wanted = [parse_chore(c) if isinstance(c, str) else (str(c[0]), str(c[1])) for c in chores]
    if wanted and seeds < 1:
        raise VerdictError(f"chores: seeds must be at least 1, got {seeds}")
    home = world if isinstance(world, World) else load_world(world)
    if not home.rooms:
        raise VerdictError(f"world {home.name!r} names no rooms: give `rooms` in its YAML")
    robot = robot_name if isinstance(robot_name, RobotModel) else load_robot(robot_name)
    robot_name = robot_name if isinstance(robot_name, str) else robot.name
    if not has_base(robot):
        raise VerdictError(
            f"robot {robot_name!r} has no mobile base (no `drive` in its description, no "
            "wheels in its tree): it stays where it is put, so it cannot be tried around a "
            "home; try mobile_manipulator or husky"
        )
    share = (0.05, 0.15, 0.25, 1.0) if not wanted else (0.02, 0.06, 0.1, 0.25)
    timings: dict[str, float] = {}
    # a base of the user's own (wheels, no `drive`): its own links make the footprint,
    # without the arm it may carry, and only the rooms part is judged
    own = not (robot.metadata or {}).get("drive")
    tell(0.0, "footprint")
    t = time.perf_counter()
    footprint = footprint_of_robot(robot, home, base_links(robot) if own else None)
    timings["footprint"] = time.perf_counter() - t
    tell(share[0], "rooms")
    t = time.perf_counter()
    grid = world_map(home)
    base = check_base(home, footprint, robot_name, grid)
    timings["base"] = time.perf_counter() - t
    reachable, stuck = None, ""
    if own and arm_joints(robot):
        stuck = (
            "reach not checked: a base whose description gives no drive is judged on its "
            "rooms and passages only"
        )
    elif arm_joints(robot):  # where the base can park matters only to an arm
        tell(share[1], "parking poses")
        t = time.perf_counter()
        costmap = Costmap(grid.occupied, tuple(grid.origin), grid.resolution, footprint)
        try:
            reachable = reachable_poses(costmap, base.dock)
        except ValueError as exc:  # the base does not fit at the dock: it parks nowhere
            stuck = f"reach not checked: at the dock, {exc}"
        timings["parking"] = time.perf_counter() - t
    t = time.perf_counter()
    if stuck:
        reach = ReachVerdict(False, stuck)
    else:
        reach = check_reach(
            home,
            robot,
            footprint,
            reachable,
            lambda f, what: tell(share[2] + f * (share[3] - share[2]), what),
        )
    timings["reach"] = time.perf_counter() - t
    done: list[ChoreVerdict] | None = None
    if wanted:
        t = time.perf_counter()
        done = run_chores(
            home,
            robot_name if robot_name in robot_names() or Path(robot_name).exists() else robot,
            wanted,
            seeds,
            lambda f, what: tell(share[3] + f * (1.0 - share[3]), what),
        )
        timings["chores"] = time.perf_counter() - t
    tell(1.0, "done")
    return HomeVerdict(
        home.name,
        robot_name,
        base,
        reach,
        done,
        time.perf_counter() - t0,
        timings,
        home,
        time.process_time() - cpu0,
    )


def _percent(v: float | None) -> str:
    return "" if v is None else f"{100 * v:.0f} %"


def compare(verdicts: Sequence[HomeVerdict]) -> dict[str, Any]:
    """Robots side by side: `robots`, `rows` (each `part`, `item`, `values` as text, one
    per robot, and `differ`), and each robot's full figures under `verdicts`."""
    if not verdicts:
        raise VerdictError("compare: no verdicts given")
    rows: list[dict[str, Any]] = []

    def row(part: str, item: str, values: list[str]) -> None:
        rows.append({"part": part, "item": item, "values": values, "differ": len(set(values)) > 1})

    row("summary", "summary", [v.summary for v in verdicts])
    row(
        "base",
        "footprint (m)",
        [f"{v.base.footprint[0]:.2f} x {v.base.footprint[1]:.2f}" for v in verdicts],
    )
    rooms = list(dict.fromkeys(r.room for v in verdicts for r in v.base.rooms))
    for name in rooms:
        values = []
        for v in verdicts:
            r = next((r for r in v.base.rooms if r.room == name), None)
            if r is None:
                values.append("")
            elif r.passage is None:
                values.append(r.colour)
            else:
                values.append(f"{r.colour} ({r.passage:.2f} m)")
        row("rooms", name, values)
    names = list(
        dict.fromkeys(s.surface for v in verdicts for s in v.reach.surfaces if v.reach.checked)
    )
    for name in names:
        values = []
        for v in verdicts:
            s = next((s for s in v.reach.surfaces if s.surface == name), None)
            values.append(v.reach.reason if s is None else f"{s.verdict} ({_percent(s.share)})")
        row("reach", name, values)
    spans = []
    for v in verdicts:
        span = v.reach.heights.span if v.reach.heights is not None else None
        spans.append(v.reach.reason or "none" if span is None else f"{span[0]:.2f}-{span[1]:.2f}")
    row("reach", "heights (m)", spans)
    chores = list(dict.fromkeys(c.name for v in verdicts for c in v.chores or []))
    for name in chores:
        values = []
        for v in verdicts:
            c = next((c for c in v.chores or [] if c.name == name), None)
            if c is None:
                values.append("")
            elif c.refused:
                values.append(f"refused: {c.refused}")
            else:
                text = f"{c.successes} of {c.runs}"
                if c.mean_time is not None:
                    text += f", {c.mean_time:.0f} s"
                if c.failed_phases:
                    failed = ", ".join(f"{p} {n}" for p, n in c.failed_phases.items())
                    text += f"; failed in {failed}"
                values.append(text)
        row("chores", name, values)
    return {
        "robots": [v.robot for v in verdicts],
        "world": verdicts[0].world,
        "rows": rows,
        "verdicts": [v.to_dict() for v in verdicts],
    }


def drive_to_rooms(
    verdict: BaseVerdict, world: World, robot: str, seed: int = 0, speed: float = 0.5
) -> list[dict[str, Any]]:
    """The verdict checked by driving: the navigation trial (AMCL in MuJoCo, the default
    stack: Hybrid-A* and the speed profile) from the dock to each room's goal,
    one run per room with `seed`. Each row: the room, what the verdict said, whether the
    robot got there, and how."""
    from robotrial.trials.nav import NavTrialSetup, run_once

    rows = []
    for room in verdict.rooms:
        if room.goal is None:
            raise VerdictError(f"room {room.room!r}: the verdict kept no goal to drive to")
        route = room.route
        yaw = 0.0
        if route is not None and len(route) > 1:
            yaw = float(np.arctan2(*(route[-1] - route[-2])[::-1]))
        setup = NavTrialSetup(
            world=world.name,
            goal=(room.goal[0], room.goal[1], yaw),
            start=verdict.dock,
            robot=robot,
            speed=speed,
        )
        run = run_once(setup, seed, world=world)
        rows.append(
            {
                "room": room.room,
                "verdict": room.colour,
                "reachable": room.reachable,
                "driven": run.success,
                "agrees": run.success == room.reachable,
                "time": round(run.time, 2),
                "message": run.message,
            }
        )
    return rows


# the page and the pictures live beside the engine; their names are part of this API
from robotrial.trials.verdict_page import pictures, plot, to_html, write_page  # noqa: E402

__all__ = [
    "BaseVerdict",
    "HomeVerdict",
    "RoomVerdict",
    "VerdictError",
    "check_base",
    "check_home",
    "compare",
    "drive_to_rooms",
    "pictures",
    "plot",
    "to_html",
    "write_page",
]
