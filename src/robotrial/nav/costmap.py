"""Costmaps of the navigation stack: static, obstacle and inflation layers (layer 3).

A `Costmap` is a grid of costs in the costmap_2d convention (0 free .. 252 near an
obstacle, 253 inscribed: the robot's centre there means contact, 254 lethal, 255
unknown) built from three layers:

- the static layer: occupied and unknown cells of a map (map_server or ground truth);
- the obstacle layer: cells marked by scan end points, and cleared along each beam
  (which also makes the unknown cells a beam crosses known free);
- the inflation layer: cost falling with the distance to the nearest lethal cell, 253
  within the footprint's inscribed radius, `252 * exp(-k (d - r_inscribed))` out to the
  inflation radius.

Besides the cost, `distance` holds the metric distance (m) from each cell centre to the
nearest lethal cell; the local planner checks its rectangular footprint against it.
Rows are y and columns x, as in nav_msgs/OccupancyGrid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage

FREE = 0
INSCRIBED = 253
LETHAL = 254
UNKNOWN = 255
MAX_INFLATED = 252


@dataclass(frozen=True)
class Footprint:
    """A rectangular robot footprint centred on the base frame: `length` along x and
    `width` along y (m)."""

    length: float
    width: float

    def __post_init__(self) -> None:
        if not (self.length > 0 and self.width > 0):
            raise ValueError(
                f"footprint: length and width must be positive, got {self.length} x {self.width}"
            )

    @property
    def inscribed_radius(self) -> float:
        return 0.5 * min(self.length, self.width)

    @property
    def circumscribed_radius(self) -> float:
        return 0.5 * float(np.hypot(self.length, self.width))

    def circles(self) -> tuple[np.ndarray, float]:
        """Circles that together cover the rectangle: (k, 2) centres in the base frame
        along its long axis and their common radius (m)."""
        long, short = max(self.length, self.width), min(self.length, self.width)
        # short segments keep the circles' sideways bulge small (1.4 cm for 0.99 x 0.67)
        k = max(1, int(np.ceil(3 * long / short)))
        seg = long / k
        offsets = (np.arange(k) + 0.5) * seg - 0.5 * long
        radius = 0.5 * float(np.hypot(seg, short))
        if self.length >= self.width:
            centres = np.stack([offsets, np.zeros(k)], axis=1)
        else:
            centres = np.stack([np.zeros(k), offsets], axis=1)
        return centres, radius


@dataclass(frozen=True)
class Inflation:
    """The inflation layer's parameters: radius (m) out to which cost spreads, and the
    exponential decay rate (1/m) beyond the inscribed radius."""

    radius: float = 1.0
    cost_scaling: float = 3.0

    def __post_init__(self) -> None:
        if not self.radius >= 0:
            raise ValueError(f"inflation radius must be >= 0, got {self.radius}")
        if not self.cost_scaling > 0:
            raise ValueError(f"inflation cost_scaling must be positive, got {self.cost_scaling}")

    def cost(self, distance: np.ndarray, inscribed_radius: float) -> np.ndarray:
        """Cost (uint8) of cells at `distance` (m) from the nearest lethal cell."""
        d = np.asarray(distance, dtype=float)
        out = np.zeros(d.shape, dtype=np.uint8)
        decay = MAX_INFLATED * np.exp(-self.cost_scaling * (d - inscribed_radius))
        eps = 1e-9  # distances are cell counts times the resolution: 3 * 0.1 > 0.3
        spread = d <= max(self.radius, inscribed_radius) + eps
        out[spread] = np.clip(decay[spread], 0, MAX_INFLATED).astype(np.uint8)
        out[d <= inscribed_radius + eps] = INSCRIBED
        out[d <= 0] = LETHAL
        return out


def coarsen(
    occupied: np.ndarray, unknown: np.ndarray | None, resolution: float, target: float
) -> tuple[np.ndarray, np.ndarray | None, float]:
    """A map at least twice as fine as `target` (m) in cells of about `target`: a cell is
    occupied where any of its map cells is, unknown where all are. The corner stays."""
    k = round(target / resolution)
    if k < 2:
        return occupied, unknown, resolution
    rows, cols = occupied.shape
    pad = ((0, -rows % k), (0, -cols % k))

    def blocks(a: np.ndarray, fill: bool) -> np.ndarray:
        a = np.pad(np.asarray(a, dtype=bool), pad, constant_values=fill)
        return a.reshape(a.shape[0] // k, k, a.shape[1] // k, k)

    occ = blocks(occupied, False).any(axis=(1, 3))
    unk = None if unknown is None else blocks(unknown, True).all(axis=(1, 3)) & ~occ
    return occ, unk, resolution * k


class Costmap:
    """A layered costmap over a fixed grid: `origin` (x, y of the corner of cell (0, 0)),
    `resolution` (m per cell). Call `update()` after changing layers; `cost` and
    `distance` are then current."""

    def __init__(
        self,
        occupied: np.ndarray,
        origin: tuple[float, float],
        resolution: float,
        footprint: Footprint,
        inflation: Inflation = Inflation(),
        unknown: np.ndarray | None = None,
        marks: np.ndarray | None = None,
    ) -> None:
        occ = np.asarray(occupied, dtype=bool)
        if occ.ndim != 2 or occ.size == 0:
            raise ValueError(
                f"costmap: the static map must be a non-empty 2D grid, got {occ.shape}"
            )
        if not resolution > 0:
            raise ValueError(f"costmap: resolution must be positive, got {resolution}")
        self.static = occ
        self.unknown = (
            np.zeros_like(occ) if unknown is None else np.asarray(unknown, dtype=bool) & ~occ
        )
        if self.unknown.shape != occ.shape:
            raise ValueError(
                f"costmap: unknown mask {self.unknown.shape} differs from the map {occ.shape}"
            )
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        self.footprint = footprint
        self.inflation = inflation
        self.obstacles = np.zeros_like(occ)
        self.cost = np.zeros(occ.shape, dtype=np.uint8)
        self.distance = np.zeros(occ.shape)
        if marks is not None:
            self.mark(marks)
        self.update()

    @property
    def shape(self) -> tuple[int, int]:
        return self.static.shape

    @property
    def lethal(self) -> np.ndarray:
        return self.static | self.obstacles

    def update(self) -> None:
        """Recompute distance and cost from the static and obstacle layers."""
        lethal = self.lethal
        if lethal.any():
            self.distance = ndimage.distance_transform_edt(~lethal) * self.resolution
        else:
            self.distance = np.full(lethal.shape, np.inf)
        self.cost = self.inflation.cost(self.distance, self.footprint.inscribed_radius)
        self.cost[self.unknown & (self.cost < INSCRIBED)] = UNKNOWN

    # --- coordinates -------------------------------------------------------------------

    def world_to_cell(self, xy: np.ndarray) -> np.ndarray:
        """(…, 2) world x, y to (…, 2) integer (row, col); may fall outside the grid."""
        p = np.asarray(xy, dtype=float)
        col = np.floor((p[..., 0] - self.origin[0]) / self.resolution).astype(np.int64)
        row = np.floor((p[..., 1] - self.origin[1]) / self.resolution).astype(np.int64)
        return np.stack([row, col], axis=-1)

    def cell_to_world(self, rc: np.ndarray) -> np.ndarray:
        """(…, 2) (row, col) to (…, 2) world x, y of the cell centres."""
        c = np.asarray(rc, dtype=float)
        x = self.origin[0] + (c[..., 1] + 0.5) * self.resolution
        y = self.origin[1] + (c[..., 0] + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    def inside(self, rc: np.ndarray) -> np.ndarray:
        rc = np.asarray(rc)
        return (
            (rc[..., 0] >= 0)
            & (rc[..., 0] < self.shape[0])
            & (rc[..., 1] >= 0)
            & (rc[..., 1] < self.shape[1])
        )

    def distance_at(self, xy: np.ndarray) -> np.ndarray:
        """Distance (m) to the nearest lethal cell at world points; outside the grid:
        infinite (nothing is known to be there)."""
        rc = self.world_to_cell(xy)
        ok = self.inside(rc)
        out = np.full(rc.shape[:-1], np.inf)
        out[ok] = self.distance[rc[ok, 0], rc[ok, 1]]
        return out

    def cost_at(self, xy: np.ndarray) -> np.ndarray:
        """Cost at world points; outside the grid: FREE."""
        rc = self.world_to_cell(xy)
        ok = self.inside(rc)
        out = np.zeros(rc.shape[:-1], dtype=np.uint8)
        out[ok] = self.cost[rc[ok, 0], rc[ok, 1]]
        return out

    # --- the obstacle layer ------------------------------------------------------------

    def mark_and_clear(
        self,
        sensor_xy: tuple[float, float],
        points_xy: np.ndarray,
        mark_range: float = 3.0,
        clear_range: float = 5.0,
        free_rays: np.ndarray | None = None,
    ) -> None:
        """Obstacle layer: clear the cells each beam crosses (up to `clear_range`), then
        mark the end points within `mark_range` of the sensor. `free_rays` are end points
        of beams that saw nothing (they only clear). Unknown cells of the map that a beam
        crosses become known free (a SLAM map's shadows behind furniture, once seen)."""
        s = np.asarray(sensor_xy, dtype=float)
        pts = np.asarray(points_xy, dtype=float).reshape(-1, 2)
        rays = pts if free_rays is None else np.vstack([pts, np.asarray(free_rays).reshape(-1, 2)])
        if len(rays):
            d = rays - s
            n = np.hypot(d[:, 0], d[:, 1])
            far = n > clear_range
            ends = rays.copy()
            ends[far] = s + d[far] * (clear_range / n[far])[:, None]
            src = self.world_to_cell(s)
            dst = self.world_to_cell(ends)
            _clear_rays(self.obstacles, int(src[0]), int(src[1]), dst)
            if self.unknown.any():
                _clear_rays(self.unknown, int(src[0]), int(src[1]), dst)
        if len(pts):
            near = np.hypot(*(pts - s).T) <= mark_range
            rc = self.world_to_cell(pts[near])
            rc = rc[self.inside(rc)]
            self.obstacles[rc[:, 0], rc[:, 1]] = True

    def mark(self, points_xy: np.ndarray) -> None:
        """Mark cells at world points as obstacles (no clearing)."""
        rc = self.world_to_cell(np.asarray(points_xy, dtype=float).reshape(-1, 2))
        rc = rc[self.inside(rc)]
        self.obstacles[rc[:, 0], rc[:, 1]] = True

    def clear_obstacles(self) -> None:
        """Forget everything the obstacle layer has marked (a 'clear costmaps' recovery)."""
        self.obstacles[:] = False

    # --- windows -----------------------------------------------------------------------

    def window(
        self, center: tuple[float, float], size: float, marks: np.ndarray | None = None
    ) -> Costmap:
        """A rolling local costmap: a `size` x `size` m window of this map's static layer
        centred on `center`, its obstacle layer holding the world points `marks` (none by
        default; cells outside this map: free)."""
        n = max(3, int(np.ceil(size / self.resolution)))
        c = self.world_to_cell(np.asarray(center, dtype=float))
        r0, c0 = int(c[0]) - n // 2, int(c[1]) - n // 2
        occ = np.zeros((n, n), dtype=bool)
        unk = np.zeros((n, n), dtype=bool)
        rs, cs = max(r0, 0), max(c0, 0)
        re, ce = min(r0 + n, self.shape[0]), min(c0 + n, self.shape[1])
        if rs < re and cs < ce:
            occ[rs - r0 : re - r0, cs - c0 : ce - c0] = self.static[rs:re, cs:ce]
            unk[rs - r0 : re - r0, cs - c0 : ce - c0] = self.unknown[rs:re, cs:ce]
        origin = (
            self.origin[0] + c0 * self.resolution,
            self.origin[1] + r0 * self.resolution,
        )
        return Costmap(occ, origin, self.resolution, self.footprint, self.inflation, unk, marks)


@numba.njit(cache=True)
def _clear_rays(grid: np.ndarray, r0: int, c0: int, ends: np.ndarray) -> None:
    """Bresenham from (r0, c0) to each end cell, clearing every cell before the end."""
    rows, cols = grid.shape
    for i in range(ends.shape[0]):
        r1, c1 = ends[i, 0], ends[i, 1]
        dr, dc = abs(r1 - r0), abs(c1 - c0)
        sr = 1 if r1 > r0 else -1
        sc = 1 if c1 > c0 else -1
        err = dc - dr
        r, c = r0, c0
        while r != r1 or c != c1:
            if 0 <= r < rows and 0 <= c < cols:
                grid[r, c] = False
            e2 = 2 * err
            if e2 > -dr:
                err -= dr
                c += sc
            if e2 < dc:
                err += dc
                r += sr
