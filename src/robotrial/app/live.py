"""The live platform behind the page's live view (layer 5): for a mobile robot in a room,
the simulator node, the SLAM node and the navigation node run on the server's bus,
paced to real time, so rosbridge clients (the page, roslibpy, Foxglove) see `/tf`,
`/scan`, `/odom`, `/map`, `/plan`, can drive through `/cmd_vel` and send goals on
`/move_base_simple/goal`.

Cameras are not rendered (they cost more than the rest together without a GPU); the
LiDAR, its 2D scan, odometry, joint states and TF are.

SLAM's map is for showing: it grows and changes every few seconds, and the navigation
node (move_base + AMCL, built for a fixed map) would start over on each one. So
navigation runs on a bus of its own with the world's ground-truth map (the role of a
map_server with a prior map), in the frame SLAM's map uses (both start at the spawn
pose); scans, odometry, goals and pose estimates (`/initialpose`) are relayed to it,
its velocity commands, plans (global and local), status line and footprint back. It is
the default navigation stack (`robotrial.nav.DEFAULT_PLANNER`) at the robot's own
speed limits.
"""

from __future__ import annotations

import logging
import threading

import numpy as np

from robotrial.app.catalog import robot_kind, world_kind
from robotrial.geometry import Pose
from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.ros.bus import Bus

log = logging.getLogger(__name__)


def runs_live(robot: RobotModel, world: World) -> bool:
    """A live platform runs for a mobile robot in a room (a world with walls)."""
    return robot_kind(robot) == "mobile" and world_kind(world) == "mobile"


class LivePlatform:
    """The simulator (and SLAM) on `bus` for `robot` in `world`, started at `spawn`.

    `start()` builds the simulation in a background thread (compiling the MuJoCo model
    takes a moment) and then steps it at `realtime` x real time; `stop()` ends it.
    The odom frame (and SLAM's map frame) starts at `spawn` in the world.
    """

    def __init__(
        self,
        bus: Bus,
        robot: RobotModel,
        world: World,
        spawn: Pose,
        *,
        slam: bool = True,
        navigation: bool = True,
        realtime: float = 1.0,
        seed: int = 0,
    ) -> None:
        self.bus = bus
        self.robot = robot
        self.world = world
        self.spawn = spawn
        self.slam = slam
        self.navigation = navigation
        self.realtime = realtime
        self.seed = seed
        self.error: str | None = None
        self._nodes: list = []
        self._relays: list = []
        self._actions: list[str] = []  # actions of the private bus offered on `bus`
        self._lock = threading.Lock()
        self._stopped = False
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="live-platform", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        from robotrial.ros.sim_node import SimNode
        from robotrial.sim.simulation import SimOptions, Simulation

        try:
            sim = Simulation.create(
                self.world,
                self.robot,
                seed=self.seed,
                spawn=self.spawn,
                options=SimOptions(cameras=False),
            )
            with self._lock:
                if self._stopped:
                    return
                if self.navigation:
                    self._start_navigation(sim)
                if self.slam:
                    from robotrial.ros.slam_node import SlamNode
                    from robotrial.slam.hector import HectorSlam

                    self._nodes.append(SlamNode(self.bus, HectorSlam()))
                node = SimNode(self.bus, sim)
                self._nodes.append(node)
                node.start(realtime=self.realtime)
        except Exception as exc:  # the server keeps serving; the page says why
            self.error = f"the live platform could not start: {exc}"
            log.exception("live platform")

    def _start_navigation(self, sim) -> None:
        """NavNode on a private bus with the ground-truth map, relayed to `self.bus`."""
        from robotrial.model.gridmap import world_map
        from robotrial.msgs.geometry_msgs import (
            Point,
            PolygonStamped,
            Pose,
            PoseStamped,
            PoseWithCovarianceStamped,
            Quaternion,
            Twist,
        )
        from robotrial.msgs.nav_msgs import MapMetaData, OccupancyGrid, Odometry, Path
        from robotrial.msgs.robotrial_msgs import NavStatus
        from robotrial.msgs.sensor_msgs import LaserScan
        from robotrial.msgs.std_msgs import Header
        from robotrial.nav.costmap import Footprint
        from robotrial.ros.nav_node import FOOTPRINT, NAV_STATUS, NavNode
        from robotrial.sim.controllers import DriveLimits
        from robotrial.sim.footprint import base_extent
        from robotrial.trials.nav import navigator_config

        if abs(self.spawn.quat[2]) > 1e-9 or abs(self.spawn.quat[3]) < 1 - 1e-9:
            log.warning("live navigation needs a spawn pose without a turn; it is off")
            return
        lidar = next((s for s in self.robot.sensors if s.type == "lidar"), None)
        if lidar is None:
            return
        base_inv = np.linalg.inv(sim.world.body_pose(sim.world.base_body))
        laser = base_inv @ sim.frame_pose(lidar.name)
        laser_pose = (laser[0, 3], laser[1, 3], float(np.arctan2(laser[1, 0], laser[0, 0])))
        grid = world_map(self.world)
        rows, cols = grid.occupied.shape
        private = Bus()
        limits = DriveLimits.from_metadata(self.robot.metadata.get("drive", {}) or {})
        config = navigator_config(
            limits.max_speed,
            limits.max_yaw_rate,
            limits.max_accel,
            max_yaw_accel=limits.max_yaw_accel,
        )
        node = NavNode(
            private,
            Footprint(*base_extent(sim)),
            config,
            laser_pose=laser_pose,
            base_frame=self.robot.root,
        )
        self._nodes.append(node)
        private.publish(
            "/map",
            OccupancyGrid(
                header=Header(frame_id="map"),
                info=MapMetaData(
                    resolution=grid.resolution,
                    width=cols,
                    height=rows,
                    origin=Pose(
                        Point(
                            grid.origin[0] - self.spawn.xyz[0], grid.origin[1] - self.spawn.xyz[1]
                        ),
                        Quaternion(),
                    ),
                ),
                data=np.where(grid.occupied, 100, 0).astype(np.int8).ravel().tolist(),
            ),
            OccupancyGrid,
        )
        relays = [
            (self.bus, private, "/odom", Odometry),
            (self.bus, private, "/scan", LaserScan),
            (self.bus, private, "/move_base_simple/goal", PoseStamped),
            (self.bus, private, "/initialpose", PoseWithCovarianceStamped),
            (private, self.bus, "/cmd_vel", Twist),
            (private, self.bus, "/plan", Path),
            (private, self.bus, "/local_plan", Path),
            (private, self.bus, NAV_STATUS, NavStatus),
            (private, self.bus, FOOTPRINT, PolygonStamped),
        ]
        for source, target, topic, cls in relays:
            latched = topic in (NAV_STATUS, FOOTPRINT)
            pub = target.advertise(topic, cls, latched=latched, node="/navigation_relay")
            self._relays.append(pub)
            self._relays.append(source.subscribe(topic, pub.publish, cls, node="/navigation_relay"))
        # its actions (/navigate_to_pose) answer on the server's bus as they are
        with self.bus._lock:
            for name, server in private.actions.items():
                self.bus.actions.setdefault(name, server)
                self._actions.append(name)

    def stop(self) -> None:
        with self._lock:
            self._stopped = True
            nodes, self._nodes = self._nodes, []
        for relay in self._relays:
            relay.close()
        with self.bus._lock:
            for name in self._actions:
                self.bus.actions.pop(name, None)
        for node in reversed(nodes):
            node.destroy()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
            self._thread = None
