"""The navigator: global plan, local control, recoveries and a final status (move_base's
role) (layer 3).

`Navigator.step` is called at the control rate with the robot's pose on the map, its
velocity and (when a new scan arrived) the scan's end points on the map. It

1. plans a global path on the global costmap (again every `replan_period` s, and when
   the path runs into a newly seen obstacle),
2. asks the DWA local planner for (v, w) on a rolling local costmap (static map window
   plus the current scan),
3. near the goal, stops on it and turns in place to the goal's heading (with a
   footprint plan only where that turn keeps the rectangle clear; elsewhere, as a
   few cm past a doorway with the rear still in it, it follows the plan's own turns),
4. when no admissible arc exists or the robot has not made progress for
   `progress_timeout` s, runs the recovery behaviours in order: clear the costmaps'
   obstacle layers, rotate in place, back up; after the last one fails it aborts. A
   base that already touches something (as mapped) may still turn or back up where
   that takes it clear or further from it.

Where the map shows the base touching something, or nearer than the footprint
planner's margin, no plan starts: the navigator first makes the least turn on the spot
and straight drive that gets it clear without going nearer (`goals.escape_move`, up to
ESCAPES times a goal), as the base stands there and the map is a few cm off.

A replan that finds no way while the base follows a plan does not stop it: it keeps to
that plan for `planner_patience` s (move_base's planner patience), as a base swinging
into a doorway a little askew, from where the footprint planner's turns on the spot
find nothing, is then through it a moment later.

The final status is SUCCEEDED or ABORTED with a message saying why (no path, stuck
after every recovery, time limit).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from robotrial.nav import DEFAULT_PLANNER, default_controller
from robotrial.nav.costmap import Costmap, Footprint, Inflation, coarsen
from robotrial.nav.dwa import DWAConfig, DWAPlanner, DWAResult, footprint_clearance, rollout
from robotrial.nav.goals import escape_move
from robotrial.nav.hybrid import HybridAStar, HybridConfig, footprint_hits, resample
from robotrial.nav.planners import PLANNERS, NoPath, StartBlocked, make_planner, smooth
from robotrial.nav.profile import ProfileConfig, ProfileController, rectangle_clearance
from robotrial.nav.pursuit import PursuitConfig, PursuitController

GLOBAL_PLANNERS = (*PLANNERS, "hybrid", "auto")
CONTROLLERS = ("dwa", "pursuit", "profile")


class Status(Enum):
    IDLE = "idle"
    ACTIVE = "active"
    SUCCEEDED = "succeeded"
    ABORTED = "aborted"


class Recovery(Enum):
    CLEAR_COSTMAPS = "clear_costmaps"
    ROTATE = "rotate"
    BACK_UP = "back_up"
    ESCAPE = "escape"  # not in the order of recoveries: before planning, from a touching pose


RECOVERY_WORDS = {
    Recovery.CLEAR_COSTMAPS.value: "clearing the costmaps",
    Recovery.ROTATE.value: "rotating in place",
    Recovery.BACK_UP.value: "backing up",
    Recovery.ESCAPE.value: "getting clear of what the map shows it touching",
}
ESCAPES = 3  # escapes from a touching pose a goal may start


@dataclass(frozen=True)
class NavigatorConfig:
    """Tolerances (m, rad), timing (s), local window size (m) and the sub-planners.
    `planner` (default `DEFAULT_PLANNER`): 'dijkstra' or 'astar' (the grid, the centre
    keeping the inscribed radius),
    'hybrid' (Hybrid-A* over poses with the footprint), or 'auto' (A*, and Hybrid-A*
    where the footprint facing along A*'s path would touch something). `controller`:
    'dwa', 'pursuit' (regulated pure pursuit, for footprint plans), both within the
    limits of `dwa`, or 'profile' (the fastest speed profile along the footprint plan
    that its clearance allows, tracked; within the limits of `profile`).
    `planner_patience` (s): how long the base keeps to its plan while replans find
    none. `turn_yaw_rate` (rad/s) and `turn_acc` (rad/s^2) bound the final turn in place to
    the goal's heading (None: the DWA's limits). `costmap_resolution` (m): the costmaps'
    cell size; a map at least twice as fine is coarsened to it (None: the map's)."""

    planner: str = DEFAULT_PLANNER
    hybrid: HybridConfig = field(default_factory=HybridConfig)
    controller: str | None = None
    pursuit: PursuitConfig = field(default_factory=PursuitConfig)
    profile: ProfileConfig = field(default_factory=ProfileConfig)
    xy_tolerance: float = 0.15
    yaw_tolerance: float = 0.15
    replan_period: float = 1.0
    progress_timeout: float = 8.0
    progress_distance: float = 0.15
    blocked_timeout: float = 1.0
    local_size: float = 5.0
    inflation: Inflation = field(default_factory=Inflation)
    dwa: DWAConfig = field(default_factory=DWAConfig)
    backup_distance: float = 0.3
    backup_speed: float = 0.15
    max_no_path: int = 3
    planner_patience: float = 3.0
    turn_yaw_rate: float | None = None
    turn_acc: float | None = None
    obstacle_range: float = 3.0
    costmap_resolution: float | None = 0.05


@dataclass
class _Behaviour:
    kind: Recovery
    until: float
    start_yaw: float = 0.0
    turned: float = 0.0
    last_yaw: float = 0.0
    distance: float = 0.0
    heading: float | None = None  # a back-up first turns on the spot to this yaw
    direction: float = -1.0  # then drives straight back (-1) or, an escape, maybe ahead


_ASIDE = ((0.02, 0.0), (-0.02, 0.0), (0.0, 0.02), (0.0, -0.02))


def _wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


class Navigator:
    """Drives a robot to a goal pose on a static map. Algorithms only: no topics."""

    def __init__(
        self,
        occupied: np.ndarray,
        origin: tuple[float, float],
        resolution: float,
        footprint: Footprint,
        config: NavigatorConfig = NavigatorConfig(),
        unknown: np.ndarray | None = None,
    ) -> None:
        self.config = config
        self.footprint = footprint
        self.set_map(occupied, origin, resolution, unknown)
        if config.planner not in GLOBAL_PLANNERS:
            raise ValueError(
                f"unknown global planner {config.planner!r}; choose from {list(GLOBAL_PLANNERS)}"
            )
        grid = "astar" if config.planner in ("hybrid", "auto") else config.planner
        self.planner = make_planner(grid)
        self.hybrid = HybridAStar(config.hybrid)
        # from a start already within the margin (a doorway, localization a few cm off)
        self.hybrid_tight = HybridAStar(replace(config.hybrid, margin=0.0))
        # a goal whose plan cannot end as near as asked (a rectangle that fits there only
        # at a heading it cannot turn to in place) may end within two thirds of the
        # navigator's own tolerance, as `check_goal` judges it
        self.loose_tolerance = 2.0 / 3.0 * config.xy_tolerance
        self.plans_by: list[str] = []
        kind = config.controller or default_controller(config.planner)
        if kind not in CONTROLLERS:
            raise ValueError(f"unknown controller {kind!r}; choose from {list(CONTROLLERS)}")
        self.controller_kind = kind
        # once turning on the goal, how far (in tolerances) the turn may drift: a DWA
        # stops up to twice the tolerance off (it cannot close a sideways gap); a
        # footprint plan ends on the goal pose
        self._near = 2.0 if kind == "dwa" else 1.3
        self.controller: DWAPlanner | PursuitController | ProfileController
        if kind == "dwa":
            self.controller = DWAPlanner(footprint, config.dwa)
        elif kind == "pursuit":
            self.controller = PursuitController(footprint, config.dwa, config.pursuit)
        else:
            # no faster than the top speed the navigator is given (the DWA's)
            top = min(config.profile.max_speed, config.dwa.max_speed)
            profile = replace(
                config.profile,
                max_speed=top,
                narrow_speed=min(config.profile.narrow_speed, top),
            )
            self.controller = ProfileController(footprint, profile)
        self._poses: np.ndarray | None = None
        self.local_costmap: Costmap | None = None
        self.status = Status.IDLE
        self.message = ""
        self.goal: np.ndarray | None = None
        self.path: np.ndarray | None = None
        self.plan_times: list[float] = []
        self.local_times: list[float] = []
        self.recoveries: list[str] = []
        self.last_result: DWAResult | None = None
        self._last_plan = -np.inf
        self._progress = (0.0, np.zeros(2))
        self._behaviour: _Behaviour | None = None
        self._next_recovery = 0
        self._no_path = 0
        self._failing_since: float | None = None
        self._escapes = 0
        self._planned = False
        self._rotating = False
        self._dirty = False
        self._blocked_since: float | None = None
        self._command = (0.0, 0.0)

    def set_map(
        self,
        occupied: np.ndarray,
        origin: tuple[float, float],
        resolution: float,
        unknown: np.ndarray | None = None,
    ) -> None:
        """Take a newer map (one SLAM has grown while the robot drives): the global
        costmap is built again from it, the goal stays, and the next step plans anew."""
        if self.config.costmap_resolution is not None:
            occupied, unknown, resolution = coarsen(
                occupied, unknown, resolution, self.config.costmap_resolution
            )
        self.global_costmap = Costmap(
            occupied, origin, resolution, self.footprint, self.config.inflation, unknown
        )
        self._dirty = False
        self._last_plan = -np.inf

    # --- goals -------------------------------------------------------------------------

    def set_goal(self, x: float, y: float, yaw: float, now: float = 0.0) -> None:
        """Start navigating to (x, y, yaw) on the map."""
        if not all(np.isfinite([x, y, yaw])):
            raise ValueError(f"navigator: the goal must be finite, got {(x, y, yaw)}")
        self.goal = np.array([x, y, yaw], dtype=float)
        self.status = Status.ACTIVE
        self.message = "navigating"
        self.path = None
        self._last_plan = -np.inf
        self._progress = (now, np.array([np.inf, np.inf]))
        self._behaviour = None
        self._next_recovery = 0
        self._no_path = 0
        self._failing_since = None
        self._planned = False
        self._rotating = False
        self._blocked_since = None
        self._escapes = 0
        if isinstance(self.controller, ProfileController):
            self.controller.reset()

    def back_out(self, now: float, pose: tuple[float, float, float]) -> None:
        """Begin the goal set last by backing up, as a plan that may also reverse does: a
        base that drove forwards into a pocket it cannot turn in gets out this way."""
        self.recoveries.append(Recovery.BACK_UP.value)
        self._planned = True
        here = np.asarray(pose, dtype=float)
        self._back_up(now, here, self._reverse_run(here))

    def phase(self) -> tuple[str, str]:
        """What the navigator is doing, for a status line: ('idle' | 'planning' |
        'driving' | 'recovering' | 'reached' | 'failed', details in words: the recovery
        running, the reason it failed)."""
        if self.status is Status.SUCCEEDED:
            return "reached", self.message
        if self.status is Status.ABORTED:
            return "failed", self.message
        if self.status is Status.IDLE or self.goal is None:
            return "idle", ""
        if self._behaviour is not None:
            return "recovering", RECOVERY_WORDS[self._behaviour.kind.value]
        if self._rotating:
            return "driving", "turning to the goal's heading"
        if self.path is None:
            return "planning", ""
        return "driving", ""

    def conclude(self, x: float, y: float, yaw: float, reached: bool, message: str) -> None:
        """End a goal without driving: reached (the base already stands on it) or
        refused (the message says why), as a goal judged before it starts."""
        self.goal = np.array([x, y, yaw], dtype=float)
        self.path = None
        self._finish(Status.SUCCEEDED if reached else Status.ABORTED, message)

    def cancel(self, reason: str = "cancelled") -> None:
        self._finish(Status.ABORTED, reason)

    def _finish(self, status: Status, message: str) -> None:
        self.status = status
        self.message = message
        self._behaviour = None

    # --- sensing -----------------------------------------------------------------------

    def observe(self, sensor_xy: tuple[float, float], points_xy: np.ndarray) -> None:
        """A scan's end points on the map: mark and clear the global obstacle layer and
        build the rolling local costmap around the sensor."""
        cm = self.global_costmap
        cm.mark_and_clear(sensor_xy, points_xy, mark_range=self.config.obstacle_range)
        self._dirty = True
        pts = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        near = np.hypot(*(pts - np.asarray(sensor_xy)).T) <= self.config.obstacle_range
        self.local_costmap = cm.window(sensor_xy, self.config.local_size, pts[near])

    # --- the control step --------------------------------------------------------------

    def step(
        self, now: float, pose: tuple[float, float, float], velocity: tuple[float, float]
    ) -> tuple[float, float]:
        """One control period: the (v, w) command for the base (0, 0 when done).

        `velocity` is the measured (odometry) one; the dynamic window is centred on the
        previous command, which the base follows within its own acceleration limits."""
        cmd = self._decide(now, pose, velocity)
        self._command = (float(cmd[0]), float(cmd[1]))
        return self._command

    def _decide(
        self, now: float, pose: tuple[float, float, float], velocity: tuple[float, float]
    ) -> tuple[float, float]:
        if self.status is not Status.ACTIVE or self.goal is None:
            return 0.0, 0.0
        pose_a = np.asarray(pose, dtype=float)
        goal = self.goal
        dist = float(np.hypot(*(goal[:2] - pose_a[:2])))
        if self._behaviour is not None:
            return self._recover(now, pose_a, velocity)
        if dist <= self.config.xy_tolerance or (
            self._rotating and dist <= self._near * self.config.xy_tolerance
        ):
            err = _wrap(goal[2] - pose_a[2])
            if abs(err) <= self.config.yaw_tolerance:
                self._finish(
                    Status.SUCCEEDED, f"reached the goal ({dist:.2f} m, {abs(err):.2f} rad off)"
                )
                return 0.0, 0.0
            if self._rotating or self._turn_clear(pose_a, err):
                self._rotating = True
                return 0.0, self._turn_rate(err, self._command[1])
        self._track_progress(now, pose_a)
        if self.status is not Status.ACTIVE:
            return 0.0, 0.0
        if self.path is None or now - self._last_plan >= self.config.replan_period:
            if not self._plan(now, pose_a):
                return 0.0, 0.0
        local = self.local_costmap
        if local is None:
            local = self.global_costmap.window(tuple(pose_a[:2]), self.config.local_size)
            self.local_costmap = local
        t0 = time.perf_counter()
        res = self.controller.compute(
            tuple(pose_a), self._command, self.path, local, goal_distance=dist, goal_yaw=goal[2]
        )
        self.local_times.append(time.perf_counter() - t0)
        self.last_result = res
        if not res.ok:
            # brake first; recover only if no arc opens up while stopping
            if self._blocked_since is None:
                self._blocked_since = now
            if now - self._blocked_since >= self.config.blocked_timeout:
                self._blocked_since = None
                self._start_recovery(now, pose_a)
            return 0.0, 0.0
        self._blocked_since = None
        if (
            self.controller_kind == "dwa"
            and dist <= 2 * self.config.xy_tolerance
            and abs(res.v) < 0.05
            and abs(float(velocity[0])) < 0.05
        ):
            # stopped beside the goal: a skid-steer base cannot close a sideways gap
            # without a detour, so the DWA finishes with the turn to the goal's heading
            # (a footprint plan ends on the goal pose itself, turns included)
            self._rotating = True
            return 0.0, self._turn_rate(_wrap(goal[2] - pose_a[2]), self._command[1])
        return res.v, res.w

    def _turn_clear(self, pose: np.ndarray, err: float) -> bool:
        """Whether the final turn on the spot by `err` rad from `pose` keeps the rectangle
        clear (with the footprint planner's margin). Within the tolerance of the goal a
        footprint plan may still have a manoeuvre to make: a base a few cm off a goal just
        past a doorway, its rear still in it, would sweep a jamb turning where it stands;
        it follows the plan instead, which turns where there is room. A DWA, which has no
        such plan, always turns."""
        if self.controller_kind == "dwa":
            return True
        n = max(2, int(np.ceil(abs(err) / 0.04)) + 1)
        yaw = pose[2] + np.linspace(0.0, err, n)
        sweep = np.column_stack([np.full(n, pose[0]), np.full(n, pose[1]), yaw])
        return not self.hybrid.collides(self.global_costmap, sweep).any()

    def _turn_rate(self, err: float, w0: float) -> float:
        c = self.config.dwa
        rate = self.config.turn_yaw_rate or c.max_yaw_rate
        acc = self.config.turn_acc or c.acc_lim_w
        # the fastest rate from which the turn can still stop on the heading
        w_stop = np.sqrt(2 * 0.8 * acc * abs(err))
        w = np.sign(err) * min(rate, w_stop, max(0.15, 4.0 * abs(err)))
        return float(np.clip(w, w0 - acc * c.period, w0 + acc * c.period))

    def _plan(self, now: float, pose: np.ndarray) -> bool:
        if self._dirty:
            self.global_costmap.update()
            self._dirty = False
        if self._escape(now, pose):
            return False
        t0 = time.perf_counter()
        try:
            path = self._global_path(pose)
        except NoPath as err:
            self.plan_times.append(time.perf_counter() - t0)
            self._last_plan = now
            if self.path is not None:
                if self._failing_since is None:
                    self._failing_since = now
                if now - self._failing_since < self.config.planner_patience:
                    return True  # on along the plan being followed
            self._failing_since = None
            self._no_path += 1
            if self._no_path >= self.config.max_no_path:
                self._finish(Status.ABORTED, f"no path to the goal: {err}")
            else:
                self.global_costmap.clear_obstacles()
                self._dirty = True
                run = self._reverse_run(pose)
                if self.config.planner in ("hybrid", "auto") and (
                    self._planned or (run is not None and run[1] > 0.0)
                ):
                    # the goal was reachable from an earlier pose (the base has come to
                    # one it cannot turn from: overshot a corner), or a plan that may
                    # reverse begins by backing up (the base stands in a pocket it drove
                    # into forwards, too narrow to turn in): it backs up as far as that says
                    self.recoveries.append(Recovery.BACK_UP.value)
                    self._back_up(now, pose, run)
            return False
        self.plan_times.append(time.perf_counter() - t0)
        self._no_path = 0
        self._failing_since = None
        self._planned = True
        self.path = path
        self._last_plan = now
        if isinstance(self.controller, ProfileController):
            plan = self._poses if self._poses is not None else path
            self.controller.set_path(plan, self.global_costmap, tuple(pose), self._command)
        return True

    def _global_path(self, pose: np.ndarray) -> np.ndarray:
        """The configured planner's path from `pose` to the goal; raises NoPath."""
        cm, goal = self.global_costmap, tuple(self.goal[:2])
        kind = self.config.planner
        self._poses = None
        if kind in ("hybrid", "auto"):
            if kind == "auto":
                path = smooth(self.planner.plan(cm, tuple(pose[:2]), goal), cm)
                d = np.diff(path, axis=0)
                along = np.column_stack([path[1:], np.arctan2(d[:, 1], d[:, 0])])
                if not self.hybrid.collides(cm, along).any():
                    self.plans_by.append("grid")
                    return path
            for planner in (self.hybrid, self.hybrid_tight):
                try:
                    self._poses = self._plan_poses(planner, pose)
                    self.plans_by.append("hybrid")
                    return resample(self._poses[:, :2], cm.resolution)
                except StartBlocked:
                    # a base within the margin of something (as mapped) plans with the
                    # rectangle itself: a grid path has a turn on the spot at every
                    # corner, which in a doorway would sweep the jambs
                    continue
            # a base whose footprint already touches something (as mapped) plans its way
            # out on the grid, where cells near the start stay open
        self.plans_by.append("grid")
        return smooth(self.planner.plan(cm, tuple(pose[:2]), goal), cm)

    def _plan_poses(self, planner: HybridAStar, pose: np.ndarray) -> np.ndarray:
        """`planner`'s poses to the goal; where it finds none, the same with the looser
        goal tolerance (its last pose then stands within that of the goal), for a first
        plan also from starts 2 cm aside: a goal the rectangle reaches only by one exact
        approach is found from some starts of the search's lattice and not from others
        a centimetre away (`check_goal` judged it from the base's nominal start)."""
        cm, goal = self.global_costmap, tuple(self.goal)
        try:
            return planner.plan_poses(cm, tuple(pose), goal)
        except StartBlocked:
            raise
        except NoPath as err:
            if self.loose_tolerance <= planner.config.goal_tolerance:
                raise
            failure = err
        loose = HybridAStar(replace(planner.config, goal_tolerance=self.loose_tolerance))
        starts = [pose[:3]]
        if not self._planned:
            starts += [pose[:3] + np.array([dx, dy, 0.0]) for dx, dy in _ASIDE]
        for start in starts:
            try:
                poses = loose.plan_poses(cm, tuple(start), goal)
                break
            except NoPath as err:  # StartBlocked too: a start aside may touch
                failure = err
        else:
            raise failure
        poses[0] = pose[:3]
        # a search that ended near the goal is put on it by a step sideways, which no
        # base drives: the plan ends where the search did, turned to the goal's heading
        # (the navigator's final turn, within its tolerance)
        if len(poses) < 3:
            return poses
        end, on = poses[-3], poses[-2]
        step = on[:2] - end[:2]
        sideways = abs(step[0] * np.sin(on[2]) - step[1] * np.cos(on[2]))
        if sideways < 1e-3:
            return poses
        return np.vstack([poses[:-2], [end[0], end[1], poses[-1, 2]]])

    def _track_progress(self, now: float, pose: np.ndarray) -> None:
        since, where = self._progress
        if np.hypot(*(pose[:2] - where)) >= self.config.progress_distance:
            self._progress = (now, pose[:2].copy())
            if now - since < self.config.progress_timeout / 2:
                self._next_recovery = 0
        elif now - since > self.config.progress_timeout:
            self._start_recovery(now, pose)

    # --- recoveries --------------------------------------------------------------------

    def _start_recovery(self, now: float, pose: np.ndarray) -> None:
        order = [Recovery.CLEAR_COSTMAPS, Recovery.ROTATE, Recovery.BACK_UP]
        if self._next_recovery >= len(order):
            self._finish(
                Status.ABORTED,
                "stuck: no admissible motion after clearing costmaps, rotating and backing up",
            )
            return
        kind = order[self._next_recovery]
        self._next_recovery += 1
        self.recoveries.append(kind.value)
        self._progress = (now, pose[:2].copy())
        if kind is Recovery.CLEAR_COSTMAPS:
            self.global_costmap.clear_obstacles()
            self._dirty = True
            self.path = None
            self._behaviour = None
            return
        if kind is Recovery.BACK_UP:
            self._back_up(now, pose, self._reverse_run(pose))
            return
        length = 2 * np.pi / max(self.config.dwa.max_yaw_rate, 0.1) + 2.0
        self._behaviour = _Behaviour(kind, now + length, float(pose[2]), 0.0, float(pose[2]))

    def _escape(self, now: float, pose: np.ndarray) -> bool:
        """Where the map shows the base touching something (or nearer than the footprint
        planner's margin, so it plans nothing from there), start the least turn and
        straight drive that gets it clear (`escape_move`), up to ESCAPES times a goal:
        the base stands there, so the map is a little off, not the base in a wall."""
        if self.config.planner not in ("hybrid", "auto") or self._escapes >= ESCAPES:
            return False
        cm, margin = self.global_costmap, self.config.hybrid.margin
        if not self.hybrid.collides(cm, pose[None, :3])[0]:
            return False
        move = escape_move(cm, tuple(pose[:3]), margin, self.hybrid.blocked(cm))
        if move is None:
            return False
        self._escapes += 1
        heading, run = move
        yaw = float(pose[2])
        turn = abs(_wrap(heading - yaw))
        length = turn / (0.5 * self.config.dwa.max_yaw_rate) + abs(run) / self.config.backup_speed
        self.recoveries.append(Recovery.ESCAPE.value)
        self._behaviour = _Behaviour(
            Recovery.ESCAPE,
            now + length + 2.0,
            yaw,
            0.0,
            yaw,
            abs(run),
            heading if turn > 0.01 else None,
            1.0 if run >= 0 else -1.0,
        )
        return True

    def _reverse_run(self, pose: np.ndarray) -> tuple[float, float] | None:
        """With a footprint planner, `HybridAStar.reverse_run` from `pose` to the goal (the
        heading a plan that may also reverse turns to, how far it then backs up); None
        without one, or when no such plan exists."""
        if self.config.planner not in ("hybrid", "auto"):
            return None
        try:
            return self.hybrid.reverse_run(self.global_costmap, pose, self.goal)
        except NoPath:
            return None

    def _back_up(self, now: float, pose: np.ndarray, run: tuple[float, float] | None) -> None:
        """Start backing up: `backup_distance` straight back, or, with a footprint planner,
        as a plan that may also reverse does (`run`, from `_reverse_run`: turning on the
        spot to the heading it backs up at, as far as it backs up: at least
        `backup_distance`, at most 1.5 m)."""
        yaw = float(pose[2])
        heading, back = yaw, 0.0
        if self.config.planner in ("hybrid", "auto"):
            heading, back = run or (yaw, 0.0)
            back += 0.1
        back = min(max(back, self.config.backup_distance), 1.5)
        turn = abs(_wrap(heading - yaw)) / (0.5 * self.config.dwa.max_yaw_rate)
        length = turn + back / self.config.backup_speed + 2.0
        turn_first = heading if abs(_wrap(heading - yaw)) > 0.05 else None
        self._behaviour = _Behaviour(
            Recovery.BACK_UP, now + length, yaw, 0.0, yaw, back, turn_first
        )

    def _touches(self, costmap: Costmap, poses: np.ndarray) -> bool:
        """Whether the footprint touches an obstacle at any of the poses: the rectangle
        itself where the controller checks it so, else its covering circles."""
        if self.config.dwa.exact_footprint:
            return bool(footprint_hits(costmap, poses, 0.0).any())
        return bool(footprint_clearance(costmap, self.footprint, poses).min() < 0.0)

    def _clearance(self, costmap: Costmap, poses: np.ndarray) -> np.ndarray:
        """The footprint's clearance (m, negative: overlap) at poses (N, 3), measured as
        `_touches` checks it."""
        if self.config.dwa.exact_footprint:
            return rectangle_clearance(costmap, poses)
        return footprint_clearance(costmap, self.footprint, poses)

    def _motion_blocked(self, costmap: Costmap, pose: np.ndarray, poses: np.ndarray) -> bool:
        """Whether a recovery's motion through `poses` (N, 3) from `pose` may not be
        made: it touches something, and either the base stands clear now or the motion
        takes it nearer (a base wedged against a doorway's jamb, as mapped, may back or
        turn away from it)."""
        poses = poses.reshape(-1, 3)
        if not self._touches(costmap, poses):
            return False
        here = self._clearance(costmap, pose[None, :3])
        if not self._touches(costmap, pose[None, :3]):
            return True
        return bool(self._clearance(costmap, poses).min() < here[0])

    def _recover(
        self, now: float, pose: np.ndarray, velocity: tuple[float, float]
    ) -> tuple[float, float]:
        b = self._behaviour
        assert b is not None
        done = now >= b.until
        cmd = (0.0, 0.0)
        local = self.local_costmap
        if b.kind is Recovery.ROTATE:
            b.turned += abs(_wrap(float(pose[2]) - b.last_yaw))
            b.last_yaw = float(pose[2])
            w = 0.5 * self.config.dwa.max_yaw_rate
            if local is not None:
                nxt = rollout(tuple(pose), np.array([0.0]), np.array([w]), 5, 0.1)
                if self._motion_blocked(local, pose, nxt):
                    done = True
            done = done or b.turned >= 2 * np.pi
            cmd = (0.0, w)
        elif b.heading is not None:
            # the reverse plan's turn on the spot before it backs up
            err = _wrap(b.heading - float(pose[2]))
            rate = 0.5 * self.config.dwa.max_yaw_rate
            w = float(np.sign(err) * min(rate, max(0.15, 2.0 * abs(err))))
            if local is not None:
                nxt = rollout(tuple(pose), np.array([0.0]), np.array([w]), 5, 0.1)
                if self._motion_blocked(local, pose, nxt):
                    b.heading = None
            if abs(err) <= 0.05:
                b.heading = None  # turned: back up from here on
            cmd = (0.0, w) if b.heading is not None else (0.0, 0.0)
        else:
            travelled = 0.0
            speed = b.direction * self.config.backup_speed
            if local is not None:
                nxt = rollout(tuple(pose), np.array([speed]), np.array([0.0]), 5, 0.1)
                if self._motion_blocked(local, pose, nxt):
                    done = True
            b.turned += abs(velocity[0]) * self.config.dwa.period
            travelled = b.turned
            done = done or travelled >= b.distance
            cmd = (speed, 0.0)
        if done:
            self._behaviour = None
            self.path = None
            self._progress = (now, pose[:2].copy())
            return 0.0, 0.0
        return cmd
