"""nav2_msgs: the NavigateToPose action (Nav2 Jazzy layout: the result has an error code)."""

from __future__ import annotations

from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.core import Message, action, float32, int16, message, string, uint16
from robotrial.msgs.geometry_msgs import PoseStamped

# NavigateToPose result error codes (Nav2 Jazzy).
NONE = 0
UNKNOWN = 9000
TIMEOUT = 9003


@message("nav2_msgs/action/NavigateToPose_Goal")
class NavigateToPoseGoal(Message):
    pose: PoseStamped
    behavior_tree: string


@message("nav2_msgs/action/NavigateToPose_Result")
class NavigateToPoseResult(Message):
    error_code: uint16
    error_msg: string


@message("nav2_msgs/action/NavigateToPose_Feedback")
class NavigateToPoseFeedback(Message):
    current_pose: PoseStamped
    navigation_time: Duration
    estimated_time_remaining: Duration
    number_of_recoveries: int16
    distance_remaining: float32


NavigateToPose = action(
    "nav2_msgs/action/NavigateToPose",
    NavigateToPoseGoal,
    NavigateToPoseResult,
    NavigateToPoseFeedback,
)
