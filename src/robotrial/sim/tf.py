"""The robot's TF tree: which frames exist and the transforms between them (layer 2).

Like robot_state_publisher: fixed joints and sensor mounts are static transforms
(published once on /tf_static); movable joints are dynamic ones computed from joint
values. Sensor frames: a sensor whose name differs from its link gets a frame named as
the sensor, a child of the link at the sensor's origin; cameras add `<frame>_optical`
(z forward, x right, y down).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from robotrial.geometry import Pose
from robotrial.model.robot import RobotModel
from robotrial.sim.sensor_kinds import SENSOR_KINDS

OPTICAL = Pose.from_xyz_rpy((0, 0, 0), (-np.pi / 2, 0.0, -np.pi / 2))


@dataclass(frozen=True)
class Transform:
    """`child` expressed in `parent`: translation (m) and rotation quat (x, y, z, w)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]

    @staticmethod
    def from_matrix(parent: str, child: str, m: np.ndarray) -> Transform:
        p = Pose.from_matrix(m)
        return Transform(parent, child, p.xyz, p.quat)

    def matrix(self) -> np.ndarray:
        return Pose(self.translation, self.rotation).matrix()


def planar_transform(
    parent: str, child: str, x: float, y: float, yaw: float, z: float = 0.0
) -> Transform:
    h = 0.5 * yaw
    return Transform(
        parent, child, (float(x), float(y), float(z)), (0.0, 0.0, math.sin(h), math.cos(h))
    )


def quat_multiply(a: tuple, b: tuple) -> tuple[float, float, float, float]:
    """Hamilton product of two (x, y, z, w) quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def sensor_frame(robot: RobotModel, sensor_name: str) -> str:
    """The TF frame a sensor's data is stamped with."""
    s = robot.sensor(sensor_name)
    return s.link if s.name == s.link else s.name


class TfTree:
    """The frames of a robot and how to compute the transforms between them."""

    def __init__(self, robot: RobotModel, frames: Mapping[str, str] | None = None) -> None:
        """`frames` may rename a sensor's frame (sensor name -> frame); the new frame must
        be a link of the robot or the sensor's own name."""
        self.robot = robot
        self.links = {lk.name for lk in robot.links}
        self.sensor_frames: dict[str, str] = {}
        statics: list[Transform] = []
        for s in robot.sensors:
            frame = (frames or {}).get(s.name, sensor_frame(robot, s.name))
            if frame not in self.links and frame != s.name:
                raise ValueError(
                    f"sensor {s.name!r}: frame {frame!r} is not in robot {robot.name!r}; "
                    f"use a link ({sorted(self.links)[:8]}...) or {s.name!r}"
                )
            self.sensor_frames[s.name] = frame
            if frame not in self.links:
                statics.append(Transform(s.link, frame, s.origin.xyz, s.origin.quat))
            if SENSOR_KINDS[s.type].optical_frame:
                statics.append(Transform(frame, frame + "_optical", OPTICAL.xyz, OPTICAL.quat))
        self.movable = [
            j
            for j in robot.topological_joints()
            if j.type in ("revolute", "continuous", "prismatic")
        ]
        axes = [np.asarray(j.axis, float) / np.linalg.norm(j.axis) for j in self.movable]
        # per movable joint, as plain floats (this runs at the joint state rate): the unit
        # axis, and for a prismatic joint its direction in the parent frame
        self._axes = [tuple(map(float, a)) for a in axes]
        self._slides = [
            tuple(map(float, j.origin.rotation() @ a)) if j.type == "prismatic" else None
            for j, a in zip(self.movable, axes, strict=True)
        ]
        for j in robot.topological_joints():
            if j.type == "fixed":
                statics.append(Transform(j.parent, j.child, j.origin.xyz, j.origin.quat))
        self.static = statics

    @property
    def frames(self) -> set[str]:
        out = set(self.links)
        for t in self.static:
            out.add(t.child)
        return out

    def dynamic(self, values: Mapping[str, float]) -> list[Transform]:
        """Transforms of the movable joints at joint `values` (missing joints at 0; mimic
        joints follow their leader)."""
        out = []
        for j, axis, slide in zip(self.movable, self._axes, self._slides, strict=True):
            v = values.get(j.name)
            if v is None and j.mimic is not None:
                v = j.mimic.multiplier * values.get(j.mimic.joint, 0.0) + j.mimic.offset
            v = float(v or 0.0)
            if slide is not None:
                x, y, z = j.origin.xyz
                xyz = (x + slide[0] * v, y + slide[1] * v, z + slide[2] * v)
                out.append(Transform(j.parent, j.child, xyz, j.origin.quat))
            else:
                sin = math.sin(0.5 * v)
                turn = (axis[0] * sin, axis[1] * sin, axis[2] * sin, math.cos(0.5 * v))
                quat = quat_multiply(j.origin.quat, turn)
                out.append(Transform(j.parent, j.child, j.origin.xyz, quat))
        return out


def chain_to_root(transforms: list[Transform], frame: str, root: str) -> np.ndarray:
    """Compose transforms (child -> parent) from `frame` up to `root`: the 4x4 of `frame` in
    `root`. Raises if the frame does not connect to the root."""
    parent_of = {t.child: t for t in transforms}
    m = np.eye(4)
    cur = frame
    seen = set()
    while cur != root:
        if cur not in parent_of or cur in seen:
            raise ValueError(f"tf: frame {frame!r} does not connect to {root!r} (stuck at {cur!r})")
        seen.add(cur)
        t = parent_of[cur]
        m = t.matrix() @ m
        cur = t.parent
    return m
