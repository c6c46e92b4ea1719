"""Log-odds occupancy grid with compiled ray tracing, the map every SLAM method builds
(layer 3).

A cell holds the log-odds l = log(p / (1 - p)) that it is occupied; 0 means unknown
(p = 0.5). A beam from the sensor to its end point lowers every cell it crosses by
`free` and raises the cell it ends in by `occupied` (unless the beam hit nothing), with
the result clamped to [`clamp_min`, `clamp_max`]. Rows are y and columns x, as in a ROS
OccupancyGrid; the cell (row, col) spans x from origin_x + col * resolution.
The grid grows (by whole cells, keeping its content) when a scan reaches past its edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class LogOddsModel:
    """How much one observation moves a cell: log-odds added for a free crossing and for
    an end point, and the clamp bounds."""

    free: float = -0.4
    occupied: float = 0.85
    clamp_min: float = -2.0
    clamp_max: float = 3.5

    def __post_init__(self) -> None:
        if not (self.free < 0 < self.occupied):
            raise ValueError(
                f"log-odds model: need free < 0 < occupied, got {self.free}, {self.occupied}"
            )
        if not self.clamp_min < 0 < self.clamp_max:
            raise ValueError("log-odds model: need clamp_min < 0 < clamp_max")

    @staticmethod
    def from_probabilities(p_free: float, p_occupied: float) -> LogOddsModel:
        """From per-observation probabilities (Hector's update_factor_free/occupied)."""
        for name, p in (("free", p_free), ("occupied", p_occupied)):
            if not 0 < p < 1:
                raise ValueError(f"log-odds model: p_{name} must be in (0, 1), got {p}")
        return LogOddsModel(
            free=float(np.log(p_free / (1 - p_free))),
            occupied=float(np.log(p_occupied / (1 - p_occupied))),
        )


@numba.njit(cache=True, nogil=True)
def _trace(
    grid: np.ndarray,
    ox: float,
    oy: float,
    res: float,
    sx: float,
    sy: float,
    ex: np.ndarray,
    ey: np.ndarray,
    hit: np.ndarray,
    l_free: float,
    l_occ: float,
    lo: float,
    hi: float,
) -> None:
    rows, cols = grid.shape
    c0 = int(np.floor((sx - ox) / res))
    r0 = int(np.floor((sy - oy) / res))
    pc, pr, ph = -1 << 30, -1 << 30, False
    for i in range(ex.shape[0]):
        c1 = int(np.floor((ex[i] - ox) / res))
        r1 = int(np.floor((ey[i] - oy) / res))
        # A beam ending in the same cell as the one before it (dense scans) adds nothing
        # but the same free cells again: skip it, so every cell counts once a beam fan.
        if c1 == pc and r1 == pr and hit[i] == ph:
            continue
        pc, pr, ph = c1, r1, hit[i]
        dc = abs(c1 - c0)
        dr = abs(r1 - r0)
        step_c = 1 if c1 > c0 else -1
        step_r = 1 if r1 > r0 else -1
        err = dc - dr
        c, r = c0, r0
        # Bresenham from the sensor cell; the end cell is handled after the loop.
        while c != c1 or r != r1:
            if 0 <= r < rows and 0 <= c < cols:
                v = grid[r, c] + l_free
                grid[r, c] = lo if v < lo else v
            e2 = 2 * err
            if e2 > -dr:
                err -= dr
                c += step_c
            if e2 < dc:
                err += dc
                r += step_r
        if 0 <= r1 < rows and 0 <= c1 < cols:
            if hit[i]:
                v = grid[r1, c1] + l_occ
                grid[r1, c1] = hi if v > hi else v
            else:
                v = grid[r1, c1] + l_free
                grid[r1, c1] = lo if v < lo else v


@numba.njit(cache=True, nogil=True)
def _halve(src: np.ndarray) -> np.ndarray:
    # Each 2x2 block keeps its most occupied cell (cells outside the grid are unknown,
    # 0): a wall one fine cell thick stays a wall at every level, as in hector_mapping's
    # maps updated at each resolution, instead of fading into the free and unknown
    # cells around it.
    rows, cols = src.shape
    out = np.empty(((rows + 1) // 2, (cols + 1) // 2), dtype=np.float32)
    for r in range(out.shape[0]):
        for c in range(out.shape[1]):
            best = -1e30
            for i in range(2):
                for j in range(2):
                    rr, cc = 2 * r + i, 2 * c + j
                    v = src[rr, cc] if rr < rows and cc < cols else 0.0
                    if v > best:
                        best = v
            out[r, c] = best
    return out


class LogOddsGrid:
    """A growable log-odds occupancy grid (float32), in a map frame."""

    def __init__(
        self,
        resolution: float,
        origin: tuple[float, float] = (0.0, 0.0),
        shape: tuple[int, int] = (0, 0),
        model: LogOddsModel | None = None,
    ) -> None:
        if not resolution > 0:
            raise ValueError(f"grid resolution must be positive, got {resolution}")
        self.resolution = float(resolution)
        self.origin = (float(origin[0]), float(origin[1]))
        self.logodds = np.zeros(shape, dtype=np.float32)
        self.model = model or LogOddsModel()

    def copy(self) -> LogOddsGrid:
        g = LogOddsGrid.__new__(LogOddsGrid)
        g.resolution, g.origin, g.model = self.resolution, self.origin, self.model
        g.logodds = self.logodds.copy()
        return g

    @property
    def shape(self) -> tuple[int, int]:
        return self.logodds.shape  # type: ignore[return-value]

    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) in metres."""
        rows, cols = self.shape
        x0, y0 = self.origin
        return x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution

    def ensure(self, xmin: float, ymin: float, xmax: float, ymax: float, pad: float = 2.0) -> None:
        """Grow (with `pad` metres to spare) so the box lies inside; cell edges stay on
        multiples of the resolution, so content never shifts."""
        x0, y0, x1, y1 = self.extent()
        empty = self.logodds.size == 0
        if not empty and xmin >= x0 and ymin >= y0 and xmax < x1 and ymax < y1:
            return
        r = self.resolution
        nx0 = min(xmin - pad, x0) if not empty else xmin - pad
        ny0 = min(ymin - pad, y0) if not empty else ymin - pad
        nx1 = max(xmax + pad, x1) if not empty else xmax + pad
        ny1 = max(ymax + pad, y1) if not empty else ymax + pad
        c0 = int(np.floor(nx0 / r))
        r0 = int(np.floor(ny0 / r))
        cols = int(np.ceil(nx1 / r)) - c0
        rows = int(np.ceil(ny1 / r)) - r0
        grown = np.zeros((rows, cols), dtype=np.float32)
        if not empty:
            oc = round((x0 - c0 * r) / r)
            orow = round((y0 - r0 * r) / r)
            h, w = self.shape
            grown[orow : orow + h, oc : oc + w] = self.logodds
        self.logodds = grown
        self.origin = (c0 * r, r0 * r)

    def integrate(
        self, sensor_xy: tuple[float, float], end_xy: np.ndarray, hit: np.ndarray
    ) -> None:
        """Trace beams from the sensor to (N, 2) end points in the map frame; `hit[i]`
        says whether beam i ended on something (else only its cells are freed)."""
        end_xy = np.asarray(end_xy, dtype=np.float64).reshape(-1, 2)
        if end_xy.shape[0] == 0:
            return
        sx, sy = float(sensor_xy[0]), float(sensor_xy[1])
        self.ensure(
            min(sx, float(end_xy[:, 0].min())),
            min(sy, float(end_xy[:, 1].min())),
            max(sx, float(end_xy[:, 0].max())),
            max(sy, float(end_xy[:, 1].max())),
        )
        m = self.model
        _trace(
            self.logodds,
            self.origin[0],
            self.origin[1],
            self.resolution,
            sx,
            sy,
            np.ascontiguousarray(end_xy[:, 0]),
            np.ascontiguousarray(end_xy[:, 1]),
            np.asarray(hit, dtype=np.bool_),
            m.free,
            m.occupied,
            m.clamp_min,
            m.clamp_max,
        )

    def pyramid(self, levels: int) -> list[np.ndarray]:
        """The grid and `levels - 1` coarser views of it: level k has cells 2^k times
        larger, each holding the highest log-odds of the cells it covers (same origin)."""
        out = [self.logodds]
        for _ in range(1, levels):
            out.append(_halve(out[-1]))
        return out

    def probability(self) -> np.ndarray:
        """Occupancy probability of every cell (0.5 where unknown)."""
        return 1.0 - 1.0 / (1.0 + np.exp(self.logodds.astype(np.float64)))

    def ros_values(self, occupied_above: float = 0.65, free_below: float = 0.35) -> np.ndarray:
        """int8 cells as a ROS OccupancyGrid carries them: 100 occupied, 0 free, -1 unknown
        (never observed, or between the thresholds)."""
        p = self.probability()
        out = np.full(self.shape, -1, dtype=np.int8)
        out[p >= occupied_above] = 100
        out[p <= free_below] = 0
        return out
