"""The sensor types a robot description may name, and how the simulation builds each
(layer 2; imports sim's sensor modules and nothing above).

`SENSOR_KINDS` maps a type to a `SensorKind`: the streams it adds besides its own, the
kind of its readings and a function that makes its reader. A new sensor is its module
(what it measures, read from MjData) plus one entry here; docs/architecture.md lists
the other places a type is named (the description format, the MJCF export, the topics).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from robotrial.model.robot import Sensor
from robotrial.sim.build import RAY_GROUP
from robotrial.sim.lidar import Lidar, LidarPattern, RayScene, ScanConfig
from robotrial.sim.scene import SimWorld
from robotrial.sim.sensors import Camera, Imu, Reading, depth_to_points

if TYPE_CHECKING:
    from robotrial.sim.simulation import SimOptions, StreamSettings

Reader = Callable[[float], list[Reading]]
"""Gives the readings due at simulated time t (s)."""

SCAN_ABOVE_FLOOR = 0.1
"""m: the 2D scan keeps points from this height above the floor to 0.5 m above the LiDAR."""


class SensorHost(Protocol):
    """What a sensor's builder may use of the simulation it joins."""

    world: SimWorld
    options: SimOptions
    closers: list[Callable[[], None]]

    def settings(self, stream: str) -> StreamSettings: ...

    def ray_scene(self) -> RayScene | None:
        """The shared ray-cast scene (None when the LiDAR sees the robot too)."""
        ...

    def height_above_floor(self, site: str) -> float: ...

    def claim(self, stream: str) -> bool:
        """True for the first sensor that asks for a shared stream (the 2D scan)."""
        ...


@dataclass(frozen=True)
class SensorKind:
    """How one sensor type joins a simulation: its readings' kind, its builder (which
    returns its reader, or None when the options leave it out), the streams it adds
    besides its own (named from the sensor), which of its parameters a stream's noise
    setting overrides, and whether it has a `<frame>_optical` TF frame (images)."""

    reading: str
    build: Callable[[SensorHost, Sensor, dict, str], Reader | None]
    extra_streams: Callable[[Sensor], list[str]] = lambda sensor: []
    noise_params: tuple[str, ...] = ("noise",)
    optical_frame: bool = False


def _lidar(host: SensorHost, s: Sensor, params: dict, frame: str) -> Reader:
    pattern = LidarPattern.from_params(params)
    lidar = Lidar(
        host.world.model,
        s.name,
        pattern,
        frame,
        threads=host.options.lidar_threads,
        scene=host.ray_scene(),
    )
    host.closers.append(lidar.close)
    scan_cfg = host.options.scan or ScanConfig(
        min_height=SCAN_ABOVE_FLOOR - host.height_above_floor(s.name),
        max_height=0.5,
        angle_increment=pattern.horizontal_resolution,
        range_min=pattern.range_min,
        range_max=min(pattern.range_max, 30.0),
    )
    scan = scan_cfg if host.settings("scan").enabled and host.claim("scan") else None
    world = host.world

    def read(t: float) -> list[Reading]:
        out = [Reading(s.name, "points", lidar.sweep(world.data, world.rng, t))]
        if scan is not None:
            sc = lidar.scan(scan)
            sc.scan_time = 1.0 / max(1e-9, host.settings(s.name).rate_hz or 10.0)
            out.append(Reading("scan", "scan", sc))
        return out

    return read


def _camera(host: SensorHost, s: Sensor, params: dict, frame: str) -> Reader | None:
    if not host.options.cameras:
        return None
    return camera_reader(host, s, params, frame)


def camera_reader(host: SensorHost, s: Sensor, params: dict, frame: str) -> Reader:
    """The reader of a camera or depth camera (its renderer made now)."""
    depth = s.type == "depth_camera"
    cam = Camera(
        host.world.model,
        s.name,
        width=int(params.get("width", 320)),
        height=int(params.get("height", 240)),
        depth=depth,
        frame=frame,
        noise=float(params.get("noise", 0.0)),
        near=float(params.get("near", 0.05)),
        far=float(params.get("far", 10.0)),
    )
    host.closers.append(cam.close)
    world = host.world

    def read(t: float) -> list[Reading]:
        img = cam.read(world.data, world.rng, t)
        out = [Reading(s.name, "image", img)]
        if depth and host.settings(f"{s.name}/points").enabled:
            points = depth_to_points(img, 2)
            out.append(Reading(f"{s.name}/points", "points_xyz", (t, img.frame, points)))
        return out

    return read


def _imu(host: SensorHost, s: Sensor, params: dict, frame: str) -> Reader:
    imu = Imu(
        host.world.model,
        s.name,
        frame,
        noise_gyro=float(params.get("noise_gyro", params.get("noise", 0.0))),
        noise_accel=float(params.get("noise_accel", params.get("noise", 0.0))),
    )
    world = host.world
    return lambda t: [Reading(s.name, "imu", imu.read(world.data, world.rng, t))]


SENSOR_KINDS: dict[str, SensorKind] = {
    "lidar": SensorKind("points", _lidar, extra_streams=lambda s: ["scan"]),
    "camera": SensorKind("image", _camera, optical_frame=True),
    "depth_camera": SensorKind(
        "image", _camera, extra_streams=lambda s: [f"{s.name}/points"], optical_frame=True
    ),
    "imu": SensorKind("imu", _imu, noise_params=("noise", "noise_gyro", "noise_accel")),
}


def ray_scene_of(world: SimWorld) -> RayScene:
    """The ray-cast scene of a world's environment geoms (the LiDAR's view without the
    robot)."""
    env = np.nonzero(world.model.geom_group == RAY_GROUP)[0]
    return RayScene(world.model, world.data, env)
