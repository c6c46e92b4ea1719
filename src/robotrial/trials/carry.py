"""The carry trial: one mobile manipulator maps a home, finds an object, picks it, carries
it to a named room and sets it down there (layer 5: the world side).

A trial has two halves on one bus. This module is the world side: it builds the world in
MuJoCo (`SimNode`: LiDAR, odometry, joints, the head's RGB-D pair rendered only when the
robot asks for a frame), starts the robot side (`robotrial.onboard`: its own SLAM and
navigation nodes, its skills and the task that strings them), steps the world, watches
for contacts and scores the end against the truth. The robot side is told only:

- the plan of the home: its start pose, the rooms as rectangles, and with
  `mapping='route'` the mapping route (`ROUTES`, waypoints given in advance, as a
  teleoperated mapping run would; for a world without one, a tour of its rooms made from
  its plan, `exploration_route`); with `mapping='frontier'` no route: the robot explores
  on its own (`onboard.explore`). The default, `mapping='auto'`, takes the given route
  where `ROUTES` has one (the apartment) and explores by frontiers everywhere else (a
  drawn or generated home);
- the order: the object's kind, the room it is in, the room to take it to and the point
  there to set it down (the room's `place`);
- the catalogue of object kinds (shape, size, colour; no poses).

Where the object and the furniture stand it finds out with its sensors: the object by
the head camera (`onboard.perception`), the arm's obstacles as voxels from the same
camera (`onboard.voxels`), the surface to set the object on by a plane fit at the place
point. The grasp holds by friction alone (`sim.controllers.Gripper`; no attachment), and
the object's offset in the hand comes from the finger readings and where the grasp put
the hand. No oracle is used; `CarryResult.oracles` lists none.

The phases (`onboard.task.PHASES`): mapping, search (turn and look from open spots of
the object's room), navigation (to a work site the arm reaches from, looking again on the
way), pick, carry (to a work site by the place, the surface measured from its staging
pose), place. A failure is named by its phase and a cause (`onboard.skills`, plus the
world's own: `touched` for a contact, `time_limit`, and after the run `misclassified`
when another object moved instead, `misplaced` when the object rests off the point).

Success: the object rests within `PLACE_TOLERANCE` of the place point, upright, on the
surface, and the robot never touched a wall, furniture or another object (MuJoCo
contacts of robot geoms with static geoms or objects; the fingers touching the object
they carry are allowed).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from robotrial.geometry import Box as BoxShape
from robotrial.geometry import Cylinder, Sphere
from robotrial.model import load_robot, load_world
from robotrial.model.world import Obstacle, World
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.geometry_msgs import Quaternion, Transform, TransformStamped, Vector3
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.nav import DEFAULT_PLANNER
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.onboard.catalogue import Catalogue, ObjectKind
from robotrial.onboard.robot import Robot, RobotSetup
from robotrial.onboard.skills import Skills
from robotrial.onboard.task import PHASES, CarryOrder, CarryTask, Plan
from robotrial.ros.bus import Bus, Node
from robotrial.ros.sim_node import SimNode
from robotrial.sim import SimOptions, Simulation, StreamSettings
from robotrial.sim.build import finger_links
from robotrial.sim.controllers import DriveLimits
from robotrial.trials.nav import ContactWatch, footprint_of, navigator_config
from robotrial.trials.slam import make_slam

__all__ = [
    "PHASES",
    "ROUTES",
    "CarryResult",
    "CarrySetup",
    "exploration_route",
    "mapping_route",
    "run_carry",
]

MAPPINGS = ("auto", "route", "frontier")
PLACE_TOLERANCE = 0.03  # m, object centre to the place point, in the plane
UPRIGHT = np.deg2rad(10.0)  # largest tilt of an object that stood upright
OBJECTS_TOPIC = "/ground_truth/objects"  # the objects' true poses, for scoring and plots
MOVED = 0.05  # m: an object this far from where it stood was moved
RECORDED = (
    "/scan",
    "/odom",
    "/ground_truth",
    OBJECTS_TOPIC,
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
    "/gripper/command",
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


def mapping_route(
    setup: CarrySetup, world: World, footprint: Footprint
) -> list[tuple[float, float]]:
    """The route the robot is given to map the home along (world x, y), or none (it
    explores by frontiers): `setup.mapping` 'route' gives the world's route in ROUTES or a
    tour made from its plan, 'frontier' none, 'auto' the route in ROUTES if there is one,
    else none."""
    given = isinstance(setup.world, str) and setup.world in ROUTES
    if setup.mapping == "frontier" or (setup.mapping == "auto" and not given):
        return []
    if given:
        return list(ROUTES[setup.world])  # type: ignore[index]
    return exploration_route(world, footprint)


def object_kind(ob: Obstacle) -> ObjectKind:
    """An object of the world as a kind of the catalogue: its shape, size and colour
    (never its pose)."""
    g = ob.geometry
    rgb = tuple(float(c) for c in ob.rgba[:3])
    if isinstance(g, Cylinder):
        return ObjectKind(ob.name, "cylinder", (2 * g.radius, 2 * g.radius, g.length), rgb)  # type: ignore[arg-type]
    if isinstance(g, Sphere):
        return ObjectKind(ob.name, "sphere", (2 * g.radius,) * 3, rgb)  # type: ignore[arg-type]
    if isinstance(g, BoxShape):
        return ObjectKind(ob.name, "box", tuple(float(v) for v in g.size), rgb)  # type: ignore[arg-type]
    raise ValueError(f"{ob.name}: the catalogue holds boxes, cylinders and spheres")


def catalogue_of(world: World) -> Catalogue:
    """The catalogue the robot gets: the kinds of the world's movable objects."""
    return Catalogue(object_kind(ob) for ob in world.objects)


