"""The robot side's own node: what it hears, what it commands, where it thinks it is
(layer 4).

`Robot` subscribes to the sensor topics a real robot has (odometry, the 2D scan, TF, joint
states, the head's RGB-D pair) and publishes commands (`/cmd_vel`, the arm's joint
trajectory, the gripper command, navigation goals). Its clock is the stamps of what it
hears. It runs the SLAM node while mapping and the navigation node after
(`start_navigation`), so its pose is SLAM's, then AMCL's. A camera frame is asked for
with the camera's capture service and arrives on the camera's topics (`capture`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robotrial.geometry import Pose
from robotrial.model.robot import RobotModel
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.control_msgs import GripperCommand
from robotrial.msgs.geometry_msgs import Pose as PoseMsg
from robotrial.msgs.geometry_msgs import (
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Twist,
    Vector3,
)
from robotrial.msgs.nav_msgs import OccupancyGrid, Odometry
from robotrial.msgs.sensor_msgs import CameraInfo, Image, JointState, LaserScan
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.std_srvs import Trigger
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.msgs.trajectory_msgs import JointTrajectory
from robotrial.nav.amcl import compose
from robotrial.nav.costmap import Footprint
from robotrial.nav.navigator import NavigatorConfig
from robotrial.onboard.camera import RgbdFrame, image_array, intrinsics
from robotrial.ros.bus import Bus, Node
from robotrial.ros.nav_node import NavNode
from robotrial.ros.slam_node import SlamNode, grid_message, yaw_of
from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.tiled import TiledGrid

CMD_RATE = 20.0  # Hz, the robot's own /cmd_vel (route driving, docking)


@dataclass(frozen=True)
class RobotSetup:
    """How the robot's software is set up (what a launch file says): its description,
    its footprint on the floor, the SLAM it maps with (an object from `slam/`; None: no
    mapping, the pose is the odometry's), the navigator's settings (None: it does not
    navigate), the RGB-D pair it looks with (colour camera and depth camera names), the
    grip force (N) and the arm planner."""

    model: RobotModel
    footprint: Footprint | None = None
    slam: object | None = None
    navigator: NavigatorConfig | None = None
    camera: str = "head_camera"
    depth: str = "head_depth"
    grip_force: float = 40.0
    planner: str = "rrt_connect"
    seed: int = 0


class Robot(Node):
    """The robot's node on the bus; `tick()` after every control period of the world."""

    def __init__(self, bus: Bus, setup: RobotSetup, name: str = "/robot") -> None:
        super().__init__(bus, name)
        self.setup = setup
        self.model = setup.model
        self.cmd_pub = self.create_publisher("/cmd_vel", Twist)
        self.goal_pub = self.create_publisher("/move_base_simple/goal", PoseStamped)
        self.init_pub = self.create_publisher("/initialpose", PoseWithCovarianceStamped)
        self.map_pub = self.create_publisher("/map", OccupancyGrid, latched=True)
        self.ref_pub = self.create_publisher("/robotrial/joint_reference", JointTrajectory)
        self.grip_pub = self.create_publisher("/gripper/command", GripperCommand)
        self.create_subscription("/odom", Odometry, self._on_odom)
        self._tf_sub = self.create_subscription("/tf", TFMessage, self._on_tf)
        self.create_subscription("/tf_static", TFMessage, self._on_tf_static)
        self.create_subscription("/scan", LaserScan, self._on_scan)
        self.create_subscription("/joint_states", JointState, self._on_joints)
        self._images: dict[str, Image] = {}
        self._infos: dict[str, CameraInfo] = {}
        for topic in (f"/{setup.camera}/image_raw", f"/{setup.depth}/depth/image_raw"):
            self.create_subscription(topic, Image, lambda m, t=topic: self._images.update({t: m}))
        for topic in (f"/{setup.camera}/camera_info", f"/{setup.depth}/depth/camera_info"):
            self.create_subscription(
                topic, CameraInfo, lambda m, t=topic: self._infos.update({t: m})
            )
        self.now = 0.0
        self.odom = np.zeros(3)
        self.velocity = (0.0, 0.0)  # m/s, rad/s, as odometry measures them
        self.map_to_odom = np.zeros(3)
        self.scan: LaserScan | None = None
        self.joints: dict[str, float] = {}
        self._static: dict[str, tuple[str, np.ndarray]] = {}
        self._last_cmd = -np.inf
        self.slam_node = SlamNode(bus, setup.slam) if setup.slam is not None else None
        self.nav_node: NavNode | None = None
        self.grid: LogOddsGrid | TiledGrid | None = None
        # the SLAM's node poses (map frame) and their scans' hits (base frame), when its
        # method keeps nodes: the raw scans the map was drawn from
        self.keyframes: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])

    # --- what it hears -----------------------------------------------------------------

    def _stamp(self, header: Header) -> None:
        self.now = max(self.now, header.stamp.sec + header.stamp.nanosec * 1e-9)

    def _on_odom(self, msg: Odometry) -> None:
        self._stamp(msg.header)
        p = msg.pose.pose
        self.odom = np.array([p.position.x, p.position.y, yaw_of(p.orientation)])
        self.velocity = (float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z))

    def _on_tf(self, msg: TFMessage) -> None:
        for tr in msg.transforms:
            if tr.header.frame_id == "map" and tr.child_frame_id == "odom":
                t = tr.transform
                self.map_to_odom = np.array([t.translation.x, t.translation.y, yaw_of(t.rotation)])

    def _on_tf_static(self, msg: TFMessage) -> None:
        for tr in msg.transforms:
            t = tr.transform
            m = Pose(
                (t.translation.x, t.translation.y, t.translation.z),
                (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w),
            ).matrix()
            self._static[tr.child_frame_id] = (tr.header.frame_id, m)

    def _on_scan(self, msg: LaserScan) -> None:
        self.scan = msg

    def _on_joints(self, msg: JointState) -> None:
        self._stamp(msg.header)
        self.joints.update(zip(msg.name, map(float, msg.position), strict=True))

    # --- where it is -------------------------------------------------------------------

    def pose(self) -> np.ndarray:
        """The robot's pose on its map (SLAM's while mapping, then AMCL's once it has the
        map and its initial pose; in between, SLAM's last correction with odometry)."""
        if self.nav_node is not None and self.nav_node.amcl is not None:
            return self.nav_node.pose()
        return compose(self.map_to_odom, self.odom)

    def static_frame(self, frame: str) -> np.ndarray:
        """A frame fixed to the base (a camera's optical frame), in the base frame, from
        /tf_static."""
        m = np.eye(4)
        cur = frame
        while cur != self.model.root:
            if cur not in self._static:
                raise ValueError(f"robot: frame {frame!r} is not fixed to {self.model.root!r}")
            parent, t = self._static[cur]
            m = t @ m
            cur = parent
        return m

    # --- what it commands --------------------------------------------------------------

    def drive(self, v: float, w: float) -> None:
        """Command the base at CMD_RATE, as a teleoperation node does (a stop goes out at
        once)."""
        if (v, w) != (0.0, 0.0) and self.now < self._last_cmd + 1.0 / CMD_RATE - 1e-9:
            return
        self._last_cmd = self.now
        self.cmd_pub.publish(Twist(linear=Vector3(x=v), angular=Vector3(z=w)))

    def grip(self, position: float, max_effort: float) -> None:
        self.grip_pub.publish(GripperCommand(position=position, max_effort=max_effort))

    def send_goal(self, goal: np.ndarray) -> None:
        head = Header(stamp=Time.from_sec(self.now), frame_id="map")
        self.goal_pub.publish(PoseStamped(header=head, pose=PoseMsg.planar(*goal)))

    def capture(self) -> RgbdFrame:
        """One RGB-D frame from the head: the capture services render it, its messages
        arrive on the camera topics, the optical frame comes from /tf_static."""
        cam, depth = self.setup.camera, self.setup.depth
        for name in (depth, cam):
            self.call(f"/{name}/capture", Trigger.Request())
        d_msg = self._images[f"/{depth}/depth/image_raw"]
        d_info = self._infos[f"/{depth}/depth/camera_info"]
        c_msg = self._images.get(f"/{cam}/image_raw")
        rgb = image_array(c_msg) if c_msg is not None else None
        stamp = d_msg.header.stamp.sec + d_msg.header.stamp.nanosec * 1e-9
        return RgbdFrame(
            image_array(d_msg),
            rgb,
            intrinsics(d_info),
            self.static_frame(d_msg.header.frame_id),
            stamp,
        )

    # --- mapping, then navigation ------------------------------------------------------

    def start_navigation(self, xy_tolerance: float, yaw_tolerance: float, **changes) -> None:
        """Stop SLAM, start AMCL and the navigator on the map SLAM built, from SLAM's
        last pose (the navigator's settings with `changes`, NavigatorConfig fields)."""
        if self.slam_node is None or self.setup.navigator is None or self.setup.footprint is None:
            raise ValueError(
                "robot: navigating needs SLAM, the navigator's settings and a footprint"
            )
        self.slam_node.settle()
        pose = self.pose()
        slam = self.slam_node.slam
        self.grid = slam.grid.copy()
        nodes, scans = getattr(slam, "nodes", []), getattr(slam, "scans", [])
        self.keyframes = (
            [np.array(q, dtype=float) for q in nodes],
            [s.hits.copy() for s in scans[: len(nodes)]],
        )
        self.slam_node.destroy()
        self.slam_node = None
        self._tf_sub.close()  # SLAM's map -> odom is all it was for
        cfg = NavigatorConfig(
            **{
                **self.setup.navigator.__dict__,
                "xy_tolerance": xy_tolerance,
                "yaw_tolerance": yaw_tolerance,
                **changes,
            }
        )
        self.nav_node = NavNode(
            self.bus, self.setup.footprint, cfg, laser_pose=self.laser, seed=self.setup.seed
        )
        self._initial = pose

    def publish_map(self, values: np.ndarray | None = None) -> None:
        """Give AMCL its initial pose and the navigator the built map (after the
        navigation node has heard the odometry): its cells as ROS values (100 occupied,
        0 free, -1 unknown), by default at the usual thresholds."""
        assert self.grid is not None
        head = Header(stamp=Time.from_sec(self.now), frame_id="map")
        cov = np.zeros(36)
        cov[0] = cov[7] = 0.05**2
        cov[35] = 0.03**2
        self.init_pub.publish(
            PoseWithCovarianceStamped(
                header=head,
                pose=PoseWithCovariance(
                    pose=PoseMsg.planar(*self._initial), covariance=cov.tolist()
                ),
            )
        )
        self.map_pub.publish(grid_message(self.grid, self.now, values=values))

    @property
    def laser(self) -> tuple[float, float, float]:
        """The 2D scan's frame on the base (x, y, yaw), from /tf_static."""
        frame = self.scan.header.frame_id if self.scan is not None else ""
        m = self.static_frame(frame)
        return float(m[0, 3]), float(m[1, 3]), float(np.arctan2(m[1, 0], m[0, 0]))

    def destroy(self) -> None:
        for node in (self.slam_node, self.nav_node):
            if node is not None:
                node.destroy()
        super().destroy()
