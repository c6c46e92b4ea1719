"""sensor_msgs: joint states, laser scans, point clouds, images, camera info, IMU."""

from __future__ import annotations

from typing import ClassVar

from robotrial.msgs.core import (
    Message,
    Ros1Spelling,
    bool_,
    fixed,
    float32,
    float64,
    message,
    string,
    uint8,
    uint8_array,
    uint32,
)
from robotrial.msgs.geometry_msgs import Quaternion, Vector3
from robotrial.msgs.std_msgs import Header


@message("sensor_msgs/msg/JointState")
class JointState(Message):
    header: Header
    name: list[string]
    position: list[float64]
    velocity: list[float64]
    effort: list[float64]


@message("sensor_msgs/msg/LaserScan")
class LaserScan(Message):
    header: Header
    angle_min: float32
    angle_max: float32
    angle_increment: float32
    time_increment: float32
    scan_time: float32
    range_min: float32
    range_max: float32
    ranges: list[float32]
    intensities: list[float32]


@message("sensor_msgs/msg/PointField")
class PointField(Message):
    INT8: ClassVar[uint8] = 1
    UINT8: ClassVar[uint8] = 2
    INT16: ClassVar[uint8] = 3
    UINT16: ClassVar[uint8] = 4
    INT32: ClassVar[uint8] = 5
    UINT32: ClassVar[uint8] = 6
    FLOAT32: ClassVar[uint8] = 7
    FLOAT64: ClassVar[uint8] = 8

    name: string
    offset: uint32
    datatype: uint8
    count: uint32


@message("sensor_msgs/msg/PointCloud2")
class PointCloud2(Message):
    header: Header
    height: uint32
    width: uint32
    fields: list[PointField]
    is_bigendian: bool_
    point_step: uint32
    row_step: uint32
    data: uint8_array
    is_dense: bool_


@message("sensor_msgs/msg/Image")
class Image(Message):
    header: Header
    height: uint32
    width: uint32
    encoding: string
    is_bigendian: uint8
    step: uint32
    data: uint8_array


@message("sensor_msgs/msg/CompressedImage")
class CompressedImage(Message):
    header: Header
    format: string
    data: uint8_array


@message("sensor_msgs/msg/RegionOfInterest")
class RegionOfInterest(Message):
    x_offset: uint32
    y_offset: uint32
    height: uint32
    width: uint32
    do_rectify: bool_


@message(
    "sensor_msgs/msg/CameraInfo",
    ros1=Ros1Spelling(rename={"d": "D", "k": "K", "r": "R", "p": "P"}),
)
class CameraInfo(Message):
    header: Header
    height: uint32
    width: uint32
    distortion_model: string
    d: list[float64]
    k: fixed(float64, 9)
    r: fixed(float64, 9)
    p: fixed(float64, 12)
    binning_x: uint32
    binning_y: uint32
    roi: RegionOfInterest


@message("sensor_msgs/msg/Imu")
class Imu(Message):
    header: Header
    orientation: Quaternion
    orientation_covariance: fixed(float64, 9)
    angular_velocity: Vector3
    angular_velocity_covariance: fixed(float64, 9)
    linear_acceleration: Vector3
    linear_acceleration_covariance: fixed(float64, 9)
