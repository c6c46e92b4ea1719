"""The arm planner on the bus: the /robotrial/plan_task service (layer 4).

`PlanningNode` plays MoveIt's move_group for the g2rViewer task. It holds no algorithm
of its own: each request is converted from its ROS message to arrays and geometry
(`task_request`), answered by `robotrial.planning.task.TaskPlanner`, and the result
converted back (`plan_task_response`, with a MoveIt error code); a successful trajectory
is also published as the joint reference the simulators track. The node plans for any
robot of a server's list: one TaskPlanner per robot, built on its first request.

Every request has a budget: at most MAX_OBSTACLES boxes, a time limit that bounds the
whole answer (a request still waiting for its robot's planner when its time is up is
answered with TIMED_OUT and never planned), and work that stops once the caller has gone.
Requests for different robots plan at the same time; the compiled planner releases the
GIL, so the server's event loop keeps answering meanwhile.

| direction | name | type |
| --- | --- | --- |
| service | `/robotrial/plan_task` | robotrial_msgs/srv/PlanTask |
| in | `/joint_states` | sensor_msgs/JointState (the current joints when a request has none) |
| out | `/robotrial/joint_reference` | trajectory_msgs/JointTrajectory |
"""

from __future__ import annotations

import logging
import re
import threading
import time
from collections.abc import Callable

import numpy as np

from robotrial.geometry import Box, Pose
from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.msgs.builtin_interfaces import Duration, Time
from robotrial.msgs.robotrial_msgs import Box as BoxMsg
from robotrial.msgs.robotrial_msgs import PlanTask, PlanTaskRequest, PlanTaskResponse
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from robotrial.planning.task import TaskError, TaskPlanner, TaskRequest, TaskResult, time_limit
from robotrial.planning.timing import Trajectory
from robotrial.ros.bus import Bus, Node, current_call

PLAN_TASK = "/robotrial/plan_task"
JOINT_REFERENCE = "/robotrial/joint_reference"

ERROR_CODES = {
    "": PlanTaskResponse.SUCCESS,
    "bad_request": PlanTaskResponse.INVALID_GOAL_CONSTRAINTS,
    "start_in_collision": PlanTaskResponse.START_STATE_IN_COLLISION,
    "unreachable": PlanTaskResponse.NO_IK_SOLUTION,
    "goal_in_collision": PlanTaskResponse.GOAL_IN_COLLISION,
    "timeout": PlanTaskResponse.TIMED_OUT,
    "planning_failed": PlanTaskResponse.PLANNING_FAILED,
    "invalid_path": PlanTaskResponse.INVALID_MOTION_PLAN,
}

MAX_OBSTACLES = 500
"""The most obstacle boxes a request may hold (the page's scenes hold a few dozen)."""
MAX_NAME = 64
"""The longest id or planner name quoted back in a message."""

log = logging.getLogger(__name__)


def _numbers(values: np.ndarray) -> str:
    return "(" + ", ".join(f"{float(v):g}" for v in values) + ")"


def _short(text: str) -> str:
    return text if len(text) <= MAX_NAME else text[:MAX_NAME] + "..."


def _finite(values: list[float], what: str) -> np.ndarray:
    out = np.array(values, dtype=float)
    if not np.all(np.isfinite(out)):
        raise TaskError(f"{what} has a non-finite number {_numbers(out)}")
    return out


def _zero(values: np.ndarray) -> bool:
    """All within 1e-8 of zero (np.allclose(values, 0) at a tenth of its cost)."""
    return bool(np.all(np.abs(values) <= 1e-8))


def _pose_of(msg, what: str) -> Pose:
    """A geometry_msgs/Pose as a Pose (an all-zero orientation is the identity)."""
    p = _finite([msg.position.x, msg.position.y, msg.position.z], what + ".position")
    o = msg.orientation
    q = _finite([o.x, o.y, o.z, o.w], what + ".orientation")
    if _zero(q):
        q = np.array([0.0, 0.0, 0.0, 1.0])
    return Pose(tuple(p), tuple(q))  # type: ignore[arg-type]


