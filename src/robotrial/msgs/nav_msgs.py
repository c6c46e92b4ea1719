"""nav_msgs: odometry, occupancy grids, paths."""

from __future__ import annotations

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.core import Message, float32, int8, message, string, uint32
from robotrial.msgs.geometry_msgs import Pose, PoseStamped, PoseWithCovariance, TwistWithCovariance
from robotrial.msgs.std_msgs import Header


@message("nav_msgs/msg/MapMetaData")
class MapMetaData(Message):
    map_load_time: Time
    resolution: float32
    width: uint32
    height: uint32
    origin: Pose


@message("nav_msgs/msg/OccupancyGrid")
class OccupancyGrid(Message):
    """Row-major cells from the origin; -1 unknown, 0 free .. 100 occupied."""

    header: Header
    info: MapMetaData
    data: list[int8]


@message("nav_msgs/msg/Odometry")
class Odometry(Message):
    header: Header
    child_frame_id: string
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@message("nav_msgs/msg/Path")
class Path(Message):
    header: Header
    poses: list[PoseStamped]
