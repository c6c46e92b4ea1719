"""Adaptive Monte Carlo Localization on a known map (the ROS amcl role) (layer 3).

A particle filter over the base's pose (x, y, yaw) in the map frame:

- motion: the odometry motion model (Probabilistic Robotics, table 5.6): each odometry
  increment is split into a rotation, a translation and a rotation, and every particle
  draws its own noisy version (alpha1..alpha4 as in amcl's `diff` model);
- measurement: the likelihood field model: each (sub-sampled) beam's end point is looked
  up in a precomputed field `z_hit * N(d; 0, sigma_hit) + z_rand / range_max`, where d
  is the distance from the end point to the nearest occupied map cell;
- resampling: low-variance sampling with a KLD-adaptive particle count (Fox 2003): draw
  until the count bounds, with probability `1 - kld_delta`, the KL divergence between
  the sample-based and the true posterior by `kld_err`, given the number of histogram
  bins the draws occupy; clamped to [min_particles, max_particles].

Updates run only after the base has moved `update_min_d` m or turned `update_min_a` rad,
like amcl. `map_to_odom` gives the map -> odom correction that, composed with odometry,
places the robot on the map between updates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage, stats


@dataclass(frozen=True)
class AMCLConfig:
    """amcl's parameters, with its names; distances in m, angles in rad."""

    min_particles: int = 100
    max_particles: int = 3000
    kld_err: float = 0.02
    kld_z: float = 0.99
    bin_xy: float = 0.25
    bin_yaw: float = np.deg2rad(10.0)
    alpha1: float = 0.1
    alpha2: float = 0.05
    alpha3: float = 0.05
    alpha4: float = 0.05
    z_hit: float = 0.9
    z_rand: float = 0.1
    sigma_hit: float = 0.1
    max_beams: int = 90
    likelihood_max_dist: float = 2.0
    beam_weight: float = 0.3
    update_min_d: float = 0.1
    update_min_a: float = 0.15

    def __post_init__(self) -> None:
        if not 0 < self.min_particles <= self.max_particles:
            raise ValueError(
                "AMCL: need 0 < min_particles <= max_particles, "
                f"got {self.min_particles}, {self.max_particles}"
            )
        if not (0 < self.kld_err and 0 < self.kld_z < 1):
            raise ValueError("AMCL: kld_err must be positive and kld_z in (0, 1)")
        if not self.sigma_hit > 0:
            raise ValueError(f"AMCL: sigma_hit must be positive, got {self.sigma_hit}")
        if self.max_beams < 1:
            raise ValueError("AMCL: max_beams must be at least 1")


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Planar pose composition a (+) b for (..., 3) x, y, yaw arrays."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack(
        [
            a[..., 0] + c * b[..., 0] - s * b[..., 1],
            a[..., 1] + s * b[..., 0] + c * b[..., 1],
            _wrap(a[..., 2] + b[..., 2]),
        ],
        axis=-1,
    )


