"""Navigation trials: the platform paper's move_base + AMCL experiment, scored (layer 5).

One run: the mobile manipulator spawns at the world's start pose in the MuJoCo
simulation; AMCL starts from a guess near the spawn (off by a seeded error) and
localizes on the map from the 2D scan (the VLP-16 cut to a plane) and the wheel
odometry (with slip); the navigator plans (Dijkstra, A*, or Hybrid-A* with the
footprint), drives with DWA or pure pursuit and recovers when stuck. The loop runs as
fast as the CPU allows, on the simulation clock.

A run succeeds when the navigator reports the goal reached, the base truly stands
within `success_radius` of the goal, and the robot never touched a wall or an obstacle
(any MuJoCo contact between a robot geom and a static geom or object: counted as a
collision, and the run ends there). Its time is simulated seconds from the goal being
given to the navigator's success. The seed varies sensor noise, odometry slip and the
initial pose guess; start and goal stay the same.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from robotrial.geometry import Pose
from robotrial.model import load_robot, load_world
from robotrial.model.gridmap import NavMap, file_map, world_map
from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.nav import DEFAULT_PLANNER
from robotrial.nav.amcl import AMCL, AMCLConfig, compose, inverse
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.dwa import DWAConfig
from robotrial.nav.hybrid import HybridConfig
from robotrial.nav.navigator import Navigator, NavigatorConfig, Status
from robotrial.nav.planners import path_length, shortest_path
from robotrial.nav.profile import ProfileConfig
from robotrial.sim import SimOptions, Simulation, StreamSettings
from robotrial.sim.controllers import DriveLimits
from robotrial.sim.footprint import base_extent

PAPER_TABLE1 = {
    "room_a": {
        "successes": 10,
        "runs": 10,
        "mean_time": 22.63,
        "min_time": 17.0,
        "max_time": 33.96,
    },
    "room_b": {
        "successes": 7,
        "runs": 10,
        "mean_time": 27.42,
        "min_time": 15.74,
        "max_time": 45.81,
    },
    "room_c": {
        "successes": 6,
        "runs": 10,
        "mean_time": 88.19,
        "min_time": 35.12,
        "max_time": 116.0,
    },
}


@dataclass(frozen=True)
class NavTrialSetup:
    """What a trial is: world, robot, start (spawn name or pose in the world: where the
    simulator puts the robot), goal (x, y, yaw on the map), the map (None: the world's
    ground truth), the top speed (m/s), the global planner and the local controller
    (None: the planner's default, `default_controller`), and where the robot starts on
    the map if the map cannot say (`initial_pose`, RViz's "2D Pose Estimate"; see
    `map_start`). A run succeeds within `success_radius` m of the goal."""

    world: str = "room_b"
    goal: tuple[float, float, float] = (6.8, 6.6, 0.0)
    start: str | tuple[float, float, float] = "default"
    robot: str = "mobile_manipulator"
    map_path: str | None = None
    speed: float = 0.3
    planner: str = DEFAULT_PLANNER
    controller: str | None = None
    time_limit: float | None = None
    initial_error: tuple[float, float] = (0.1, 0.05)
    success_radius: float = 0.15
    initial_pose: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not 0 < self.speed:
            raise ValueError(f"nav trial: speed must be positive, got {self.speed} m/s")
        if len(self.goal) != 3 or not all(np.isfinite(self.goal)):
            raise ValueError(f"nav trial: the goal is x y yaw, got {_fmt_pose(self.goal)}")
        p = self.initial_pose
        if p is not None and (len(p) != 3 or not all(np.isfinite(p))):
            raise ValueError(f"nav trial: the initial pose is x y yaw, got {_fmt_pose(p)}")


def _fmt_pose(p) -> str:
    try:
        return "(" + ", ".join(f"{float(v):.2f}" for v in p) + ")"
    except (TypeError, ValueError):
        return repr(p)


@dataclass
class RunResult:
    """One run: success, time (s, simulated), final status and message, whether it
    collided, the true path on the map (N, 2), the final true position error (m), the
    distance driven (m), global planning and local planner step times (s, wall),
    recoveries, and the true final pose in the world (`end`: x, y, yaw)."""

    seed: int
    success: bool
    time: float
    status: str
    message: str
    collision: bool
    path: np.ndarray
    final_error: float
    distance: float
    plan_times: list[float] = field(default_factory=list)
    local_times: list[float] = field(default_factory=list)
    recoveries: list[str] = field(default_factory=list)
    wall_time: float = 0.0
    end: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def summary(self) -> dict:
        return {
            "seed": self.seed,
            "success": self.success,
            "time": round(self.time, 3),
            "status": self.status,
            "message": self.message,
            "collision": self.collision,
            "final_error": round(self.final_error, 3),
            "distance": round(self.distance, 3),
            "recoveries": self.recoveries,
            "plan_ms_mean": round(1e3 * float(np.mean(self.plan_times)), 3)
            if self.plan_times
            else None,
            "local_ms_mean": round(1e3 * float(np.mean(self.local_times)), 3)
            if self.local_times
            else None,
            "wall_time": round(self.wall_time, 2),
            "end": [round(float(v), 3) for v in self.end],
        }


def footprint_of(sim: Simulation, links: Collection[str] | None = None) -> Footprint:
    """The robot's footprint (sim/footprint.py) as the costmaps take it; with `links`,
    of those links only."""
    return Footprint(*base_extent(sim, links))


def footprint_of_robot(
    robot: RobotModel | str, world: World | str = "room_a", links: Collection[str] | None = None
) -> Footprint:
    """The footprint of a robot (a model, a built-in name or a file), taken in a
    simulation of it; with `links`, of those links only (a base without its arm)."""
    sim = Simulation.create(world, robot, options=SimOptions(cameras=False))
    try:
        return footprint_of(sim, links)
    finally:
        sim.close()


class ContactWatch:
    """Tells robot-versus-environment contacts from MuJoCo's contact list."""

    def __init__(self, sim: Simulation) -> None:
        m = sim.world.model
        robot_bodies = set()
        root = sim.world.base_body
        for b in range(m.nbody):
            if b != 0 and (b == root or _descends(m, b, root)):
                robot_bodies.add(b)
        self.robot = np.array([m.geom_bodyid[g] in robot_bodies for g in range(m.ngeom)])
        self.env = np.zeros(m.ngeom, dtype=bool)
        self.names = {}
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g])) or ""
            if name.startswith(("wall/", "obstacle/")) or body.startswith("object/"):
                self.env[g] = True
                self.names[g] = name or body

    def touching(self, data: mujoco.MjData) -> str | None:
        """The name of an obstacle the robot touches now, or None."""
        n = data.ncon
        if n == 0:
            return None
        geoms = data.contact.geom[:n]
        dist = data.contact.dist[:n]
        for (g1, g2), dd in zip(geoms, dist, strict=True):
            if dd > 0:
                continue
            if self.robot[g1] and self.env[g2]:
                return self.names[g2]
            if self.robot[g2] and self.env[g1]:
                return self.names[g1]
        return None


