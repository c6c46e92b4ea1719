"""SLAM on the bus: scans (and odometry) in, the map, the map -> odom transform and the
pose out, like slam_gmapping and hector_mapping (layer 4).

| direction | topic | type |
| --- | --- | --- |
| in | `/scan` | sensor_msgs/LaserScan |
| in | `/odom` | nav_msgs/Odometry (GMapping needs it; Hector and the graph use it if any) |
| in | `/tf_static` | tf2_msgs/TFMessage (where the laser sits on the base) |
| out | `/map` | nav_msgs/OccupancyGrid, latched, every `map_update_interval` s of scan time |
| out | `/tf` | map -> odom (map -> base frame when there is no odometry) |
| out | `/slam_out_pose` | geometry_msgs/PoseStamped, the base in the map frame |

The algorithm objects come from robotrial.slam; this module only converts messages.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.geometry_msgs import (
    Pose,
    PoseStamped,
    Quaternion,
    Transform,
    TransformStamped,
    Vector3,
)
from robotrial.msgs.nav_msgs import MapMetaData, OccupancyGrid, Odometry
from robotrial.msgs.sensor_msgs import LaserScan
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.ros.bus import Bus, Node
from robotrial.slam.gmapping import GMappingSlam
from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.hector import HectorSlam
from robotrial.slam.posegraph import PoseGraphSlam
from robotrial.slam.scan import Beams, beams, compose, relative
from robotrial.slam.tiled import TiledGrid

POSE_TOPIC = "/slam_out_pose"


def stamp_of(header: Header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def yaw_of(q: Any) -> float:
    """Yaw (rad) of a geometry_msgs/Quaternion."""
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))


def odom_pose(msg: Odometry) -> np.ndarray:
    """(x, y, yaw) of an Odometry message's pose."""
    p = msg.pose.pose
    return np.array([p.position.x, p.position.y, yaw_of(p.orientation)])


