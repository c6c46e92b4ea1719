"""The PlanTask service logic: the g2rViewer "Move Robot!" request in, a timed path out.

Layer 3, over arrays and geometry (the ROS messages are converted in
`robotrial.ros.planning_node`). `TaskPlanner` holds what a robot contributes once
(kinematics, link spheres and self-collision pairs); each request adds its obstacles and
the carried object, solves IK for the end-effector goal, plans, shortcuts and rounds the
path, times it (both compiled), and validates the timed trajectory densely before
answering: the spheres clear what they can, MuJoCo decides the samples near a contact.
The collision checkers of the last few scenes are kept, so a request in a scene already
seen (the same obstacles, the same object) builds nothing. Failures are explicit: a goal
out of reach (by how much), a start or goal in collision (which links touch what), no
path within the time limit.
"""

from __future__ import annotations

import hashlib
import math
import os
import pickle
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

import robotrial.collision
import robotrial.kinematics
from robotrial.cache import cache_dir
from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import (
    OBJECT,
    CollisionChecker,
    Environment,
    HeldObject,
    RobotSpheres,
    Wall,
)
from robotrial.geometry import Box, Pose, Shape
from robotrial.kinematics.chain import Kinematics, default_planning_joints
from robotrial.kinematics.ik import solve_ik
from robotrial.model.robot import RobotModel
from robotrial.model.stand import seen_from, stand
from robotrial.model.world import World
from robotrial.planning import planner_class
from robotrial.planning.base import PlanResult, Problem, path_length
from robotrial.planning.goal import GoalSearch, search, seeds
from robotrial.planning.smoothing import densify, round_corners, shortcut, shortcut_and_round
from robotrial.planning.timing import Trajectory, time_parameterize, time_parameterize_reference

DEFAULT_TIME_LIMIT = 2.0  # s
MAX_TIME_LIMIT = 60.0  # s: the longest answer a request may ask for
HOLD_DISTANCE = 0.05  # m: an object this close to the tcp is in the hand
DEFAULT_ACCEL_RATIO = 2.0  # joint acceleration limit = ratio x velocity limit, per second
FLOOR_THICKNESS = 0.1  # m
SCENES_KEPT = 8  # collision checkers of this many recent scenes are kept
REFERENCE_PERIOD = 0.1  # s between the trajectory's samples; trackers interpolate (Hermite)

Obstacles = list[tuple[str, Shape, Pose]]

FAILURES = (
    "bad_request",
    "start_in_collision",
    "unreachable",
    "goal_in_collision",
    "timeout",
    "planning_failed",
    "invalid_path",
)


class TaskError(ValueError):
    """A request that cannot be planned as given (names the field)."""


class _OutOfTime(Exception):
    """The request's time limit has passed, or its caller stopped waiting."""


@dataclass
class TaskRequest:
    """One Move Robot! request: from the joints `positions` (named by `joint_names`; none:
    the planning joints, or all of the robot's joints, by count) to the end effector at
    `goal_position` (m, base frame) with `goal_orientation` (quaternion x, y, z, w; None:
    position only), or to the planning joints `goal_joints` (a joint-space goal, as
    MoveIt's joint target; the goal pose is then not used), around `obstacles`, carrying
    `object` (name, box, pose; None: nothing). `planner` "" is the default; `time_limit`
    (s) bounds the whole answer, IK and smoothing included (0: the default,
    DEFAULT_TIME_LIMIT for the planner)."""

    positions: np.ndarray
    goal_position: np.ndarray
    goal_orientation: np.ndarray | None = None
    joint_names: list[str] = field(default_factory=list)
    obstacles: Obstacles = field(default_factory=list)
    object: tuple[str, Box, Pose] | None = None
    planner: str = ""
    time_limit: float = 0.0
    goal_joints: np.ndarray | None = None