def inverse(a: np.ndarray) -> np.ndarray:
    """The inverse of a planar pose (x, y, yaw)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack(
        [-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1], _wrap(-a[..., 2])], axis=-1
    )


@numba.njit(cache=True)
def _log_likelihood(particles, laser, ranges, angles, field, origin_x, origin_y, res, floor):
    """Sum over beams of log(field at the beam's end point), for every particle."""
    n = particles.shape[0]
    rows, cols = field.shape
    out = np.empty(n)
    lx, ly, lth = laser[0], laser[1], laser[2]
    for i in range(n):
        x, y, th = particles[i, 0], particles[i, 1], particles[i, 2]
        c, s = np.cos(th), np.sin(th)
        sx = x + c * lx - s * ly
        sy = y + s * lx + c * ly
        total = 0.0
        for k in range(ranges.shape[0]):
            a = th + lth + angles[k]
            ex = sx + ranges[k] * np.cos(a)
            ey = sy + ranges[k] * np.sin(a)
            col = int(np.floor((ex - origin_x) / res))
            row = int(np.floor((ey - origin_y) / res))
            if 0 <= row < rows and 0 <= col < cols:
                total += field[row, col]
            else:
                total += floor
        out[i] = total
    return out


def kld_count(bins: int, err: float, z: float) -> float:
    """How many samples bound the KL divergence by `err` with probability `z`, when the
    samples occupy `bins` histogram bins (Wilson-Hilferty approximation)."""
    k = np.asarray(bins, dtype=float)
    zq = stats.norm.ppf(z)
    k1 = np.maximum(k - 1, 1)
    a = 2.0 / (9.0 * k1)
    return np.where(k > 1, k1 / (2 * err) * (1 - a + np.sqrt(a) * zq) ** 3, 1.0)


class AMCL:
    """The particle filter. Feed odometry poses (odom frame) and scans; read `estimate`."""

    def __init__(
        self,
        occupied: np.ndarray,
        origin: tuple[float, float],
        resolution: float,
        config: AMCLConfig = AMCLConfig(),
        seed: int = 0,
        range_max: float = 30.0,
    ) -> None:
        occ = np.asarray(occupied, dtype=bool)
        if occ.ndim != 2 or not occ.any():
            raise ValueError("AMCL: the map must be a 2D grid with some occupied cells")
        self.config = c = config
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        self.rng = np.random.default_rng(seed)
        d = np.minimum(ndimage.distance_transform_edt(~occ) * resolution, c.likelihood_max_dist)
        p = c.z_hit * np.exp(-0.5 * (d / c.sigma_hit) ** 2) + c.z_rand / range_max
        self.field = np.log(p)
        self.floor = float(np.log(c.z_rand / range_max))
        self.particles = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self._odom: np.ndarray | None = None
        self._pending = np.zeros(3)
        self.updates = 0

    @property
    def count(self) -> int:
        return len(self.particles)

    def initialize(
        self, pose: tuple[float, float, float], std: tuple[float, float, float] = (0.25, 0.25, 0.2)
    ) -> None:
        """Spread particles around an initial guess (RViz's '2D Pose Estimate')."""
        n = self.config.max_particles // 2
        p = np.asarray(pose, dtype=float) + self.rng.normal(size=(n, 3)) * np.asarray(std)
        p[:, 2] = _wrap(p[:, 2])
        self.particles = p
        self.weights = np.full(n, 1.0 / n)
        self._odom = None

    def initialize_global(self, free: np.ndarray, count: int | None = None) -> None:
        """Spread `count` particles (default: `max_particles`) uniformly over the cells
        where `free` (a grid like the map's) is True, with uniform headings: amcl's
        `global_localization`, for a robot that does not know where it stands. The
        scans that follow, while it turns or drives, gather them on its pose."""
        rows, cols = np.nonzero(np.asarray(free, dtype=bool))
        if len(rows) == 0:
            raise ValueError("AMCL: no free cell to spread the particles over")
        n = int(count or self.config.max_particles)
        k = self.rng.integers(0, len(rows), n)
        res = self.resolution
        p = np.column_stack(
            [
                self.origin[0] + (cols[k] + self.rng.random(n)) * res,
                self.origin[1] + (rows[k] + self.rng.random(n)) * res,
                self.rng.uniform(-np.pi, np.pi, n),
            ]
        )
        self.particles = p
        self.weights = np.full(n, 1.0 / n)
        self._odom = None

    def converged(self, xy_std: float = 0.1, yaw_std: float = 0.1) -> bool:
        """Whether the particles have gathered on one pose: the estimate's standard
        deviations under `xy_std` (m, each axis) and `yaw_std` (rad)."""
        _, cov = self.estimate()
        return bool(np.sqrt(max(cov[0, 0], cov[1, 1])) < xy_std and np.sqrt(cov[2, 2]) < yaw_std)

    def estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean pose (x, y, yaw) and its 3x3 covariance."""
        if not self.count:
            raise ValueError("AMCL: not initialized; call initialize(pose) first")
        w = self.weights
        p = self.particles
        mean_xy = w @ p[:, :2]
        yaw = float(np.arctan2(w @ np.sin(p[:, 2]), w @ np.cos(p[:, 2])))
        dev = np.column_stack([p[:, :2] - mean_xy, _wrap(p[:, 2] - yaw)])
        cov = (dev * w[:, None]).T @ dev
        return np.array([mean_xy[0], mean_xy[1], yaw]), cov

    def map_to_odom(self, odom_pose: np.ndarray) -> np.ndarray:
        """The map -> odom transform (x, y, yaw) that puts `odom_pose` at the estimate."""
        est, _ = self.estimate()
        return compose(est, inverse(np.asarray(odom_pose, dtype=float)))

    def _motion(self, delta: np.ndarray) -> None:
        """Apply the odometry increment `delta` (in the odom frame's motion, expressed as
        a relative pose) to every particle with sampled noise."""
        c = self.config
        dx, dy, dth = delta
        trans = float(np.hypot(dx, dy))
        rot1 = float(np.arctan2(dy, dx)) if trans > 0.01 else 0.0
        backwards = abs(_wrap(rot1)) > np.pi / 2 and trans > 0.01
        if backwards:
            rot1 = float(_wrap(rot1 + np.pi))
            trans = -trans
        rot2 = float(_wrap(dth - rot1))
        n = self.count
        r1 = min(abs(rot1), abs(_wrap(rot1 + np.pi)))
        r2 = min(abs(rot2), abs(_wrap(rot2 + np.pi)))
        sd_r1 = np.sqrt(c.alpha1 * r1**2 + c.alpha2 * trans**2)
        sd_t = np.sqrt(c.alpha3 * trans**2 + c.alpha4 * (r1**2 + r2**2))
        sd_r2 = np.sqrt(c.alpha1 * r2**2 + c.alpha2 * trans**2)
        h1 = rot1 + self.rng.normal(0, 1, n) * sd_r1
        t = trans + self.rng.normal(0, 1, n) * sd_t
        h2 = rot2 + self.rng.normal(0, 1, n) * sd_r2
        p = self.particles
        p[:, 0] += t * np.cos(p[:, 2] + h1)
        p[:, 1] += t * np.sin(p[:, 2] + h1)
        p[:, 2] = _wrap(p[:, 2] + h1 + h2)

    def update(
        self,
        odom_pose: tuple[float, float, float],
        ranges: np.ndarray | None = None,
        angles: np.ndarray | None = None,
        laser_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        force: bool = False,
    ) -> bool:
        """Account for odometry up to `odom_pose`; when the base has moved enough (or
        `force`), move the particles, weigh them with the scan (`ranges` at `angles` in
        the laser frame, `laser_pose` in the base frame; inf/NaN beams are skipped) and
        resample. Returns True if the filter updated."""
        if not self.count:
            raise ValueError("AMCL: not initialized; call initialize(pose) first")
        c = self.config
        odom = np.asarray(odom_pose, dtype=float)
        if self._odom is None:
            self._odom = odom
            if not force:
                return False
        delta = compose(inverse(self._odom), odom)
        moved = np.hypot(delta[0], delta[1]) >= c.update_min_d or abs(delta[2]) >= c.update_min_a
        if not (moved or force):
            return False
        self._motion(delta)
        self._odom = odom
        if ranges is not None and angles is not None:
            self._sense(np.asarray(ranges, float), np.asarray(angles, float), laser_pose)
            self._resample()
        self.updates += 1
        return True

    def _sense(self, ranges: np.ndarray, angles: np.ndarray, laser_pose) -> None:
        c = self.config
        ok = np.isfinite(ranges)
        r, a = ranges[ok], angles[ok]
        if len(r) == 0:
            return
        if len(r) > c.max_beams:
            idx = np.linspace(0, len(r) - 1, c.max_beams).astype(int)
            r, a = r[idx], a[idx]
        ll = _log_likelihood(
            self.particles,
            np.asarray(laser_pose, dtype=float),
            r,
            a,
            self.field,
            self.origin[0],
            self.origin[1],
            self.resolution,
            self.floor,
        )
        ll = c.beam_weight * ll
        logw = np.log(np.maximum(self.weights, 1e-300)) + ll
        w = np.exp(logw - logw.max())
        self.weights = w / w.sum()

    def _resample(self) -> None:
        c = self.config
        n_max = c.max_particles
        # low-variance draws in random order, so that any prefix is a fair sample
        u = (self.rng.random() + np.arange(n_max)) / n_max
        idx = np.searchsorted(np.cumsum(self.weights), u)
        idx = np.minimum(idx, self.count - 1)
        idx = idx[self.rng.permutation(n_max)]
        draws = self.particles[idx]
        keys = np.column_stack(
            [
                np.floor(draws[:, 0] / c.bin_xy),
                np.floor(draws[:, 1] / c.bin_xy),
                np.floor(_wrap(draws[:, 2]) / c.bin_yaw),
            ]
        ).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        new_bin = np.zeros(n_max, dtype=bool)
        new_bin[first] = True
        bins = np.cumsum(new_bin)
        need = kld_count(bins, c.kld_err, c.kld_z)
        enough = np.nonzero(np.arange(1, n_max + 1) >= np.maximum(need, c.min_particles))[0]
        n = int(enough[0]) + 1 if len(enough) else n_max
        self.particles = draws[:n].copy()
        self.weights = np.full(n, 1.0 / n)