def transform_matrix(tr: Transform) -> np.ndarray:
    m = np.eye(4)
    r = tr.rotation
    m[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
    m[:3, 3] = [tr.translation.x, tr.translation.y, tr.translation.z]
    return m


def frame_in(static: dict[str, tuple[str, np.ndarray]], frame: str, base: str) -> np.ndarray:
    """4x4 pose of `frame` in `base` through static transforms (child -> (parent, 4x4))."""
    m = np.eye(4)
    seen: set[str] = set()
    while frame != base:
        if frame not in static or frame in seen:
            raise ValueError(
                f"no static transform chain from {frame!r} to the base frame {base!r} "
                "(is /tf_static recorded?)"
            )
        seen.add(frame)
        parent, t = static[frame]
        m = t @ m
        frame = parent
    return m


def planar(m: np.ndarray) -> tuple[float, float, float]:
    """(x, y, yaw) of a 4x4 pose."""
    return float(m[0, 3]), float(m[1, 3]), float(np.arctan2(m[1, 0], m[0, 0]))


def scan_to_beams(
    msg: LaserScan,
    laser_pose: tuple[float, float, float],
    min_range: float,
    usable_range: float,
    max_range: float = np.inf,
) -> Beams:
    """A LaserScan as SLAM beams in the base frame, with the method's range limits
    (`slam.scan.beams`: past `max_range` a beam is left out, past `usable_range` cut)."""
    rmax = float(msg.range_max) if msg.range_max > 0 else usable_range
    return beams(
        np.asarray(msg.ranges, dtype=np.float64),
        float(msg.angle_min),
        float(msg.angle_increment),
        max(float(msg.range_min), min_range),
        min(rmax, usable_range),
        laser_pose,
        max_range,
    )


def grid_message(
    grid: LogOddsGrid | TiledGrid,
    stamp: float,
    frame: str = "map",
    values: np.ndarray | None = None,
) -> OccupancyGrid:
    """The map as nav_msgs/OccupancyGrid (100 occupied, 0 free, -1 unknown): `values`
    when given (the grid's shape), else the grid's at the usual thresholds."""
    values = grid.ros_values() if values is None else values
    h, w = values.shape
    return OccupancyGrid(
        header=Header(stamp=Time.from_sec(stamp), frame_id=frame),
        info=MapMetaData(
            map_load_time=Time.from_sec(stamp),
            resolution=float(grid.resolution),
            width=w,
            height=h,
            origin=Pose.planar(grid.origin[0], grid.origin[1], 0.0),
        ),
        data=values.ravel().tolist(),
    )


class SlamNode(Node):
    """Runs a GMappingSlam, HectorSlam or PoseGraphSlam on the bus's /scan (and /odom)."""

    def __init__(
        self,
        bus: Bus,
        slam: GMappingSlam | HectorSlam | PoseGraphSlam,
        map_update_interval: float | None = None,
        name: str = "/slam",
        map_frame: str = "map",
        odom_frame: str = "odom",
    ) -> None:
        super().__init__(bus, bus.unique_node_name(name))
        self.slam = slam
        if map_update_interval is None:
            params = slam.params
            map_update_interval = float(
                getattr(params, "map_update_interval", getattr(params, "map_pub_period", 5.0))
            )
        self.map_update_interval = map_update_interval
        self.map_frame, self.odom_frame = map_frame, odom_frame
        self.base_frame: str | None = None
        self._static: dict[str, tuple[str, np.ndarray]] = {}
        self._mounts: dict[str, tuple[float, float, float]] = {}
        self._odom: list[tuple[float, np.ndarray]] = []
        self._last_map: float | None = None
        self._lock = threading.Lock()
        self.scans = 0
        self.scan_times: list[float] = []
        self.dropped = 0
        self.pose: np.ndarray | None = None
        self._map_pub = self.create_publisher("/map", OccupancyGrid, latched=True)
        self._tf_pub = self.create_publisher("/tf", TFMessage)
        self._pose_pub = self.create_publisher(POSE_TOPIC, PoseStamped)
        self.create_subscription("/tf_static", TFMessage, self._on_static)
        self.create_subscription("/odom", Odometry, self._on_odom)
        self.create_subscription("/scan", LaserScan, self._on_scan)

    def _on_static(self, msg: TFMessage) -> None:
        with self._lock:
            for tr in msg.transforms:
                self._static[tr.child_frame_id] = (
                    tr.header.frame_id,
                    transform_matrix(tr.transform),
                )
            self._mounts.clear()

    def _on_odom(self, msg: Odometry) -> None:
        with self._lock:
            self.base_frame = self.base_frame or msg.child_frame_id
            self.odom_frame = msg.header.frame_id or self.odom_frame
            self._odom.append((stamp_of(msg.header), odom_pose(msg)))
            if len(self._odom) > 200:
                del self._odom[:100]

    def _odom_at(self, t: float) -> np.ndarray | None:
        if not self._odom:
            return None
        best = min(self._odom, key=lambda s: abs(s[0] - t))
        return best[1] if abs(best[0] - t) <= 0.1 else None

    def _mount(self, frame: str) -> tuple[float, float, float] | None:
        if self.base_frame is None or frame == self.base_frame or not frame:
            return (0.0, 0.0, 0.0)
        if frame not in self._mounts:
            try:
                self._mounts[frame] = planar(frame_in(self._static, frame, self.base_frame))
            except ValueError:
                return None
        return self._mounts[frame]

    def _on_scan(self, msg: LaserScan) -> None:
        with self._lock:
            t = stamp_of(msg.header)
            # Every method is given the odometry when there is some; GMapping needs it.
            odom = self._odom_at(t)
            mount = self._mount(msg.header.frame_id)
            if (self.slam.uses_odometry and odom is None) or mount is None:
                self.dropped += 1
                return
            t0 = time.perf_counter()
            low, top, usable = self.slam.range_limits(float(msg.range_max))
            b = scan_to_beams(msg, mount, low, usable, top)
            self.pose = pose = self.slam.process(b, t, odom)
            self.scan_times.append(time.perf_counter() - t0)
            self.scans += 1
        self._publish(t, pose, odom)

    def _publish(self, t: float, pose: np.ndarray, odom: np.ndarray | None) -> None:
        header = Header(stamp=Time.from_sec(t), frame_id=self.map_frame)
        self._pose_pub.publish(
            PoseStamped(
                header=header,
                pose=Pose.planar(*pose[:3]),
            )
        )
        if odom is not None:
            child = self.odom_frame
            m2o = compose(pose, relative(odom, np.zeros(3)))
        else:
            child = self.base_frame or "base_link"
            m2o = pose
        self._tf_pub.publish(
            TFMessage(
                transforms=[
                    TransformStamped(
                        header=header,
                        child_frame_id=child,
                        transform=Transform(
                            translation=Vector3(x=m2o[0], y=m2o[1], z=0.0),
                            rotation=Quaternion.from_yaw(m2o[2]),
                        ),
                    )
                ]
            )
        )
        if self._last_map is None or t - self._last_map >= self.map_update_interval:
            self.publish_map(t)

    def settle(self) -> None:
        """Let the method finish its pending work (the pose graph's back end: loop
        searches and the optimisation), so that its map and pose are final."""
        with self._lock:
            if isinstance(self.slam, PoseGraphSlam):
                self.slam.settle()
                self.pose = self.slam.pose.copy()

    def destroy(self) -> None:
        """Leave the bus and stop the method's worker thread, if it has one."""
        super().destroy()
        if isinstance(self.slam, PoseGraphSlam):
            self.slam.close()

    def publish_map(self, t: float) -> None:
        """Publish the current map on /map (latched)."""
        with self._lock:
            msg = grid_message(self.slam.grid, t, self.map_frame)
            self._last_map = t
        self._map_pub.publish(msg)
