"""std_msgs: Header and the simple wrapper types."""

from __future__ import annotations

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.core import (
    Message,
    Ros1Spelling,
    bool_,
    float32,
    float64,
    int32,
    int64,
    message,
    string,
    uint8,
    uint32,
)


@message("std_msgs/msg/Header", ros1=Ros1Spelling(extra={"seq": ("uint32", 0)}))
class Header(Message):
    """Stamp and frame of a message. ROS 1 adds `seq`, always 0 here and ignored on input."""

    stamp: Time
    frame_id: string


@message("std_msgs/msg/Empty")
class Empty(Message):
    pass


@message("std_msgs/msg/String")
class String(Message):
    data: string


@message("std_msgs/msg/Bool")
class Bool(Message):
    data: bool_


@message("std_msgs/msg/Float32")
class Float32(Message):
    data: float32


@message("std_msgs/msg/Float64")
class Float64(Message):
    data: float64


@message("std_msgs/msg/Int32")
class Int32(Message):
    data: int32


@message("std_msgs/msg/Int64")
class Int64(Message):
    data: int64


@message("std_msgs/msg/UInt8")
class UInt8(Message):
    data: uint8


@message("std_msgs/msg/ColorRGBA")
class ColorRGBA(Message):
    r: float32
    g: float32
    b: float32
    a: float32


@message("std_msgs/msg/MultiArrayDimension")
class MultiArrayDimension(Message):
    label: string
    size: uint32
    stride: uint32


@message("std_msgs/msg/MultiArrayLayout")
class MultiArrayLayout(Message):
    dim: list[MultiArrayDimension]
    data_offset: uint32


@message("std_msgs/msg/Float64MultiArray")
class Float64MultiArray(Message):
    layout: MultiArrayLayout
    data: list[float64]


@message("std_msgs/msg/Float32MultiArray")
class Float32MultiArray(Message):
    layout: MultiArrayLayout
    data: list[float32]