@dataclass
class TaskResult:
    """A PlanTask answer. `failure`: "" on success, else one of FAILURES; `message` says
    what happened in words; `object_held`: the object counted as held in the hand (else
    as an obstacle); `planning_time` in seconds, the whole request."""

    success: bool = False
    failure: str = ""
    message: str = ""
    object_held: bool = False
    planning_time: float = 0.0
    stats: dict[str, Any] = field(default_factory=dict)
    start: np.ndarray | None = None
    path: np.ndarray | None = None
    trajectory: Trajectory | None = None
    joint_names: list[str] = field(default_factory=list)
    checker: CollisionChecker | None = None
    exact: ExactChecker | None = None

    @property
    def goal_joints(self) -> np.ndarray | None:
        """The trajectory's last configuration (None when nothing was planned)."""
        return None if self.trajectory is None else self.trajectory.q[-1]


@dataclass
class _Scene:
    """What one set of obstacles and held object costs to build, kept for the next request."""

    env: Environment
    obstacles: Obstacles
    held: HeldObject | None
    checker: CollisionChecker
    exact: ExactChecker | None


def _scene_key(obstacles: Obstacles, held: HeldObject | None, start: np.ndarray) -> tuple:
    """What a scene's checkers depend on: the obstacles, and the held object with the
    configuration it is picked up in (which links may touch it)."""
    parts: list[Any] = [  # a box (what requests send) is its own key; other shapes by repr
        (
            name,
            shape if type(shape) is Box else (type(shape).__name__, repr(shape)),
            pose.xyz,
            pose.quat,
        )
        for name, shape, pose in obstacles
    ]
    if held is not None:
        parts.append((repr(held.shape), held.pose_in_link.tobytes(), held.link, start.tobytes()))
    return tuple(parts)


def _code_digest() -> bytes:
    """The source of the modules that compute a robot's spheres and pairs: a new version
    of them must not read an old answer."""
    h = hashlib.sha256()
    for package in (robotrial.collision, robotrial.kinematics):
        for f in sorted(Path(package.__path__[0]).glob("*.py")):
            h.update(f.read_bytes())
    return h.digest()


def robot_spheres(kin: Kinematics, fine: bool = False) -> RobotSpheres:
    """The robot's spheres and self-collision pairs (seconds of work for a robot: sphere
    covers of every shape, thousands of sampled configurations), kept on disk by robot,
    joint group, the other joints' held values and code version, so that a fresh process
    reads them back. With `fine`,
    the fine covers too (made otherwise on first use, `RobotSpheres.refine`)."""
    held = (kin.model, kin.joint_names, sorted(kin.fixed_values.items()))
    key = hashlib.sha256(pickle.dumps(held) + _code_digest()).hexdigest()[:32]
    path = cache_dir("robot-spheres") / f"{key}.pickle"
    spheres = None
    try:
        kept = pickle.loads(path.read_bytes())
        if isinstance(kept, RobotSpheres):
            spheres, spheres.kin = kept, kin
    except Exception:  # not kept yet, unreadable, or from other code: compute it
        pass
    if spheres is not None and (spheres.refined or not fine):
        return spheres
    spheres = spheres or RobotSpheres(kin)
    if fine:
        spheres.refine()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_bytes(pickle.dumps(spheres))
        tmp.replace(path)
    except OSError:
        pass  # a read-only home: compute it again next time
    return spheres


