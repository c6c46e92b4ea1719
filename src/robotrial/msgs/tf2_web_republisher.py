"""tf2_web_republisher's types: what roslibjs's TFClient (ROS 1, over actionlib) and
ROS2TFClient (a ROS 2 action, or the /republish_tfs service) ask for, and actionlib_msgs'
goal id and status that ROS 1 actions carry."""

from __future__ import annotations

from typing import ClassVar

from robotrial.msgs.builtin_interfaces import Duration, Time
from robotrial.msgs.core import Message, action, float32, message, service, string, uint8
from robotrial.msgs.geometry_msgs import TransformStamped
from robotrial.msgs.std_msgs import Header


@message("actionlib_msgs/msg/GoalID")
class GoalID(Message):
    stamp: Time
    id: string


@message("actionlib_msgs/msg/GoalStatus")
class GoalStatus(Message):
    PENDING: ClassVar[uint8] = 0
    ACTIVE: ClassVar[uint8] = 1
    PREEMPTED: ClassVar[uint8] = 2
    SUCCEEDED: ClassVar[uint8] = 3
    ABORTED: ClassVar[uint8] = 4
    REJECTED: ClassVar[uint8] = 5
    PREEMPTING: ClassVar[uint8] = 6
    RECALLING: ClassVar[uint8] = 7
    RECALLED: ClassVar[uint8] = 8
    LOST: ClassVar[uint8] = 9
    goal_id: GoalID
    status: uint8
    text: string


@message("tf2_web_republisher_interfaces/action/TFSubscription_Goal")
class TFSubscriptionGoal(Message):
    source_frames: list[string]
    target_frame: string
    angular_thres: float32
    trans_thres: float32
    rate: float32


@message("tf2_web_republisher_interfaces/action/TFSubscription_Result")
class TFSubscriptionResult(Message):
    pass


@message("tf2_web_republisher_interfaces/action/TFSubscription_Feedback")
class TFSubscriptionFeedback(Message):
    transforms: list[TransformStamped]


TFSubscription = action(
    "tf2_web_republisher_interfaces/action/TFSubscription",
    TFSubscriptionGoal,
    TFSubscriptionResult,
    TFSubscriptionFeedback,
)


@message("tf2_web_republisher_interfaces/msg/TFArray")
class TFArray(Message):
    transforms: list[TransformStamped]


@message("tf2_web_republisher_interfaces/srv/RepublishTFs_Request")
class RepublishTFsRequest(Message):
    source_frames: list[string]
    target_frame: string
    angular_thres: float32
    trans_thres: float32
    rate: float32
    timeout: Duration


@message("tf2_web_republisher_interfaces/srv/RepublishTFs_Response")
class RepublishTFsResponse(Message):
    topic_name: string


RepublishTFs = service(
    "tf2_web_republisher_interfaces/srv/RepublishTFs", RepublishTFsRequest, RepublishTFsResponse
)


# ROS 1: the same action over actionlib's topics (/goal, /cancel, /feedback, ...).
@message("tf2_web_republisher/msg/TFSubscriptionGoal")
class Ros1TFSubscriptionGoal(Message):
    source_frames: list[string]
    target_frame: string
    angular_thres: float32
    trans_thres: float32
    rate: float32


@message("tf2_web_republisher/msg/TFSubscriptionFeedback")
class Ros1TFSubscriptionFeedback(Message):
    transforms: list[TransformStamped]


@message("tf2_web_republisher/msg/TFSubscriptionActionGoal")
class TFSubscriptionActionGoal(Message):
    header: Header
    goal_id: GoalID
    goal: Ros1TFSubscriptionGoal


@message("tf2_web_republisher/msg/TFSubscriptionActionFeedback")
class TFSubscriptionActionFeedback(Message):
    header: Header
    status: GoalStatus
    feedback: Ros1TFSubscriptionFeedback