def _top(ob: Obstacle) -> float:
    g = ob.geometry
    half = (
        g.size[2] / 2
        if isinstance(g, BoxShape)
        else g.length / 2
        if isinstance(g, Cylinder)
        else g.radius
    )  # type: ignore[union-attr]
    return float(ob.pose.xyz[2] + half)


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
    # 'route': the given route; 'frontier': it explores on its own; 'auto': the route
    # where ROUTES has one for the world, else frontiers
    mapping: str = "auto"
    on: str = ""  # the furniture the order says the object is on (a body name), or none

    def __post_init__(self) -> None:
        if not self.speed > 0:
            raise ValueError(f"carry trial: speed must be positive, got {self.speed} m/s")
        if self.mapping not in MAPPINGS:
            raise ValueError(
                f"carry trial: no mapping {self.mapping!r}; choose from {', '.join(MAPPINGS)}"
            )


@dataclass
class CarryResult:
    """What a run gave: success, the phase that failed with its cause and reason, each
    phase's simulated and wall time, the final object error, contacts, what the robot saw
    and how far that was from the truth, where it found the object (`found`, on the
    plan), the paths and joint curves, the oracles used (none)."""

    seed: int
    success: bool
    failed_phase: str = ""
    cause: str = ""
    reason: str = ""
    phases: list[dict[str, Any]] = field(default_factory=list)
    sim_time: float = 0.0
    wall_time: float = 0.0
    place_error: float | None = None
    tilt: float | None = None
    seen_error: float | None = None
    collision: str = ""
    grasp: str = ""
    looks: int = 0
    found: str = ""
    stopped: str = ""
    oracles: list[str] = field(default_factory=list)
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
            "cause": self.cause,
            "reason": self.reason,
            "oracles": self.oracles,
            "sim_time": round(self.sim_time, 2),
            "wall_time": round(self.wall_time, 2),
            "real_time_factor": round(self.sim_time / self.wall_time, 2)
            if self.wall_time
            else None,
            "phases": self.phases,
            "place_error": None if self.place_error is None else round(self.place_error, 4),
            "tilt_deg": None if self.tilt is None else round(float(np.rad2deg(self.tilt)), 2),
            "seen_error": None if self.seen_error is None else round(self.seen_error, 4),
            "collision": self.collision,
            "grasp": self.grasp,
            "looks": self.looks,
            "found": self.found,
            "stopped": self.stopped,
            "arm_plans": self.arm_plans,
        }


