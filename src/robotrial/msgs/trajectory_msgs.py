"""trajectory_msgs: joint trajectories (the planner's answer and /robotrial/joint_reference)."""

from __future__ import annotations

from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.core import Message, float64, message, string
from robotrial.msgs.std_msgs import Header


@message("trajectory_msgs/msg/JointTrajectoryPoint")
class JointTrajectoryPoint(Message):
    positions: list[float64]
    velocities: list[float64]
    accelerations: list[float64]
    effort: list[float64]
    time_from_start: Duration


@message("trajectory_msgs/msg/JointTrajectory")
class JointTrajectory(Message):
    header: Header
    joint_names: list[string]
    points: list[JointTrajectoryPoint]
