"""Poses, rigid transforms and primitive shapes: the vocabulary every layer shares.

Layer 0: imports nothing from robotrial. Quaternions are (x, y, z, w), the ROS and
scipy order; angles are radians, lengths metres. A pose's matrix and the URDF's roll,
pitch and yaw are computed here; scipy's Rotation (whose import takes a third of a
second) only where a matrix or angles are read back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

IDENTITY_QUAT: Quat = (0.0, 0.0, 0.0, 1.0)


def _floats(v, n: int) -> bool:
    """`v` is a tuple of `n` Python floats already (most poses are made so)."""
    return type(v) is tuple and len(v) == n and all(type(x) is float for x in v)


def _vec3(v) -> Vec3:
    if _floats(v, 3):
        return v
    a = np.asarray(v, dtype=float).reshape(3)
    return (float(a[0]), float(a[1]), float(a[2]))


def _quat(q) -> Quat:
    if _floats(q, 4):
        n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        if n == 1.0:
            return q
        if math.isfinite(n) and n >= 1e-12:
            return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)
    a = np.asarray(q, dtype=float).reshape(4)
    n = float(np.linalg.norm(a))
    if not np.isfinite(n) or n < 1e-12:
        raise ValueError(f"quaternion {tuple(a)} has no rotation (norm {n})")
    a = a / n
    return (float(a[0]), float(a[1]), float(a[2]), float(a[3]))


@dataclass(frozen=True)
class Pose:
    """A rigid transform: position `xyz` and orientation `quat` (x, y, z, w)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = IDENTITY_QUAT

    def __post_init__(self) -> None:
        object.__setattr__(self, "xyz", _vec3(self.xyz))
        object.__setattr__(self, "quat", _quat(self.quat))

    @staticmethod
    def from_xyz_rpy(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> Pose:
        """The URDF convention: fixed-axis roll, pitch, yaw (rotate about x, then y, then z)."""
        r, p, y = (0.5 * float(a) for a in np.asarray(rpy, dtype=float).reshape(3))
        cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
        return Pose(
            xyz,
            (
                sr * cp * cy - cr * sp * sy,
                cr * sp * cy + sr * cp * sy,
                cr * cp * sy - sr * sp * cy,
                cr * cp * cy + sr * sp * sy,
            ),
        )

    @staticmethod
    def from_matrix(m: np.ndarray) -> Pose:
        from scipy.spatial.transform import Rotation

        m = np.asarray(m, dtype=float)
        return Pose(m[:3, 3], Rotation.from_matrix(m[:3, :3]).as_quat())

    @staticmethod
    def from_xy_yaw(x: float, y: float, yaw: float, z: float = 0.0) -> Pose:
        return Pose((x, y, z), (0.0, 0.0, np.sin(0.5 * yaw), np.cos(0.5 * yaw)))

    @property
    def rpy(self) -> Vec3:
        from scipy.spatial.transform import Rotation

        return _vec3(Rotation.from_quat(self.quat).as_euler("xyz"))

    @property
    def yaw(self) -> float:
        from scipy.spatial.transform import Rotation

        return float(Rotation.from_quat(self.quat).as_euler("xyz")[2])

    def rotation(self) -> np.ndarray:
        x, y, z, w = self.quat
        x2, y2, z2, w2 = x * x, y * y, z * z, w * w
        xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
        return np.array(
            [
                [x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
                [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
                [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2],
            ]
        )

    def matrix(self) -> np.ndarray:
        """The 4x4 homogeneous matrix."""
        m = np.eye(4)
        m[:3, :3] = self.rotation()
        m[:3, 3] = self.xyz
        return m

    def __matmul__(self, other: Pose) -> Pose:
        return Pose.from_matrix(self.matrix() @ other.matrix())

    def inverse(self) -> Pose:
        return Pose.from_matrix(np.linalg.inv(self.matrix()))

    def is_identity(self, tol: float = 1e-12) -> bool:
        return bool(np.allclose(self.matrix(), np.eye(4), atol=tol))


def quat_from_rotation(r: np.ndarray) -> Quat:
    """The unit quaternion (x, y, z, w) of a rotation matrix that is orthonormal to
    rounding (eigenvectors, products of rotations), from its largest diagonal term
    (Shepperd's method); `Pose.from_matrix` takes any matrix near a rotation."""
    r = np.asarray(r, dtype=float)
    tr = r[0, 0] + r[1, 1] + r[2, 2]
    k = int(np.argmax([r[0, 0], r[1, 1], r[2, 2], tr]))
    if k == 3:
        q = [r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1], 1.0 + tr]
    else:
        i, j, m = k, (k + 1) % 3, (k + 2) % 3
        q = [0.0, 0.0, 0.0, r[m, j] - r[j, m]]
        q[i] = 1.0 - tr + 2.0 * r[i, i]
        q[j] = r[j, i] + r[i, j]
        q[m] = r[m, i] + r[i, m]
    return _quat(q)


def transform_points(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to (N, 3) points."""
    p = np.asarray(points, dtype=float)
    return p @ m[:3, :3].T + m[:3, 3]


@dataclass(frozen=True)
class Box:
    """A box with full edge lengths `size` along its own x, y, z."""

    size: Vec3

    def __post_init__(self) -> None:
        object.__setattr__(self, "size", _vec3(self.size))


@dataclass(frozen=True)
class Cylinder:
    """A cylinder along its own z axis."""

    radius: float
    length: float


@dataclass(frozen=True)
class Sphere:
    radius: float


@dataclass(frozen=True, eq=False)
class MeshData:
    """Triangle mesh held in memory: (N, 3) float vertices, (M, 3) int faces."""

    vertices: np.ndarray
    faces: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "vertices", np.ascontiguousarray(self.vertices, dtype=float))
        object.__setattr__(self, "faces", np.ascontiguousarray(self.faces, dtype=np.int64))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, MeshData):
            return NotImplemented
        return (
            self.vertices.shape == other.vertices.shape
            and self.faces.shape == other.faces.shape
            and np.allclose(self.vertices, other.vertices, atol=1e-6)
            and np.array_equal(self.faces, other.faces)
        )

    def __hash__(self) -> int:
        return hash((self.vertices.shape, self.faces.shape))


@dataclass(frozen=True)
class Mesh:
    """A mesh shape: a file (absolute path once resolved) and/or the triangles themselves.

    `filename` keeps where the mesh came from; `data` holds the triangles once loaded
    (from a file, or from an RDTF buffer where there is no file). `scale` applies to both.
    """

    filename: str = ""
    scale: Vec3 = (1.0, 1.0, 1.0)
    data: MeshData | None = field(default=None, compare=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "scale", _vec3(self.scale))


Shape = Box | Cylinder | Sphere | Mesh
