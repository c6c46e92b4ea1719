"""The PlanTask service's messages as the planner's task and back (layer 4): the request
checked and converted to arrays and geometry (`task_request`), the result as a response
with MoveIt's error code (`plan_task_response`), and both around a `TaskPlanner` call
(`answer`). Without the bus, so that `robotrial plan` does not load the server's parts.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable
from functools import cache
from typing import Any

import numpy as np

from robotrial.geometry import Box, Pose
from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.core import Dialect, Message, encode_given
from robotrial.msgs.robotrial_msgs import Box as BoxMsg
from robotrial.msgs.robotrial_msgs import PlanTaskRequest, PlanTaskResponse
from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from robotrial.planning.task import TaskError, TaskPlanner, TaskRequest, TaskResult, time_limit
from robotrial.planning.timing import Trajectory

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


def _numbers(values: list[float]) -> str:
    return "(" + ", ".join(f"{float(v):g}" for v in values) + ")"


def _short(text: str) -> str:
    return text if len(text) <= MAX_NAME else text[:MAX_NAME] + "..."


def _finite(values: list[float], what: str) -> list[float]:
    out = [float(v) for v in values]
    if not all(map(math.isfinite, out)):
        raise TaskError(f"{what} has a non-finite number {_numbers(out)}")
    return out


def _zero(values: list[float]) -> bool:
    """All within 1e-8 of zero."""
    return all(abs(v) <= 1e-8 for v in values)


def _pose_of(msg, what: str) -> Pose:
    """A geometry_msgs/Pose as a Pose (an all-zero orientation is the identity)."""
    p = _finite([msg.position.x, msg.position.y, msg.position.z], what + ".position")
    o = msg.orientation
    q = _finite([o.x, o.y, o.z, o.w], what + ".orientation")
    if _zero(q):
        q = [0.0, 0.0, 0.0, 1.0]
    return Pose(tuple(p), tuple(q))  # type: ignore[arg-type]


def _box_of(msg: BoxMsg, what: str, none_ok: bool) -> tuple[Box, Pose] | None:
    """A robotrial_msgs/Box as a shape and pose; None when all sizes are 0 and
    `none_ok` (the object's way of saying "none"), else TaskError for an empty box."""
    size = [float(msg.size.x), float(msg.size.y), float(msg.size.z)]
    if not all(math.isfinite(v) and v >= 0 for v in size):
        raise TaskError(f"{what}.size must be finite and non-negative, got {_numbers(size)}")
    if not any(size) and none_ok:
        return None
    if not all(size):
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
        goal_position=np.array(position),
        goal_orientation=None if _zero(q) else np.array(q),
        obstacles=obstacles,
        object=None if obj is None else (_short(request.object.id), *obj),
        planner=request.planner,
        time_limit=float(request.time_limit),
    )


def joint_trajectory(names: list[str], traj: Trajectory) -> JointTrajectory:
    """A trajectory_msgs/JointTrajectory of the samples (time from the start)."""
    return JointTrajectory(joint_names=list(names), points=_point_messages(traj))


def _point_messages(traj: Trajectory) -> list[JointTrajectoryPoint]:
    return [
        JointTrajectoryPoint(q, qd, qdd, [], Duration(*divmod(ns, 1_000_000_000)))
        for ns, q, qd, qdd in zip(
            _nanoseconds(traj), traj.q.tolist(), traj.qd.tolist(), traj.qdd.tolist(), strict=True
        )
    ]


def _nanoseconds(traj: Trajectory) -> list[int]:
    """The samples' times in whole nanoseconds (halves to even, as NumPy rounds)."""
    return [round(t * 1e9) for t in traj.t.tolist()]


