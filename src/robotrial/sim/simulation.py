"""Simulation: a robot in a world with its controllers and sensors, on one clock (layer 2).

This is what a trial drives in a tight loop (and what the sim node puts on the bus):
command the base and the arm, `advance` the clock, and get the sensor readings that fell
due, each stamped with simulated time. Streams and their default rates:

| stream | kind | default rate |
| --- | --- | --- |
| each lidar sensor (e.g. `velodyne`) | `points` (PointCloud) | the sensor's rate (10 Hz) |
| `scan` (2D, from the first lidar) | `scan` (Scan) | the lidar's rate |
| each camera / depth camera | `image` (ImageReading); depth adds `NAME/points` | sensor rate |
| each imu | `imu` (ImuReading) | sensor rate |
| `odom` | `odom` (OdometryReading, odom -> base) | 50 Hz |
| `ground_truth` | `odom` (OdometryReading, world -> base) | 50 Hz |
| `joint_states` | `joint_states` (JointStateReading) | 50 Hz |
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import mujoco
import numpy as np

from robotrial.geometry import Pose
from robotrial.kinematics.reference import link_poses
from robotrial.model.robot import RobotModel
from robotrial.model.stand import stand
from robotrial.model.world import World
from robotrial.sim.build import compile_world
from robotrial.sim.controllers import (
    BaseController,
    DriveLimits,
    Gripper,
    JointController,
    JointReference,
)
from robotrial.sim.lidar import RayScene, ScanConfig
from robotrial.sim.odometry import OdometryNoise, WheelOdometry
from robotrial.sim.scene import SimWorld
from robotrial.sim.sensor_kinds import SENSOR_KINDS, Reader, camera_reader, ray_scene_of
from robotrial.sim.sensors import JointStates, OdometryReading, Reading
from robotrial.sim.tf import TfTree, chain_to_root

DEFAULT_RATES = {"odom": 50.0, "ground_truth": 50.0, "joint_states": 50.0}


@dataclass(frozen=True)
class StreamSettings:
    """Overrides for one stream: rate (Hz), TF frame, noise (the sensor's unit), a
    camera's image size (width, height in pixels), or off."""

    rate_hz: float | None = None
    frame: str | None = None
    noise: float | None = None
    enabled: bool = True
    size: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if self.rate_hz is not None and not self.rate_hz > 0:
            raise ValueError(f"stream rate must be positive, got {self.rate_hz} Hz")
        if self.noise is not None and self.noise < 0:
            raise ValueError(f"stream noise must be >= 0, got {self.noise}")
        if self.size is not None and (len(self.size) != 2 or min(self.size) < 1):
            raise ValueError(f"stream size must be (width, height) >= 1, got {self.size}")


@dataclass
class _Stream:
    name: str
    kind: str
    period: float
    read: Reader
    next_due: float = 0.0


@dataclass
class SimOptions:
    """How the simulation runs: control rate (Hz), which streams, noise models, threads."""

    control_rate: float = 100.0
    streams: Mapping[str, StreamSettings] = field(default_factory=dict)
    odometry_noise: OdometryNoise = field(default_factory=OdometryNoise)
    scan: ScanConfig | None = None
    cameras: bool = True
    lidar_threads: int = 1
    lidar_sees_robot: bool = False


def _wheel_sides(robot: RobotModel, wheels: list[str]) -> dict[str, float]:
    poses = link_poses(robot, {})
    return {w: float(poses[robot.joint(w).child][1, 3]) for w in wheels}


class Simulation:
    """A robot in a world: controllers, sensors, odometry, TF, all on the sim clock."""

    def __init__(
        self, world: SimWorld, robot: RobotModel, options: SimOptions | None = None
    ) -> None:
        self.world = world
        self.robot = robot
        self.options = opts = options or SimOptions()
        model = world.model
        if not opts.control_rate > 0:
            raise ValueError(f"control rate must be positive, got {opts.control_rate}")
        self.substeps = max(1, round(1.0 / (opts.control_rate * world.dt)))
        self.control_dt = self.substeps * world.dt

        drive = dict(robot.metadata.get("drive", {}) or {})
        groups = dict(robot.metadata.get("groups", {}) or {})
        actuated = [j.name for j in robot.actuated_joints]
        wheels = [w for w in groups.get("base", []) if w in actuated]
        if not wheels:
            wheels = [j for j in actuated if "wheel" in j and robot.joint(j).type == "continuous"]
        self.base: BaseController | None = None
        if world.planar:
            self.base = BaseController(
                model,
                DriveLimits.from_metadata(drive),
                wheels=_wheel_sides(robot, wheels),
                wheel_radius=float(drive.get("wheel_radius", 0.165)),
                time_constant=max(5 * world.dt, 2 * self.control_dt),
            )
        else:
            wheels = []
        grip = robot.metadata.get("gripper") or {}
        fingers = [f for f in grip.get("joints", []) if f in actuated and f not in wheels]
        self.arm_joints = [j for j in actuated if j not in wheels and j not in fingers]
        effort = [
            (robot.joint(j).limit.effort if robot.joint(j).limit else 0.0) for j in self.arm_joints
        ]
        self.joints = (
            JointController(model, self.arm_joints, effort=effort) if self.arm_joints else None
        )
        if self.joints is not None:
            self.joints.hold(world.data)
        self.gripper: Gripper | None = None
        if fingers:
            self.gripper = Gripper(
                model,
                fingers,
                open_value=float(grip.get("open", 0.0)),
                closed_value=float(grip.get("closed", 0.0)),
            )
            for f in fingers:
                qadr = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f)]
                world.data.qpos[qadr] = self.gripper.open_value
            world.forward()
        self.state_reader = JointStates(model, actuated) if actuated else None

        known = self._stream_names()
        unknown = sorted(set(opts.streams) - set(known))
        if unknown:
            raise ValueError(f"sim: unknown streams {unknown}; this robot has {sorted(known)}")
        frames = {
            k: v.frame
            for k, v in opts.streams.items()
            if v.frame and k in {s.name for s in robot.sensors}
        }
        self.tf = TfTree(robot, frames)
        self.base_frame = robot.root
        self.odometry = WheelOdometry(opts.odometry_noise, seed=world.seed + 1)
        self.streams: list[_Stream] = []
        self.closers: list[Callable[[], None]] = []
        self.closed = False
        self._build_streams()
        self.latest: dict[str, Reading] = {}

    # --- construction ------------------------------------------------------------------

    @staticmethod
    def create(
        world: World | str,
        robot: RobotModel | str,
        seed: int = 0,
        spawn: Pose | str = "default",
        base: str = "auto",
        options: SimOptions | None = None,
    ) -> Simulation:
        """Build from a world and a robot (objects, built-in names or files). `spawn`: a
        spawn's name in the world, or the root's pose used as given. `base`: "planar",
        "free", "fixed", or "auto": planar for a robot with a `<drive>`, else fixed."""
        from robotrial.model import load_robot, load_world

        w = load_world(world) if isinstance(world, str) else world
        r = load_robot(robot) if isinstance(robot, str) else robot
        if base == "auto":
            base = "planar" if r.metadata.get("drive") else "fixed"
        pose = w.spawn(spawn) if isinstance(spawn, str) else spawn
        if base == "fixed" and isinstance(spawn, str):
            # at a world's spawn, on the floor if its legs reach below it (model/stand.py);
            # a pose given as such is where the caller puts the root
            pose = pose @ stand(r, w, pose)
        model = compile_world(w, r, base=base, spawn=pose)
        sw = SimWorld(model, seed=seed, base_body=r.root)
        if base != "fixed":
            sw.spawn(pose)
        return Simulation(sw, r, options)

    def _stream_names(self) -> list[str]:
        names = list(DEFAULT_RATES)
        for s in self.robot.sensors:
            names += [s.name, *SENSOR_KINDS[s.type].extra_streams(s)]
        return list(dict.fromkeys(names))

    def settings(self, stream: str) -> StreamSettings:
        """The options' overrides for one stream (defaults when none)."""
        return self.options.streams.get(stream, StreamSettings())

    def ray_scene(self) -> RayScene | None:
        """The LiDARs' shared ray-cast scene, or None when they see the robot too."""
        if self.options.lidar_sees_robot:
            return None
        if self._scene is None:
            self._scene = ray_scene_of(self.world)
        return self._scene

    def claim(self, stream: str) -> bool:
        """True the first time a sensor asks for shared stream `stream` (the 2D scan
        comes from the first LiDAR)."""
        first = stream not in self._claimed
        self._claimed.add(stream)
        return first

    def _add(self, name: str, kind: str, rate: float, read: Reader) -> None:
        st = self.settings(name)
        if not st.enabled:
            return
        hz = st.rate_hz or rate
        if not hz > 0:
            raise ValueError(f"stream {name!r}: rate must be positive, got {hz} Hz")
        self.streams.append(_Stream(name, kind, 1.0 / hz, read))

    def _build_streams(self) -> None:
        w = self.world
        self._mobile = w.planar or (w.base_body >= 0 and w.model.body_jntadr[w.base_body] >= 0)
        self._scene: RayScene | None = None
        self._claimed: set[str] = set()
        self._captures: dict[str, Reader] = {}
        if self.state_reader is not None:
            self._add(
                "joint_states", "joint_states", DEFAULT_RATES["joint_states"], self._read_joints
            )
        if self._mobile:
            self._add("odom", "odom", DEFAULT_RATES["odom"], self._read_odom)
            self._add("ground_truth", "odom", DEFAULT_RATES["ground_truth"], self._read_truth)
        for s in self.robot.sensors:
            st = self.settings(s.name)
            if not st.enabled:
                continue
            kind = SENSOR_KINDS[s.type]
            params = self._params(s.name)
            read = kind.build(self, s, params, self.tf.sensor_frames[s.name])
            if read is not None:
                self._add(s.name, kind.reading, s.rate_hz, read)

    def _params(self, sensor: str) -> dict:
        """A sensor's parameters with its stream's overrides (noise, image size)."""
        s = self.robot.sensor(sensor)
        params = dict(s.params)
        st = self.settings(sensor)
        if st.noise is not None:
            params.update(dict.fromkeys(SENSOR_KINDS[s.type].noise_params, st.noise))
        if st.size is not None:
            params["width"], params["height"] = st.size
        return params

    def height_above_floor(self, site: str) -> float:
        """Height (m) of a sensor site above the floor geom (z = 0 without one)."""
        model, data = self.world.model, self.world.data
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        fid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        floor = float(data.geom_xpos[fid][2]) if fid >= 0 else 0.0
        return float(data.site_xpos[sid][2]) - floor

    def _read_joints(self, t: float) -> list[Reading]:
        assert self.state_reader is not None
        return [Reading("joint_states", "joint_states", self.state_reader.read(self.world.data, t))]

    def _read_odom(self, t: float) -> list[Reading]:
        st = self.odometry.state
        r = OdometryReading(t, "odom", self.base_frame, st.x, st.y, 0.0, st.yaw, st.v, st.vy, st.w)
        return [Reading("odom", "odom", r)]

    def _read_truth(self, t: float) -> list[Reading]:
        x, y, yaw = self.world.base_pose2d()
        bid = self.world.base_body
        z = float(self.world.data.xpos[bid][2]) if bid >= 0 else 0.0
        vel = np.zeros(6)
        if bid >= 0:
            mujoco.mj_objectVelocity(
                self.world.model, self.world.data, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 1
            )
        r = OdometryReading(
            t, "world", self.base_frame, x, y, z, yaw, float(vel[3]), float(vel[4]), float(vel[2])
        )
        return [Reading("ground_truth", "odom", r)]

    # --- commands ----------------------------------------------------------------------

    def drive(self, v: float, w: float) -> None:
        """Command the base: forward speed (m/s) and yaw rate (rad/s), like /cmd_vel."""
        if self.base is None:
            raise ValueError(f"robot {self.robot.name!r} has no mobile base to drive")
        self.base.set_command(v, w)

    def follow(self, reference: JointReference) -> None:
        """Track a joint trajectory starting now."""
        if self.joints is None:
            raise ValueError(f"robot {self.robot.name!r} has no joints to control")
        self.joints.follow(reference, self.world.time)

    def set_joint_targets(self, values: Mapping[str, float]) -> None:
        if self.joints is None:
            raise ValueError(f"robot {self.robot.name!r} has no joints to control")
        self.joints.set_targets(dict(values))

    def grip(self, position: float, max_effort: float | None = None) -> None:
        """Drive the gripper's fingers toward `position` (the finger joint's value) with
        at most `max_effort` N, as control_msgs/GripperCommand asks."""
        if self.gripper is None:
            raise ValueError(f"robot {self.robot.name!r} has no gripper")
        self.gripper.command(position, max_effort)

    def capture(self, sensor: str) -> list[Reading]:
        """One frame of camera `sensor` now, whether or not its stream runs: a camera
        renders only when the robot looks (the renderer is made on the first capture)."""
        reader = self._captures.get(sensor)
        if reader is None:
            s = next((s for s in self.robot.sensors if s.name == sensor), None)
            if s is None or not SENSOR_KINDS[s.type].optical_frame:
                cams = [s.name for s in self.robot.sensors if SENSOR_KINDS[s.type].optical_frame]
                raise ValueError(f"sim: no camera {sensor!r}; this robot has {cams}")
            frame = self.tf.sensor_frames[s.name]
            reader = camera_reader(self, s, self._params(s.name), frame)
            self._captures[sensor] = reader
        got = reader(self.world.time)
        for r in got:
            self.latest[r.stream] = r
        return got

    # --- the loop ----------------------------------------------------------------------

    def joint_values(self) -> dict[str, float]:
        if self.state_reader is None:
            return {}
        q = self.world.data.qpos[self.state_reader.qadr]
        return dict(zip(self.state_reader.names, q.tolist(), strict=True))

    def control_step(self) -> list[Reading]:
        """One control period: controllers, physics substeps, odometry, due sensors."""
        if self.closed:
            raise ValueError(f"the simulation of {self.robot.name!r} is closed")
        w = self.world
        data = w.data
        data.qfrc_applied[:] = 0.0
        if self.joints is not None:
            self.joints.apply(data, w.time, self.control_dt)
        if self.gripper is not None:
            self.gripper.apply(data)
        if self.base is not None:
            self.base.apply(data, self.control_dt)
        w.step(self.substeps)
        t = w.time
        if self._mobile:
            x, y, yaw = w.base_pose2d()
            self.odometry.update(x, y, yaw, self.control_dt)
        out: list[Reading] = []
        for s in self.streams:
            if t + 1e-9 >= s.next_due:
                s.next_due = max(s.next_due + s.period, t)
                got = s.read(t)
                for r in got:
                    self.latest[r.stream] = r
                out.extend(got)
        return out

    def start(self) -> list[Reading]:
        """Sample every stream at the current time (the first readings of a run)."""
        if self._mobile:
            x, y, yaw = self.world.base_pose2d()
            self.odometry.update(x, y, yaw, 0.0)
        t = self.world.time
        out: list[Reading] = []
        for s in self.streams:
            s.next_due = t + s.period
            got = s.read(t)
            for r in got:
                self.latest[r.stream] = r
            out.extend(got)
        return out

    def step(self, n: int = 1) -> list[Reading]:
        """`n` control periods; the readings that fell due."""
        if n < 0:
            raise ValueError(f"cannot step a negative number of control periods ({n})")
        out: list[Reading] = []
        for _ in range(n):
            out.extend(self.control_step())
        return out

    def spawn(self, pose: Pose) -> None:
        """Put the base at `pose` (world frame) and restart there: clock 0, odometry at the
        origin of a new odom frame."""
        self.world.spawn(pose)
        self.reset()

    def advance(
        self, duration: float, on_reading: Callable[[Reading], None] | None = None
    ) -> list[Reading]:
        """Run for `duration` simulated seconds; readings go to `on_reading` (if given,
        none are returned) or come back as a list."""
        if duration < 0:
            raise ValueError(f"cannot advance by a negative duration ({duration} s)")
        steps = round(duration / self.control_dt)
        out: list[Reading] = []
        for _ in range(steps):
            got = self.control_step()
            if on_reading is None:
                out.extend(got)
            else:
                for r in got:
                    on_reading(r)
        return out

    def reset(self, seed: int | None = None) -> None:
        """Back to the spawn state: clock 0, odometry at the origin, controllers holding."""
        self.world.reset(seed)
        self.odometry = WheelOdometry(self.options.odometry_noise, seed=self.world.seed + 1)
        if self.joints is not None:
            self.joints.hold(self.world.data)
        if self.base is not None:
            self.base.command = (0.0, 0.0)
            self.base.velocity = (0.0, 0.0)
        for s in self.streams:
            s.next_due = 0.0
        self.latest.clear()

    def frame_pose(self, frame: str) -> np.ndarray:
        """True world 4x4 pose of a TF frame (a link or a sensor frame)."""
        bid = self.world.base_body
        base = self.world.body_pose(bid) if bid >= 0 else np.eye(4)
        transforms = self.tf.static + self.tf.dynamic(self.joint_values())
        return base @ chain_to_root(transforms, frame, self.robot.root)

    def close(self) -> None:
        """Release the sensors' resources (renderers, threads); the simulation no longer
        steps after this."""
        self.closed = True
        for c in self.closers:
            c()
        self.closers.clear()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
