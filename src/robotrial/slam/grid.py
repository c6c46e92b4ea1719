"""Log-odds occupancy grid with compiled ray tracing, the map every SLAM method builds
(layer 3).

A cell holds the log-odds l = log(p / (1 - p)) that it is occupied; 0 means unknown
(p = 0.5). A beam that hit something lowers by `free` every cell it crosses up to
`hit_margin` cells short of its end point and raises by `occupied` the cell there and
the cell of the end point; a beam that hit nothing lowers every cell up to and including
its end's. Results are clamped to [`clamp_min`, `clamp_max`]. Rows are y and columns x, as in a ROS
OccupancyGrid; the cell (row, col) spans x from origin_x + col * resolution.
The grid grows (by whole cells, keeping its content) when a scan reaches past its edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from robotrial.slam import cells


@dataclass(frozen=True)
class LogOddsModel:
    """How much one observation moves a cell: log-odds added for a free crossing and for
    an end point, the clamp bounds, and how far short of a hit the free trace stops.

    A hit is a surface somewhere within the range noise of the end point, and the map
    shows it as the centres of the cells that hold it. Without the margin a wall whose
    face lies on a cell boundary loses the cell in front of it to the beams whose end
    points fell just behind the face (they cross it), keeps the cell behind (no beam
    crosses it) and moves half a cell outward. With it, the cell up to a margin short
    of the end point is marked too, so a face near a boundary fills the cells on both
    sides and reads at the boundary, one inside a cell reads at that cell's centre.
    A quarter of a cell would halve the worst error of either reading (to a quarter
    cell); a little more makes up for the end points that the range noise carries
    behind a face, which nothing frees."""

    free: float = -0.4
    occupied: float = 0.85
    clamp_min: float = -2.0
    clamp_max: float = 3.5
    # In cells (of whatever resolution the grid has).
    hit_margin: float = 0.35

    def __post_init__(self) -> None:
        if not 0 <= self.hit_margin <= 0.5:
            raise ValueError(
                f"log-odds model: hit_margin must be in [0, 0.5] cells, got {self.hit_margin}"
            )
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


def stop_points(
    sensor_xy: tuple[float, float] | np.ndarray, end_xy: np.ndarray, hit: np.ndarray, margin: float
) -> np.ndarray:
    """Where each beam's free trace ends ((N, 2), the frame of the inputs): `margin`
    metres short of a hit (the surface lies anywhere within the range noise of it, see
    `LogOddsModel.hit_margin`), at the end of a beam that ran out. Computed once a scan:
    it does not depend on the pose the scan is written at."""
    s = np.asarray(sensor_xy, dtype=np.float64).reshape(1, 2)
    d = end_xy - s
    length = np.hypot(d[:, 0], d[:, 1])
    cut = np.where(np.asarray(hit, dtype=bool), np.minimum(margin, length), 0.0)
    f = np.divide(cut, length, out=np.zeros_like(length), where=length > 0)
    return np.ascontiguousarray(end_xy - f[:, None] * d)


@numba.njit(cache=True, nogil=True)
def trace_fan(
    view: np.ndarray | tuple, ox: float, oy: float, res: float, pose: np.ndarray,
    sensor: np.ndarray, ends: np.ndarray, stops: np.ndarray, hit: np.ndarray,
    starts: np.ndarray, l_free: float, l_occ: float, lo: float, hi: float,
) -> None:  # fmt: skip
    """Write a scan into a map (a `cells` view) at `pose`: the laser at `sensor`, beam i
    ending at ends[i] (on something if hit[i]) with its free trace ending at stops[i],
    all in the frame of `pose`, in scan order. Every cell a beam crosses takes `l_free`;
    where it hit, the cell where its trace stopped and the hit's cell take `l_occ`; where
    it ran out, its end cell takes `l_free`; clamped to [lo, hi].

    Beam i has level k = trailing zeros of i (at most K = len(starts) - 1). The beams of
    level > k are at most half a cell apart closer than starts[k] metres, so a beam of
    level k is traced from there on. A cell at d metres takes 2^j frees, j the lowest
    level traced at d: it loses about as much as if every beam of the fan crossed it.
    With starts = [0] every beam is traced from the sensor."""
    c_, s_ = np.cos(pose[2]), np.sin(pose[2])
    sx = pose[0] + c_ * sensor[0] - s_ * sensor[1]
    sy = pose[1] + s_ * sensor[0] + c_ * sensor[1]
    top = starts.shape[0] - 1
    pc, pr, ph, pcr, pcc = -1 << 30, -1 << 30, False, -1 << 30, -1 << 30
    pending = 0
    for i in range(ends.shape[0]):
        ex = pose[0] + c_ * ends[i, 0] - s_ * ends[i, 1]
        ey = pose[1] + s_ * ends[i, 0] + c_ * ends[i, 1]
        fx = pose[0] + c_ * stops[i, 0] - s_ * stops[i, 1]
        fy = pose[1] + s_ * stops[i, 0] + c_ * stops[i, 1]
        level = top
        if i > 0:
            level = 0
            b = i
            while b & 1 == 0 and level < top:
                b >>= 1
                level += 1
        level = max(level, pending)
        c1 = int(np.floor((fx - ox) / res))
        r1 = int(np.floor((fy - oy) / res))
        rh = int(np.floor((ey - oy) / res))
        ch = int(np.floor((ex - ox) / res))
        # A beam whose trace stops in the same cell as the one before it and whose end
        # falls in the same cell (dense scans) adds nothing but the same cells again:
        # skip it, so every cell counts once a beam fan.
        if c1 == pc and r1 == pr and hit[i] == ph and rh == pcr and ch == pcc:
            pending = level
            continue
        pending = 0
        pc, pr, ph, pcr, pcc = c1, r1, hit[i], rh, ch
        length = np.hypot(fx - sx, fy - sy)
        d0 = starts[level]
        if d0 < length:
            f = d0 / length if length > 0 else 0.0
            c = int(np.floor((sx + f * (fx - sx) - ox) / res))
            r = int(np.floor((sy + f * (fy - sy) - oy) / res))
            dc = abs(c1 - c)
            dr = abs(r1 - r)
            step_c = 1 if c1 > c else -1
            step_r = 1 if r1 > r else -1
            err = dc - dr
            # Bresenham takes max(dc, dr) steps, one cell along the major axis each, and
            # ends in the stop's cell, which is handled after the walk.
            steps = max(dc, dr)
            step_len = (length - d0) / max(1, steps)
            m = 0
            j = level
            while m < steps:
                until = steps
                if j > 0:
                    until = min(steps, max(m, int(np.ceil((starts[j - 1] - d0) / step_len))))
                w = l_free * (1 << j)
                # The array holding the walk's tile, looked up once a tile (a walk stays
                # in one for up to TILE cells).
                arr, r0, c0 = cells.block(view, r, c)
                ltr, ltc = r >> cells.SHIFT, c >> cells.SHIFT
                while m < until:
                    if r >> cells.SHIFT != ltr or c >> cells.SHIFT != ltc:
                        arr, r0, c0 = cells.block(view, r, c)
                        ltr, ltc = r >> cells.SHIFT, c >> cells.SHIFT
                    a, b = r - r0, c - c0
                    if 0 <= a < arr.shape[0] and 0 <= b < arr.shape[1]:
                        v = arr[a, b] + w
                        arr[a, b] = lo if v < lo else v
                    e2 = 2 * err
                    if e2 > -dr:
                        err -= dr
                        c += step_c
                    if e2 < dc:
                        err += dc
                        r += step_r
                    m += 1
                if j > 0:
                    j -= 1
        if not hit[i]:
            cells.add(view, r1, c1, l_free, lo, hi)
        else:
            cells.add(view, r1, c1, l_occ, lo, hi)
            if rh != r1 or ch != c1:
                cells.add(view, rh, ch, l_occ, lo, hi)


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


def fan_starts(resolution: float, angle_step: float, levels: int = 8) -> np.ndarray:
    """Where a beam of each thinning level starts to be traced (m): beams 2^(k+1) steps
    apart are half a cell apart at starts[k] (a cell apart, lines of cells drawn by
    Bresenham leave gaps, and the weighted frees of a beam grazing a wall erase it); the
    top level starts at the sensor."""
    k = np.arange(levels, dtype=np.float64)
    out = resolution / (2.0 ** (k + 2) * angle_step)
    out[-1] = 0.0
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

    @property
    def nbytes(self) -> int:
        """The memory of the cells."""
        return self.logodds.nbytes

    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) in metres."""
        rows, cols = self.shape
        x0, y0 = self.origin
        return x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution

    def ensure(self, xmin: float, ymin: float, xmax: float, ymax: float, pad: float = 2.0) -> None:
        """Grow (with `pad` metres to spare, and at least a quarter of the grid's size, so
        that a robot exploring a large site does not copy the grid every few metres) so
        the box lies inside; cell edges stay on multiples of the resolution, so content
        never shifts."""
        x0, y0, x1, y1 = self.extent()
        empty = self.logodds.size == 0
        if not empty and xmin >= x0 and ymin >= y0 and xmax < x1 and ymax < y1:
            return
        if not empty:
            pad = max(pad, 0.25 * max(x1 - x0, y1 - y0))
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
        self,
        sensor_xy: tuple[float, float],
        end_xy: np.ndarray,
        hit: np.ndarray,
        angle_step: float | None = None,
        weight: float = 1.0,
    ) -> None:
        """Trace beams from the sensor to (N, 2) end points in the map frame; `hit[i]`
        says whether beam i ended on something (else only its cells are freed). The
        updates are scaled by `weight`: -1 takes back what the same scan at the same pose
        wrote with 1 (exactly, on a grid whose clamps are never reached).

        With `angle_step` (the angle between neighbouring beams of a fan given in scan
        order), near the sensor, where many beams cross each cell, only a thinned set is
        traced and each crossing frees as much as the beams it stands for: about the
        same map for a fraction of the work (the GMapping filter writes one scan into
        every particle's map)."""
        end_xy = np.ascontiguousarray(end_xy, dtype=np.float64).reshape(-1, 2)
        if end_xy.shape[0] == 0:
            return
        sensor = np.array([float(sensor_xy[0]), float(sensor_xy[1])])
        lo, hi = np.minimum(end_xy.min(axis=0), sensor), np.maximum(end_xy.max(axis=0), sensor)
        self.ensure(lo[0], lo[1], hi[0], hi[1])
        m = self.model
        hit = np.ascontiguousarray(hit, dtype=np.bool_)
        stops = stop_points(sensor, end_xy, hit, m.hit_margin * self.resolution)
        # Without an angle step every beam is traced from the sensor (one level).
        fan = angle_step is not None and angle_step > 0
        starts = fan_starts(self.resolution, angle_step) if fan else np.zeros(1)
        trace_fan(self.logodds, self.origin[0], self.origin[1], self.resolution, np.zeros(3),
                  sensor, end_xy, stops, hit, starts, m.free * weight, m.occupied * weight,
                  m.clamp_min, m.clamp_max)  # fmt: skip

    @property
    def view(self) -> np.ndarray:
        """The cells as the compiled kernels read them (`cells`)."""
        return self.logodds

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
        # On the log-odds directly: no float64 copy of a large map.
        occ = np.float32(np.log(occupied_above / (1 - occupied_above)))
        free = np.float32(np.log(free_below / (1 - free_below)))
        out = np.full(self.shape, -1, dtype=np.int8)
        out[self.logodds >= occ] = 100
        out[self.logodds <= free] = 0
        return out