class TaskPlanner:
    """Plans PlanTask requests for one robot, optionally standing in a world.

    `joints`: the planning joints (default: the arm group, else the chain to the end
    effector); `fixed`: the values other joints are held at (default 0, e.g. a torso lift's
    height). `padding` (m) keeps the robot's spheres that far from obstacles.
    `checker`: the collision checker class built for each scene (a subclass of
    `CollisionChecker` suited to the scenes at hand, e.g. `collision.voxels.VoxelChecker`).
    With `reference`, each answer is post-processed as before the compiled path (NumPy
    shortcuts, scipy's spline, every validation sample through MuJoCo): the baseline of
    `robotrial bench planning --service`.
    """

    def __init__(
        self,
        robot: RobotModel,
        world: World | None = None,
        joints: list[str] | None = None,
        padding: float = 0.0,
        validate: bool = True,
        checker: type[CollisionChecker] = CollisionChecker,
        reference: bool = False,
        fixed: Mapping[str, float] | None = None,
    ) -> None:
        self.robot = robot
        self.reference = reference
        self.checker_class = checker
        # the world in the robot's frame: a robot that stands on the floor sees it shifted
        self.world = None if world is None else seen_from(world, stand(robot, world))
        world = self.world
        self.joint_names = list(joints) if joints else default_planning_joints(robot)
        self.kin = Kinematics(robot, self.joint_names, fixed)
        self.spheres = robot_spheres(self.kin)
        self.seeds = seeds(self.kin)
        self._limits = (self.kin.lower.tolist(), self.kin.upper.tolist())
        self.padding = float(padding)
        self.validate = validate
        lim = {j.name: j.limit for j in robot.joints}
        self.vmax = np.array(
            [
                lim[n].velocity if lim[n] is not None and lim[n].velocity > 0 else 1.0
                for n in self.joint_names
            ]
        )
        self.amax = DEFAULT_ACCEL_RATIO * self.vmax
        self._scenes: OrderedDict[tuple, _Scene] = OrderedDict()
        self._deadline = 0.0
        self._abandoned: threading.Event | None = None
        self.world_env = Environment()
        if world is not None:
            fl = world.floor
            self.world_env.add(
                "floor",
                Box((fl.size[0], fl.size[1], FLOOR_THICKNESS)),
                Pose((fl.center[0], fl.center[1], fl.height - FLOOR_THICKNESS / 2)),
            )
            for ob in world.static_bodies:
                self.world_env.add(ob.name, ob.geometry, ob.pose)

    # --- request parsing ---------------------------------------------------------

    def start_from(self, names: list[str], positions: Sequence[float]) -> np.ndarray:
        """The planning joints' values from a JointState's names and positions."""
        pos = positions.tolist() if isinstance(positions, np.ndarray) else list(positions)
        if not names:
            if len(pos) == self.kin.d:
                names = self.joint_names
            elif len(pos) == len(self.robot.joint_names):
                names = self.robot.joint_names
            else:
                raise TaskError(
                    f"current_joints has {len(pos)} positions and no names; expected "
                    f"{self.kin.d} for {self.joint_names}"
                )
        if len(names) != len(pos):
            raise TaskError(f"current_joints has {len(names)} names but {len(pos)} positions")
        if names == self.joint_names:  # as the page and `robotrial plan` send them
            q = [float(v) for v in pos]
        else:
            given = dict(zip(names, pos, strict=True))
            missing = [n for n in self.joint_names if n not in given]
            if missing:
                raise TaskError(f"current_joints lacks the planning joints {missing}")
            q = [float(given[n]) for n in self.joint_names]
        if not all(map(math.isfinite, q)):
            raise TaskError("current_joints has a non-finite position")
        for n, v, lo, hi in zip(self.joint_names, q, *self._limits, strict=True):
            if v < lo - 1e-3 or v > hi + 1e-3:
                raise TaskError(
                    f"current_joints: {n} = {v:.4f} is outside its limits [{lo:.4f}, {hi:.4f}]"
                )
        return np.array([min(max(v, lo), hi) for v, lo, hi in zip(q, *self._limits, strict=True)])

    # --- the service -------------------------------------------------------------

    def warm(self, tries: int = 200) -> TaskResult | None:
        """Answer one request between two free configurations of this world: numba
        compiles the kernels on their first use (half a minute after an install), and a
        server does this at start so that the first user does not wait. None when two
        free configurations did not turn up in `tries` samples."""
        checker = self.checker_class(self.spheres, self.world_env, self.padding)
        qs = np.random.default_rng(0).uniform(self.kin.lower, self.kin.upper, (tries, self.kin.d))
        free = qs[checker.valid(qs)]
        if len(free) < 2:
            return None
        hand = self.kin.link_pose(free[1])[:3, 3]
        result = self.plan(TaskRequest(free[0], hand, joint_names=self.joint_names), seed=0)
        # an answer that went straight leaves the tree search and the shortcut unused:
        # the first request that needs them would load (or compile) them
        a, b = free[0], free[1]
        planner_class("")().solve(Problem(a, b[None], 1.0, 0), checker)
        shortcut_and_round(np.stack([a, a, b]), checker, np.random.default_rng(0))
        return result

    def plan(
        self,
        request: TaskRequest,
        seed: int | None = None,
        abandoned: threading.Event | None = None,
    ) -> TaskResult:
        """Answer one request (never raises for a bad request: the result says why).
        The answer comes within the request's time limit; once `abandoned` is set (the
        caller has gone) the work stops at the next stage."""
        t0 = time.perf_counter()
        result = TaskResult(joint_names=self.joint_names)
        try:
            limit = time_limit(request.time_limit)
            self._deadline = math.inf if limit is None else t0 + limit
            self._abandoned = abandoned
            self._plan(request, seed, result)
        except TaskError as exc:
            self._fail(result, "bad_request", str(exc))
        except _OutOfTime as exc:
            self._fail(result, "timeout", str(exc))
        finally:
            self._abandoned = None
        result.planning_time = time.perf_counter() - t0
        result.stats["total_time"] = result.planning_time
        return result

    def _solve(self, planner, problem: Problem, checker, found: GoalSearch | None) -> PlanResult:
        """Plan to the goal the IK search found. One the start reaches in a straight line,
        or a joint-space goal (no `found`), is the only goal; else every free solution
        found is one (the goal tree grows from all of them, the nearest first): on arms
        whose joints turn twice around, the nearest solution can sit in a pocket the
        start has no free motion into, where a search aimed at it alone spends its time."""
        if found is None or found.direct:
            return planner.solve(problem, checker)
        return planner.solve(replace(problem, goals=found.free), checker)

    def _remaining(self, stage: str) -> float:
        """Seconds left for the request; _OutOfTime (naming `stage`) when none are, or
        when the caller has gone."""
        if self._abandoned is not None and self._abandoned.is_set():
            raise _OutOfTime(f"stopped before {stage}: the caller no longer waits")
        left = self._deadline - time.perf_counter()
        if left <= 0:
            raise _OutOfTime(f"the time limit ran out before {stage}")
        return left

    def _scene(self, obstacles: Obstacles, held: HeldObject | None, start: np.ndarray) -> _Scene:
        """The checkers for these obstacles and this held object: kept from an earlier
        request in the same scene, else built (and the oldest kept scene dropped)."""
        key = _scene_key(obstacles, held, start)
        scene = self._scenes.get(key)
        if scene is not None:
            self._scenes.move_to_end(key)
            return scene
        env = Environment(
            list(self.world_env.names),
            list(self.world_env.kinds),
            list(self.world_env.poses),
            list(self.world_env.dims),
        )
        for name, shape, pose in obstacles:
            env.add(name, shape, pose)
        checker = self.checker_class(self.spheres, env, self.padding, held, held_touch_at=start)
        exact = None
        if self.validate:
            exact = ExactChecker(
                checker,
                self.world,
                obstacles,
                held=(held.shape, Pose.from_matrix(held.pose_in_link), held.link) if held else None,
            )
        scene = _Scene(env, obstacles, held, checker, exact)
        self._scenes[key] = scene
        while len(self._scenes) > SCENES_KEPT:
            self._scenes.popitem(last=False)
        return scene

    def _plan(self, request: TaskRequest, seed: int | None, result: TaskResult) -> None:
        start = self.start_from(list(request.joint_names), request.positions)
        stats = result.stats
        result.start = start

        obstacles = list(request.obstacles)
        held = None
        held_note = ""
        if request.object is not None:
            name, shape, pose = request.object
            tcp = self.kin.link_pose(start)
            in_tcp = np.linalg.inv(tcp) @ pose.matrix()
            gap = np.maximum(np.abs(in_tcp[:3, 3] @ in_tcp[:3, :3]) - np.asarray(shape.size) / 2, 0)
            if float(np.linalg.norm(gap)) <= HOLD_DISTANCE:
                held = HeldObject(shape, in_tcp, self.kin.tip_name)
                result.object_held = True
            else:
                obstacles.append((name or OBJECT, shape, pose))
                held_note = " (the object is not at the hand, so it is treated as an obstacle)"
        t = time.perf_counter()
        scene = self._scene(obstacles, held, start)
        stats["scene_time"] = time.perf_counter() - t
        self._remaining("the collision checks")
        checker, exact = scene.checker, scene.exact
        result.checker, result.exact = checker, exact

        # the first sphere cover is the fast path; where it refuses an end, the fine one
        # decides (`CollisionChecker.finer`), and the whole request goes on with it
        if not checker.free(start):
            finer = checker.finer(start)
            if finer is None or not finer.free(start):
                touching = sorted((finer or checker).contacts(start))
                self._fail(
                    result, "start_in_collision", "start in collision: " + _describe(touching)
                )
                return
            checker = finer

        # --- the goal: given in joint space, else by IK
        if request.goal_joints is not None:
            goal = np.asarray(request.goal_joints, dtype=float)
            if goal.shape != (self.kin.d,) or not np.all(np.isfinite(goal)):
                raise TaskError(f"goal_joints must be {self.kin.d} finite joint values")
            if not checker.free(goal):
                touching = sorted(checker.contacts(goal))
                self._fail(result, "goal_in_collision", "goal in collision: " + _describe(touching))
                return
            found = None
        else:
            ik = self._ik_goal(request, start, seed, checker, stats, result)
            if ik is None:
                return
            checker, found = ik
            goal = found.free[0]

        # --- plan, shortcut, round, time, validate; retry finer if MuJoCo disagrees
        try:
            kind = planner_class(request.planner)
        except ValueError as exc:
            raise TaskError(f"planner: {exc}") from None
        planner = None  # made when a path is to be planned (a straight one is not)
        limit = request.time_limit if request.time_limit > 0 else DEFAULT_TIME_LIMIT
        for attempt in range(3):
            left = min(limit, self._remaining("planning"))
            if attempt:
                checker = self.checker_class(
                    self.spheres,
                    scene.env,
                    self.padding + 0.005 * attempt,
                    held,
                    held_touch_at=start,
                    resolution_scale=0.5**attempt,
                    fine=checker.fine,
                )
            # the goal search proved the straight motion free with the first checker
            straight = attempt == 0 and found is not None and found.direct
            if straight:
                res = PlanResult(True, np.array((start, goal)), "solved", {"planning_time": 0.0})
            else:
                planner = planner or kind()
                res = self._solve(planner, Problem(start, goal[None], left, seed), checker, found)
            stats.update({f"planner_{k}": v for k, v in res.stats.items()})
            stats["planner"] = kind.name
            stats["attempts"] = attempt + 1
            if not res.success and res.status == "timeout":
                self._fail(
                    result,
                    "timeout",
                    f"no path found by {kind.name} within its time limit of {limit:g} s "
                    f"({res.stats.get('nodes', 0)} nodes explored)",
                )
                return
            if not res.success:
                self._fail(
                    result,
                    "planning_failed",
                    f"{kind.name} stopped without a path ({res.status.replace('_', ' ')}, "
                    f"attempt {attempt + 1} of 3 with a padding of "
                    f"{1e3 * checker.padding:.0f} mm)",
                )
                return
            self._remaining("smoothing")
            t_post = time.perf_counter()
            if len(res.path) == 2:  # one straight motion: nothing to shortcut or round
                path = smooth = res.path
            elif self.reference:
                path = shortcut(res.path, checker, np.random.default_rng(seed))
                smooth = round_corners(path, checker)
            else:
                path, smooth = shortcut_and_round(res.path, checker, np.random.default_rng(seed))
            stats["shortcut_time"] = stats.get("shortcut_time", 0.0) + time.perf_counter() - t_post
            self._remaining("timing and validation")
            traj = self._timed_and_checked(smooth, path, checker, exact, stats)
            if traj is not None:
                break
        else:
            self._fail(
                result,
                "invalid_path",
                "every planned path failed the dense MuJoCo check (3 attempts, finer each time)",
            )
            return
        result.path = path
        result.trajectory = traj
        result.checker = checker
        stats["path_length"] = path_length(path)
        stats["waypoints"] = len(path)
        stats["duration"] = duration = traj.duration
        checked = ", validated with MuJoCo" if exact is not None else ""
        result.success = True
        how = (
            "a straight motion to the goal, free as the goal search found it"
            if straight
            else f"planned with {kind.name} in {res.planning_time * 1e3:.1f} ms"
        )
        result.message = (
            f"{how}; {len(path)} waypoints, {duration:.2f} s trajectory{checked}{held_note}"
        )

    def _ik_goal(
        self,
        request: TaskRequest,
        start: np.ndarray,
        seed: int | None,
        checker: CollisionChecker,
        stats: dict[str, Any],
        result: TaskResult,
    ) -> tuple[CollisionChecker, GoalSearch] | None:
        """The IK search for the request's goal pose (`planning.goal.search`) and the
        checker its solutions were found free with; None after failing `result` (out of
        reach, past a wall, or every solution colliding)."""
        self._remaining("inverse kinematics")
        target = np.asarray(request.goal_position, dtype=float)
        if target.shape != (3,) or not all(map(math.isfinite, target.tolist())):
            raise TaskError(f"ee_goal.position must be three finite numbers, got {target}")
        goal_pose = None
        if request.goal_orientation is not None:
            goal_pose = Pose(tuple(target), tuple(request.goal_orientation))  # type: ignore[arg-type]
        ik_target = target if goal_pose is None else goal_pose.matrix()
        t_ik = time.perf_counter()
        found = search(self.kin, ik_target, start, checker, self.seeds)
        finer = None
        # the finer cover can free a converged solution; none converged, or all of them
        # past a wall, it has none to free
        wall = _wall_past(checker, start, found)
        if (
            wall is None
            and not len(found.free)
            and found.converged
            and (finer := checker.finer()) not in (None, checker)
        ):
            again = search(self.kin, ik_target, start, finer, self.seeds)
            if len(again.free):
                found, checker = again, finer
        stats["ik_time"] = time.perf_counter() - t_ik
        stats["ik_seeds"] = found.seeds_tried
        if len(found.free):
            stats["ik_solutions"] = len(found.free)
            return checker, found
        # why not: the target out of reach, a wall, or every solution colliding
        if not found.converged:
            self._out_of_reach(
                result, target, goal_pose, start, found.position_error, found.orientation_error
            )
            return None
        rng = np.random.default_rng(seed)
        free_ik = partial(solve_ik, self.kin, ik_target, start, rng=rng, batch=4, wanted=2)
        if w := wall or _wall_before(finer or checker, start, free_ik):
            where = (
                f"where {w.body} runs into {w.obstacle}"
                if w.sure
                else f"where {w.body} passes within {1e3 * w.bulge:.0f} mm of {w.obstacle} "
                "(closer than the planner's spheres tell from touching it)"
            )
            self._fail(
                result,
                "unreachable",
                f"goal out of reach from the start: its IK solutions have "
                f"{self.kin.joint_names[w.joint]} past {w.low:.2f} to {w.high:.2f}, "
                f"{where} whatever the other joints do",
            )
            return None
        free = solve_ik(self.kin, ik_target, start, rng=rng, wanted=1)
        if not free.success:
            self._out_of_reach(
                result, target, goal_pose, start, free.position_error, free.orientation_error
            )
            return None
        touching = sorted((finer or checker).contacts(free.q))
        self._fail(
            result,
            "goal_in_collision",
            "goal in collision: every IK solution found collides, e.g. " + _describe(touching),
        )
        return None

    def _out_of_reach(
        self,
        result: TaskResult,
        target: np.ndarray,
        goal_pose: Pose | None,
        start: np.ndarray,
        position_error: float,
        orientation_error: float,
    ) -> None:
        """Fail `result` as out of reach, with how near the end effector came."""
        base = self.kin.fk(start)[0, :3, 3]
        where = ", ".join(f"{v:.3f}" for v in target)
        turn = (
            f" and {orientation_error:.2f} rad from the orientation"
            if goal_pose is not None
            else ""
        )
        self._fail(
            result,
            "unreachable",
            f"goal out of reach: the end effector gets no closer than "
            f"{position_error:.3f} m to ({where}){turn}; the target is "
            f"{np.linalg.norm(target - base):.3f} m from the robot's base",
        )

    def _timed_and_checked(self, smooth, path, checker, exact, stats) -> Trajectory | None:
        """Time the rounded path, else the plain one with denser waypoints; keep the first
        whose motion as a tracker follows it (Hermite between the samples) passes the
        dense check (MuJoCo when validating, on the samples the planning checker's
        spheres do not clear; else the spheres)."""
        timed = time_parameterize_reference if self.reference else time_parameterize
        for candidate, gap in ((smooth, 0.05), (path, 0.01)):
            t = time.perf_counter()
            traj = timed(candidate, self.vmax, self.amax, period=REFERENCE_PERIOD, max_gap=gap)
            tracked = traj.tracked(REFERENCE_PERIOD / 2)
            stats["timing_time"] = stats.get("timing_time", 0.0) + time.perf_counter() - t
            t = time.perf_counter()
            if exact is not None:
                screen = None if self.reference else checker
                ok, _ = exact.path_valid(tracked, screen=screen)
            else:
                dense = densify(tracked, float(np.min(checker.resolution)) / 2)
                ok = bool(np.all(checker.valid(dense)))
            stats["validation_time"] = stats.get("validation_time", 0.0) + time.perf_counter() - t
            stats["timed_candidates"] = stats.get("timed_candidates", 0) + 1
            if ok:
                return traj
        return None

    def _fail(self, result: TaskResult, failure: str, message: str) -> None:
        result.success = False
        result.failure = failure
        result.message = message


