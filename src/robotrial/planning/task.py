"""The PlanTask service logic: the g2rViewer "Move Robot!" request in, a timed path out.

Layer 3. `TaskPlanner` holds what a robot contributes once (kinematics, link spheres and
self-collision pairs); each request adds its obstacles and the carried object, solves IK
for the end-effector goal, plans, shortcuts and rounds the path, times it with toppra,
and validates the timed trajectory densely with MuJoCo before answering. Failures are
explicit: a goal out of reach (by how much), a start or goal in collision (which links
touch what), no path within the time limit.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import (
    OBJECT,
    CollisionChecker,
    Environment,
    HeldObject,
    RobotSpheres,
)
from robotrial.geometry import Box, Pose, Shape
from robotrial.kinematics.chain import Kinematics, default_planning_joints
from robotrial.kinematics.ik import solve_ik
from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.geometry_msgs import Point, Quaternion
from robotrial.msgs.geometry_msgs import Pose as PoseMsg
from robotrial.msgs.robotrial_msgs import PlanTaskRequest, PlanTaskResponse
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from robotrial.planning import planner_class
from robotrial.planning.base import Problem, path_length
from robotrial.planning.smoothing import densify, round_corners, shortcut
from robotrial.planning.timing import Trajectory, time_parameterize

DEFAULT_TIME_LIMIT = 2.0  # s
HOLD_DISTANCE = 0.05  # m: an object this close to the tcp is in the hand
# TaskResult.failure -> the response's error_code
FAILURE_CODES = {
    "bad_request": PlanTaskResponse.INVALID_GOAL_CONSTRAINTS,
    "start_in_collision": PlanTaskResponse.START_STATE_IN_COLLISION,
    "unreachable": PlanTaskResponse.NO_IK_SOLUTION,
    "goal_in_collision": PlanTaskResponse.GOAL_IN_COLLISION,
    "timeout": PlanTaskResponse.TIMED_OUT,
    "invalid_path": PlanTaskResponse.INVALID_MOTION_PLAN,
}
DEFAULT_ACCEL_RATIO = 2.0  # joint acceleration limit = ratio x velocity limit, per second
FLOOR_THICKNESS = 0.1  # m


class TaskError(ValueError):
    """A request that cannot be planned as given (names the field)."""


@dataclass
class TaskResult:
    """A PlanTask answer with what the response has no field for.

    `failure`: "" on success, else bad_request, start_in_collision, unreachable,
    goal_in_collision, timeout or invalid_path.
    """

    response: PlanTaskResponse
    failure: str = ""
    stats: dict[str, Any] = field(default_factory=dict)
    start: np.ndarray | None = None
    path: np.ndarray | None = None
    trajectory: Trajectory | None = None
    joint_names: list[str] = field(default_factory=list)
    checker: CollisionChecker | None = None
    exact: ExactChecker | None = None


def _box_of(msg, what: str) -> tuple[Box, Pose] | None:
    """A robotrial_msgs/Box as a shape and pose; None when all sizes are 0."""
    size = np.array([msg.size.x, msg.size.y, msg.size.z], dtype=float)
    if not np.all(np.isfinite(size)) or np.any(size < 0):
        raise TaskError(f"{what}.size must be finite and non-negative, got {tuple(size)}")
    if np.all(size == 0):
        return None
    if np.any(size == 0):
        raise TaskError(f"{what}.size has a zero edge {tuple(size)}; give all three edges")
    return Box(tuple(size)), _pose_of(msg.pose, what + ".pose")  # type: ignore[arg-type]


def _pose_of(msg, what: str, identity_if_zero: bool = True) -> Pose:
    q = np.array([msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w])
    p = np.array([msg.position.x, msg.position.y, msg.position.z])
    if not np.all(np.isfinite(p)) or not np.all(np.isfinite(q)):
        raise TaskError(f"{what} has a non-finite number")
    if np.allclose(q, 0) and identity_if_zero:
        q = np.array([0.0, 0.0, 0.0, 1.0])
    return Pose(tuple(p), tuple(q))  # type: ignore[arg-type]


class TaskPlanner:
    """Plans PlanTask requests for one robot, optionally standing in a world.

    `joints`: the planning joints (default: the arm group, else the chain to the end
    effector). `padding` (m) keeps the robot's spheres that far from obstacles.
    """

    def __init__(
        self,
        robot: RobotModel,
        world: World | None = None,
        joints: list[str] | None = None,
        padding: float = 0.0,
        validate: bool = True,
    ) -> None:
        self.robot = robot
        self.world = world
        self.joint_names = list(joints) if joints else default_planning_joints(robot)
        self.kin = Kinematics(robot, self.joint_names)
        self.spheres = RobotSpheres(self.kin)
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

    def start_from(self, names: list[str], positions: list[float]) -> np.ndarray:
        """The planning joints' values from a JointState's names and positions."""
        pos = np.asarray(positions, dtype=float)
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
        given = dict(zip(names, pos, strict=True))
        missing = [n for n in self.joint_names if n not in given]
        if missing:
            raise TaskError(f"current_joints lacks the planning joints {missing}")
        q = np.array([given[n] for n in self.joint_names])
        if not np.all(np.isfinite(q)):
            raise TaskError("current_joints has a non-finite position")
        for n, v, lo, hi in zip(self.joint_names, q, self.kin.lower, self.kin.upper, strict=True):
            if v < lo - 1e-3 or v > hi + 1e-3:
                raise TaskError(
                    f"current_joints: {n} = {v:.4f} is outside its limits [{lo:.4f}, {hi:.4f}]"
                )
        return np.clip(q, self.kin.lower, self.kin.upper)

    # --- the service -------------------------------------------------------------

    def warm(self, tries: int = 200) -> TaskResult | None:
        """Answer one request between two free configurations of this world: numba
        compiles the kernels on their first use (half a minute after an install), and a
        server does this at start so that the first user does not wait. None when two
        free configurations did not turn up in `tries` samples."""
        checker = CollisionChecker(self.spheres, self.world_env, self.padding)
        qs = np.random.default_rng(0).uniform(self.kin.lower, self.kin.upper, (tries, self.kin.d))
        free = qs[checker.valid(qs)]
        if len(free) < 2:
            return None
        hand = self.kin.link_pose(free[1])[:3, 3]
        request = PlanTaskRequest(
            current_joints=JointState(name=list(self.joint_names), position=list(free[0])),
            ee_goal=PoseMsg(Point(*hand), Quaternion(0, 0, 0, 0)),
        )
        return self.plan(request, seed=0)

    def plan(self, request: PlanTaskRequest, seed: int | None = None) -> TaskResult:
        """Answer one request (never raises for a bad request: the response says why)."""
        t0 = time.perf_counter()
        try:
            result = self._plan(request, seed, t0)
        except TaskError as exc:
            response = PlanTaskResponse(
                success=False,
                message=str(exc),
                error_code=FAILURE_CODES["bad_request"],
            )
            result = TaskResult(response, "bad_request")
        result.response.planning_time = time.perf_counter() - t0
        result.stats["total_time"] = result.response.planning_time
        result.joint_names = self.joint_names
        return result

    def _plan(self, request: PlanTaskRequest, seed: int | None, t0: float) -> TaskResult:
        rng = np.random.default_rng(seed)
        js = request.current_joints
        start = self.start_from(list(js.name), list(js.position))
        stats: dict[str, Any] = {}

        env = Environment(
            list(self.world_env.names),
            list(self.world_env.kinds),
            list(self.world_env.poses),
            list(self.world_env.dims),
        )
        obstacles: list[tuple[str, Shape, Pose]] = []
        for i, box in enumerate(request.obstacles):
            what = f"obstacles[{i}]"
            sb = _box_of(box, what)
            if sb is not None:
                obstacles.append((box.id or f"obstacle{i}", *sb))
        held = None
        held_note = ""
        obj = _box_of(request.object, "object")
        if obj is not None:
            shape, pose = obj
            tcp = self.kin.link_pose(start)
            in_tcp = np.linalg.inv(tcp) @ pose.matrix()
            gap = np.maximum(np.abs(in_tcp[:3, 3] @ in_tcp[:3, :3]) - np.asarray(shape.size) / 2, 0)
            if float(np.linalg.norm(gap)) <= HOLD_DISTANCE:
                held = HeldObject(shape, in_tcp, self.kin.tip_name)
            else:
                obstacles.append((request.object.id or OBJECT, shape, pose))
                held_note = " (the object is not at the hand, so it is treated as an obstacle)"
        for name, shape, pose in obstacles:
            env.add(name, shape, pose)
        checker = CollisionChecker(self.spheres, env, self.padding, held, held_touch_at=start)
        response = PlanTaskResponse(object_held=held is not None)
        result = TaskResult(response, stats=stats, start=start, checker=checker)

        if not checker.valid(start[None])[0]:
            touching = sorted(checker.contacts(start))
            return self._fail(
                result, "start_in_collision", "start in collision: " + _describe(touching)
            )

        # --- the goal, by IK
        o = request.ee_goal.orientation
        position_only = np.allclose([o.x, o.y, o.z, o.w], 0.0)
        goal_pose = None if position_only else _pose_of(request.ee_goal, "ee_goal")
        p = request.ee_goal.position
        target = np.array([p.x, p.y, p.z], dtype=float)
        if not np.all(np.isfinite(target)):
            raise TaskError("ee_goal.position has a non-finite number")
        ik_target = target if goal_pose is None else goal_pose.matrix()
        t_ik = time.perf_counter()
        ik = solve_ik(self.kin, ik_target, start, rng=rng, accept=checker.valid)
        stats["ik_time"] = time.perf_counter() - t_ik
        if not ik.success:
            free = solve_ik(self.kin, ik_target, start, rng=rng, wanted=1)
            if not free.success:
                base = self.kin.fk(start)[0, :3, 3]
                where = ", ".join(f"{v:.3f}" for v in target)
                turn = (
                    f" and {free.orientation_error:.2f} rad from the orientation"
                    if goal_pose is not None
                    else ""
                )
                return self._fail(
                    result,
                    "unreachable",
                    f"goal out of reach: the end effector gets no closer than "
                    f"{free.position_error:.3f} m to ({where}){turn}; the target is "
                    f"{np.linalg.norm(target - base):.3f} m from the robot's base",
                )
            touching = sorted(checker.contacts(free.q))
            return self._fail(
                result,
                "goal_in_collision",
                "goal in collision: every IK solution found collides, e.g. " + _describe(touching),
            )
        goal = ik.q
        stats["ik_solutions"] = len(ik.solutions)

        # --- plan, shortcut, round, time, validate; retry finer if MuJoCo disagrees
        planner = planner_class(request.planner)()
        limit = request.time_limit if request.time_limit > 0 else DEFAULT_TIME_LIMIT
        exact = None
        if self.validate:
            t = time.perf_counter()
            exact = ExactChecker(
                checker,
                self.world,
                obstacles,
                held=(held.shape, Pose.from_matrix(held.pose_in_link), held.link) if held else None,
            )
            stats["exact_build_time"] = time.perf_counter() - t
        result.exact = exact
        for attempt in range(3):
            if attempt:
                checker = CollisionChecker(
                    self.spheres,
                    env,
                    self.padding + 0.005 * attempt,
                    held,
                    held_touch_at=start,
                    resolution_scale=0.5**attempt,
                )
            res = planner.solve(Problem(start, goal[None], limit, seed), checker)
            stats.update({f"planner_{k}": v for k, v in res.stats.items()})
            stats["planner"] = planner.name
            stats["attempts"] = attempt + 1
            if not res.success:
                return self._fail(
                    result,
                    "timeout",
                    f"no path found by {planner.name} within {limit:g} s "
                    f"({res.stats.get('nodes', 0)} nodes explored)",
                )
            t_post = time.perf_counter()
            path = shortcut(res.path, checker, rng)
            smooth = round_corners(path, checker)
            stats["shortcut_time"] = time.perf_counter() - t_post
            traj = self._timed_and_checked(smooth, path, checker, exact, stats)
            if traj is not None:
                break
        else:
            return self._fail(
                result,
                "invalid_path",
                "every planned path failed the dense MuJoCo check (3 attempts, finer each time)",
            )
        result.path = path
        result.trajectory = traj
        result.checker = checker
        stats["path_length"] = path_length(path)
        stats["waypoints"] = len(path)
        stats["duration"] = traj.duration
        checked = ", validated with MuJoCo" if exact is not None else ""
        result.response = PlanTaskResponse(
            success=True,
            message=(
                f"planned with {planner.name} in {res.planning_time * 1e3:.1f} ms; "
                f"{len(path)} waypoints, {traj.duration:.2f} s trajectory{checked}{held_note}"
            ),
            goal_joints=[float(v) for v in traj.q[-1]],
            trajectory=to_joint_trajectory(self.joint_names, traj),
            error_code=PlanTaskResponse.SUCCESS,
            object_held=held is not None,
        )
        return result

    def _timed_and_checked(self, smooth, path, checker, exact, stats) -> Trajectory | None:
        """Time the rounded path, else the plain one with denser waypoints; keep the first
        whose samples pass the dense check (MuJoCo when validating, else the spheres)."""
        for candidate, gap in ((smooth, 0.05), (path, 0.01)):
            t = time.perf_counter()
            traj = time_parameterize(candidate, self.vmax, self.amax, max_gap=gap)
            stats["timing_time"] = time.perf_counter() - t
            t = time.perf_counter()
            if exact is not None:
                ok, _ = exact.path_valid(traj.q)
            else:
                dense = densify(traj.q, float(np.min(checker.resolution)) / 2)
                ok = bool(np.all(checker.valid(dense)))
            stats["validation_time"] = time.perf_counter() - t
            if ok:
                return traj
        return None

    def _fail(self, result: TaskResult, failure: str, message: str) -> TaskResult:
        result.failure = failure
        held = result.response.object_held
        result.response = PlanTaskResponse(
            success=False, message=message, error_code=FAILURE_CODES[failure], object_held=held
        )
        return result


def _describe(pairs: list[tuple[str, str]]) -> str:
    if not pairs:
        return "no contact named"
    return "; ".join(f"{a} touches {b}" for a, b in pairs[:6]) + (
        f" (and {len(pairs) - 6} more)" if len(pairs) > 6 else ""
    )


def to_joint_trajectory(names: list[str], traj: Trajectory) -> JointTrajectory:
    """A trajectory_msgs/JointTrajectory of the samples (time from the start)."""
    points = [
        JointTrajectoryPoint(
            positions=[float(v) for v in traj.q[i]],
            velocities=[float(v) for v in traj.qd[i]],
            accelerations=[float(v) for v in traj.qdd[i]],
            time_from_start=Duration.from_sec(float(traj.t[i])),
        )
        for i in range(len(traj.t))
    ]
    return JointTrajectory(joint_names=list(names), points=points)


_PLANNERS: dict[tuple[int, int], tuple[RobotModel, World | None, TaskPlanner]] = {}


def task_planner(robot: RobotModel, world: World | None = None) -> TaskPlanner:
    """The TaskPlanner for this robot and world, built once and reused."""
    key = (id(robot), id(world))
    hit = _PLANNERS.get(key)
    if hit is None or hit[0] is not robot or hit[1] is not world:
        hit = (robot, world, TaskPlanner(robot, world))
        _PLANNERS[key] = hit
    return hit[2]


def plan_task(
    robot: RobotModel, request: PlanTaskRequest, world: World | None = None
) -> PlanTaskResponse:
    """The /robotrial/plan_task service: a PlanTask request in, its response out."""
    return task_planner(robot, world).plan(request).response
