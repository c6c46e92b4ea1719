"""Simulated 3D LiDAR (VLP-16 class) and its 2D scan (layer 2).

`LidarPattern` is the fixed set of beam directions of a spinning multi-ring LiDAR;
`Lidar` casts them from a MuJoCo site: against a `RayScene` (the environment's geoms, in
compiled code: sim/raycast.py), or against the whole model with mj_multiRay;
`laserscan_from_points` turns a point cloud into a planar scan the way ROS's
pointcloud_to_laserscan does (a height band, one range per angle bin), except that a bin
holds the median of the returns near the nearest, not the nearest itself (unbiased with
range noise; see `ScanConfig.surface_tolerance`), and `Lidar.scan` does the same for a
sweep without computing angles.
"""

from __future__ import annotations

import dataclasses
import itertools
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import mujoco
import numba
import numpy as np

from robotrial.sim.raycast import RayScene, keep_nearer, valid_ranges


@dataclass(frozen=True)
class LidarPattern:
    """Beam layout: `rings` elevations evenly from `vertical_min` to `vertical_max` (rad),
    azimuths every `horizontal_resolution` (rad) over a full turn; ranges in metres."""

    rings: int = 16
    vertical_min: float = np.deg2rad(-15.0)
    vertical_max: float = np.deg2rad(15.0)
    horizontal_resolution: float = np.deg2rad(0.4)
    range_min: float = 0.4
    range_max: float = 100.0
    noise: float = 0.0

    def __post_init__(self) -> None:
        if int(self.rings) < 1:
            raise ValueError(f"lidar: rings must be at least 1, got {self.rings}")
        if not 0 < self.horizontal_resolution <= np.pi:
            raise ValueError(
                f"lidar: horizontal_resolution must be in (0, pi] rad, "
                f"got {self.horizontal_resolution}"
            )
        if self.vertical_max < self.vertical_min:
            raise ValueError("lidar: vertical_max is below vertical_min")
        if not 0 <= self.range_min < self.range_max:
            raise ValueError(
                f"lidar: need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}"
            )
        if self.noise < 0:
            raise ValueError(f"lidar: noise must be >= 0, got {self.noise}")

    @staticmethod
    def from_params(params: dict[str, Any]) -> LidarPattern:
        """From a Sensor's params (docs/robots.md, lidar params); missing keys keep the
        VLP-16 defaults."""
        known = {f for f in LidarPattern.__dataclass_fields__}
        kw = {k: float(v) for k, v in params.items() if k in known}
        if "rings" in kw:
            kw["rings"] = int(kw["rings"])
        return LidarPattern(**kw)

    @property
    def elevations(self) -> np.ndarray:
        if self.rings == 1:
            return np.array([0.5 * (self.vertical_min + self.vertical_max)])
        return np.linspace(self.vertical_min, self.vertical_max, self.rings)

    @property
    def azimuths(self) -> np.ndarray:
        n = round(2 * np.pi / self.horizontal_resolution)
        return np.arange(n) * (2 * np.pi / n) - np.pi

    def directions(self) -> np.ndarray:
        """(rings * columns, 3) unit vectors in the sensor frame, ring-major."""
        el, az = np.meshgrid(self.elevations, self.azimuths, indexing="ij")
        return np.stack(
            [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1
        ).reshape(-1, 3)


@dataclass
class PointCloud:
    """One LiDAR sweep in the sensor frame: (N, 3) float32 points of valid returns, their
    ring index and range; `frame` names the sensor frame, `stamp` the sim time (s)."""

    stamp: float
    frame: str
    points: np.ndarray
    ring: np.ndarray
    range: np.ndarray


@dataclass
class Scan:
    """A planar scan like sensor_msgs/LaserScan: `ranges` (inf where nothing was seen)."""

    stamp: float
    frame: str
    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray
    scan_time: float = 0.0


class Lidar:
    """Casts a LidarPattern from a MuJoCo site with mj_multiRay.

    `geomgroup` selects which geom groups the beams see (MuJoCo's visibility groups);
    `exclude_body` is the body the sensor sits on; or `scene` gives a RayScene to cast
    against instead of the whole model. `threads` > 1 splits the beams that mj_multiRay
    casts (the whole model, or a scene's meshes) across threads (mj_multiRay releases the
    GIL; it pays only on an idle multi-core machine).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        site: str,
        pattern: LidarPattern,
        frame: str = "",
        geomgroup: np.ndarray | None = None,
        exclude_body: int | None = None,
        threads: int = 1,
        scene: RayScene | None = None,
    ) -> None:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        if sid < 0:
            raise ValueError(f"lidar: no site {site!r} in the MuJoCo model")
        self.model = model
        self.site = sid
        self.pattern = pattern
        self.frame = frame or site
        self.directions = pattern.directions()
        self.n = len(self.directions)
        self.geomgroup = None if geomgroup is None else np.asarray(geomgroup, dtype=np.uint8)
        self.exclude_body = int(model.site_bodyid[sid]) if exclude_body is None else exclude_body
        self._dist = np.zeros(self.n)
        self._geom = np.zeros(self.n, dtype=np.int32)
        self._world_vec = np.zeros((self.n, 3))
        self._mesh_dist = np.zeros(self.n)
        self._mesh_geom = np.zeros(self.n, dtype=np.int32)
        self._noise = np.zeros(self.n)
        self.threads = max(1, int(threads))
        self.scene = scene
        self._last: tuple[np.ndarray, PointCloud] | None = None
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        bounds = np.linspace(0, self.n, self.threads + 1).astype(int)
        self._parts = list(itertools.pairwise(bounds.tolist()))

    def _cast(self, data: mujoco.MjData, pnt: np.ndarray, lo: int, hi: int) -> None:
        """mj_multiRay for beams lo..hi: against the whole model, or the scene's meshes."""
        scene = self.scene
        if scene is None:
            model, geomgroup, exclude = self.model, self.geomgroup, self.exclude_body
            geom, dist = self._geom, self._dist
        else:
            model, data, geomgroup, exclude = scene.model, scene.data, scene.mesh_groups, -1
            geom, dist = self._mesh_geom, self._mesh_dist
        mujoco.mj_multiRay(
            model,
            data,
            pnt,
            self._world_vec[lo:hi].reshape(-1),
            geomgroup,
            True,
            exclude,
            geom[lo:hi],
            dist[lo:hi],
            None,
            hi - lo,
            self.pattern.range_max,
        )

    def ranges(self, data: mujoco.MjData, rng: np.random.Generator | None = None) -> np.ndarray:
        """Distance along every beam (ring-major; inf = no return within range)."""
        pnt = data.site_xpos[self.site].copy()
        rot = data.site_xmat[self.site].reshape(3, 3)
        scene = self.scene
        if scene is not None:
            scene.sync(data)
            scene.cast_primitives(
                pnt, rot, self.directions, self._dist, self._geom, self.n // self.pattern.rings
            )
        if scene is None or scene.has_meshes:
            np.matmul(self.directions, rot.T, out=self._world_vec)
            if self._pool is None:
                self._cast(data, pnt, 0, self.n)
            else:
                list(self._pool.map(lambda p: self._cast(data, pnt, *p), self._parts))
            if scene is not None:
                keep_nearer(self._dist, self._geom, self._mesh_dist, self._mesh_geom)
        noise = None
        if self.pattern.noise > 0 and rng is not None:
            noise = rng.standard_normal(self.n, out=self._noise)
        r = np.empty(self.n)
        valid_ranges(
            self._dist,
            self._geom,
            noise,
            self.pattern.noise,
            self.pattern.range_min,
            self.pattern.range_max,
            r,
        )
        return r

    def sweep(
        self, data: mujoco.MjData, rng: np.random.Generator | None = None, stamp: float = 0.0
    ) -> PointCloud:
        """One full sweep as a point cloud of the valid returns in the sensor frame."""
        r = self.ranges(data, rng)
        pts = np.empty((self.n, 3), dtype=np.float32)
        ring = np.empty(self.n, dtype=np.uint16)
        dist = np.empty(self.n, dtype=np.float32)
        k = _returns(self.directions, r, self.n // self.pattern.rings, pts, ring, dist)
        self._last = (r, PointCloud(stamp, self.frame, pts[:k], ring[:k], dist[:k]))
        return self._last[1]

    def scan(self, config: ScanConfig) -> Scan:
        """The 2D scan of the last sweep: what `laserscan_from_points` makes of its points.
        When the scan's bins are the beams' azimuths (a full turn from -pi at the LiDAR's
        step) each return goes to its beam's bin without computing its angle."""
        if self._last is None:
            raise ValueError("lidar: scan() needs a sweep first")
        ranges, cloud = self._last
        full_turn, nbins = _scan_bins(config)
        cols = self.n // self.pattern.rings
        aligned = (
            full_turn
            and nbins == cols
            and abs(config.angle_min + np.pi) < 1e-9
            and cols * abs(config.angle_increment - 2 * np.pi / cols)
            < 1e-3 * config.angle_increment
        )
        if not aligned:
            tol = self.surface_tolerance(config)
            if tol != config.surface_tolerance:
                config = dataclasses.replace(config, surface_tolerance=tol)
            return laserscan_from_points(cloud.points, config, stamp=cloud.stamp, frame=cloud.frame)
        out = np.full(nbins, np.inf)
        _flatten_beams(
            self.directions,
            ranges,
            cols,
            config.min_height,
            config.max_height,
            config.range_min,
            config.range_max,
            self.surface_tolerance(config),
            out,
        )
        return _make_scan(config, nbins, out, cloud.stamp, cloud.frame)

    def surface_tolerance(self, config: ScanConfig) -> float:
        """How far (m) behind the nearest return of an angle the returns still count as
        the same surface: the configured tolerance, widened to 5 times the range noise
        (returns of one wall spread with the noise)."""
        return max(config.surface_tolerance, 5.0 * self.pattern.noise)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None


@numba.njit(cache=True)
def _bin_of(x, y, angle_min, inc, wrap, nbins):
    """The angle bin of a point (x, y); out of 0..nbins-1 when outside the window."""
    a = np.arctan2(y, x)
    if wrap and a < angle_min:
        a += 2.0 * np.pi
    k = int(np.floor((a - angle_min) / inc + 0.5))
    if wrap and k == nbins:
        k = 0
    return k


@numba.njit(cache=True)
def _median_near(values, lo, hi, nearest, tol):
    """Median of values[lo:hi] that lie within `tol` of `nearest` (their minimum)."""
    kept = np.empty(hi - lo)
    n = 0
    for i in range(lo, hi):
        if values[i] <= nearest + tol:
            kept[n] = values[i]
            n += 1
    kept = np.sort(kept[:n])
    if n % 2 == 1:
        return kept[n // 2]
    return 0.5 * (kept[n // 2 - 1] + kept[n // 2])


@numba.njit(cache=True)
def _flatten(points, min_h, max_h, rmin, rmax, angle_min, inc, wrap, tol, out):
    """Per angle bin of the points inside the height band and the range limits: the
    median horizontal range of those within `tol` of the nearest."""
    nbins = out.shape[0]
    n = points.shape[0]
    bins = np.full(n, -1, np.int64)
    ranges = np.empty(n)
    counts = np.zeros(nbins + 1, np.int64)
    for i in range(n):
        z = points[i, 2]
        if z < min_h or z > max_h:
            continue
        x = np.float64(points[i, 0])
        y = np.float64(points[i, 1])
        r = np.sqrt(x * x + y * y)
        if r < rmin or r > rmax:
            continue
        k = _bin_of(x, y, angle_min, inc, wrap, nbins)
        if 0 <= k < nbins:
            bins[i] = k
            ranges[i] = r
            counts[k + 1] += 1
            if r < out[k]:
                out[k] = r
    # Group the kept ranges by bin (a counting sort), then take each bin's median.
    starts = np.cumsum(counts)
    fill = starts[:-1].copy()
    grouped = np.empty(starts[-1])
    for i in range(n):
        k = bins[i]
        if k >= 0:
            grouped[fill[k]] = ranges[i]
            fill[k] += 1
    for k in range(nbins):
        if starts[k + 1] > starts[k]:
            out[k] = _median_near(grouped, starts[k], starts[k + 1], out[k], tol)


@numba.njit(cache=True)
def _flatten_beams(directions, ranges, cols, min_h, max_h, rmin, rmax, tol, out):
    """`_flatten` of the points `_returns` makes from `ranges`, with beam i in bin
    i % cols (its azimuth's bin): the rings of one azimuth are beams k, k + cols, ..."""
    rings = ranges.shape[0] // cols
    horizontal = np.full(ranges.shape[0], np.inf)
    for i in range(ranges.shape[0]):
        r = ranges[i]
        if not np.isfinite(r):
            continue
        z = np.float32(directions[i, 2] * r)
        if z < min_h or z > max_h:
            continue
        x = np.float64(np.float32(directions[i, 0] * r))
        y = np.float64(np.float32(directions[i, 1] * r))
        h = np.sqrt(x * x + y * y)
        if h < rmin or h > rmax:
            continue
        horizontal[i] = h
        k = i % cols
        if h < out[k]:
            out[k] = h
    kept = np.empty(rings)
    for k in range(cols):
        nearest = out[k]
        if not np.isfinite(nearest):
            continue
        n = 0
        for ring in range(rings):
            h = horizontal[k + ring * cols]
            if np.isfinite(h):
                kept[n] = h
                n += 1
        if n > 1:
            out[k] = _median_near(kept, 0, n, nearest, tol)


@numba.njit(cache=True)
def _returns(directions, ranges, rings_cols, points, ring, rng_out):
    """Points, ring index and range of the finite returns; returns how many there are."""
    n = 0
    for i in range(ranges.shape[0]):
        r = ranges[i]
        if np.isfinite(r):
            points[n, 0] = directions[i, 0] * r
            points[n, 1] = directions[i, 1] * r
            points[n, 2] = directions[i, 2] * r
            ring[n] = i // rings_cols
            rng_out[n] = r
            n += 1
    return n


@dataclass(frozen=True)
class ScanConfig:
    """pointcloud_to_laserscan settings: the height band (m, in the target frame), the
    angular window and step (rad) and the range limits (m)."""

    min_height: float = -0.2
    max_height: float = 0.5
    angle_min: float = -np.pi
    angle_max: float = np.pi
    angle_increment: float = np.deg2rad(0.4)
    range_min: float = 0.4
    range_max: float = 30.0
    # Of the returns of one angle within this distance (m) of the nearest, the median
    # range is taken. The nearest alone (pointcloud_to_laserscan's choice) is the
    # minimum of several noisy rings and reads a wall short (about 1.3 sigma with four
    # to eight rings in the band); the median of the rings that see the same surface is
    # unbiased, and an obstacle more than this in front of the wall still wins.
    surface_tolerance: float = 0.05

    def __post_init__(self) -> None:
        if not self.surface_tolerance >= 0:
            raise ValueError(
                f"scan: surface_tolerance must be >= 0 m, got {self.surface_tolerance}"
            )
        if self.max_height < self.min_height:
            raise ValueError("scan: max_height is below min_height")
        if not self.angle_increment > 0:
            raise ValueError(f"scan: angle_increment must be positive, got {self.angle_increment}")
        if self.angle_max <= self.angle_min:
            raise ValueError("scan: angle_max must be above angle_min")
        if not 0 <= self.range_min < self.range_max:
            raise ValueError("scan: need 0 <= range_min < range_max")


def laserscan_from_points(
    points: np.ndarray,
    config: ScanConfig = ScanConfig(),
    transform: np.ndarray | None = None,
    stamp: float = 0.0,
    frame: str = "",
) -> Scan:
    """Flatten (N, 3) points into a planar scan: keep points whose z (after `transform`,
    a 4x4 into the scan frame) lies in the height band, then per angle bin the median
    range of the points within `config.surface_tolerance` of the nearest."""
    p = np.asarray(points)
    if p.dtype not in (np.float32, np.float64):
        p = p.astype(np.float64)
    if transform is not None:
        p = p @ transform[:3, :3].T + transform[:3, 3]
    p = np.ascontiguousarray(p).reshape(-1, 3)
    full_turn, nbins = _scan_bins(config)
    out = np.full(nbins, np.inf)
    _flatten(
        p,
        config.min_height,
        config.max_height,
        config.range_min,
        config.range_max,
        config.angle_min,
        config.angle_increment,
        full_turn,
        config.surface_tolerance,
        out,
    )
    return _make_scan(config, nbins, out, stamp, frame)


def _scan_bins(config: ScanConfig) -> tuple[bool, int]:
    """Whether the scan wraps around a full turn, and its number of bins."""
    full_turn = config.angle_max - config.angle_min >= 2 * np.pi - 1e-9
    nbins = round((config.angle_max - config.angle_min) / config.angle_increment)
    return full_turn, nbins if full_turn else nbins + 1


def _make_scan(
    config: ScanConfig, nbins: int, ranges: np.ndarray, stamp: float, frame: str
) -> Scan:
    return Scan(
        stamp=stamp,
        frame=frame,
        angle_min=config.angle_min,
        angle_max=config.angle_min + (nbins - 1) * config.angle_increment,
        angle_increment=config.angle_increment,
        range_min=config.range_min,
        range_max=config.range_max,
        ranges=ranges.astype(np.float32),
    )
