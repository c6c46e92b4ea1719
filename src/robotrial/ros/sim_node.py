"""The simulator on the bus: publishes what a Gazebo + ROS robot publishes (layer 4).

`SimNode` wraps a `robotrial.sim.Simulation`. Topics (the ROS names of docs/ros.md, plus the
sensor topics a Gazebo robot has):

| topic | type | from |
| --- | --- | --- |
| `/points` | sensor_msgs/PointCloud2 (x, y, z float32, ring uint16) | the (first) lidar |
| `/scan` | sensor_msgs/LaserScan | 3D-to-2D conversion |
| `/odom` | nav_msgs/Odometry (odom -> base) | wheel odometry with slip |
| `/ground_truth` | nav_msgs/Odometry (world -> base) | the true pose, for scoring |
| `/imu` | sensor_msgs/Imu | the IMU |
| `/joint_states` | sensor_msgs/JointState | all actuated joints |
| `/tf` | tf2_msgs/TFMessage | odom -> base, movable joints |
| `/tf_static` | tf2_msgs/TFMessage (latched) | fixed joints, sensor mounts |
| `/robot_description` | std_msgs/String (latched) | the robot's URDF, when it came from a file |
| `/NAME/image_raw`, `/NAME/camera_info` | Image rgb8, CameraInfo | each camera |
| `/NAME/depth/image_raw`, `/NAME/depth/camera_info` | Image 32FC1, CameraInfo | depth camera |
| `/NAME/points` | sensor_msgs/PointCloud2 (x, y, z) | depth camera, from the image |

The simulated time is the bus's clock (`Bus.set_clock`) while the node lives, and goes
out on `/clock` (rosgraph_msgs/Clock) every control period while someone listens, as
Gazebo publishes it for `use_sim_time` nodes.

It listens to `/cmd_vel` (geometry_msgs/Twist), `/robotrial/joint_reference`
(trajectory_msgs/JointTrajectory) and `/gripper/command` (control_msgs/GripperCommand:
the fingers' opening and the most they may push), and offers the arm's
`/arm_controller/follow_joint_trajectory` action (`trajectory_action`). Each camera also
offers `/NAME/capture` (std_srvs/Trigger): one frame rendered now and published on its
topics, for a robot that renders only when it looks (its stream switched off). Other
lidars publish on `/NAME/points`.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.control_msgs import GripperCommand
from robotrial.msgs.geometry_msgs import (
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovariance,
    Vector3,
)
from robotrial.msgs.nav_msgs import Odometry
from robotrial.msgs.rosgraph_msgs import Clock
from robotrial.msgs.sensor_msgs import (
    CameraInfo,
    Image,
    Imu,
    JointState,
    LaserScan,
    PointCloud2,
    PointField,
)
from robotrial.msgs.std_msgs import Header, String
from robotrial.msgs.std_srvs import Trigger, TriggerResponse
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.msgs.trajectory_msgs import JointTrajectory
from robotrial.ros.bus import Bus, Node
from robotrial.ros.trajectory_action import JointTrajectoryAction
from robotrial.sim.controllers import JointReference
from robotrial.sim.lidar import Scan
from robotrial.sim.odometry import wrap_angle
from robotrial.sim.scene import Pacer
from robotrial.sim.sensors import ImageReading, ImuReading, JointStateReading, OdometryReading
from robotrial.sim.simulation import Reading, Simulation
from robotrial.sim.tf import Transform as SimTransform
from robotrial.sim.tf import planar_transform

GROUND_TRUTH = "/ground_truth"
ROBOT_DESCRIPTION = "/robot_description"
log = logging.getLogger(__name__)


def header(stamp: float, frame: str) -> Header:
    return Header(stamp=Time.from_sec(stamp), frame_id=frame)


def cloud_message(
    stamp: float, frame: str, points: np.ndarray, ring: np.ndarray | None = None
) -> PointCloud2:
    """An unorganized PointCloud2 with float32 x, y, z (and uint16 ring when given)."""
    n = len(points)
    if ring is None:
        dtype = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4")])
    else:
        dtype = np.dtype(
            {
                "names": ["x", "y", "z", "ring"],
                "formats": ["<f4", "<f4", "<f4", "<u2"],
                "offsets": [0, 4, 8, 12],
                "itemsize": 16,
            }
        )
    arr = np.zeros(n, dtype=dtype)
    arr["x"], arr["y"], arr["z"] = points[:, 0], points[:, 1], points[:, 2]
    fields = [
        PointField(name=c, offset=4 * i, datatype=PointField.FLOAT32, count=1)
        for i, c in enumerate("xyz")
    ]
    if ring is not None:
        arr["ring"] = ring
        fields.append(PointField(name="ring", offset=12, datatype=PointField.UINT16, count=1))
    return PointCloud2(
        header=header(stamp, frame),
        height=1,
        width=n,
        fields=fields,
        is_bigendian=False,
        point_step=dtype.itemsize,
        row_step=dtype.itemsize * n,
        data=arr.tobytes(),
        is_dense=True,
    )


def cloud_points(msg: PointCloud2) -> np.ndarray:
    """(N, 3) float32 x, y, z of a PointCloud2 with float32 x, y, z fields."""
    off = {f.name: f.offset for f in msg.fields}
    n = msg.width * msg.height
    dtype = np.dtype(
        {
            "names": ["x", "y", "z"],
            "formats": ["<f4"] * 3,
            "offsets": [off["x"], off["y"], off["z"]],
            "itemsize": msg.point_step,
        }
    )
    arr = np.frombuffer(msg.data, dtype=dtype, count=n)
    return np.stack([arr["x"], arr["y"], arr["z"]], axis=-1)


def _f32(x: float) -> float:
    """A float32 field's value as it will travel (so a recording reads back equal)."""
    return float(np.float32(x))