class CarryTrial(Node):
    """The world side of one run: the simulation, the truth, the score."""

    def __init__(self, setup: CarrySetup, seed: int, out: Path | None) -> None:
        world = setup.world if isinstance(setup.world, World) else load_world(setup.world)
        robot = load_robot(setup.robot)
        self.target = world.body(setup.object)
        if self.target.kind != "object":
            raise ValueError(f"carry trial: {setup.object!r} is furniture, not an object")
        self.room = world.room(setup.to)
        if self.room.place is None:
            raise ValueError(f"carry trial: room {setup.to!r} has no place to set things down")
        x, y = self.target.pose.xyz[:2]
        found_in = [r for r in world.rooms if r.contains(x, y)]
        if not found_in:
            raise ValueError(f"carry trial: the {setup.object} stands in no room of the plan")
        self.setup, self.seed, self.world, self.model = setup, seed, world, robot
        named = self._named(world)
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
        super().__init__(self.bus, "/world")
        self.sim_node = SimNode(self.bus, self.sim)
        self.recorder = None
        if out is not None:
            from robotrial.ros.recorder import BusRecorder, Recorder

            out.mkdir(parents=True, exist_ok=True)
            self.recorder = Recorder(out / f"carry_{seed}.mcap")
            BusRecorder(self.bus, self.recorder, list(RECORDED))
        self.tf_pub = self.create_publisher(OBJECTS_TOPIC, TFMessage)

        spawn = world.spawn("default")
        self.spawn = np.array([spawn.xyz[0], spawn.xyz[1], spawn.yaw])
        limits = DriveLimits.from_metadata(robot.metadata.get("drive", {}) or {})
        speed = min(setup.speed, limits.max_speed)
        footprint = footprint_of(self.sim)
        route = mapping_route(setup, world, footprint)
        plan = Plan(
            start=(float(spawn.xyz[0]), float(spawn.xyz[1]), float(spawn.yaw)),
            rooms={r.name: r.bounds for r in world.rooms},
            route=tuple(route),
        )
        order = CarryOrder(setup.object, found_in[0].name, setup.to, self.room.place, named)
        robot_setup = RobotSetup(
            model=robot,
            footprint=footprint,
            slam=make_slam(setup.slam),
            navigator=navigator_config(
                speed, limits.max_yaw_rate, limits.max_accel, DEFAULT_PLANNER, limits.max_yaw_accel
            ),
            planner=setup.planner,
            seed=seed,
        )
        self.robot = Robot(self.bus, robot_setup)
        self.skills = Skills(self.robot, catalogue_of(world))
        self.task = CarryTask(self.skills, plan, order, speed)

        self.watch = ContactWatch(self.sim)
        m = self.sim.world.model
        fingers = set(finger_links(robot)) | {
            str((robot.metadata.get("gripper") or {}).get("link"))
        }
        self.hand_geoms = {
            g for g in range(m.ngeom) if _body_name(m, int(m.geom_bodyid[g])) in fingers
        }
        self.target_geoms = {
            g
            for g in range(m.ngeom)
            if _body_name(m, int(m.geom_bodyid[g])) == f"object/{setup.object}"
        }
        self.start_poses = {ob.name: self._object_pose(ob.name)[0] for ob in world.objects}
        self.result = CarryResult(seed, False, joint_names=list(self.skills.arm_names))
        self.result.map_in_world = tuple(float(v) for v in self.spawn)  # type: ignore[assignment]
        self._truth: list[tuple[float, float, float]] = []
        self._estimate: list[tuple[float, float, float]] = []
        self._joints: list[list[float]] = []
        self._steps = 0

    # --- the loop ----------------------------------------------------------------------

    def run(
        self, on_progress: Callable[[str, float], None] | None = None, until: str = ""
    ) -> CarryResult:
        """Run to the end, or until the task begins phase `until` (then the result holds
        what was done so far: not a success, no failure, `stopped` names the phase)."""
        if until and until not in PHASES:
            raise ValueError(f"carry trial: no phase {until!r}; the phases: {', '.join(PHASES)}")
        wall0 = time.perf_counter()
        self.sim_node.start_streams()
        try:
            while not self.task.finished:
                if until and self.task.phase == until:
                    self.result.stopped = until
                    break
                self.sim_node.step()
                self._observe()
                if self.sim.world.time > self.setup.time_limit:
                    self.task.fail("time_limit", f"not done after {self.setup.time_limit:.0f} s")
                    break
                self.task.tick()
                if on_progress is not None and self._steps % 50 == 0:
                    on_progress(self.task.phase, self.sim.world.time)
            if self.task.outcome.done:
                self._score()
        finally:
            self.result.wall_time = time.perf_counter() - wall0
            self._finish()
        return self.result

    def _observe(self) -> None:
        """After each control period: contacts, paths, joint curves, object poses."""
        self._steps += 1
        touch = self._touching()
        if touch is not None and not self.result.collision:
            part, hit = touch
            self.result.collision = hit
            self.task.fail("touched", f"the robot's {part} touched {hit}")
        if self._steps % 5:
            return
        t = self.sim.world.time
        x, y, _ = self.sim.world.base_pose2d()
        self._truth.append((t, x, y))
        e = self.robot.pose()
        self._estimate.append((t, float(e[0]), float(e[1])))
        values = self.sim.joint_values()
        self._joints.append([t] + [values[n] for n in self.skills.arm_names])
        if self._steps % 10 == 0:
            self._publish_objects(t)

    def _touching(self) -> tuple[str, str] | None:
        """The robot's body that touches something now and the name of what it touches
        (the hand may touch the object it is to carry), or None."""
        data = self.sim.world.data
        w = self.watch
        for i in range(data.ncon):
            if data.contact.dist[i] > 0:
                continue
            g1, g2 = (int(g) for g in data.contact.geom[i])
            for a, b in ((g1, g2), (g2, g1)):
                if w.robot[a] and w.env[b]:
                    if a in self.hand_geoms and b in self.target_geoms:
                        continue
                    m = self.sim.world.model
                    body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[a]))
                    return body or "body", w.names[b]
        return None

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

    def _to_world(self, p: np.ndarray) -> np.ndarray:
        """A point of the robot's map frame (x, y[, z]) in the world."""
        c, s = np.cos(self.spawn[2]), np.sin(self.spawn[2])
        return self.spawn[:2] + np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])

    def _named(self, world: World) -> tuple[str, tuple[tuple[float, float], ...]] | None:
        """The furniture the order names (`setup.on`) with its outline on the plan, or
        None; a ValueError when the world has no such furniture."""
        name = self.setup.on
        if not name:
            return None
        body = world.body(name)
        if body.kind != "furniture":
            raise ValueError(f"carry trial: {name!r} is not furniture, so nothing stands on it")
        g = body.geometry
        half = (
            (g.size[0] / 2, g.size[1] / 2)
            if isinstance(g, BoxShape)
            else (g.radius, g.radius)
            if isinstance(g, Cylinder)
            else (0.0, 0.0)
        )  # type: ignore[union-attr]
        x, y, yaw = float(body.pose.xyz[0]), float(body.pose.xyz[1]), float(body.pose.yaw)
        c, s = abs(np.cos(yaw)), abs(np.sin(yaw))
        hx, hy = c * half[0] + s * half[1], s * half[0] + c * half[1]
        return name, ((x - hx, y - hy), (x + hx, y + hy))

    def _found_words(self, found: dict[str, Any]) -> str:
        """Where the robot found the object, on the plan: its room and the furniture top
        (the named one, or the piece's centre as the robot mapped it)."""
        top = f"{found['top']:.2f} m high"
        before = f"not on the {found['not_on']}; " if found["not_on"] else ""
        if found["on"]:
            return f"{before}in the {found['room']}, on the {found['on']}, {top}"
        if found["furniture"] is None:
            x, y = self._to_world(found["at"])
            return f"{before}in the {found['room']}, on a surface {top} at ({x:.2f}, {y:.2f})"
        x, y = self._to_world(found["furniture"])
        return f"{before}in the {found['room']}, on the furniture top at ({x:.2f}, {y:.2f}), {top}"

    # --- the result --------------------------------------------------------------------

    def _score(self) -> None:
        for _ in range(round(1.0 / self.sim.control_dt)):
            self.sim_node.step()
        target = self.room.place
        assert target is not None
        height = _top(self.world.body(self.room.place_on)) + _height(self.target) / 2
        pos, quat = self._object_pose(self.setup.object)
        err = float(np.hypot(pos[0] - target[0], pos[1] - target[1]))
        up = Rotation.from_quat(quat).apply([0.0, 0.0, 1.0])
        tilt = float(np.arccos(np.clip(up[2], -1.0, 1.0)))
        self.result.place_error = err
        self.result.tilt = tilt
        reasons = []
        if err > PLACE_TOLERANCE:
            reasons.append(f"the {self.setup.object} rests {100 * err:.1f} cm from the place point")
        if abs(pos[2] - height) > 0.03:
            reasons.append(
                f"the {self.setup.object} is at height {pos[2]:.2f} m, not on the surface"
            )
        if tilt > UPRIGHT:
            reasons.append(f"the {self.setup.object} is tilted {np.rad2deg(tilt):.0f} deg")
        if reasons:
            self.task.outcome.phase, self.task.outcome.cause = "place", "misplaced"
            self.task.outcome.reason = "; ".join(reasons)
        else:
            self.result.success = True

    def _diagnose(self) -> None:
        """A failed run in which another object moved and the one ordered did not was a
        misclassification, whatever the robot noticed."""
        out = self.task.outcome
        if self.result.success or not out.cause:
            return
        moved = [
            ob.name
            for ob in self.world.objects
            if np.linalg.norm(self._object_pose(ob.name)[0] - self.start_poses[ob.name]) > MOVED
        ]
        if moved and self.setup.object not in moved:
            out.reason = (
                f"it took the {moved[0]} for the {self.setup.object} ({out.cause}: {out.reason})"
            )
            out.cause = "misclassified"

    def _finish(self) -> None:
        self._diagnose()
        r, out, log = self.result, self.task.outcome, self.skills.log
        r.failed_phase, r.cause, r.reason = out.phase, out.cause, out.reason
        r.phases = out.phases
        r.sim_time = self.sim.world.time
        r.grasp, r.arm_plans, r.looks = log.grasp, log.arm_plans, len(log.looks)
        if log.found is not None:
            r.found = self._found_words(log.found)
        if log.target is not None:
            seen = self._to_world(log.target)
            truth = self.start_poses[self.setup.object]
            r.seen_error = float(np.hypot(*(seen - truth[:2])))
        grid = self.robot.grid
        if grid is not None:
            r.map_image = grid.ros_values().copy()
            r.map_origin = grid.origin
            r.map_resolution = grid.resolution
        r.truth = np.array(self._truth) if self._truth else np.zeros((0, 3))
        r.estimate = np.array(self._estimate) if self._estimate else np.zeros((0, 3))
        r.joints = np.array(self._joints) if self._joints else np.zeros((0, 7))
        if self.recorder is not None:
            self.recorder.close()
        self.robot.destroy()
        self.sim.close()


