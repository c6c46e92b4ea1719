"""The carry trial: one mobile manipulator maps a home, drives on its own map, picks an
object, carries it to a named room and sets it down there (layer 5).

Everything runs on one bus, as a ROS robot would: the simulator node (MuJoCo: LiDAR,
odometry, joints, ground truth), a SLAM node (the pose graph, Hector or GMapping, live), then the
navigation node (AMCL on the map SLAM built, costmaps, global planner, DWA), and the arm
planner (the PlanTask machinery) for the arm. The task itself is a sequence of phases:

1. `mapping`: from the spawn, with no map, the robot drives the world's exploration
   route (`ROUTES`, waypoints given in advance, as a teleoperated mapping run would; for
   a world without one, a tour of its rooms made from its plan, `exploration_route`),
   localized by SLAM as it builds the map.
2. `navigation`: on the finished map, AMCL starts from SLAM's last pose. The base pose
   for the pick is chosen from the arm's reach (poses around the object that are free on
   the map and from which the arm planner finds a grasp); the robot drives to a point
   0.35 m behind it and then straight in.
3. `pick`: the arm moves to a side grasp, the fingers close until both touch the
   object, and the object is then attached to the hand (the report says so: the grasp
   is not held by friction), lifted and carried in front of the robot.
4. `carry`: as `navigation`, to a base pose that reaches the room's place point and the
   point LIFT above it.
5. `place`: standing still, the pose comes from scans matched to the built map
   (`_docked_pose`); if the navigator's tolerance left the point out of reach, the base
   drives straight to the next of REACHES. The hand goes where the object, as it sits
   in the hand, lands on the point; the arm lowers it, lets go and withdraws; the base
   backs away.

What the robot is told: its spawn on the plan of the home, the route, the object's and
the place point's positions, and the furniture near them as boxes for the arm planner.
It is not given the occupancy map: it navigates on the map it built. The object's offset
in the hand is read from the simulation when the fingers close (a wrist camera's job).

Success: the object rests within `PLACE_TOLERANCE` of the place point, upright, and the
robot never touched a wall or furniture (MuJoCo contacts of robot geoms with static
geoms or other objects; the gripper touching the carried object is allowed).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from robotrial.geometry import Box as BoxShape
from robotrial.geometry import Cylinder, Pose, Sphere
from robotrial.model import load_robot, load_world
from robotrial.model.world import Obstacle, World
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.geometry_msgs import Pose as PoseMsg
from robotrial.msgs.geometry_msgs import (
    PoseStamped,
    PoseWithCovariance,
    PoseWithCovarianceStamped,
    Quaternion,
    Transform,
    TransformStamped,
    Twist,
    Vector3,
)
from robotrial.msgs.nav_msgs import OccupancyGrid
from robotrial.msgs.sensor_msgs import LaserScan
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.msgs.trajectory_msgs import JointTrajectory
from robotrial.nav import DEFAULT_PLANNER
from robotrial.nav.amcl import compose, inverse
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.navigator import NavigatorConfig, Status
from robotrial.planning.task import Obstacles, TaskPlanner, TaskRequest, TaskResult
from robotrial.ros.bus import Bus, Node
from robotrial.ros.nav_node import NavNode
from robotrial.ros.planning_node import joint_trajectory
from robotrial.ros.sim_node import SimNode
from robotrial.ros.slam_node import SlamNode, grid_message, scan_to_beams, yaw_of
from robotrial.sim import SimOptions, Simulation, StreamSettings
from robotrial.sim.controllers import DriveLimits
from robotrial.sim.odometry import wrap_angle
from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.matcher import ScanMatcher
from robotrial.trials.nav import ContactWatch, footprint_of, navigator_config
from robotrial.trials.slam import RouteDrive, make_slam

PHASES = ("mapping", "navigation", "pick", "carry", "place")
PLACE_TOLERANCE = 0.05  # m, object centre to the place point, in the plane
UPRIGHT = np.deg2rad(10.0)  # largest tilt of an object that stood upright
OBJECTS_TOPIC = "/tf"  # the objects' true poses: world -> object/NAME transforms
STANDOFF = 0.35  # m driven straight in to the base pose and back out
REACHES = (0.5, 0.45, 0.55)  # m, arm base to the object, in the plane, in this order
GRASP_BACKOFF = 0.1  # m, pre-grasp distance along the approach
LIFT = 0.06  # m
CARRY_TCP = (0.35, 0.0, 0.95)  # m, in the base frame: the hand while driving
SETTLE = 0.3  # s after each arm motion
FINGER_SPEED = 0.03  # m/s while closing
MAPPING_SPEED = 0.3  # m/s, the top speed while the map is being built
CMD_RATE = 20.0  # Hz, the trial's own /cmd_vel (route driving, docking)
DOCK_SCANS = 5  # scans matched to the map for the pose at a work site
RECORDED = (
    "/scan",
    "/odom",
    "/ground_truth",
    "/tf",
    "/tf_static",
    "/joint_states",
    "/cmd_vel",
    "/map",
    "/slam_out_pose",
    "/amcl_pose",
    "/plan",
    "/move_base/status",
    "/move_base_simple/goal",
    "/initialpose",
    "/robotrial/joint_reference",
)

# Exploration routes (world x, y in m) from the world's default spawn, passing every room
# the carry trial uses. The apartment's: the living room, the kitchen through D5 and
# back, across the corridor from D3 to D1, into the bedroom.
ROUTES: dict[str, list[tuple[float, float]]] = {
    "apartment": [
        (5.5, 3.2),
        (5.9, 2.5),
        (7.3, 2.5),
        (7.6, 3.3),
        (7.2, 2.5),
        (5.9, 2.5),
        (4.0, 3.3),
        (2.6, 3.5),
        (2.6, 5.0),
        (2.55, 5.85),
        (1.6, 6.4),
    ],
}

# The hand's orientation for a side grasp approaching along base +x: the gripper's
# approach axis (z) forward, its x axis up (the hand camera on top), fingers closing
# sideways.
SIDE_GRASP = Rotation.from_matrix([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


def exploration_route(world: World, footprint: Footprint) -> list[tuple[float, float]]:
    """A mapping route for a world without one in ROUTES: from the default spawn through
    each room's most open spot and back, as straight legs the footprint drives clear of
    everything (`robotrial.nav.tour`). Raises ValueError when it reaches no room."""
    from robotrial.model.gridmap import world_map
    from robotrial.nav.planners import StartBlocked
    from robotrial.nav.tour import open_spot, room_tour

    if not world.rooms:
        raise ValueError(
            f"carry trial: world {world.name!r} names no rooms, so no mapping route can be "
            "made for it: give `rooms` in its YAML"
        )
    grid = world_map(world)
    origin, res = np.asarray(grid.origin, dtype=float), grid.resolution
    costmap = Costmap(grid.occupied, tuple(origin), res, footprint)
    goals = [open_spot(costmap.distance, origin, res, room.bounds) for room in world.rooms]
    spawn = world.spawn("default")
    dock = (float(spawn.xyz[0]), float(spawn.xyz[1]), float(spawn.yaw))
    try:
        route, visited = room_tour(costmap, dock, goals)
    except StartBlocked as exc:
        raise ValueError(f"carry trial: no mapping route in {world.name!r}: {exc}") from None
    if not visited:
        raise ValueError(
            f"carry trial: no mapping route in {world.name!r}: the base reaches no room "
            "from its spawn"
        )
    return route


class PhaseFailed(RuntimeError):
    """A phase could not be completed; the message says why."""

    def __init__(self, phase: str, reason: str) -> None:
        super().__init__(f"{phase}: {reason}")
        self.phase = phase
        self.reason = reason


@dataclass(frozen=True)
class CarrySetup:
    """One carry task: which object goes to which room, in which world, mapped by which
    SLAM method, at what top speed (m/s)."""

    world: str | World = "apartment"  # a built-in name, a World YAML file or a World
    object: str = "cup"
    to: str = "bedroom"
    slam: str = "graph"
    speed: float = 0.5
    robot: str = "mobile_manipulator"
    planner: str = "rrt_connect"
    time_limit: float = 600.0  # s, simulated

    def __post_init__(self) -> None:
        if not self.speed > 0:
            raise ValueError(f"carry trial: speed must be positive, got {self.speed} m/s")


@dataclass
class CarryResult:
    """What a run gave: success, the phase that failed and why, each phase's simulated
    and wall time, the final object error, contacts, the paths and joint curves."""

    seed: int
    success: bool
    failed_phase: str = ""
    reason: str = ""
    phases: list[dict[str, Any]] = field(default_factory=list)
    sim_time: float = 0.0
    wall_time: float = 0.0
    place_error: float | None = None
    tilt: float | None = None
    collision: str = ""
    grasp: str = ""
    skipped: list[str] = field(default_factory=list)
    arm_plans: list[dict[str, Any]] = field(default_factory=list)
    truth: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    estimate: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    joints: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    joint_names: list[str] = field(default_factory=list)
    map_image: np.ndarray | None = None
    map_origin: tuple[float, float] = (0.0, 0.0)
    map_resolution: float = 0.05
    map_in_world: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def summary(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "success": self.success,
            "failed_phase": self.failed_phase,
            "reason": self.reason,
            "sim_time": round(self.sim_time, 2),
            "wall_time": round(self.wall_time, 2),
            "real_time_factor": round(self.sim_time / self.wall_time, 2)
            if self.wall_time
            else None,
            "phases": self.phases,
            "place_error": None if self.place_error is None else round(self.place_error, 4),
            "tilt_deg": None if self.tilt is None else round(float(np.rad2deg(self.tilt)), 2),
            "collision": self.collision,
            "grasp": self.grasp,
            "skipped": self.skipped,
            "arm_plans": self.arm_plans,
        }


def _box(name: str, size, pose: Pose) -> tuple[str, BoxShape, Pose]:
    return name, BoxShape(tuple(float(v) for v in size)), pose


def _bounding_size(ob: Obstacle) -> tuple[float, float, float]:
    g = ob.geometry
    if isinstance(g, BoxShape):
        return tuple(g.size)  # type: ignore[return-value]
    if isinstance(g, Cylinder):
        return (2 * g.radius, 2 * g.radius, g.length)
    if isinstance(g, Sphere):
        return (2 * g.radius,) * 3  # type: ignore[return-value]
    raise ValueError(f"{ob.name}: the carry trial handles boxes, cylinders and spheres")


def _top(ob: Obstacle) -> float:
    return float(ob.pose.xyz[2] + _bounding_size(ob)[2] / 2)


class CarryTrial(Node):
    """The task node: runs the phases against the simulator, SLAM and navigation nodes.
    `tick()` is called after every control period; the phases are a generator that
    yields once per period."""

    def __init__(self, setup: CarrySetup, seed: int, out: Path | None) -> None:
        world = setup.world if isinstance(setup.world, World) else load_world(setup.world)
        robot = load_robot(setup.robot)
        self.target = world.body(setup.object)
        if self.target.kind != "object":
            raise ValueError(f"carry trial: {setup.object!r} is furniture, not an object")
        self.room = world.room(setup.to)
        if self.room.place is None:
            raise ValueError(f"carry trial: room {setup.to!r} has no place to set things down")
        self.setup, self.seed, self.world, self.robot = setup, seed, world, robot
        off = StreamSettings(enabled=False)
        streams = {s.name: off for s in robot.sensors if s.type not in ("lidar",)}
        self.sim = Simulation.create(
            world,
            robot,
            seed=seed,
            spawn="default",
            options=SimOptions(cameras=False, streams=streams),
        )
        self.bus = Bus()
        super().__init__(self.bus, "/carry")
        self.sim_node = SimNode(self.bus, self.sim)
        self.slam_node: SlamNode | None = SlamNode(self.bus, make_slam(setup.slam))
        self.nav_node: NavNode | None = None
        self.recorder = None
        if out is not None:
            from robotrial.ros.recorder import BusRecorder, Recorder

            out.mkdir(parents=True, exist_ok=True)
            self.recorder = Recorder(out / f"carry_{seed}.mcap")
            BusRecorder(self.bus, self.recorder, list(RECORDED))
        self.cmd_pub = self.create_publisher("/cmd_vel", Twist)
        self._last_cmd = -np.inf
        self.goal_pub = self.create_publisher("/move_base_simple/goal", PoseStamped)
        self.init_pub = self.create_publisher("/initialpose", PoseWithCovarianceStamped)
        self.tf_pub = self.create_publisher(OBJECTS_TOPIC, TFMessage)
        self.map_pub = self.create_publisher("/map", OccupancyGrid, latched=True)
        self.ref_pub = self.create_publisher("/robotrial/joint_reference", JointTrajectory)
        self.create_subscription("/odom", None, self._on_odom)
        self._tf_sub = self.create_subscription("/tf", TFMessage, self._on_tf)
        self.create_subscription("/scan", LaserScan, self._on_scan)

        spawn = world.spawn("default")
        self.spawn = np.array([spawn.xyz[0], spawn.xyz[1], spawn.yaw])
        self.odom = np.zeros(3)
        self.velocity = (0.0, 0.0)
        self.map_to_odom = np.zeros(3)
        self.scan: LaserScan | None = None
        self.limits = DriveLimits.from_metadata(robot.metadata.get("drive", {}) or {})
        self.speed = min(setup.speed, self.limits.max_speed)
        self.footprint: Footprint = footprint_of(self.sim)
        if isinstance(setup.world, str) and setup.world in ROUTES:
            self.route = list(ROUTES[setup.world])
        else:
            self.route = exploration_route(world, self.footprint)
        base_inv = np.linalg.inv(self.sim.world.body_pose(self.sim.world.base_body))
        lidar = next(s for s in robot.sensors if s.type == "lidar")
        laser_m = base_inv @ self.sim.frame_pose(lidar.link)
        self.laser = np.array(
            [laser_m[0, 3], laser_m[1, 3], np.arctan2(laser_m[1, 0], laser_m[0, 0])]
        )
        arm_m = base_inv @ self.sim.frame_pose("arm_base_link")
        self.arm_offset = float(arm_m[0, 3])

        self.planner = TaskPlanner(robot)
        self.matcher = ScanMatcher()
        self.slam_grid: LogOddsGrid | None = None
        self.arm_names = self.planner.joint_names
        self.watch = ContactWatch(self.sim)
        self._allow_gripper_contacts()
        self.result = CarryResult(seed, False, joint_names=list(self.arm_names))
        self.result.map_in_world = tuple(float(v) for v in self.spawn)  # type: ignore[assignment]
        self._truth: list[tuple[float, float, float]] = []
        self._estimate: list[tuple[float, float, float]] = []
        self._joints: list[list[float]] = []
        self._steps = 0
        self._phase: dict[str, Any] | None = None
        self.in_hand = np.zeros(3)  # the held object's centre in the tool frame (m)
        self._task: Iterator[None] = self._run()

    # --- inputs ------------------------------------------------------------------------

    def _on_odom(self, msg) -> None:
        p = msg.pose.pose
        q = p.orientation
        yaw = yaw_of(q)
        self.odom = np.array([p.position.x, p.position.y, yaw])
        self.velocity = (float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z))

    def _on_tf(self, msg: TFMessage) -> None:
        for tr in msg.transforms:
            if tr.header.frame_id == "map" and tr.child_frame_id == "odom":
                yaw = yaw_of(tr.transform.rotation)
                self.map_to_odom = np.array(
                    [tr.transform.translation.x, tr.transform.translation.y, yaw]
                )

    def _on_scan(self, msg: LaserScan) -> None:
        self.scan = msg

    def pose(self) -> np.ndarray:
        """The robot's pose on its map (SLAM's, then AMCL's)."""
        if self.nav_node is not None:
            return self.nav_node.pose()
        return compose(self.map_to_odom, self.odom)

    def to_map(self, xy_yaw) -> np.ndarray:
        """World (x, y, yaw) to the map frame (the spawn)."""
        return compose(inverse(self.spawn), np.asarray(xy_yaw, dtype=float))

    # --- the loop ----------------------------------------------------------------------

    def run(self, on_progress: Callable[[str, float], None] | None = None) -> CarryResult:
        wall0 = time.perf_counter()
        self.sim_node.start_streams()
        self.sim.set_joint_targets({f: self._finger_open for f in self._fingers})
        done = False
        try:
            while not done:
                self.sim_node.step()
                self._observe()
                if self.sim.world.time > self.setup.time_limit:
                    raise PhaseFailed(
                        self._phase["name"] if self._phase else "mapping",
                        f"time limit: not done after {self.setup.time_limit:.0f} s",
                    )
                try:
                    next(self._task)
                except StopIteration:
                    done = True
                if on_progress is not None and self._steps % 50 == 0:
                    on_progress(self._phase["name"] if self._phase else "", self.sim.world.time)
        except PhaseFailed as exc:
            self.result.failed_phase, self.result.reason = exc.phase, exc.reason
        finally:
            self._end_phase()
            self.result.sim_time = self.sim.world.time
            self.result.wall_time = time.perf_counter() - wall0
            self._finish()
        return self.result

    def _observe(self) -> None:
        """After each control period: contacts, paths, joint curves, object poses."""
        self._steps += 1
        data = self.sim.world.data
        hit = self.watch.touching(data)
        if hit is not None and not self.result.collision:
            self.result.collision = hit
            raise PhaseFailed(
                self._phase["name"] if self._phase else "mapping", f"the robot touched {hit}"
            )
        if self._steps % 5:
            return
        t = self.sim.world.time
        x, y, _ = self.sim.world.base_pose2d()
        self._truth.append((t, x, y))
        e = self.pose()
        self._estimate.append((t, float(e[0]), float(e[1])))
        values = self.sim.joint_values()
        self._joints.append([t] + [values[n] for n in self.arm_names])
        if self._steps % 10 == 0:
            self._publish_objects(t)

    def _publish_objects(self, t: float) -> None:
        head = Header(stamp=Time.from_sec(t), frame_id="world")
        transforms = []
        for ob in self.world.objects:
            pos, quat = self._object_pose(ob.name)
            transforms.append(
                TransformStamped(
                    header=head,
                    child_frame_id=f"object/{ob.name}",
                    transform=Transform(
                        translation=Vector3(*map(float, pos)),
                        rotation=Quaternion(*map(float, quat)),
                    ),
                )
            )
        self.tf_pub.publish(TFMessage(transforms=transforms))

    def _object_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """True position and quaternion (x, y, z, w) of an object in the world."""
        m, d = self.sim.world.model, self.sim.world.data
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"object/{name}")
        w, x, y, z = d.xquat[b]
        return d.xpos[b].copy(), np.array([x, y, z, w])

    # --- phases ------------------------------------------------------------------------

    def _begin(self, name: str) -> None:
        self._end_phase()
        self._phase = {"name": name, "start": self.sim.world.time, "wall": time.perf_counter()}

    def _end_phase(self) -> None:
        if self._phase is None:
            return
        p = self._phase
        self.result.phases.append(
            {
                "phase": p["name"],
                "start": round(p["start"], 2),
                "time": round(self.sim.world.time - p["start"], 2),
                "wall_time": round(time.perf_counter() - p["wall"], 2),
            }
        )
        self._phase = None

    def _run(self) -> Iterator[None]:
        self._begin("mapping")
        yield from self._explore()
        yield from self._start_navigation()
        obj = self.world.body(self.setup.object)
        self._begin("navigation")
        yield from self._go_near(obj.pose.xyz, "navigation", holding=False)
        self._begin("pick")
        yield from self._pick()
        self._begin("carry")
        place = self.room.place
        assert place is not None
        surface = self.world.body(self.room.place_on)
        height = _top(surface) + _bounding_size(self.target)[2] / 2
        target = np.array([place[0], place[1], height])
        yield from self._go_near(target, "carry", holding=True)
        self._begin("place")
        yield from self._place(target)
        self._end_phase()
        self._score(target)

    # --- mapping -----------------------------------------------------------------------

    def _explore(self) -> Iterator[None]:
        """Drive the given route, localized by SLAM as it builds the map: turn towards
        each route point, then drive to it (a teleoperated mapping run)."""
        route = [tuple(self.to_map((x, y, 0.0))[:2]) for x, y in self.route]
        follow = RouteDrive(route, min(self.speed, MAPPING_SPEED))
        while not follow.done:
            v, w = follow.command(*self.pose())
            self._drive(v, w)
            yield
        self._drive(0.0, 0.0)
        for _ in range(10):
            yield

    def _nav_config(self, **changes) -> NavigatorConfig:
        base = navigator_config(
            self.speed,
            self.limits.max_yaw_rate,
            self.limits.max_accel,
            DEFAULT_PLANNER,
            self.limits.max_yaw_accel,
        )
        return NavigatorConfig(**{**base.__dict__, **changes})

    def _drive(self, v: float, w: float) -> None:
        """Command the base on /cmd_vel at CMD_RATE, as a teleoperation node does (a stop
        goes out at once)."""
        t = self.sim.world.time
        if (v, w) != (0.0, 0.0) and t < self._last_cmd + 1.0 / CMD_RATE - 1e-9:
            return
        self._last_cmd = t
        self.cmd_pub.publish(Twist(linear=Vector3(x=v), angular=Vector3(z=w)))

    def _start_navigation(self) -> Iterator[None]:
        """Stop SLAM, start AMCL + the navigator, then hand them SLAM's map and last pose."""
        assert self.slam_node is not None
        self.slam_node.settle()
        pose = self.pose()
        grid = self.slam_node.slam.grid
        self.slam_grid = grid.copy()
        values = grid.ros_values()
        self.result.map_image = values.copy()
        self.result.map_origin = grid.origin
        self.result.map_resolution = grid.resolution
        self.map_occupied = values == 100
        self.map_unknown = values < 0
        self.map_origin, self.map_res = grid.origin, grid.resolution
        self.slam_node.destroy()
        self.slam_node = None
        self._tf_sub.close()  # SLAM's map -> odom is all it was for
        self.nav_node = NavNode(
            self.bus,
            self.footprint,
            self._nav_config(xy_tolerance=0.08, yaw_tolerance=0.08),
            laser_pose=tuple(self.laser),
            seed=self.seed,
        )
        for _ in range(5):  # the navigation node hears the odometry first
            yield
        t = self.sim.world.time
        head = Header(stamp=Time.from_sec(t), frame_id="map")
        cov = np.zeros(36)
        cov[0] = cov[7] = 0.05**2
        cov[35] = 0.03**2
        self.init_pub.publish(
            PoseWithCovarianceStamped(
                header=head,
                pose=PoseWithCovariance(pose=PoseMsg.planar(*pose), covariance=cov.tolist()),
            )
        )
        self.map_pub.publish(grid_message(grid, t))

    # --- navigation --------------------------------------------------------------------

    def _go_near(self, target, phase: str, holding: bool) -> Iterator[None]:
        """Drive to a base pose from which the arm reaches `target` (world x, y, z)."""
        target_map = self.to_map((target[0], target[1], 0.0))
        z = float(target[2])
        candidates = self._base_candidates(target_map[:2])
        if not candidates:
            raise PhaseFailed(phase, "no free base pose on the map within the arm's reach")
        tried = []
        for base, stage in candidates:
            ok = self._arm_reaches(base, np.array([*target_map[:2], z]), holding)
            if not ok:
                tried.append(base)
                continue
            status = yield from self._navigate(stage)
            if status != "succeeded":
                raise PhaseFailed(phase, f"to the pose before {self._where(target)}: {status}")
            yield from self._straight(STANDOFF)
            return base
        raise PhaseFailed(
            phase,
            f"the arm reaches {self._where(target)} from none of the {len(tried)} free base "
            "poses around it",
        )

    def _where(self, target) -> str:
        return f"({target[0]:.2f}, {target[1]:.2f})"

    def _base_candidates(self, xy: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Base poses (and their staging poses STANDOFF behind) that face `xy` from the
        arm's reach, free on the built map, the most clearance first."""
        blocked = self.map_occupied | self.map_unknown
        dist = ndimage.distance_transform_edt(~blocked) * self.map_res
        half_l, half_w = self.footprint.length / 2, self.footprint.width / 2
        u = np.linspace(-1, 1, 9)
        outline = np.concatenate(
            [
                np.column_stack([half_l * u, np.full_like(u, half_w)]),
                np.column_stack([half_l * u, np.full_like(u, -half_w)]),
                np.column_stack([np.full_like(u, half_l), half_w * u]),
                np.column_stack([np.full_like(u, -half_l), half_w * u]),
            ]
        )

        def at(pose: np.ndarray) -> float:
            col = int((pose[0] - self.map_origin[0]) / self.map_res)
            row = int((pose[1] - self.map_origin[1]) / self.map_res)
            if not (0 <= row < dist.shape[0] and 0 <= col < dist.shape[1]):
                return 0.0
            return float(dist[row, col])

        def clearance(pose: np.ndarray) -> float:
            c, s = np.cos(pose[2]), np.sin(pose[2])
            px = pose[0] + c * outline[:, 0] - s * outline[:, 1]
            py = pose[1] + s * outline[:, 0] + c * outline[:, 1]
            col = np.floor((px - self.map_origin[0]) / self.map_res).astype(int)
            row = np.floor((py - self.map_origin[1]) / self.map_res).astype(int)
            inside = (row >= 0) & (row < dist.shape[0]) & (col >= 0) & (col < dist.shape[1])
            if not inside.all():
                return -1.0
            return float(dist[row, col].min())

        out = []
        for reach in REACHES:
            for th in np.deg2rad(np.arange(0, 360, 10)):
                d = np.array([np.cos(th), np.sin(th)])
                centre = xy - (self.arm_offset + reach) * d
                base = np.array([centre[0], centre[1], th])
                stage = np.array([*(centre - STANDOFF * d), th])
                c1, c2 = clearance(base), clearance(stage)
                turn = self.footprint.circumscribed_radius + 0.1  # room to turn at the stage
                if c1 >= 0.04 and c2 >= 0.15 and at(stage) >= turn:
                    out.append((reach, -min(c1, 0.2) - 0.5 * min(c2, 0.5), base, stage))
        out.sort(key=lambda r: (REACHES.index(r[0]), r[1]))
        return [(b, s) for _, _, b, s in out]

    def _arm_reaches(self, base: np.ndarray, target: np.ndarray, holding: bool) -> bool:
        """Whether the arm planner finds the way in (the approach point to pick, the point
        LIFT above to place) and the final hand pose at `target` (map frame) with the
        base at `base`."""
        local = self._in_base(base, target)
        first = local + np.array([0.0, 0.0, LIFT]) if holding else self._approach_point(local)
        q = np.zeros(len(self.arm_names))
        for point in (first, local):
            res = self._plan(q, point, base, holding=False, quiet=True)
            if res is None:
                return False
            q = res.trajectory.q[-1]
        return True

    def _navigate(self, goal: np.ndarray) -> Iterator[None]:
        assert self.nav_node is not None
        head = Header(stamp=Time.from_sec(self.sim.world.time), frame_id="map")
        self.goal_pub.publish(PoseStamped(header=head, pose=PoseMsg.planar(*goal)))
        nav = self.nav_node.navigator
        assert nav is not None
        while self.nav_node.goal_pending or nav.status is Status.ACTIVE:
            yield
        self._drive(0.0, 0.0)
        for _ in range(10):
            yield
        return nav.status.value if nav.status is Status.SUCCEEDED else nav.message

    def _straight(self, distance: float, speed: float = 0.12) -> Iterator[None]:
        """Drive `distance` m straight ahead (negative: back), holding the heading."""
        start = self.pose()
        heading = start[2]
        direction = np.sign(distance)
        while True:
            p = self.pose()
            along = (p[0] - start[0]) * np.cos(heading) + (p[1] - start[1]) * np.sin(heading)
            left = abs(distance) - direction * along
            if left <= 0.005:
                break
            v = direction * min(speed, max(0.03, 1.5 * left))
            err = wrap_angle(heading - p[2])
            self._drive(v, 2.0 * err)
            yield
        self._drive(0.0, 0.0)
        for _ in range(10):
            yield

    # --- the arm -----------------------------------------------------------------------

    def _in_base(self, base: np.ndarray, p: np.ndarray) -> np.ndarray:
        """A map-frame point (x, y, z) in the base frame of a base pose (x, y, yaw)."""
        d = compose(inverse(base), np.array([p[0], p[1], 0.0]))
        return np.array([d[0], d[1], p[2]])

    def _approach_point(self, local: np.ndarray) -> np.ndarray:
        d = local[:2] - np.array([self.arm_offset, 0.0])
        d = d / max(np.linalg.norm(d), 1e-9)
        return np.array(
            [local[0] - GRASP_BACKOFF * d[0], local[1] - GRASP_BACKOFF * d[1], local[2]]
        )

    def _orientation(self, local: np.ndarray) -> Rotation:
        d = local[:2] - np.array([self.arm_offset, 0.0])
        yaw = float(np.arctan2(d[1], d[0]))
        return Rotation.from_euler("z", yaw) * SIDE_GRASP

    def _obstacles(self, base: np.ndarray) -> Obstacles:
        """Furniture and walls within reach of the arm, as boxes in the base frame
        (cylinders by their bounding boxes), and the floor."""
        inv = compose(inverse(base), self.to_map((0.0, 0.0, 0.0)))
        out = [_box("floor", (4.0, 4.0, 0.1), Pose((0.0, 0.0, -0.05)))]
        for ob in self.world.static_bodies:
            p = compose(inv, np.array([ob.pose.xyz[0], ob.pose.xyz[1], ob.pose.yaw]))
            size = _bounding_size(ob)
            if np.hypot(p[0], p[1]) - 0.5 * np.hypot(size[0], size[1]) > 1.5:
                continue
            out.append(
                _box(
                    ob.name,
                    size,
                    Pose.from_xyz_rpy((p[0], p[1], ob.pose.xyz[2]), (0.0, 0.0, p[2])),
                )
            )
        return out

    def _plan(
        self,
        start: np.ndarray,
        local: np.ndarray,
        base: np.ndarray,
        holding: bool,
        quiet: bool = False,
        orientation: Rotation | None = None,
    ) -> TaskResult | None:
        """Plan the hand to `local` (base frame) with a side grasp; None when the planner
        finds nothing (raises PhaseFailed instead unless `quiet`)."""
        q = (orientation or self._orientation(local)).as_quat()
        obj = None
        if holding:
            size = _bounding_size(self.target)
            tcp = self.planner.kin.link_pose(start)
            obj = _box(self.setup.object, size, Pose.from_matrix(tcp))
        request = TaskRequest(
            positions=np.asarray(start, dtype=float),
            joint_names=list(self.arm_names),
            goal_position=np.asarray(local, dtype=float),
            goal_orientation=np.asarray(q, dtype=float),
            obstacles=self._obstacles(base),
            object=obj,
            planner=self.setup.planner,
            time_limit=2.0,
        )
        res = self.planner.plan(request, seed=self.seed)
        self.result.arm_plans.append(
            {
                "phase": self._phase["name"] if self._phase else "",
                "success": res.success,
                "planning_time": round(res.planning_time, 4),
                "message": res.message,
            }
        )
        if not res.success:
            if quiet:
                return None
            raise PhaseFailed(self._phase["name"], f"arm planning: {res.message}")
        return res

    def _move_arm(
        self,
        local: np.ndarray,
        base: np.ndarray,
        holding: bool,
        orientation: Rotation | None = None,
        quiet: bool = False,
    ) -> Generator[None, None, bool]:
        """Plan and follow a hand motion to `local`; False when `quiet` and no plan."""
        start = np.array([self.sim.joint_values()[n] for n in self.arm_names])
        res = self._plan(start, local, base, holding, quiet=quiet, orientation=orientation)
        if res is None:
            return False
        self.ref_pub.publish(joint_trajectory(self.arm_names, res.trajectory))
        end = self.sim.world.time + res.trajectory.duration + SETTLE
        while self.sim.world.time < end:
            yield
        return True

    def _reaches(self, local: np.ndarray, base: np.ndarray, pose: np.ndarray) -> bool:
        """Whether, with the base moved to `pose`, the held object's hand reaches the point
        that is `local` from `base` and the point LIFT above it."""
        start = np.array([self.sim.joint_values()[n] for n in self.arm_names])
        p = self._in_base(pose, self._to_map_point(base, local))
        return all(
            self._plan(start, p + np.array([0.0, 0.0, dz]), pose, holding=True, quiet=True)
            for dz in (LIFT, 0.0)
        )

    def _reach(self, local: np.ndarray, base: np.ndarray) -> Iterator[None]:
        """Drive straight so that the arm reaches `local` (base frame) at one of REACHES,
        in their order, when the docking left it a little far or too close (the
        navigator stops within its tolerance of the staging pose)."""
        ahead = float(np.hypot(local[0] - self.arm_offset, local[1]))
        for shift in (ahead - r for r in REACHES):
            if abs(shift) < 0.005:
                continue
            if self._reaches(local, base, compose(base, np.array([shift, 0.0, 0.0]))):
                yield from self._straight(shift, speed=0.06)
                return

    def _docked_pose(self) -> Iterator[None]:
        """The pose at a work site (its return value), from the scans matched to the built
        map (AMCL's particles settle a few cm off; standing still, the scans say better)."""
        poses = []
        guess = self.pose()
        for _ in range(DOCK_SCANS):
            seen = self.scan
            while self.scan is seen:
                yield
            b = scan_to_beams(self.scan, tuple(self.laser), 0.1, 12.0)
            assert self.slam_grid is not None
            poses.append(self.matcher.match(self.slam_grid, b.hits, guess).pose)
        p = np.array(poses)
        mean_yaw = float(np.arctan2(np.sin(p[:, 2]).mean(), np.cos(p[:, 2]).mean()))
        return np.array([p[:, 0].mean(), p[:, 1].mean(), mean_yaw])

    def _to_map_point(self, base: np.ndarray, local: np.ndarray) -> np.ndarray:
        """A base-frame point (x, y, z) of base pose `base` in the map frame."""
        p = compose(base, np.array([local[0], local[1], 0.0]))
        return np.array([p[0], p[1], local[2]])

    @property
    def _fingers(self) -> list[str]:
        g = self.sim.gripper
        return [] if g is None else g.fingers

    @property
    def _finger_open(self) -> float:
        g = self.sim.gripper
        return 0.0 if g is None else g.open_value

    def _allow_gripper_contacts(self) -> None:
        """The gripper may touch the object it is to carry."""
        m = self.sim.world.model
        names = {"arm_gripper_base", "arm_finger_left_link", "arm_finger_right_link"}
        self.finger_geoms = {
            name: [g for g in range(m.ngeom) if _body_name(m, int(m.geom_bodyid[g])) == name]
            for name in names
        }
        target = f"object/{self.setup.object}"
        self.target_geoms = [
            g for g in range(m.ngeom) if _body_name(m, int(m.geom_bodyid[g])) == target
        ]
        for gs in self.finger_geoms.values():
            for g in gs:
                self.watch.robot[g] = False

    def _fingers_touch(self) -> bool:
        data = self.sim.world.data
        touching = set()
        for i in range(data.ncon):
            if data.contact.dist[i] > 0:
                continue
            g1, g2 = (int(g) for g in data.contact.geom[i])
            for name in ("arm_finger_left_link", "arm_finger_right_link"):
                fg = self.finger_geoms[name]
                if (g1 in fg and g2 in self.target_geoms) or (g2 in fg and g1 in self.target_geoms):
                    touching.add(name)
        return len(touching) == 2

    def _hand_offset(self) -> float:
        """The true distance (m) between the tool point and the target object's centre."""
        tcp = self.sim.frame_pose(self.robot.end_effector)[:3, 3]
        return float(np.linalg.norm(tcp - self._object_pose(self.setup.object)[0]))

    def _pick(self) -> Iterator[None]:
        base = yield from self._docked_pose()
        obj_world = np.asarray(self.target.pose.xyz, dtype=float)
        obj_map = self.to_map((obj_world[0], obj_world[1], 0.0))
        local = self._in_base(base, np.array([obj_map[0], obj_map[1], obj_world[2]]))
        yield from self._move_arm(self._approach_point(local), base, holding=False)
        yield from self._move_arm(local, base, holding=False)
        g = self.sim.gripper
        assert g is not None and g.joints is not None
        finger = self._fingers[0]
        value = g.open_value
        step = FINGER_SPEED * self.sim.control_dt * np.sign(g.closed_value - g.open_value)
        deadline = self.sim.world.time + abs(g.open_value - g.closed_value) / FINGER_SPEED + 2.0
        while not self._fingers_touch():
            if self.sim.world.time > deadline:
                raise PhaseFailed(
                    "pick",
                    "the fingers closed without both touching the object (the hand was "
                    f"{100 * self._hand_offset():.1f} cm from it)",
                )
            if (g.closed_value - value) * np.sign(step) > 0:
                value += step
            self.sim.set_joint_targets({finger: value})
            yield
        width = self.sim.joint_values()[finger]
        self.sim.set_joint_targets({finger: width + 2 * step})
        for _ in range(10):
            yield
        name = g.grasp(self.sim.world.data, self.setup.object)
        if name is None:
            raise PhaseFailed("pick", "the object slipped out of the hand before it was held")
        tcp = self.sim.frame_pose(self.robot.end_effector)
        obj = np.append(self._object_pose(self.setup.object)[0], 1.0)
        self.in_hand = (np.linalg.inv(tcp) @ obj)[:3]
        self.result.grasp = (
            "attached: both fingers touched the object, which then moves with the hand "
            f"(finger opening {2 * width * 100:.1f} cm)"
        )
        lifted = local + np.array([0.0, 0.0, LIFT])
        yield from self._move_arm(lifted, base, holding=True)
        yield from self._straight(-STANDOFF)
        yield from self._move_arm(np.array(CARRY_TCP), self.pose(), holding=True)

    def _place(self, target_world: np.ndarray) -> Iterator[None]:
        t_map = self.to_map((target_world[0], target_world[1], 0.0))
        point = np.array([t_map[0], t_map[1], target_world[2]])
        for moves in range(len(REACHES) + 1):
            base = yield from self._docked_pose()
            local = self._in_base(base, point)
            # the hand goes where the object, as it sits in the hand, lands on the point
            hand = local - self._orientation(local).apply(self.in_hand)
            if moves == len(REACHES) or self._reaches(hand, base, base):
                break
            yield from self._reach(hand, base)
        orientation = self._orientation(local)
        above = hand + np.array([0.0, 0.0, LIFT])
        yield from self._move_arm(above, base, holding=True, orientation=orientation)
        yield from self._move_arm(
            hand + np.array([0.0, 0.0, 0.005]), base, holding=True, orientation=orientation
        )
        g = self.sim.gripper
        assert g is not None
        # open the fingers clear of the object before it is back under physics
        self.sim.set_joint_targets({f: g.open_value for f in self._fingers})
        for _ in range(round(0.5 / self.sim.control_dt)):
            yield
        g.release(self.sim.world.data)
        for _ in range(round(0.3 / self.sim.control_dt)):
            yield
        # back off along the grasp, else (the arm folded against the base) straight up
        if not (yield from self._move_arm(self._approach_point(local), base, False, quiet=True)):
            yield from self._move_arm(hand + np.array([0.0, 0.0, LIFT]), base, False, orientation)
        yield from self._straight(-STANDOFF)

    # --- the result --------------------------------------------------------------------

    def _score(self, target: np.ndarray) -> None:
        for _ in range(round(1.0 / self.sim.control_dt)):
            self.sim_node.step()
        pos, quat = self._object_pose(self.setup.object)
        err = float(np.hypot(pos[0] - target[0], pos[1] - target[1]))
        up = Rotation.from_quat(quat).apply([0.0, 0.0, 1.0])
        tilt = float(np.arccos(np.clip(up[2], -1.0, 1.0)))
        self.result.place_error = err
        self.result.tilt = tilt
        reasons = []
        if err > PLACE_TOLERANCE:
            reasons.append(f"the {self.setup.object} rests {100 * err:.1f} cm from the place point")
        if abs(pos[2] - target[2]) > 0.03:
            reasons.append(
                f"the {self.setup.object} is at height {pos[2]:.2f} m, not on the surface"
            )
        if tilt > UPRIGHT:
            reasons.append(f"the {self.setup.object} is tilted {np.rad2deg(tilt):.0f} deg")
        if reasons:
            self.result.failed_phase, self.result.reason = "place", "; ".join(reasons)
        else:
            self.result.success = True

    def _finish(self) -> None:
        r = self.result
        r.truth = np.array(self._truth) if self._truth else np.zeros((0, 3))
        r.estimate = np.array(self._estimate) if self._estimate else np.zeros((0, 3))
        r.joints = np.array(self._joints) if self._joints else np.zeros((0, 7))
        if self.recorder is not None:
            self.recorder.close()
        self.sim.close()


def _body_name(m: mujoco.MjModel, b: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or ""


def run_carry(
    setup: CarrySetup,
    seed: int,
    out: Path | None = None,
    on_progress: Callable[[str, float], None] | None = None,
) -> CarryResult:
    """One carry trial; with `out`, its MCAP, JSON summary and plot go there."""
    trial = CarryTrial(setup, seed, out)
    result = trial.run(on_progress)
    if out is not None:
        (out / f"carry_{seed}.json").write_text(json.dumps(result.summary(), indent=2))
        plot_carry(out / f"carry_{seed}.png", result, trial.world, setup)
    return result


def plot_carry(png: Path, r: CarryResult, world: World, setup: CarrySetup) -> Path:
    """The built map with the true and estimated paths, the arm's joint curves and a
    timeline of the phases."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(12, 7))
    ax_map = fig.add_subplot(1, 2, 1)
    ax_j = fig.add_subplot(2, 2, 2)
    ax_t = fig.add_subplot(2, 2, 4)
    sx, sy, syaw = r.map_in_world
    if r.map_image is not None:
        h, w = r.map_image.shape
        img = np.where(r.map_image == 100, 0.0, np.where(r.map_image < 0, 0.7, 1.0))
        # the map is drawn in the world frame: rotate its cell centres by the spawn
        ys, xs = np.mgrid[0:h, 0:w]
        mx = r.map_origin[0] + (xs + 0.5) * r.map_resolution
        my = r.map_origin[1] + (ys + 0.5) * r.map_resolution
        wx = sx + np.cos(syaw) * mx - np.sin(syaw) * my
        wy = sy + np.sin(syaw) * mx + np.cos(syaw) * my
        ax_map.pcolormesh(wx, wy, img, cmap="gray", vmin=0, vmax=1, shading="auto")
    if len(r.truth):
        ax_map.plot(r.truth[:, 1], r.truth[:, 2], "g-", lw=1.2, label="driven (truth)")
    if len(r.estimate):
        ex, ey = r.estimate[:, 1], r.estimate[:, 2]
        wx = sx + np.cos(syaw) * ex - np.sin(syaw) * ey
        wy = sy + np.sin(syaw) * ex + np.cos(syaw) * ey
        ax_map.plot(wx, wy, "b--", lw=0.8, label="estimated")
    obj = world.body(setup.object).pose.xyz
    ax_map.plot(obj[0], obj[1], "r^", ms=8, label=setup.object)
    place = world.room(setup.to).place
    if place is not None:
        ax_map.plot(place[0], place[1], "m*", ms=12, label=f"place ({setup.to})")
    ax_map.set_aspect("equal")
    ax_map.set_xlabel("x (m)")
    ax_map.set_ylabel("y (m)")
    ax_map.legend(loc="lower right", fontsize=7)
    verdict = "success" if r.success else f"failed in {r.failed_phase}: {r.reason}"
    ax_map.set_title(f"{setup.object} to the {setup.to}, seed {r.seed}: {verdict}"[:90], fontsize=9)
    if len(r.joints):
        for j, name in enumerate(r.joint_names):
            ax_j.plot(r.joints[:, 0], r.joints[:, j + 1], lw=1, label=name)
        ax_j.set_xlabel("time (s)")
        ax_j.set_ylabel("joint (rad)")
        ax_j.legend(fontsize=6, ncol=3)
        ax_j.set_title("arm joints")
    colours = dict(
        zip(PHASES, ["tab:gray", "tab:blue", "tab:orange", "tab:green", "tab:purple"], strict=True)
    )
    for p in r.phases:
        ax_t.barh(
            0, p["time"], left=p["start"], color=colours.get(p["phase"], "k"), label=p["phase"]
        )
        ax_t.text(
            p["start"] + p["time"] / 2,
            0,
            f"{p['phase']}\n{p['time']:.0f} s",
            ha="center",
            va="center",
            fontsize=7,
        )
    ax_t.set_yticks([])
    ax_t.set_xlabel("simulated time (s)")
    ax_t.set_title("phases")
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=100)
    plt.close(fig)
    return png
