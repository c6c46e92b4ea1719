"""tf2_msgs: TFMessage, the payload of /tf and /tf_static."""

from __future__ import annotations

from robotrial.msgs.core import Message, message
from robotrial.msgs.geometry_msgs import TransformStamped


@message("tf2_msgs/msg/TFMessage")
class TFMessage(Message):
    transforms: list[TransformStamped]