def scan_message(s: Scan) -> LaserScan:
    return LaserScan(
        header=header(s.stamp, s.frame),
        angle_min=_f32(s.angle_min),
        angle_max=_f32(s.angle_max),
        angle_increment=_f32(s.angle_increment),
        time_increment=0.0,
        scan_time=_f32(s.scan_time),
        range_min=_f32(s.range_min),
        range_max=_f32(s.range_max),
        ranges=s.ranges.astype(float).tolist(),
        intensities=[],
    )


def _quat_yaw(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=float(np.sin(yaw / 2)), w=float(np.cos(yaw / 2)))


def odometry_message(o: OdometryReading, covariance: float = 0.0) -> Odometry:
    cov = [0.0] * 36
    if covariance > 0:
        for i in range(6):
            cov[7 * i] = covariance
    return Odometry(
        header=header(o.stamp, o.frame),
        child_frame_id=o.child_frame,
        pose=PoseWithCovariance(
            pose=Pose(
                position=Point(x=float(o.x), y=float(o.y), z=float(o.z)),
                orientation=_quat_yaw(o.yaw),
            ),
            covariance=cov,
        ),
        twist=TwistWithCovariance(
            twist=Twist(
                linear=Vector3(x=float(o.v), y=float(o.vy), z=0.0),
                angular=Vector3(x=0.0, y=0.0, z=float(o.w)),
            ),
            covariance=cov,
        ),
    )


def imu_message(r: ImuReading) -> Imu:
    q = r.orientation
    return Imu(
        header=header(r.stamp, r.frame),
        orientation=Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])),
        angular_velocity=Vector3(*map(float, r.angular_velocity)),
        linear_acceleration=Vector3(*map(float, r.linear_acceleration)),
    )


def image_message(r: ImageReading) -> Image:
    h, w = r.pixels.shape[:2]
    data = np.ascontiguousarray(r.pixels)
    if r.encoding == "32FC1":
        data = data.astype("<f4")
    return Image(
        header=header(r.stamp, r.frame),
        height=h,
        width=w,
        encoding=r.encoding,
        is_bigendian=0,
        step=data.nbytes // h,
        data=data.tobytes(),
    )


