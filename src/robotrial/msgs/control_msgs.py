"""control_msgs: the FollowJointTrajectory action of ros2_control's trajectory controller,
and the GripperCommand a parallel gripper takes.

The multi-DOF trajectory and per-component tolerance fields are left out: the arms here
have only single-DOF joints.
"""

from __future__ import annotations

from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.core import Message, action, float64, int32, message, string
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

# FollowJointTrajectory result error codes.
SUCCESSFUL = 0
INVALID_GOAL = -1
INVALID_JOINTS = -2
OLD_HEADER_TIMESTAMP = -3
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5


@message("control_msgs/msg/JointTolerance")
class JointTolerance(Message):
    """Bounds on one joint's error; 0 means the controller's default, -1 no bound."""

    name: string
    position: float64
    velocity: float64
    acceleration: float64


@message("control_msgs/msg/GripperCommand")
class GripperCommand(Message):
    """Move the fingers to `position` (the finger joint's value, m) pushing with at most
    `max_effort` (N; 0 or less: the gripper's own limit)."""

    position: float64
    max_effort: float64


@message("control_msgs/action/FollowJointTrajectory_Goal")
class FollowJointTrajectoryGoal(Message):
    trajectory: JointTrajectory
    path_tolerance: list[JointTolerance]
    goal_tolerance: list[JointTolerance]
    goal_time_tolerance: Duration


@message("control_msgs/action/FollowJointTrajectory_Result")
class FollowJointTrajectoryResult(Message):
    error_code: int32
    error_string: string


@message("control_msgs/action/FollowJointTrajectory_Feedback")
class FollowJointTrajectoryFeedback(Message):
    header: Header
    joint_names: list[string]
    desired: JointTrajectoryPoint
    actual: JointTrajectoryPoint
    error: JointTrajectoryPoint


FollowJointTrajectory = action(
    "control_msgs/action/FollowJointTrajectory",
    FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult,
    FollowJointTrajectoryFeedback,
)
