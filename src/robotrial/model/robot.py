"""RobotModel: what a robot IS, the one in-memory truth every format maps to.

Layer 1: imports only `robotrial.geometry`. A RobotModel is immutable; joint values,
poses and simulator state are separate values passed alongside it (as MuJoCo keeps
MjModel apart from MjData).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from robotrial.geometry import IDENTITY_QUAT, Pose, Shape, Vec3

JointType = Literal["revolute", "continuous", "prismatic", "fixed", "floating", "planar"]
JOINT_TYPES: tuple[str, ...] = (
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
)
SensorType = Literal["lidar", "camera", "depth_camera", "imu"]
SENSOR_TYPES: tuple[str, ...] = ("lidar", "camera", "depth_camera", "imu")


class ModelError(ValueError):
    """A robot or world description that cannot be used, with where it went wrong."""


@dataclass(frozen=True)
class Material:
    name: str
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)
    texture: str = ""


@dataclass(frozen=True)
class Inertial:
    """Mass (kg), centre of mass frame `origin`, inertia about it (kg m^2)."""

    mass: float
    origin: Pose = Pose()
    ixx: float = 0.0
    ixy: float = 0.0
    ixz: float = 0.0
    iyy: float = 0.0
    iyz: float = 0.0
    izz: float = 0.0

    def tensor(self) -> np.ndarray:
        return np.array(
            [
                [self.ixx, self.ixy, self.ixz],
                [self.ixy, self.iyy, self.iyz],
                [self.ixz, self.iyz, self.izz],
            ]
        )


@dataclass(frozen=True)
class Visual:
    geometry: Shape
    origin: Pose = Pose()
    material: str = ""
    name: str = ""


@dataclass(frozen=True)
class Collision:
    geometry: Shape
    origin: Pose = Pose()
    name: str = ""


@dataclass(frozen=True)
class Link:
    name: str
    inertial: Inertial | None = None
    visuals: tuple[Visual, ...] = ()
    collisions: tuple[Collision, ...] = ()


@dataclass(frozen=True)
class JointLimit:
    """Position limits (rad or m), effort (N m or N) and speed (rad/s or m/s)."""

    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0


@dataclass(frozen=True)
class JointDynamics:
    damping: float = 0.0
    friction: float = 0.0


@dataclass(frozen=True)
class Mimic:
    """This joint's value = multiplier * value of `joint` + offset."""

    joint: str
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class Joint:
    name: str
    type: JointType
    parent: str
    child: str
    origin: Pose = Pose()
    axis: Vec3 = (1.0, 0.0, 0.0)
    limit: JointLimit | None = None
    dynamics: JointDynamics | None = None
    mimic: Mimic | None = None

    @property
    def actuated(self) -> bool:
        """A joint with one degree of freedom that a controller drives (not fixed, not mimic)."""
        return self.type in ("revolute", "continuous", "prismatic") and self.mimic is None


@dataclass(frozen=True)
class Sensor:
    """A sensor mounted on `link` at `origin`, producing data at `rate_hz`.

    `params` holds the type's settings, e.g. for a lidar: rings, vertical_min,
    vertical_max (rad), horizontal_resolution (rad), range_min, range_max (m), noise (m);
    for a camera: width, height, fov (rad), near, far.
    """

    name: str
    type: SensorType
    link: str
    origin: Pose = Pose()
    rate_hz: float = 10.0
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class CollisionSphere:
    """A sphere of the planner's collision model, in its link's frame."""

    link: str
    center: Vec3
    radius: float


