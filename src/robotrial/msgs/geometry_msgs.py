"""geometry_msgs: points, vectors, poses, transforms, twists."""

from __future__ import annotations

import numpy as np

from robotrial import geometry
from robotrial.msgs.core import Message, fixed, float32, float64, message, string
from robotrial.msgs.std_msgs import Header


@message("geometry_msgs/msg/Vector3")
class Vector3(Message):
    x: float64
    y: float64
    z: float64

    def to_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])


@message("geometry_msgs/msg/Point")
class Point(Message):
    x: float64
    y: float64
    z: float64

    def to_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])


@message("geometry_msgs/msg/Point32")
class Point32(Message):
    x: float32
    y: float32
    z: float32


@message("geometry_msgs/msg/Quaternion")
class Quaternion(Message):
    """x, y, z, w; the default is the identity (w = 1), as in ROS 2."""

    x: float64
    y: float64
    z: float64
    w: float64 = 1.0

    def to_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z, self.w])

    @staticmethod
    def from_yaw(yaw: float) -> Quaternion:
        """A turn of `yaw` radians about z (a heading on the floor)."""
        return Quaternion(x=0.0, y=0.0, z=float(np.sin(yaw / 2)), w=float(np.cos(yaw / 2)))


@message("geometry_msgs/msg/Pose")
class Pose(Message):
    position: Point
    orientation: Quaternion

    @staticmethod
    def from_pose(pose: geometry.Pose) -> Pose:
        """From robotrial's own Pose (xyz + quaternion x, y, z, w)."""
        return Pose(Point(*pose.xyz), Quaternion(*pose.quat))

    @staticmethod
    def planar(x: float, y: float, yaw: float) -> Pose:
        """A pose on the floor: (x, y) at height 0, heading `yaw` (rad)."""
        return Pose(Point(x=float(x), y=float(y), z=0.0), Quaternion.from_yaw(yaw))

    def to_pose(self) -> geometry.Pose:
        """To robotrial's own Pose; raises ValueError on an all-zero quaternion."""
        p, q = self.position, self.orientation
        return geometry.Pose((p.x, p.y, p.z), (q.x, q.y, q.z, q.w))


@message("geometry_msgs/msg/Pose2D")
class Pose2D(Message):
    x: float64
    y: float64
    theta: float64


@message("geometry_msgs/msg/PoseStamped")
class PoseStamped(Message):
    header: Header
    pose: Pose


@message("geometry_msgs/msg/PoseArray")
class PoseArray(Message):
    header: Header
    poses: list[Pose]


@message("geometry_msgs/msg/PoseWithCovariance")
class PoseWithCovariance(Message):
    pose: Pose
    covariance: fixed(float64, 36)


@message("geometry_msgs/msg/PoseWithCovarianceStamped")
class PoseWithCovarianceStamped(Message):
    header: Header
    pose: PoseWithCovariance


@message("geometry_msgs/msg/PointStamped")
class PointStamped(Message):
    header: Header
    point: Point


@message("geometry_msgs/msg/Vector3Stamped")
class Vector3Stamped(Message):
    header: Header
    vector: Vector3


@message("geometry_msgs/msg/Transform")
class Transform(Message):
    translation: Vector3
    rotation: Quaternion

    @staticmethod
    def from_pose(pose: geometry.Pose) -> Transform:
        return Transform(Vector3(*pose.xyz), Quaternion(*pose.quat))

    def to_pose(self) -> geometry.Pose:
        t, q = self.translation, self.rotation
        return geometry.Pose((t.x, t.y, t.z), (q.x, q.y, q.z, q.w))


@message("geometry_msgs/msg/TransformStamped")
class TransformStamped(Message):
    header: Header
    child_frame_id: string
    transform: Transform


@message("geometry_msgs/msg/Twist")
class Twist(Message):
    linear: Vector3
    angular: Vector3


@message("geometry_msgs/msg/TwistStamped")
class TwistStamped(Message):
    header: Header
    twist: Twist


@message("geometry_msgs/msg/TwistWithCovariance")
class TwistWithCovariance(Message):
    twist: Twist
    covariance: fixed(float64, 36)


@message("geometry_msgs/msg/TwistWithCovarianceStamped")
class TwistWithCovarianceStamped(Message):
    header: Header
    twist: TwistWithCovariance


@message("geometry_msgs/msg/Accel")
class Accel(Message):
    linear: Vector3
    angular: Vector3


@message("geometry_msgs/msg/Wrench")
class Wrench(Message):
    force: Vector3
    torque: Vector3


@message("geometry_msgs/msg/Polygon")
class Polygon(Message):
    points: list[Point32]


@message("geometry_msgs/msg/PolygonStamped")
class PolygonStamped(Message):
    header: Header
    polygon: Polygon
