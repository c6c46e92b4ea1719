"""Planar poses and laser beams as SLAM consumes them (layer 3).

A pose is (x, y, yaw) in metres and radians. `beams` turns the ranges of a planar scan
into end points in the robot's base frame, given where the laser sits on the base, and
says which beams hit something. Two limits apply, as in GMapping: a beam longer than the
maximum range (maxRange; a "no return", read as inf, always is) is left out; a beam
longer than the usable range (maxUrange) is cut there and only frees the cells it
crosses. Hector's laser_max_dist is both limits at once: past it, a beam is left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def wrap(a: float) -> float:
    """An angle in [-pi, pi)."""
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def compose(a: np.ndarray | tuple, b: np.ndarray | tuple) -> np.ndarray:
    """a ⊕ b: pose b, given in the frame of pose a, expressed in a's parent frame."""
    c, s = np.cos(a[2]), np.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2])])


def relative(a: np.ndarray | tuple, b: np.ndarray | tuple) -> np.ndarray:
    """The pose of b seen from a (so compose(a, relative(a, b)) == b)."""
    c, s = np.cos(a[2]), np.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2])])


def transform_points(pose: np.ndarray | tuple, points: np.ndarray) -> np.ndarray:
    """(N, 2) points in the frame of `pose` into its parent frame."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    out = np.empty_like(points, dtype=np.float64)
    out[:, 0] = pose[0] + c * points[:, 0] - s * points[:, 1]
    out[:, 1] = pose[1] + s * points[:, 0] + c * points[:, 1]
    return out


@dataclass(frozen=True)
class Beams:
    """One scan in the base frame: the laser's position, beam end points (N, 2) in scan
    order, whether each ended on something, and the angle between neighbouring beams
    (None when not known)."""

    origin: tuple[float, float]
    ends: np.ndarray
    hit: np.ndarray
    angle_step: float | None = None

    @property
    def hits(self) -> np.ndarray:
        """End points of the beams that hit something (what scan matching uses)."""
        return self.ends[self.hit]


def beams(
    ranges: np.ndarray,
    angle_min: float,
    angle_increment: float,
    range_min: float,
    usable_range: float,
    laser_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    max_range: float = np.inf,
) -> Beams:
    """Beams of a planar scan (`ranges`: inf where nothing returned, nan where nothing
    was measured) in the base frame of a laser mounted at `laser_pose` (x, y, yaw on the
    base). Beams longer than `max_range` are left out, beams longer than `usable_range`
    cut there (free space only)."""
    r = np.asarray(ranges, dtype=np.float64).ravel()
    if not usable_range > 0:
        raise ValueError(f"usable laser range must be positive, got {usable_range}")
    if not angle_increment != 0:
        raise ValueError("scan angle_increment is 0")
    angles = angle_min + angle_increment * np.arange(r.size)
    valid = ~np.isnan(r) & (r >= range_min) & (r > 0) & (r <= max_range)
    hit = valid & (r <= usable_range)
    dist = np.where(hit, r, usable_range)[valid]
    a = angles[valid] + laser_pose[2]
    ends = np.empty((dist.size, 2))
    ends[:, 0] = laser_pose[0] + dist * np.cos(a)
    ends[:, 1] = laser_pose[1] + dist * np.sin(a)
    return Beams(
        (float(laser_pose[0]), float(laser_pose[1])), ends, hit[valid], abs(float(angle_increment))
    )


def motion_sigma(
    d: np.ndarray | tuple,
    trans_per_trans: float,
    trans_per_rot: float,
    rot_per_trans: float,
    rot_per_rot: float,
) -> tuple[float, float, float]:
    """Standard deviations (x, y in the frame of the pose moved from, yaw) of an odometry
    motion `d` (x, y, yaw): GMapping's model, growing with the distance and the angle
    moved (srr, str, srt, stt are its names for the four gains)."""
    dx, dy, dth = (abs(float(v)) for v in d)
    side = 0.3 * trans_per_trans
    return (
        trans_per_trans * dx + trans_per_rot * dth + side * dy,
        trans_per_trans * dy + trans_per_rot * dth + side * dx,
        rot_per_rot * dth + rot_per_trans * float(np.hypot(dx, dy)),
    )
