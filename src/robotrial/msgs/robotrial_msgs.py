"""robotrial_msgs: the platform's own types, Box and the PlanTask service (DESIGN.md)."""

from __future__ import annotations

from typing import Any

from robotrial.msgs.core import Message, bool_, float64, int32, message, service, string
from robotrial.msgs.geometry_msgs import Pose, Vector3
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
        """Decode rosbridge JSON; an `ee_goal` sent without `orientation` is a position-only
        goal (all zeros), not the identity rotation a missing Quaternion decodes to."""
        request = super().from_dict(data, path)
        goal = data.get("ee_goal") if isinstance(data, dict) else None
        if not isinstance(goal, dict) or "orientation" not in goal:
            request.ee_goal.orientation.w = 0.0
        return request


@message("robotrial_msgs/srv/PlanTask_Response")
class PlanTaskResponse(Message):
    """`message` says why when `success` is false and `error_code` (MoveItErrorCodes)
    what kind of failure it was; `planning_time` in seconds; `object_held`: whether the
    server counted the request's object as held in the hand (else as an obstacle)."""

    success: bool_
    message: string
    goal_joints: list[float64]
    trajectory: JointTrajectory
    planning_time: float64
    error_code: int32
    object_held: bool_


class MoveItErrorCodes:
    """PlanTask's `error_code` values, MoveIt's moveit_msgs/MoveItErrorCodes numbers."""

    SUCCESS = 1
    PLANNING_FAILED = -1  # the planner stopped without a path for another reason
    INVALID_MOTION_PLAN = -2  # every planned path failed the dense MuJoCo check
    TIMED_OUT = -6  # no path within the time limit
    START_STATE_IN_COLLISION = -10
    GOAL_IN_COLLISION = -12  # every IK solution for the goal collides
    INVALID_GOAL_CONSTRAINTS = -16  # a bad request: the message names the field
    NO_IK_SOLUTION = -31  # the goal is out of reach


PlanTask = service("robotrial_msgs/srv/PlanTask", PlanTaskRequest, PlanTaskResponse)