def camera_info_message(r: ImageReading) -> CameraInfo:
    """Pinhole intrinsics of an image (no distortion), as image_proc and Foxglove use."""
    h, w = r.pixels.shape[:2]
    fx, fy, cx, cy = r.intrinsics()
    return CameraInfo(
        header=header(r.stamp, r.frame),
        height=h,
        width=w,
        distortion_model="plumb_bob",
        d=[0.0] * 5,
        k=[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p=[fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    )


def joint_state_message(r: JointStateReading) -> JointState:
    return JointState(
        header=header(r.stamp, ""),
        name=list(r.names),
        position=r.position.tolist(),
        velocity=r.velocity.tolist(),
        effort=r.effort.tolist(),
    )


def tf_message(transforms: list[SimTransform], stamp: float) -> TFMessage:
    return TFMessage(
        transforms=[
            TransformStamped(
                header=header(stamp, t.parent),
                child_frame_id=t.child,
                transform=Transform(
                    translation=Vector3(*map(float, t.translation)),
                    rotation=Quaternion(*map(float, t.rotation)),
                ),
            )
            for t in transforms
        ]
    )


def reference_from_message(msg: JointTrajectory) -> JointReference:
    """A JointReference from trajectory_msgs/JointTrajectory (velocities used if every
    point has them)."""
    if not msg.points:
        raise ValueError("joint trajectory has no points")
    times = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in msg.points]
    pos = np.array([p.positions for p in msg.points], dtype=float)
    vel = None
    if all(len(p.velocities) == len(msg.joint_names) for p in msg.points):
        vel = np.array([p.velocities for p in msg.points], dtype=float)
    return JointReference(msg.joint_names, times, pos, vel)


Topics = dict[str, tuple[str, type]]
"""stream -> (topic, message type)"""

SENSOR_TOPICS: dict[str, Callable[[str, bool], Topics]] = {
    "lidar": lambda name, first: {name: ("/points" if first else f"/{name}/points", PointCloud2)},
    "imu": lambda name, first: {name: ("/imu" if name == "imu" else f"/{name}/imu", Imu)},
    "camera": lambda name, first: {
        name: (f"/{name}/image_raw", Image),
        f"{name}/info": (f"/{name}/camera_info", CameraInfo),
    },
    "depth_camera": lambda name, first: {
        name: (f"/{name}/depth/image_raw", Image),
        f"{name}/info": (f"/{name}/depth/camera_info", CameraInfo),
        f"{name}/points": (f"/{name}/points", PointCloud2),
    },
}
"""For each sensor type (`sim.sensor_kinds.SENSOR_KINDS`), the topics of a sensor's
streams, given its name and whether it is the first of its type (the first LiDAR
publishes /points, as a robot with one LiDAR does in ROS)."""


class SimNode(Node):
    """Puts a Simulation on the bus and steps it: `run(duration)` in the caller's thread
    (as fast as possible or paced), or `start()`/`stop()` in a background thread.

    A topic's message is only built when the topic has subscribers; `counts` holds the
    messages per topic produced either way."""

    def __init__(self, bus: Bus, sim: Simulation, name: str = "/simulator") -> None:
        super().__init__(bus, name)
        self.sim = sim
        self.counts: dict[str, int] = {}
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._pubs: dict[str, Any] = {}
        self.topics: dict[str, tuple[str, type]] = {
            "scan": ("/scan", LaserScan),
            "odom": ("/odom", Odometry),
            "ground_truth": (GROUND_TRUTH, Odometry),
            "joint_states": ("/joint_states", JointState),
        }
        seen: set[str] = set()
        for s in sim.robot.sensors:
            self.topics.update(SENSOR_TOPICS[s.type](s.name, s.type not in seen))
            seen.add(s.type)
        for topic, cls in self.topics.values():
            self._pubs[topic] = self.create_publisher(topic, cls)
        self._tf = self.create_publisher("/tf", TFMessage)
        self._tf_static = self.create_publisher("/tf_static", TFMessage, latched=True)
        self._description = self.create_publisher(ROBOT_DESCRIPTION, String, latched=True)
        self._clock = self.create_publisher("/clock", Clock)
        bus.set_clock(lambda: sim.world.time)
        self.create_subscription("/cmd_vel", Twist, self._on_cmd_vel)
        self.create_subscription("/robotrial/joint_reference", JointTrajectory, self._on_reference)
        if sim.gripper is not None:
            self.create_subscription("/gripper/command", GripperCommand, self._on_gripper)
        for s in sim.robot.sensors:
            if s.type in ("camera", "depth_camera"):
                self.create_service(
                    f"/{s.name}/capture", Trigger, lambda _req, name=s.name: self._capture(name)
                )
        self._started = False
        self.rejected: list[str] = []
        self.trajectory_action = JointTrajectoryAction(self) if sim.joints is not None else None

    # --- inputs ---------------------------------------------------------------------

    def _on_cmd_vel(self, msg: Twist) -> None:
        if self.sim.base is None:
            return
        with self._lock:
            self.sim.drive(float(msg.linear.x), float(msg.angular.z))

    def _on_reference(self, msg: JointTrajectory) -> None:
        """Track a joint trajectory; one the robot cannot follow is logged and dropped."""
        try:
            ref = reference_from_message(msg)
            with self._lock:
                self.sim.follow(ref)
        except ValueError as exc:
            self.rejected.append(str(exc))
            log.warning("%s: joint reference ignored: %s", self.name, exc)

    def _on_gripper(self, msg: GripperCommand) -> None:
        try:
            with self._lock:
                self.sim.grip(float(msg.position), float(msg.max_effort))
        except ValueError as exc:
            self.rejected.append(str(exc))
            log.warning("%s: gripper command ignored: %s", self.name, exc)

    def _capture(self, sensor: str) -> TriggerResponse:
        """Render one frame of a camera now and publish it on the camera's topics."""
        with self._lock:
            readings = self.sim.capture(sensor)
        for r in readings:
            self.publish_reading(r)
        return TriggerResponse(success=True, message=f"{sensor}: one frame published")

    # --- outputs --------------------------------------------------------------------

    def _send(self, topic: str, make: Callable[[], Any]) -> None:
        """Publish `make()` on `topic`; the message is only built when someone listens
        (a run nobody records costs no conversions). Counted either way."""
        if self.bus.subscriber_count(topic):
            self._pubs[topic].publish(make())
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def _send_tf(self, make: Callable[[], list[SimTransform]], stamp: float) -> None:
        if self.bus.subscriber_count("/tf"):
            self._tf.publish(tf_message(make(), stamp))
        self.counts["/tf"] = self.counts.get("/tf", 0) + 1

    def publish_reading(self, r: Reading) -> None:
        """Turn one sensor reading into its message(s) and publish them."""
        topic = self.topics.get(r.stream, (None, None))[0]
        d = r.data
        if r.kind == "points":
            self._send(topic, lambda: cloud_message(d.stamp, d.frame, d.points, d.ring))
        elif r.kind == "points_xyz":
            stamp, frame, pts = d
            self._send(topic, lambda: cloud_message(stamp, frame, pts))
        elif r.kind == "scan":
            self._send(topic, lambda: scan_message(d))
        elif r.kind == "image":
            self._send(topic, lambda: image_message(d))
            self._send(self.topics[f"{r.stream}/info"][0], lambda: camera_info_message(d))
        elif r.kind == "imu":
            self._send(topic, lambda: imu_message(d))
        elif r.kind == "joint_states":
            self._send(topic, lambda: joint_state_message(d))
            values = dict(zip(d.names, d.position.tolist(), strict=True))
            self._send_tf(lambda: self.sim.tf.dynamic(values), d.stamp)
        elif r.kind == "odom":
            if r.stream == "odom":
                self._send(topic, lambda: odometry_message(d, covariance=0.01))
                yaw = wrap_angle(d.yaw)
                self._send_tf(
                    lambda: [planar_transform("odom", d.child_frame, d.x, d.y, yaw)], d.stamp
                )
            else:
                self._send(topic, lambda: odometry_message(d))

    def start_streams(self) -> None:
        """Publish /tf_static and the first reading of every stream."""
        if self._started:
            return
        self._started = True
        self._tf_static.publish(tf_message(self.sim.tf.static, self.sim.world.time))
        self.counts["/tf_static"] = 1
        self.publish_description()
        for r in self.sim.start():
            self.publish_reading(r)

    def publish_description(self) -> None:
        """Latch the robot's URDF on /robot_description (as robot_state_publisher does),
        so Foxglove's 3D panel and RViz draw the robot; a robot without a URDF file
        publishes nothing."""
        from robotrial.model.robot import ModelError
        from robotrial.model.urdf import description_text

        try:
            text = description_text(self.sim.robot)
        except ModelError as exc:
            log.info("no %s: %s", ROBOT_DESCRIPTION, exc)
            return
        self._description.publish(String(data=text))
        self.counts[ROBOT_DESCRIPTION] = 1

    def step(self) -> None:
        """One control period of the simulation, its readings published."""
        with self._lock:
            readings = self.sim.control_step()
        if self.bus.subscriber_count("/clock"):
            self._clock.publish(Clock(clock=Time.from_sec(self.sim.world.time)))
        for r in readings:
            self.publish_reading(r)

    def run(
        self,
        duration: float,
        realtime: float | None = None,
        on_step: Callable[[float], None] | None = None,
    ) -> None:
        """Simulate `duration` seconds, as fast as possible or at `realtime` x real time.
        `on_step(sim_time)` is called after every control period (progress, teleop)."""
        if duration < 0:
            raise ValueError(f"duration must be >= 0, got {duration}")
        self.start_streams()
        pacer = Pacer(realtime)
        steps = round(duration / self.sim.control_dt)
        for _ in range(steps):
            if self._stop.is_set():
                break
            self.step()
            pacer.wait(self.sim.world.time)
            if on_step is not None:
                on_step(self.sim.world.time)

    def start(self, realtime: float | None = 1.0) -> None:
        """Run in a background thread until `stop()` (for the live app)."""
        if self._thread is not None:
            return
        self._stop.clear()

        def loop() -> None:
            self.start_streams()
            pacer = Pacer(realtime)
            while not self._stop.is_set():
                self.step()
                pacer.wait(self.sim.world.time)

        self._thread = threading.Thread(target=loop, name="simulator", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    def destroy(self) -> None:
        self.stop()
        self.bus.set_clock(None)
        super().destroy()