def _descends(m: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = int(m.body_parentid[body])
    return False


def start_pose(world: World, start: str | tuple[float, float, float]) -> tuple[float, float, float]:
    if isinstance(start, str):
        p = world.spawn(start)
        return float(p.xyz[0]), float(p.xyz[1]), float(p.yaw)
    return float(start[0]), float(start[1]), float(start[2])


XY_TOLERANCE = 0.1
"""How near (m) the navigator must believe the base is to a goal: a run counts within
0.15 m of it, and localization puts the base a few cm off where it believes it is."""


def navigator_config(
    speed: float,
    max_yaw_rate: float,
    max_accel: float,
    planner: str = DEFAULT_PLANNER,
    max_yaw_accel: float = 2.0,
    controller: str | None = None,
) -> NavigatorConfig:
    """The navigation stack's settings for a top speed (m/s); the final turn in place
    uses the base's own yaw rate and acceleration limits, as does the 'profile' controller
    throughout. With a footprint-aware planner ('hybrid', 'auto') the DWA also caps its
    speed by the footprint's clearance."""
    yaw_rate = min(max_yaw_rate, max(0.8, 1.6 * speed))
    dwa = DWAConfig(
        max_speed=speed,
        max_yaw_rate=yaw_rate,
        acc_lim_v=max_accel,
        acc_lim_w=2.0,
        sim_time=max(1.5, 1.2 + speed),
        lookahead=max(0.8, 1.5 * speed),
        goal_heading_bias=0.5,
        goal_heading_range=1.5,
        footprint_speed=planner in ("hybrid", "auto"),
        exact_footprint=planner in ("hybrid", "auto"),
        narrow_speed=0.3,
    )
    profile = ProfileConfig(
        max_speed=speed,
        max_yaw_rate=max_yaw_rate,
        max_accel=max_accel,
        max_yaw_accel=max_yaw_accel,
    )
    return NavigatorConfig(
        planner=planner,
        # the footprint plan ends within half the navigator's tolerance (its last
        # straight drive and turn to the goal's heading are planned)
        hybrid=HybridConfig(goal_tolerance=0.5 * XY_TOLERANCE),
        dwa=dwa,
        profile=profile,
        controller=controller,
        turn_yaw_rate=max_yaw_rate,
        turn_acc=max_yaw_accel,
        xy_tolerance=XY_TOLERANCE,
    )


@dataclass(frozen=True)
class MapStart:
    """Where a run starts on its map: the robot's pose on the map (None: unknown, AMCL
    localizes globally) and the map frame's true pose in the world (for scoring; the
    robot never sees it), and how the start was known."""

    pose: tuple[float, float, float] | None
    frame_in_world: tuple[float, float, float]
    how: str


def map_start(
    nav_map: NavMap,
    world: World,
    spawn: tuple[float, float, float],
    initial_pose: tuple[float, float, float] | None = None,
) -> MapStart:
    """The robot's start on the map, for a robot the simulator puts at `spawn` (world):
    `initial_pose` when given (RViz's "2D Pose Estimate"); else from the map's own
    metadata (a world's ground truth, or a map `robotrial slam` wrote: where its frame
    lies in the world); else unknown (AMCL's global localization). The map frame's true
    pose comes from the metadata, else from the initial pose, else from laying the map
    on the world's ground truth (`locate_map`)."""
    frame = nav_map.frame_in_world
    if initial_pose is not None:
        pose = tuple(float(v) for v in initial_pose)
        if frame is None:
            frame = tuple(compose(np.asarray(spawn), inverse(np.asarray(pose))))
        return MapStart(pose, tuple(float(v) for v in frame), "initial pose")  # type: ignore[arg-type]
    if frame is not None:
        pose = compose(inverse(np.asarray(frame, dtype=float)), np.asarray(spawn, dtype=float))
        how = "ground truth" if nav_map.source == "ground truth" else "the map's metadata"
        return MapStart(tuple(float(v) for v in pose), tuple(frame), how)  # type: ignore[arg-type]
    return MapStart(None, locate_map(nav_map, world), "global localization")


def locate_map(nav_map: NavMap, world: World) -> tuple[float, float, float]:
    """Where a map's frame lies in the world (x, y, yaw), for scoring a run on a map that
    does not say: the pose that lays the map's occupied cells closest to the world's
    (1 deg steps and a cell-wise correlation, then refined)."""
    from scipy import ndimage, optimize, signal

    from robotrial.model.gridmap import world_occupancy

    res = nav_map.resolution
    truth = world_occupancy(world, res, z_band=(0.05, 1.5))
    dist = ndimage.distance_transform_edt(~truth.occupied) * res
    near = np.exp(-0.5 * (np.minimum(dist, 1.0) / 0.1) ** 2)
    rows, cols = np.nonzero(nav_map.occupied)
    if len(rows) < 10:
        raise ValueError(f"map {nav_map.source}: too few occupied cells to place it in the world")
    pts = np.column_stack(
        [nav_map.origin[0] + (cols + 0.5) * res, nav_map.origin[1] + (rows + 0.5) * res]
    )
    if len(pts) > 4000:
        pts = pts[np.random.default_rng(0).choice(len(pts), 4000, replace=False)]
    best = (-np.inf, 0.0, 0.0, 0.0)
    for yaw in np.radians(np.arange(0.0, 360.0, 1.0)):
        c, s_ = np.cos(yaw), np.sin(yaw)
        q = pts @ np.array([[c, s_], [-s_, c]])
        lo = q.min(axis=0)
        idx = np.floor((q - lo) / res).astype(int)
        img = np.zeros(idx.max(axis=0)[::-1] + 1)
        np.add.at(img, (idx[:, 1], idx[:, 0]), 1.0)
        score = signal.fftconvolve(near, img[::-1, ::-1], mode="full")
        r, cc = np.unravel_index(int(np.argmax(score)), score.shape)
        if score[r, cc] > best[0]:
            # the image's cell (0, 0) lies on the world grid's cell (r, cc) - (shape - 1)
            x = truth.origin[0] + (cc - img.shape[1] + 1) * res - lo[0]
            y = truth.origin[1] + (r - img.shape[0] + 1) * res - lo[1]
            best = (float(score[r, cc]), x, y, float(yaw))

    def cost(p: np.ndarray) -> float:
        c, s_ = np.cos(p[2]), np.sin(p[2])
        q = pts @ np.array([[c, s_], [-s_, c]]) + p[:2]
        ij = np.stack(
            [(q[:, 1] - truth.origin[1]) / res - 0.5, (q[:, 0] - truth.origin[0]) / res - 0.5]
        )
        return float(np.mean(ndimage.map_coordinates(dist, ij, order=1, mode="nearest") ** 2))

    fit = optimize.minimize(cost, np.array(best[1:]), method="Nelder-Mead")
    x, y, yaw = fit.x
    return float(x), float(y), float((yaw + np.pi) % (2 * np.pi) - np.pi)


def refuse_goal(setup: NavTrialSetup, nav_map: NavMap, start: MapStart, footprint: Footprint):
    """The footprint planner's verdict on the goal before anything drives
    (`robotrial.nav.goals.check_goal`), on the map, from the start if it is known."""
    from robotrial.nav.goals import check_goal

    cm = Costmap(
        nav_map.occupied, nav_map.origin, nav_map.resolution, footprint, unknown=nav_map.unknown
    )
    return check_goal(cm, setup.goal, start.pose)


def run_once(
    setup: NavTrialSetup,
    seed: int,
    nav_map: NavMap | None = None,
    world: World | None = None,
) -> RunResult:
    """One run of the trial with this seed."""
    wall0 = time.perf_counter()
    world = world or load_world(setup.world)
    nav_map = nav_map or (file_map(setup.map_path) if setup.map_path else world_map(world))
    spawn = start_pose(world, setup.start)
    start = map_start(nav_map, world, spawn, setup.initial_pose)
    robot = load_robot(setup.robot)
    streams = {
        "joint_states": StreamSettings(enabled=False),
        "ground_truth": StreamSettings(enabled=False),
    }
    for s in robot.sensors:
        if s.type == "imu":
            streams[s.name] = StreamSettings(enabled=False)
    sim = Simulation.create(
        world,
        robot,
        seed=seed,
        spawn=Pose.from_xy_yaw(*spawn),
        options=SimOptions(cameras=False, streams=streams),
    )
    try:
        return _drive(setup, seed, sim, nav_map, start, wall0)
    finally:
        sim.close()


LOCALIZE_TURNS = 2.0
"""Turns on the spot a robot that does not know where it stands makes while AMCL's
particles gather, before it gives up."""


def _drive(
    setup: NavTrialSetup,
    seed: int,
    sim: Simulation,
    nav_map: NavMap,
    start: MapStart,
    wall0: float,
) -> RunResult:
    limits = DriveLimits.from_metadata(sim.robot.metadata.get("drive", {}) or {})
    speed = min(setup.speed, limits.max_speed)
    config = navigator_config(
        speed,
        limits.max_yaw_rate,
        limits.max_accel,
        setup.planner,
        limits.max_yaw_accel,
        setup.controller,
    )
    footprint = footprint_of(sim)
    frame = np.asarray(start.frame_in_world, dtype=float)
    goal_world = compose(frame, np.asarray(setup.goal, dtype=float))

    def on_map(xy: np.ndarray) -> np.ndarray:
        p = np.column_stack([xy, np.zeros(len(xy))])
        return compose(inverse(frame), p)[:, :2]

    check = refuse_goal(setup, nav_map, start, footprint)
    if not check.ok and check.kind != "here":
        x, y, yaw = sim.world.base_pose2d()
        here = on_map(np.array([[x, y]]))
        return RunResult(
            seed=seed,
            success=False,
            time=0.0,
            status="refused",
            message=check.reason,
            collision=False,
            path=here,
            final_error=float(np.hypot(*(goal_world[:2] - (x, y)))),
            distance=0.0,
            wall_time=time.perf_counter() - wall0,
            end=(float(x), float(y), float(yaw)),
        )
    nav = Navigator(
        nav_map.occupied, nav_map.origin, nav_map.resolution, footprint, config, nav_map.unknown
    )
    rng = np.random.default_rng(seed + 1000)
    amcl = AMCL(nav_map.occupied, nav_map.origin, nav_map.resolution, AMCLConfig(), seed=seed)
    if start.pose is not None:
        error = np.zeros(3)
        if start.how != "initial pose":
            error = np.concatenate(
                [rng.normal(0, setup.initial_error[0], 2), rng.normal(0, setup.initial_error[1], 1)]
            )
        amcl.initialize(tuple(np.array(start.pose) + error), std=(0.2, 0.2, 0.1))
    else:
        from scipy import ndimage

        room = ndimage.distance_transform_edt(~nav_map.occupied) * nav_map.resolution
        free = (room >= footprint.inscribed_radius) & ~nav_map.unknown
        amcl.initialize_global(free, count=4 * AMCLConfig().max_particles)
    watch = ContactWatch(sim)
    readings = sim.start()
    scan = next((r.data for r in readings if r.kind == "scan"), None)
    if scan is None:
        raise ValueError(f"robot {setup.robot!r} has no lidar: navigation needs a scan")
    base_inv = np.linalg.inv(sim.world.body_pose(sim.world.base_body))
    laser_m = base_inv @ sim.frame_pose(scan.frame)
    laser = np.array([laser_m[0, 3], laser_m[1, 3], np.arctan2(laser_m[1, 0], laser_m[0, 0])])
    odo = sim.odometry.state
    amcl.update((odo.x, odo.y, odo.yaw), *_beams(scan), laser_pose=tuple(laser), force=True)
    map_to_odom = amcl.map_to_odom(np.array([odo.x, odo.y, odo.yaw]))

    straight = _straight(start.pose or setup.goal, setup.goal)
    time_limit = setup.time_limit or max(60.0, 6.0 * straight / speed + 30.0)
    localizing = start.pose is None
    turned, last_yaw = 0.0, float(odo.yaw)
    if not localizing:
        nav.set_goal(*setup.goal, now=0.0)
    t0 = sim.world.time
    period_steps = max(1, round(config.dwa.period / sim.control_dt))
    truth = [sim.world.base_pose2d()[:2]]
    collision: str | None = None
    new_scan = True
    step = 0
    while nav.status is Status.ACTIVE or localizing:
        now = sim.world.time - t0
        if now > time_limit:
            nav.cancel(f"time limit: not at the goal after {time_limit:.0f} s")
            break
        if step % period_steps == 0:
            odo = sim.odometry.state
            odom_pose = np.array([odo.x, odo.y, odo.yaw])
            if new_scan:
                ranges, angles = _beams(scan)
                if amcl.update(tuple(odom_pose), ranges, angles, laser_pose=tuple(laser)):
                    map_to_odom = amcl.map_to_odom(odom_pose)
                pose = compose(map_to_odom, odom_pose)
                sensor = compose(pose, laser)
                ok = np.isfinite(ranges)
                a = sensor[2] + angles[ok]
                pts = np.column_stack(
                    [sensor[0] + ranges[ok] * np.cos(a), sensor[1] + ranges[ok] * np.sin(a)]
                )
                if not localizing:
                    nav.observe((float(sensor[0]), float(sensor[1])), pts)
                new_scan = False
            pose = compose(map_to_odom, odom_pose)
            if localizing:
                turned += abs((odo.yaw - last_yaw + np.pi) % (2 * np.pi) - np.pi)
                last_yaw = float(odo.yaw)
                if amcl.updates >= 10 and amcl.converged():
                    localizing = False
                    sim.drive(0.0, 0.0)
                    nav.set_goal(*setup.goal, now=now)
                elif turned >= LOCALIZE_TURNS * 2 * np.pi:
                    localizing = False
                    nav.cancel(
                        "could not localize: AMCL's particles did not gather on one pose in "
                        f"{LOCALIZE_TURNS:.0f} turns on the spot"
                    )
                    break
                else:
                    sim.drive(0.0, 0.5 * limits.max_yaw_rate)
            else:
                v, w = nav.step(now, tuple(pose), (float(odo.v), float(odo.w)))
                sim.drive(v, w)
        for r in sim.control_step():
            if r.kind == "scan":
                scan = r.data
                new_scan = True
        step += 1
        if step % 10 == 0:
            truth.append(sim.world.base_pose2d()[:2])
        collision = watch.touching(sim.world.data)
        if collision is not None:
            nav.cancel(f"collision with {collision}")
            break
        if not sim.world.is_finite():
            nav.cancel("the simulation diverged")
            break
    sim.drive(0.0, 0.0)
    x, y, yaw = sim.world.base_pose2d()
    truth.append((x, y))
    err = float(np.hypot(x - goal_world[0], y - goal_world[1]))
    elapsed = sim.world.time - t0
    success = nav.status is Status.SUCCEEDED and collision is None and err <= setup.success_radius
    message = nav.message
    if nav.status is Status.SUCCEEDED and err > setup.success_radius:
        message = f"believed it arrived, but stands {err:.2f} m from the goal (localization error)"
    world_path = np.array(truth)
    path = on_map(world_path)
    return RunResult(
        seed=seed,
        success=success,
        time=elapsed,
        status=nav.status.value,
        message=message,
        collision=collision is not None,
        path=path,
        final_error=err,
        distance=path_length(path),
        plan_times=nav.plan_times,
        local_times=nav.local_times,
        recoveries=nav.recoveries,
        wall_time=time.perf_counter() - wall0,
        end=(float(x), float(y), float(yaw)),
    )


def _straight(a, b) -> float:
    return float(np.hypot(b[0] - a[0], b[1] - a[1]))


def _beams(scan) -> tuple[np.ndarray, np.ndarray]:
    ranges = np.asarray(scan.ranges, dtype=float)
    angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    ranges = np.where((ranges >= scan.range_min) & (ranges < scan.range_max), ranges, np.inf)
    return ranges, angles


def shortest_time(
    setup: NavTrialSetup,
    nav_map: NavMap,
    footprint: Footprint,
    start: tuple[float, float, float],
) -> tuple[float, float]:
    """The shortest collision-free path length (m) from `start` (on the map) to the goal
    for a robot whose centre keeps its inscribed radius from every obstacle, and that
    length over the top speed (s)."""
    p = shortest_path(
        nav_map.occupied,
        nav_map.origin,
        nav_map.resolution,
        footprint.inscribed_radius,
        tuple(start[:2]),
        setup.goal[:2],
    )
    length = path_length(p)
    return length, length / setup.speed


def footprint_time(
    nav_map: NavMap,
    footprint: Footprint,
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    speed: float,
    limits: DriveLimits,
) -> tuple[float | None, float | None]:
    """The footprint-aware yardstick (s): the least time in which a base with `limits`
    (top speed capped at `speed`) follows a Hybrid-A* plan from `start` to `goal` from
    rest to rest (the cheaper of the cheapest plan and the navigator's own, each with
    curves where the rectangle takes them), and turns to the goal's heading; and the same
    for the plans exactly as planned (every turn on the spot kept). None where
    Hybrid-A* finds no way for the rectangle."""
    from robotrial.nav.costmap import Costmap, coarsen
    from robotrial.nav.hybrid import HybridAStar, HybridConfig
    from robotrial.nav.planners import NoPath
    from robotrial.nav.profile import ProfileConfig, minimum_time

    occupied, unknown, res = coarsen(nav_map.occupied, nav_map.unknown, nav_map.resolution, 0.05)
    cm = Costmap(occupied, nav_map.origin, res, footprint, unknown=unknown)
    base = ProfileConfig(
        max_speed=min(speed, limits.max_speed),
        max_yaw_rate=limits.max_yaw_rate,
        max_accel=limits.max_accel,
        max_yaw_accel=limits.max_yaw_accel,
    )
    curves, planned = np.inf, np.inf
    # the cheapest plan, and the navigator's own (heuristic weight 1.1)
    for config in (HybridConfig(heuristic_weight=1.0), HybridConfig()):
        try:
            poses = HybridAStar(config).plan_poses(cm, start, goal)
        except NoPath:
            continue
        curves = min(curves, minimum_time(poses, base, goal[2], cm, config.margin))
        planned = min(planned, minimum_time(poses, base, goal[2]))
    if not np.isfinite(planned):
        return None, None
    return min(curves, planned), planned


def summarize(results: list[RunResult], shortest: float | None = None) -> dict:
    """Successes, and mean/min/max time over the successful runs (as Table 1 reports)."""
    times = [r.time for r in results if r.success]
    out: dict = {
        "runs": len(results),
        "successes": sum(r.success for r in results),
        "collisions": sum(r.collision for r in results),
        "mean_time": float(np.mean(times)) if times else None,
        "min_time": float(np.min(times)) if times else None,
        "max_time": float(np.max(times)) if times else None,
    }
    if shortest:
        out["shortest_time"] = shortest
        out["ratio"] = out["mean_time"] / shortest if times else None
    plans = [t for r in results for t in r.plan_times]
    local = [t for r in results for t in r.local_times]
    out["plan_ms_mean"] = 1e3 * float(np.mean(plans)) if plans else None
    out["local_ms_mean"] = 1e3 * float(np.mean(local)) if local else None
    return out


def run_trials(
    setup: NavTrialSetup,
    runs: int,
    seed: int = 0,
    on_run: Callable[[RunResult], None] | None = None,
) -> tuple[list[RunResult], NavMap, World]:
    """`runs` runs with seeds seed, seed+1, ...; `on_run` hears of each as it ends."""
    if runs < 1:
        raise ValueError(f"nav trial: runs must be at least 1, got {runs}")
    world = load_world(setup.world)
    nav_map = file_map(setup.map_path) if setup.map_path else world_map(world)
    out = []
    for i in range(runs):
        r = run_once(setup, seed + i, nav_map, world)
        out.append(r)
        if on_run is not None:
            on_run(r)
    return out, nav_map, world


def plot_paths(
    path: str | Path,
    nav_map: NavMap,
    results: list[RunResult],
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    title: str = "",
) -> Path:
    """A PNG of every run's true path over the map (green: success, red: failure)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    h, w = nav_map.occupied.shape
    img = np.where(nav_map.occupied, 0.1, np.where(nav_map.unknown, 0.6, 1.0))
    fig, ax = plt.subplots(figsize=(6, 6 * h / max(w, 1)))
    ax.imshow(img, origin="lower", extent=nav_map.extent, cmap="gray", vmin=0, vmax=1)
    for r in results:
        ax.plot(
            r.path[:, 0],
            r.path[:, 1],
            color="tab:green" if r.success else "tab:red",
            lw=1,
            alpha=0.7,
        )
    ax.plot(start[0], start[1], "bo", label="start")
    ax.plot(goal[0], goal[1], "m*", ms=12, label="goal")
    ok = sum(r.success for r in results)
    ax.set_title(title or f"{ok}/{len(results)} successes")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
