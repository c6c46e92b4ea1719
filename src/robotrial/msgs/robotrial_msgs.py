"""robotrial_msgs: the platform's own types: Box, the PlanTask service, NavStatus (docs/ros.md)."""

from __future__ import annotations

from typing import Any, ClassVar

from robotrial.msgs.core import Message, bool_, float64, int32, message, service, string
from robotrial.msgs.geometry_msgs import Pose, PoseStamped, Vector3
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.trajectory_msgs import JointTrajectory


@message("robotrial_msgs/msg/Box")
class Box(Message):
    """An obstacle or an object: full edge lengths `size` (m) along the box's own axes,
    `pose` of its centre in the robot's base frame."""

    id: string
    size: Vector3
    pose: Pose


@message("robotrial_msgs/srv/PlanTask_Request")
class PlanTaskRequest(Message):
    """Plan a carry: from `current_joints` to `ee_goal` around `obstacles` holding `object`
    (all sizes 0 = nothing held). `ee_goal` orientation all 0 = position only;
    `planner` "" = rrt_connect; `time_limit` 0 = the default (s)."""

    current_joints: JointState
    obstacles: list[Box]
    object: Box
    ee_goal: Pose
    planner: string
    time_limit: float64

    @classmethod
    def from_dict(cls, data: Any, path: str | None = None) -> Any:
        """As any message, except that an `ee_goal` sent without `orientation` means a
        position-only goal (all zeros), not the identity a ROS default would give."""
        if isinstance(data, dict):
            goal = data.get("ee_goal")
            if goal is None or (isinstance(goal, dict) and "orientation" not in goal):
                zero = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}
                data = {**data, "ee_goal": {**(goal or {}), "orientation": zero}}
        return super().from_dict(data, path)


@message("robotrial_msgs/srv/PlanTask_Response")
class PlanTaskResponse(Message):
    """`message` says why when `success` is false, `error_code` the same as a number
    (the constants below: MoveIt's MoveItErrorCodes numbers); `planning_time` in seconds;
    `object_held`: the server's decision whether the request's object moves with the hand."""

    SUCCESS: ClassVar[int32] = 1
    PLANNING_FAILED: ClassVar[int32] = -1
    INVALID_MOTION_PLAN: ClassVar[int32] = -2
    TIMED_OUT: ClassVar[int32] = -6
    START_STATE_IN_COLLISION: ClassVar[int32] = -10
    GOAL_IN_COLLISION: ClassVar[int32] = -12
    INVALID_GOAL_CONSTRAINTS: ClassVar[int32] = -16
    NO_IK_SOLUTION: ClassVar[int32] = -31

    success: bool_
    message: string
    goal_joints: list[float64]
    trajectory: JointTrajectory
    planning_time: float64
    error_code: int32
    object_held: bool_


PlanTask = service("robotrial_msgs/srv/PlanTask", PlanTaskRequest, PlanTaskResponse)


@message("robotrial_msgs/msg/NavStatus")
class NavStatus(Message):
    """What the navigation node is doing, for a status line (the live view's): `state`
    one of idle, planning, driving, recovering, reached, failed, refused; `text` in
    words (the recovery running, why it failed or refused a goal); `distance_remaining`
    (m along the plan, -1 when unknown) and `elapsed` (s since the goal) while a goal
    runs; `goal` the goal it answers."""

    state: string
    text: string
    distance_remaining: float64
    elapsed: float64
    goal: PoseStamped