def time_limit(asked: float) -> float | None:
    """The seconds a whole answer may take: `asked`, or None for 0 (the default: the
    planner alone is held to DEFAULT_TIME_LIMIT, so that a first request that compiles
    the kernels is answered); TaskError for a negative, non-finite or too long limit."""
    if not math.isfinite(asked) or asked < 0 or asked > MAX_TIME_LIMIT:
        raise TaskError(
            f"time_limit must be 0 (the default: {DEFAULT_TIME_LIMIT:g} s of planning) to "
            f"{MAX_TIME_LIMIT:g} s, got {float(asked):g}"
        )
    return float(asked) if asked > 0 else None


def _wall_past(checker: CollisionChecker, start: np.ndarray, found: GoalSearch) -> Wall | None:
    """The wall of `checker` that the goal search's solutions lie past, when none of them
    lies on the start's side (free or colliding), or None."""
    if len(found.free) or found.colliding or not len(found.past_wall):
        return None
    return _crossed(checker.walls(), start, found.past_wall[:1])


def _wall_before(checker: CollisionChecker, start: np.ndarray, free_ik: Callable) -> Wall | None:
    """The wall of `checker` (`CollisionChecker.walls`) that a free IK solution lies past
    from `start`, or None (no walls, no free solution, or one on the start's side)."""
    walls = checker.walls()
    past = free_ik(accept=checker.valid) if walls else None
    if past is None or not past.success:
        return None
    return _crossed(walls, start, np.atleast_2d(past.q))


def _crossed(walls: list[Wall], start: np.ndarray, q: np.ndarray) -> Wall | None:
    """The first of `walls` between `start` and the configuration `q` (1, d), or None."""
    return next((w for w in walls if w.crossed(start, q)[0]), None)


def _describe(pairs: list[tuple[str, str]]) -> str:
    if not pairs:
        return "no contact named"
    return "; ".join(f"{a} touches {b}" for a, b in pairs[:6]) + (
        f" (and {len(pairs) - 6} more)" if len(pairs) > 6 else ""
    )
