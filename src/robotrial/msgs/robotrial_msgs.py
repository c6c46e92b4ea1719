"""robotrial_msgs: the platform's own types, Box and the PlanTask service (docs/ros.md)."""

from __future__ import annotations

from robotrial.msgs.core import Message, bool_, float64, message, service, string
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


@message("robotrial_msgs/srv/PlanTask_Response")
class PlanTaskResponse(Message):
    """`message` says why when `success` is false; `planning_time` in seconds."""

    success: bool_
    message: string
    goal_joints: list[float64]
    trajectory: JointTrajectory
    planning_time: float64


PlanTask = service("robotrial_msgs/srv/PlanTask", PlanTaskRequest, PlanTaskResponse)