class _Timed(JointTrajectory):
    """A JointTrajectory whose points are made from the trajectory's arrays when first
    read: until then (the service writes its answer and nothing reads the points) its
    rosbridge JSON comes straight from the arrays, without a message per point."""

    def __init__(self, names: list[str], traj: Trajectory) -> None:
        super().__init__(joint_names=list(names))
        del self.points
        self.timed = traj

    def __getattr__(self, name: str) -> Any:
        if name != "points":
            raise AttributeError(name)
        self.points = _point_messages(self.timed)
        return self.points

    def written(self, dialect: Dialect) -> list[dict] | None:
        """The points' rosbridge JSON objects: from the arrays while no point message has
        been made (one could have been changed since), else from the messages (the node
        publishes the trajectory before it answers); None when a number is not finite."""
        if "points" in self.__dict__:
            return _points(self.points, dialect)
        traj = self.timed
        if not math.isfinite(float(traj.q.sum() + traj.qd.sum() + traj.qdd.sum())):
            return None  # the generic encoder writes a non-finite number as null
        rows = (
            (ns // 1_000_000_000, ns % 1_000_000_000, q, qd, qdd, [])
            for ns, q, qd, qdd in zip(
                _nanoseconds(traj),
                traj.q.tolist(),
                traj.qd.tolist(),
                traj.qdd.tolist(),
                strict=True,
            )
        )
        return _point_objects(rows, dialect)


class _Answer(PlanTaskResponse):
    """A PlanTask response whose rosbridge JSON (`to_dict`) writes the trajectory's points
    straight from its arrays (`_Timed`): the generic encoder converts every field of every
    point message by its type, about five times the time for a trajectory of 20 points."""

    def to_dict(self, dialect: Dialect = "ros2") -> dict[str, Any]:
        trajectory = self.trajectory
        points = trajectory.written(dialect) if isinstance(trajectory, _Timed) else None
        if points is None:
            return super().to_dict(dialect)
        written = encode_given(trajectory, dialect, {"points": points})
        return encode_given(self, dialect, {"trajectory": written})


def _points(points: list[JointTrajectoryPoint], dialect: Dialect) -> list[dict] | None:
    """Trajectory point messages as rosbridge JSON objects, or None when a number is not
    finite."""
    total = 0.0  # finite only when every number is (an overflow just takes the slow path)
    for p in points:
        total += sum(p.positions) + sum(p.velocities) + sum(p.accelerations) + sum(p.effort)
    if not math.isfinite(total):
        return None
    rows = (
        (
            p.time_from_start.sec,
            p.time_from_start.nanosec,
            p.positions,
            p.velocities,
            p.accelerations,
            p.effort,
        )
        for p in points
    )
    return _point_objects(rows, dialect)


def _point_objects(rows: Iterable[tuple], dialect: Dialect) -> list[dict]:
    """Trajectory points as rosbridge JSON objects, from rows of (sec, nanosec,
    positions, velocities, accelerations, effort)."""
    pos, vel, acc, eff, when = _spelling(JointTrajectoryPoint, dialect)
    sec, nanosec = _spelling(Duration, dialect)
    return [
        {pos: q, vel: qd, acc: qdd, eff: e, when: {sec: s, nanosec: ns}}
        for s, ns, q, qd, qdd, e in rows
    ]


@cache
def _spelling(cls: type[Message], dialect: Dialect) -> list[str]:
    """The keys of `cls`'s fields in `dialect`'s JSON, in field order."""
    rename = cls.__ros1__.rename if dialect == "ros1" else {}
    return [rename.get(f.name, f.name) for f in cls.__fields_spec__]


def plan_task_response(result: TaskResult) -> PlanTaskResponse:
    """The PlanTask response of a result, with MoveIt's error code for its failure."""
    traj = result.trajectory if result.success else None
    return _Answer(
        success=result.success,
        message=result.message,
        goal_joints=[] if traj is None else traj.q[-1].tolist(),
        trajectory=JointTrajectory() if traj is None else _Timed(result.joint_names, traj),
        planning_time=result.planning_time,
        error_code=ERROR_CODES[result.failure],
        object_held=result.object_held,
    )


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