def _box_of(msg: BoxMsg, what: str, none_ok: bool) -> tuple[Box, Pose] | None:
    """A robotrial_msgs/Box as a shape and pose; None when all sizes are 0 and
    `none_ok` (the object's way of saying "none"), else TaskError for an empty box."""
    size = np.array([msg.size.x, msg.size.y, msg.size.z], dtype=float)
    if not np.all(np.isfinite(size)) or np.any(size < 0):
        raise TaskError(f"{what}.size must be finite and non-negative, got {_numbers(size)}")
    if np.all(size == 0) and none_ok:
        return None
    if np.any(size == 0):
        raise TaskError(f"{what}.size has a zero edge {_numbers(size)}; give all three edges")
    return Box(tuple(size)), _pose_of(msg.pose, what + ".pose")  # type: ignore[arg-type]


def task_request(request: PlanTaskRequest) -> TaskRequest:
    """A PlanTask request as arrays and geometry; raises TaskError naming the bad field.
    An all-zero `ee_goal.orientation` asks for the position only."""
    if len(request.obstacles) > MAX_OBSTACLES:
        raise TaskError(
            f"obstacles: {len(request.obstacles)} boxes; a request may hold at most {MAX_OBSTACLES}"
        )
    time_limit(request.time_limit)
    obstacles = []
    for i, box in enumerate(request.obstacles):
        shape = _box_of(box, f"obstacles[{i}]", none_ok=False)
        assert shape is not None
        obstacles.append((_short(box.id) or f"obstacle{i}", *shape))
    obj = _box_of(request.object, "object", none_ok=True)
    g = request.ee_goal
    position = _finite([g.position.x, g.position.y, g.position.z], "ee_goal.position")
    q = _finite(
        [g.orientation.x, g.orientation.y, g.orientation.z, g.orientation.w],
        "ee_goal.orientation",
    )
    return TaskRequest(
        positions=np.asarray(request.current_joints.position, dtype=float),
        joint_names=list(request.current_joints.name),
        goal_position=position,
        goal_orientation=None if _zero(q) else q,
        obstacles=obstacles,
        object=None if obj is None else (_short(request.object.id), *obj),
        planner=request.planner,
        time_limit=float(request.time_limit),
    )


def joint_trajectory(names: list[str], traj: Trajectory) -> JointTrajectory:
    """A trajectory_msgs/JointTrajectory of the samples (time from the start)."""
    points = [
        JointTrajectoryPoint(
            positions=q,
            velocities=qd,
            accelerations=qdd,
            time_from_start=Duration.from_sec(t),
        )
        for t, q, qd, qdd in zip(
            traj.t.tolist(), traj.q.tolist(), traj.qd.tolist(), traj.qdd.tolist(), strict=True
        )
    ]
    return JointTrajectory(joint_names=list(names), points=points)


def plan_task_response(result: TaskResult) -> PlanTaskResponse:
    """The PlanTask response of a result, with MoveIt's error code for its failure."""
    response = PlanTaskResponse(
        success=result.success,
        message=result.message,
        planning_time=result.planning_time,
        error_code=ERROR_CODES[result.failure],
        object_held=result.object_held,
    )
    if result.success and result.trajectory is not None:
        response.goal_joints = result.trajectory.q[-1].tolist()
        response.trajectory = joint_trajectory(result.joint_names, result.trajectory)
    return response


def answer(
    planner: TaskPlanner,
    request: PlanTaskRequest,
    seed: int | None = None,
    abandoned: threading.Event | None = None,
) -> tuple[PlanTaskResponse, TaskResult]:
    """Plan a PlanTask request with `planner`: the response and the full result.
    `abandoned`: set when the caller has gone (the planner then stops)."""
    try:
        task = task_request(request)
    except TaskError as exc:
        result = TaskResult(failure="bad_request", message=str(exc))
    else:
        result = planner.plan(task, seed=seed, abandoned=abandoned)
    return plan_task_response(result), result


def robot_service(robot: str) -> str:
    """The PlanTask service for one robot of a server's list: `/robotrial/robots/NAME/plan_task`
    (characters a ROS name cannot hold become `_`)."""
    safe = re.sub(r"[^A-Za-z0-9_]", "_", robot)
    if not safe or not (safe[0].isalpha() or safe[0] == "_"):
        safe = "r_" + safe
    return f"/robotrial/robots/{safe}{PLAN_TASK.removeprefix('/robotrial')}"