@dataclass(frozen=True)
class RobotModel:
    """A robot: its kinematic tree, physical properties, sensors and planner spheres.

    `tcp` names the end-effector link (the tool centre point); `metadata` carries what
    URDF has no element for, e.g. `drive` (skid-steer base parameters) and `gripper`.
    `repairs` lists what the loader changed to make the description usable.
    """

    name: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...] = ()
    materials: Mapping[str, Material] = field(default_factory=dict)
    sensors: tuple[Sensor, ...] = ()
    spheres: tuple[CollisionSphere, ...] = ()
    tcp: str = ""
    metadata: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""
    repairs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        names = [lk.name for lk in self.links]
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ModelError(f"robot {self.name!r}: duplicate link names {dup}")
        jnames = [j.name for j in self.joints]
        if len(set(jnames)) != len(jnames):
            dup = sorted({n for n in jnames if jnames.count(n) > 1})
            raise ModelError(f"robot {self.name!r}: duplicate joint names {dup}")
        known = set(names)
        for j in self.joints:
            for end in (j.parent, j.child):
                if end not in known:
                    raise ModelError(
                        f"robot {self.name!r}: joint {j.name!r} names link {end!r}, "
                        "which does not exist"
                    )
        children = [j.child for j in self.joints]
        if len(set(children)) != len(children):
            dup = sorted({c for c in children if children.count(c) > 1})
            raise ModelError(f"robot {self.name!r}: links {dup} have more than one parent joint")
        if self.links and len(self.root_links()) != 1:
            raise ModelError(
                f"robot {self.name!r}: expected one root link, found {self.root_links()}"
            )
        for s in self.sensors:
            if s.link not in known:
                raise ModelError(
                    f"robot {self.name!r}: sensor {s.name!r} is mounted on link {s.link!r}, "
                    "which does not exist"
                )
            if not s.rate_hz > 0:
                raise ModelError(
                    f"robot {self.name!r}: sensor {s.name!r} has rate {s.rate_hz} Hz; "
                    "it must be positive"
                )
        if self.tcp and self.tcp not in known:
            raise ModelError(f"robot {self.name!r}: tcp link {self.tcp!r} does not exist")

    # --- lookups -------------------------------------------------------------------

    def link(self, name: str) -> Link:
        for lk in self.links:
            if lk.name == name:
                return lk
        raise KeyError(f"robot {self.name!r} has no link {name!r}")

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"robot {self.name!r} has no joint {name!r}")

    def root_links(self) -> list[str]:
        children = {j.child for j in self.joints}
        return [lk.name for lk in self.links if lk.name not in children]

    @property
    def root(self) -> str:
        return self.root_links()[0]

    def parent_joint(self, link: str) -> Joint | None:
        for j in self.joints:
            if j.child == link:
                return j
        return None

    def child_joints(self, link: str) -> list[Joint]:
        return [j for j in self.joints if j.parent == link]

    def chain(self, tip: str, base: str = "") -> list[Joint]:
        """The joints from `base` (default: the root) down to `tip`, in order."""
        base = base or self.root
        out: list[Joint] = []
        cur = tip
        while cur != base:
            j = self.parent_joint(cur)
            if j is None:
                raise KeyError(f"robot {self.name!r}: link {tip!r} is not below {base!r}")
            out.append(j)
            cur = j.parent
        return out[::-1]

    def topological_joints(self) -> list[Joint]:
        """All joints ordered so that a joint's parent link is placed before it."""
        order: list[Joint] = []
        stack = [self.root]
        while stack:
            link = stack.pop()
            kids = self.child_joints(link)
            order.extend(kids)
            stack.extend(j.child for j in reversed(kids))
        return order

    @property
    def actuated_joints(self) -> list[Joint]:
        """Joints with one driven degree of freedom, in tree order: the order of `q`."""
        return [j for j in self.topological_joints() if j.actuated]

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.actuated_joints]

    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper position limits of the actuated joints (continuous: +-pi)."""
        lo, hi = [], []
        for j in self.actuated_joints:
            if j.type == "continuous" or j.limit is None:
                lo.append(-np.pi)
                hi.append(np.pi)
            else:
                lo.append(j.limit.lower)
                hi.append(j.limit.upper)
        return np.array(lo, dtype=float), np.array(hi, dtype=float)

    @property
    def end_effector(self) -> str:
        """The `tcp` link if named, else the last link of the longest chain."""
        if self.tcp:
            return self.tcp
        best, depth = self.root, 0
        for lk in self.links:
            d = len(self.chain(lk.name))
            if d > depth:
                best, depth = lk.name, d
        return best

    @property
    def total_mass(self) -> float:
        return float(sum(lk.inertial.mass for lk in self.links if lk.inertial))

    def sensor(self, name: str) -> Sensor:
        for s in self.sensors:
            if s.name == name:
                return s
        raise KeyError(f"robot {self.name!r} has no sensor {name!r}")

    def with_changes(self, **changes: Any) -> RobotModel:
        """A copy with some fields replaced (the model itself never changes)."""
        return replace(self, **changes)


__all__ = [
    "IDENTITY_QUAT",
    "JOINT_TYPES",
    "SENSOR_TYPES",
    "Collision",
    "CollisionSphere",
    "Inertial",
    "Joint",
    "JointDynamics",
    "JointLimit",
    "Link",
    "Material",
    "Mimic",
    "ModelError",
    "RobotModel",
    "Sensor",
    "Visual",
]
