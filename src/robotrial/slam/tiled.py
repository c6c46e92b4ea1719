"""The particle filter's maps: one log-odds grid per particle, stored as tiles that the
particles share until one of them writes into a tile (copy on write), as GMapping's
patches are shared (layer 3).

A particle's map is an index of tiles (`TILE` x `TILE` cells each, -1 where nothing was
ever written) into one pool that all particles draw from; each tile counts how many
particles hold it. Resampling copies indexes, not cells: a child shares every tile with
its parent. Writing a scan first makes each tile it touches the particle's own (a
shared tile is copied, a missing one allocated), so the maps cost the cells they hold
once, plus what the particles wrote since their lineages parted. On a large site with
long-range scans (MIT Killian Court, 50 m) this is the difference between a full grid
per particle (30 x 120 MB) and about one.

The kernels are grid.py's beam fan and matcher.py's Gauss-Newton and likelihood field,
run on a particle's tiles through their `cells` view (index, pool, refs, free, top, k).
"""

from __future__ import annotations

import numba
import numpy as np

from robotrial.slam.cells import TILE
from robotrial.slam.grid import (
    LogOddsGrid,
    LogOddsModel,
    _halve,
    fan_starts,
    stop_points,
    trace_fan,
)
from robotrial.slam.matcher import COARSE_TOL, _gauss_newton, _likelihood
from robotrial.slam.scan import Beams