class PlanningNode(Node):
    """Answers PlanTask requests for `robot` (standing in `world`, if given) at PLAN_TASK.

    With `robots(name) -> (robot model, world)`, `add_robot(name)` also offers
    `robot_service(name)` for another robot of the server's list; its TaskPlanner is built
    on the first request and kept. `robot` None: no PLAN_TASK, only the robots added.
    """

    def __init__(
        self,
        bus: Bus,
        robot: RobotModel | None,
        world: World | None = None,
        name: str = "/robotrial_planner",
        robots: Callable[[str], tuple[RobotModel, World | None]] | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.planner = None if robot is None else TaskPlanner(robot, world)
        self._robots = robots
        self._planners: dict[str, TaskPlanner] = {}
        self._services: dict[str, str] = {}
        self._lock = threading.Lock()  # guards the dictionaries
        # one plan at a time per planner: a planner's checker buffers are shared
        self._busy: dict[int, threading.Lock] = {}
        self._joints: JointState | None = None
        self.reference = self.create_publisher(JOINT_REFERENCE, JointTrajectory)
        self.create_subscription("/joint_states", JointState, self._on_joint_states)
        if self.planner is not None:
            self.create_service(PLAN_TASK, PlanTask, self._on_request)

    def add_robot(self, robot: str) -> str:
        """Offer PlanTask for `robot` (a name `robots` knows); returns the service name."""
        if self._robots is None:
            raise ValueError("this planning node was given no robot list")
        if robot in self._services:
            return self._services[robot]
        service, n = robot_service(robot), 1
        while self.bus.service(service) is not None:  # another name spelled the same
            n += 1
            service = robot_service(f"{robot}_{n}")
        self.create_service(service, PlanTask, lambda req: self._on_robot_request(robot, req))
        self._services[robot] = service
        return service

    def services(self) -> dict[str, str]:
        """Robot name -> its PlanTask service, for every robot added."""
        return dict(self._services)

    def forget(self, robot: str, default: bool = False) -> None:
        """Drop `robot`'s TaskPlanner (its description changed): the next request builds
        one for what `robots` gives then. With `default`, `robot` is the one PLAN_TASK
        answers for, and its planner is built again now."""
        with self._lock:
            self._planners.pop(robot, None)
        if default and self._robots is not None:
            planner = TaskPlanner(*self._robots(robot))
            with self._lock:
                self.planner = planner

    def planner_for(self, robot: str) -> TaskPlanner:
        """The TaskPlanner of `robot`, built on first use."""
        with self._lock:
            planner = self._planners.get(robot)
            if planner is None:
                assert self._robots is not None
                model, world = self._robots(robot)
                planner = self._planners[robot] = TaskPlanner(model, world)
            return planner

    def _on_joint_states(self, msg: JointState) -> None:
        self._joints = msg

    def _on_request(self, request: PlanTaskRequest) -> PlanTaskResponse:
        if not request.current_joints.position and self._joints is not None:
            request.current_joints = self._joints
        assert self.planner is not None
        return self._answer(self.planner, request)

    def _on_robot_request(self, robot: str, request: PlanTaskRequest) -> PlanTaskResponse:
        try:
            planner = self.planner_for(robot)
        except Exception as exc:  # a robot that cannot be planned for is answered so
            return PlanTaskResponse(
                success=False,
                message=f"no planner for robot {robot!r}: {exc}",
                error_code=PlanTaskResponse.PLANNING_FAILED,
            )
        return self._answer(planner, request)

    def _answer(self, planner: TaskPlanner, request: PlanTaskRequest) -> PlanTaskResponse:
        call = current_call()
        abandoned = call.abandoned if call is not None else None
        arrived = time.monotonic()
        with self._lock:
            busy = self._busy.setdefault(id(planner), threading.Lock())
        try:
            limit = time_limit(request.time_limit)
        except TaskError:  # refused before any planning: no need to wait for the planner
            return answer(planner, request)[0]
        if not busy.acquire(timeout=-1 if limit is None else limit):
            return PlanTaskResponse(
                success=False,
                message=f"the planner for this robot was busy for the whole time limit "
                f"({limit:g} s); try again",
                error_code=PlanTaskResponse.TIMED_OUT,
            )
        if limit:  # the time spent waiting counts against the limit given
            request.time_limit = max(limit - (time.monotonic() - arrived), 1e-3)
        try:
            response, _ = answer(planner, request, abandoned=abandoned)
        except Exception as exc:  # answered, so that the client is not left waiting
            log.exception("plan_task failed")
            response = PlanTaskResponse(
                success=False,
                message=f"planning failed: {exc}",
                error_code=PlanTaskResponse.PLANNING_FAILED,
            )
        finally:
            busy.release()
        if response.success:
            response.trajectory.header.stamp = Time.now()
            self.reference.publish(response.trajectory)
        return response
