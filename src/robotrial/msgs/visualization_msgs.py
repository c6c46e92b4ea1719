"""visualization_msgs: markers (ROS 2 fields; the texture and mesh-file fields are ROS 2 only)."""

from __future__ import annotations

from typing import ClassVar

from robotrial.msgs.builtin_interfaces import Duration
from robotrial.msgs.core import (
    Message,
    Ros1Spelling,
    bool_,
    float32,
    int32,
    message,
    string,
    uint8_array,
)
from robotrial.msgs.geometry_msgs import Point, Pose, Vector3
from robotrial.msgs.sensor_msgs import CompressedImage
from robotrial.msgs.std_msgs import ColorRGBA, Header


@message("visualization_msgs/msg/UVCoordinate")
class UVCoordinate(Message):
    u: float32
    v: float32


@message("visualization_msgs/msg/MeshFile")
class MeshFile(Message):
    filename: string
    data: uint8_array


@message(
    "visualization_msgs/msg/Marker",
    ros1=Ros1Spelling(drop=("texture_resource", "texture", "uv_coordinates", "mesh_file")),
)
class Marker(Message):
    ARROW: ClassVar[int32] = 0
    CUBE: ClassVar[int32] = 1
    SPHERE: ClassVar[int32] = 2
    CYLINDER: ClassVar[int32] = 3
    LINE_STRIP: ClassVar[int32] = 4
    LINE_LIST: ClassVar[int32] = 5
    CUBE_LIST: ClassVar[int32] = 6
    SPHERE_LIST: ClassVar[int32] = 7
    POINTS: ClassVar[int32] = 8
    TEXT_VIEW_FACING: ClassVar[int32] = 9
    MESH_RESOURCE: ClassVar[int32] = 10
    TRIANGLE_LIST: ClassVar[int32] = 11
    ADD: ClassVar[int32] = 0
    MODIFY: ClassVar[int32] = 0
    DELETE: ClassVar[int32] = 2
    DELETEALL: ClassVar[int32] = 3

    header: Header
    ns: string
    id: int32
    type: int32
    action: int32
    pose: Pose
    scale: Vector3
    color: ColorRGBA
    lifetime: Duration
    frame_locked: bool_
    points: list[Point]
    colors: list[ColorRGBA]
    texture_resource: string
    texture: CompressedImage
    uv_coordinates: list[UVCoordinate]
    text: string
    mesh_resource: string
    mesh_file: MeshFile
    mesh_use_embedded_materials: bool_


@message("visualization_msgs/msg/MarkerArray")
class MarkerArray(Message):
    markers: list[Marker]