def _height(ob: Obstacle) -> float:
    return object_kind(ob).height


def _body_name(m: mujoco.MjModel, b: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or ""


def run_carry(
    setup: CarrySetup,
    seed: int,
    out: Path | None = None,
    on_progress: Callable[[str, float], None] | None = None,
    until: str = "",
) -> CarryResult:
    """One carry trial (to the end, or until phase `until` begins); with `out`, its
    MCAP, JSON summary and plot go there."""
    if until and until not in PHASES:
        raise ValueError(f"carry trial: no phase {until!r}; the phases: {', '.join(PHASES)}")
    trial = CarryTrial(setup, seed, out)
    result = trial.run(on_progress, until)
    if out is not None:
        write_outputs(trial, result, out)
    return result


def write_outputs(trial: CarryTrial, result: CarryResult, out: Path) -> None:
    """A run's JSON summary and plot (its MCAP is written as it runs)."""
    (out / f"carry_{result.seed}.json").write_text(json.dumps(result.summary(), indent=2))
    plot_carry(out / f"carry_{result.seed}.png", result, trial.world, trial.setup)


def draw_map(
    ax: Any,
    values: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    frame: tuple[float, float, float],
) -> None:
    """A built map (ROS values: 100 occupied, 0 free, -1 unknown) drawn in the world
    frame on matplotlib axes, its frame lying at `frame` (x, y, yaw) in the world."""
    sx, sy, syaw = frame
    h, w = values.shape
    img = np.where(values == 100, 0.0, np.where(values < 0, 0.7, 1.0))
    ys, xs = np.mgrid[0:h, 0:w]
    mx = origin[0] + (xs + 0.5) * resolution
    my = origin[1] + (ys + 0.5) * resolution
    wx = sx + np.cos(syaw) * mx - np.sin(syaw) * my
    wy = sy + np.sin(syaw) * mx + np.cos(syaw) * my
    ax.pcolormesh(wx, wy, img, cmap="gray", vmin=0, vmax=1, shading="auto")


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
        draw_map(ax_map, r.map_image, r.map_origin, r.map_resolution, r.map_in_world)
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
    verdict = "success" if r.success else f"failed in {r.failed_phase} ({r.cause}): {r.reason}"
    ax_map.set_title(f"{setup.object} to the {setup.to}, seed {r.seed}: {verdict}"[:90], fontsize=9)
    if len(r.joints):
        for j, name in enumerate(r.joint_names):
            ax_j.plot(r.joints[:, 0], r.joints[:, j + 1], lw=1, label=name)
        ax_j.set_xlabel("time (s)")
        ax_j.set_ylabel("joint (rad)")
        ax_j.legend(fontsize=6, ncol=3)
        ax_j.set_title("arm joints")
    colours = dict(
        zip(
            PHASES,
            ["tab:gray", "tab:cyan", "tab:blue", "tab:orange", "tab:green", "tab:purple"],
            strict=True,
        )
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