@numba.njit(cache=True, nogil=True)
def _match_all(
    index: np.ndarray, pool: np.ndarray, refs: np.ndarray, free: np.ndarray,
    top: np.ndarray, ox: float, oy: float, res: float, coarse: numba.typed.List,
    cox: float, coy: float, match_pts: np.ndarray, pts: np.ndarray, stride: int,
    guesses: np.ndarray, centres: np.ndarray, prior_weight: np.ndarray, iterations: int,
    kernel: int, sigma: float, lsigma: float, null_likelihood: float, min_score: float,
    write: bool,
    sensor: np.ndarray, ends: np.ndarray, stops: np.ndarray, hit: np.ndarray,
    starts: np.ndarray, model: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    n = guesses.shape[0]
    poses = np.empty((n, 3))
    logliks = np.empty(n)
    for k in range(n):
        view = (index, pool, refs, free, top, k)
        start = guesses[k].copy()
        centre = centres[k].copy()
        pose = start.copy()
        if match_pts.shape[0] > 0:
            for level in range(len(coarse), 0, -1):
                block = 1 << level
                pose, _, _ = _gauss_newton(
                    coarse[level - 1], cox, coy, res * block, 1, match_pts, block, pose,
                    iterations, centre, prior_weight, COARSE_TOL,
                )  # fmt: skip
            pose, _, _ = _gauss_newton(
                view, ox, oy, res, 1, match_pts, 1, pose, iterations, centre, prior_weight, 0.05
            )
        score, loglik, _ = _likelihood(view, ox, oy, res, pts, stride, pose, kernel, sigma,
                                       lsigma, null_likelihood)  # fmt: skip
        if score <= min_score:
            pose = start
            _, loglik, _ = _likelihood(view, ox, oy, res, pts, stride, pose, kernel, sigma,
                                       lsigma, null_likelihood)  # fmt: skip
        poses[k] = pose
        logliks[k] = loglik
        if write:
            trace_fan(view, ox, oy, res, pose, sensor, ends, stops, hit, starts, model[0],
                      model[1], model[2], model[3])  # fmt: skip
    return poses, logliks


@numba.njit(cache=True, nogil=True)
def _unpack(index: np.ndarray, pool: np.ndarray, k: int, out: np.ndarray, ros: bool,
            occ: float, free: float) -> None:  # fmt: skip
    # Map k's tiles into a dense array, cells of missing tiles left as they are: the
    # log-odds, or with `ros` the cells as a ROS OccupancyGrid holds them (100 at or
    # above `occ`, 0 at or below `free`, else left: `out` starts at -1, unknown).
    for a in range(index.shape[1]):
        for b in range(index.shape[2]):
            t = index[k, a, b]
            if t < 0:
                continue
            for i in range(TILE):
                for j in range(TILE):
                    v = pool[t, i, j]
                    if not ros:
                        out[a * TILE + i, b * TILE + j] = v
                    elif v >= occ:
                        out[a * TILE + i, b * TILE + j] = 100
                    elif v <= free:
                        out[a * TILE + i, b * TILE + j] = 0


@numba.njit(cache=True, nogil=True)
def _tile_counts(index: np.ndarray, refs: np.ndarray) -> None:
    refs[:] = 0
    for k in range(index.shape[0]):
        for a in range(index.shape[1]):
            for b in range(index.shape[2]):
                t = index[k, a, b]
                if t >= 0:
                    refs[t] += 1


def landing_box(
    points: np.ndarray, poses: np.ndarray, pad: float
) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of (N, 2) points placed at every one of the (M, 3) poses,
    widened by `pad` m."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    x = poses[:, :1] + c * points[:, 0] - s * points[:, 1]
    y = poses[:, 1:2] + s * points[:, 0] + c * points[:, 1]
    return float(x.min() - pad), float(y.min() - pad), float(x.max() + pad), float(y.max() + pad)


class TiledMaps:
    """`n` particle maps of `resolution` m cells over one frame, sharing their tiles.

    The frame's origin is the corner of tile (0, 0); `ensure` grows every index to hold a
    box. `write` traces a scan into every map at its particle's pose; `match` refines
    and weighs the particles and writes the scan; `resample` makes child maps share
    their parents' tiles; `dense(k)` is particle k's map as a LogOddsGrid."""

    def __init__(self, n: int, resolution: float, model: LogOddsModel | None = None) -> None:
        if n < 1 or not resolution > 0:
            raise ValueError(f"tiled maps: need n >= 1 and resolution > 0, got {n}, {resolution}")
        self.resolution = float(resolution)
        self.model = model or LogOddsModel()
        self.origin = (0.0, 0.0)
        self.index = np.full((n, 0, 0), -1, dtype=np.int32)
        self.pool = np.zeros((0, TILE, TILE), dtype=np.float32)
        self.refs = np.zeros(0, dtype=np.int32)
        self.free = np.zeros(0, dtype=np.int32)
        self.top = np.zeros(1, dtype=np.int64)

    def view(self, k: int) -> tuple:
        """Particle k's map as the compiled kernels read and write it (`cells`)."""
        return (self.index, self.pool, self.refs, self.free, self.top, k)

    @property
    def tiles_held(self) -> int:
        """Tiles in use (held by at least one particle)."""
        return int(self.pool.shape[0] - self.top[0])

    @property
    def nbytes(self) -> int:
        """The memory of the maps: the tiles in use and the indexes."""
        return self.tiles_held * TILE * TILE * 4 + self.index.nbytes

    def ensure(self, xmin: float, ymin: float, xmax: float, ymax: float, pad: float = 2.0) -> None:
        """Grow the indexes (whole tiles, content kept) so the box lies inside."""
        span = TILE * self.resolution
        n, rows, cols = self.index.shape
        x0, y0 = self.origin
        empty = rows == 0
        if (
            not empty
            and x0 <= xmin
            and y0 <= ymin
            and xmax < x0 + cols * span
            and (ymax < y0 + rows * span)
        ):
            return
        lo_x = xmin - pad if empty else min(xmin - pad, x0)
        lo_y = ymin - pad if empty else min(ymin - pad, y0)
        hi_x = xmax + pad if empty else max(xmax + pad, x0 + cols * span)
        hi_y = ymax + pad if empty else max(ymax + pad, y0 + rows * span)
        c0, r0 = int(np.floor(lo_x / span)), int(np.floor(lo_y / span))
        c1, r1 = int(np.ceil(hi_x / span)), int(np.ceil(hi_y / span))
        grown = np.full((n, r1 - r0, c1 - c0), -1, dtype=np.int32)
        if not empty:
            oc, orow = round(x0 / span) - c0, round(y0 / span) - r0
            grown[:, orow : orow + rows, oc : oc + cols] = self.index
        self.index = grown
        self.origin = (c0 * span, r0 * span)

    def reserve(self, count: int) -> None:
        """Make at least `count` free tiles ready (the pool grows by half at least)."""
        if self.top[0] >= count:
            return
        have = self.pool.shape[0]
        size = have + max(count - int(self.top[0]), have // 2, 64)
        # Zeroed pages the maps never write stay unallocated by the system: only the
        # tiles held are copied (a free tile is cleared or overwritten when taken).
        pool = np.zeros((size, TILE, TILE), np.float32)
        held = np.flatnonzero(self.refs > 0)
        pool[held] = self.pool[held]
        refs = np.zeros(size, np.int32)
        refs[:have] = self.refs
        spare = self.free[: self.top[0]]
        free = np.zeros(size, np.int32)
        fresh = np.arange(size - 1, have - 1, -1, dtype=np.int32)
        free[: len(fresh)] = fresh
        free[len(fresh) : len(fresh) + len(spare)] = spare
        self.pool, self.refs, self.free = pool, refs, free
        self.top[0] = len(fresh) + len(spare)

    def _prepare(self, poses: np.ndarray, scan: Beams) -> None:
        """Grow the indexes to hold the scan at every pose, and reserve the tiles its box
        covers for every particle (the most it can make its own)."""
        pts = np.vstack([scan.ends, np.array(scan.origin)[None, :]])
        x0, y0, x1, y1 = landing_box(pts, poses, 0.0)
        lo, hi = (x0, y0), (x1, y1)
        self.ensure(lo[0], lo[1], hi[0], hi[1])
        span = TILE * self.resolution
        per = (int((hi[0] - lo[0]) / span) + 2) * (int((hi[1] - lo[1]) / span) + 2)
        self.reserve(per * len(poses))

    def _scan_args(self, scan: Beams) -> tuple[np.ndarray, ...]:
        if not (scan.angle_step is not None and scan.angle_step > 0):
            raise ValueError("tiled maps: the scan to write needs its angle step")
        m = self.model
        sensor = np.array(scan.origin, dtype=np.float64)
        ends = np.ascontiguousarray(scan.ends, dtype=np.float64).reshape(-1, 2)
        hit = np.ascontiguousarray(scan.hit, dtype=np.bool_)
        stops = stop_points(sensor, ends, hit, m.hit_margin * self.resolution)
        model = np.array([m.free, m.occupied, m.clamp_min, m.clamp_max])
        return sensor, ends, stops, hit, fan_starts(self.resolution, scan.angle_step), model

    def write(self, poses: np.ndarray, scan: Beams) -> None:
        """Trace `scan` (beams in scan order, base frame) into map k at poses[k]."""
        poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(-1, 3)
        if len(poses) != self.index.shape[0]:
            raise ValueError(f"tiled maps: {len(poses)} poses for {self.index.shape[0]} maps")
        if scan.ends.shape[0] == 0:
            return
        self._prepare(poses, scan)
        sensor, ends, stops, hit, starts, model = self._scan_args(scan)
        ox, oy = self.origin
        for k in range(len(poses)):
            trace_fan(self.view(k), ox, oy, self.resolution, poses[k], sensor, ends, stops, hit,
                      starts, model[0], model[1], model[2], model[3])  # fmt: skip

    def match(
        self,
        coarse: list[np.ndarray],
        coarse_origin: tuple[float, float],
        match_points: np.ndarray,
        points: np.ndarray,
        guesses: np.ndarray,
        prior_sigma: tuple[float, float, float],
        iterations: int = 5,
        stride: int = 1,
        kernel: int = 1,
        sigma: float = 0.05,
        lsigma: float = 0.075,
        null_likelihood: float = -0.5,
        min_score: float = 0.0,
        scan: Beams | None = None,
        prior_means: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """GMapping's improved proposal and weights for every particle in one compiled
        call: particle k's guess (guesses[k], x y yaw) is refined by Gauss-Newton with
        `match_points` ((N, 2), base frame) on the shared coarse levels (`coarse`, block
        sizes 2, 4, ..., anchored at `coarse_origin`), then on its own map, with the
        motion prior `prior_sigma` centred on `prior_means` ((N, 3); default the guesses);
        then scored with every `stride`-th of `points` on its
        own map's likelihood field (GMapping's formulas, `kernel` cells around). A match
        scoring at most `min_score` is not trusted and the guess is kept. With `scan`,
        the scan is then written into each map at its matched pose. Returns (poses
        (N, 3), log-likelihoods (N,))."""
        guesses = np.ascontiguousarray(guesses, dtype=np.float64).reshape(-1, 3)
        centres = guesses if prior_means is None else prior_means
        centres = np.ascontiguousarray(centres, dtype=np.float64).reshape(-1, 3)
        weight = 1.0 / np.maximum(np.asarray(prior_sigma, dtype=np.float64), 1e-3) ** 2
        levels = numba.typed.List([np.ascontiguousarray(c, dtype=np.float32) for c in coarse])
        if len(levels) == 0:
            levels = numba.typed.List.empty_list(numba.float32[:, ::1])
        write = scan is not None and scan.ends.shape[0] > 0
        if write:
            assert scan is not None
            # The matched poses are within a few cells of the guesses.
            self._prepare(guesses, scan)
            sensor, ends, stops, hit, starts, model = self._scan_args(scan)
        else:
            sensor, ends, stops = np.zeros(2), np.zeros((0, 2)), np.zeros((0, 2))
            hit, starts, model = np.zeros(0, np.bool_), np.zeros(1), np.zeros(4)
        ox, oy = self.origin
        return _match_all(
            self.index, self.pool, self.refs, self.free, self.top, ox, oy, self.resolution,
            levels, float(coarse_origin[0]), float(coarse_origin[1]),
            np.ascontiguousarray(match_points, dtype=np.float64).reshape(-1, 2),
            np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2), max(1, stride),
            guesses, centres, weight, int(iterations), int(kernel), float(sigma), float(lsigma),
            float(null_likelihood), float(min_score), write, sensor, ends, stops, hit,
            starts, model,
        )  # fmt: skip

    def resample(self, parents: np.ndarray) -> None:
        """Child k takes parent parents[k]'s map, sharing its tiles; tiles no particle
        holds any more go back to the free stack."""
        held = self.refs > 0
        self.index = np.ascontiguousarray(self.index[np.asarray(parents)])
        _tile_counts(self.index, self.refs)
        dropped = np.flatnonzero(held & (self.refs == 0)).astype(np.int32)
        if len(dropped):
            t = int(self.top[0])
            self.free[t : t + len(dropped)] = dropped
            self.top[0] = t + len(dropped)

    def dense(self, k: int) -> LogOddsGrid:
        """Particle k's map as a LogOddsGrid (missing tiles unknown)."""
        _, rows, cols = self.index.shape
        grid = LogOddsGrid(self.resolution, self.origin, (rows * TILE, cols * TILE), self.model)
        _unpack(self.index, self.pool, k, grid.logodds, False, 0.0, 0.0)
        return grid

    def coarse(
        self, k: int, box: tuple[float, float, float, float], levels: int
    ) -> tuple[list[np.ndarray], tuple[float, float]]:
        """The coarse levels (block sizes 2, 4, ... 2^(levels-1)) of particle k's map over
        `box` (xmin, ymin, xmax, ymax; whole tiles), and their origin."""
        span = TILE * self.resolution
        _, rows, cols = self.index.shape
        x0, y0 = self.origin
        c0 = max(0, int(np.floor((box[0] - x0) / span)))
        r0 = max(0, int(np.floor((box[1] - y0) / span)))
        c1 = min(cols, int(np.ceil((box[2] - x0) / span)) + 1)
        r1 = min(rows, int(np.ceil((box[3] - y0) / span)) + 1)
        if c1 <= c0 or r1 <= r0:
            return [], (x0, y0)
        crop = np.zeros(((r1 - r0) * TILE, (c1 - c0) * TILE), dtype=np.float32)
        for a, b in np.argwhere(self.index[k, r0:r1, c0:c1] >= 0):
            t = self.index[k, r0 + a, c0 + b]
            crop[a * TILE : (a + 1) * TILE, b * TILE : (b + 1) * TILE] = self.pool[t]
        out = []
        level = crop
        for _ in range(1, levels):
            level = _halve(level)
            out.append(level)
        return out, (x0 + c0 * span, y0 + r0 * span)


class TiledGrid:
    """One log-odds map in tiles, allocated where a scan reaches: a robot that crosses a
    large site along its corridors keeps the cells it saw, not the site's bounding box
    (Hector's and the pose graph's 2.5 cm maps of MIT Killian Court, 270 x 300 m: the
    box alone would be 130 million cells). Growing it copies only the tile index.

    It reads like a LogOddsGrid (`resolution`, `origin`, `shape`, `extent`,
    `ros_values`, `probability`, `logodds`, `copy`) and is written like one
    (`integrate`); `logodds` and `probability` make dense arrays, for small maps.
    `ScanMatcher.match` matches on it through its `view`."""

    def __init__(self, resolution: float, model: LogOddsModel | None = None) -> None:
        self._tiles = TiledMaps(1, resolution, model)

    @property
    def resolution(self) -> float:
        return self._tiles.resolution

    @property
    def model(self) -> LogOddsModel:
        return self._tiles.model

    @property
    def origin(self) -> tuple[float, float]:
        return self._tiles.origin

    @property
    def shape(self) -> tuple[int, int]:
        _, rows, cols = self._tiles.index.shape
        return rows * TILE, cols * TILE

    @property
    def nbytes(self) -> int:
        """The memory of the cells held and the index."""
        return self._tiles.nbytes

    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) in metres."""
        rows, cols = self.shape
        x0, y0 = self.origin
        return x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution

    def integrate(
        self,
        sensor_xy: tuple[float, float] | np.ndarray,
        end_xy: np.ndarray,
        hit: np.ndarray,
        angle_step: float | None = None,
    ) -> None:
        """Trace beams from the sensor to (N, 2) end points in the map frame, as
        `LogOddsGrid.integrate` does (with `angle_step`, the thinned fan)."""
        end_xy = np.ascontiguousarray(end_xy, dtype=np.float64).reshape(-1, 2)
        if end_xy.shape[0] == 0:
            return
        t = self._tiles
        sensor = np.array([float(sensor_xy[0]), float(sensor_xy[1])])
        lo = np.minimum(end_xy.min(axis=0), sensor)
        hi = np.maximum(end_xy.max(axis=0), sensor)
        t.ensure(lo[0], lo[1], hi[0], hi[1])
        span = TILE * t.resolution
        t.reserve((int((hi[0] - lo[0]) / span) + 2) * (int((hi[1] - lo[1]) / span) + 2))
        m = t.model
        hit = np.ascontiguousarray(hit, dtype=np.bool_)
        stops = stop_points(sensor, end_xy, hit, m.hit_margin * t.resolution)
        # Without an angle step every beam is traced from the sensor (one level).
        fan = angle_step is not None and angle_step > 0
        starts = fan_starts(t.resolution, angle_step) if fan else np.zeros(1)
        ox, oy = t.origin
        trace_fan(t.view(0), ox, oy, t.resolution, np.zeros(3), sensor, end_xy, stops, hit,
                  starts, m.free, m.occupied, m.clamp_min, m.clamp_max)  # fmt: skip

    def ros_values(self, occupied_above: float = 0.65, free_below: float = 0.35) -> np.ndarray:
        """int8 cells as a ROS OccupancyGrid carries them: 100 occupied, 0 free, -1 unknown."""
        occ = float(np.float32(np.log(occupied_above / (1 - occupied_above))))
        free = float(np.float32(np.log(free_below / (1 - free_below))))
        out = np.full(self.shape, -1, dtype=np.int8)
        _unpack(self._tiles.index, self._tiles.pool, 0, out, True, occ, free)
        return out

    @property
    def logodds(self) -> np.ndarray:
        """The cells as one dense float32 array (rows = y), unknown 0."""
        return self._tiles.dense(0).logodds

    def probability(self) -> np.ndarray:
        """Occupancy probability of every cell (0.5 where unknown)."""
        return self._tiles.dense(0).probability()

    def copy(self) -> TiledGrid:
        out = TiledGrid.__new__(TiledGrid)
        t = TiledMaps(1, self.resolution, self.model)
        src = self._tiles
        t.origin, t.index, t.pool = src.origin, src.index.copy(), src.pool.copy()
        t.refs, t.free, t.top = src.refs.copy(), src.free.copy(), src.top.copy()
        out._tiles = t
        return out

    @property
    def view(self) -> tuple:
        """The cells as the compiled kernels read and write them (`cells`)."""
        return self._tiles.view(0)
