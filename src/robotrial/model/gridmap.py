"""The ground-truth occupancy grid of a World, for scoring maps and planning on known rooms.

`NavMap` is the grid navigation plans on: a world's ground truth (`world_map`) or a
map_server file (`file_map`, e.g. one `robotrial slam` saved).

Layer 1: imports `robotrial.geometry` and `robotrial.model`. Every wall, obstacle and
(optionally) movable object is cut by a height band (the slab a 2D LiDAR scan or a
costmap cares about) and its cross-section, projected onto the floor, is rasterized:
boxes, tilted cylinders and meshes as convex polygons, upright cylinders and spheres as
exact circles. Any orientation is allowed. Meshes count as their convex hull.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from robotrial.geometry import Box, Cylinder, Mesh, Sphere
from robotrial.model.robot import ModelError
from robotrial.model.world import Obstacle, World

MAX_CELLS = 50_000_000
_EPS = 1e-9
_PRISM_SIDES = 32


class GroundTruthGrid(NamedTuple):
    """`occupied[row, col]` is True where something stands; row = y, col = x (as a ROS
    OccupancyGrid). Cell (col, row) spans x from origin[0] + col * resolution, y likewise."""

    occupied: np.ndarray
    origin: tuple[float, float]
    resolution: float

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """The (row, col) of the cell holding world point (x, y); may lie outside the grid."""
        col = int(np.floor((x - self.origin[0]) / self.resolution))
        row = int(np.floor((y - self.origin[1]) / self.resolution))
        return row, col

    def cell_centers(self) -> tuple[np.ndarray, np.ndarray]:
        """World x and y of every cell centre, each shaped like `occupied`."""
        rows, cols = self.occupied.shape
        xs = self.origin[0] + (np.arange(cols) + 0.5) * self.resolution
        ys = self.origin[1] + (np.arange(rows) + 0.5) * self.resolution
        return np.meshgrid(xs, ys)


class _Circle(NamedTuple):
    cx: float
    cy: float
    r: float


def world_occupancy(
    world: World,
    resolution: float = 0.05,
    z_band: tuple[float, float] = (0.05, 2.0),
    margin: float = 0.5,
    *,
    bounds: tuple[tuple[float, float], tuple[float, float]] | None = None,
    include_objects: bool = True,
    conservative: bool = True,
) -> GroundTruthGrid:
    """Rasterize what stands in the world between heights z_band[0] and z_band[1] (m).

    The grid covers the interior and every body found in the band, plus `margin` (m) on
    each side, unless `bounds` ((xmin, ymin), (xmax, ymax)) is given. With
    `conservative`, a cell is occupied if the cross-section overlaps it at all (thin
    walls never leak); otherwise only if the cell's centre lies inside.
    """
    if not resolution > 0:
        raise ModelError(f"world_occupancy: resolution must be positive, got {resolution}")
    z_lo, z_hi = (float(v) for v in z_band)
    if not z_hi > z_lo:
        raise ModelError(
            f"world_occupancy: z_band must be (low, high) with low < high, got {z_band}"
        )
    if margin < 0:
        raise ModelError(f"world_occupancy: margin must be >= 0, got {margin}")
    bodies = world.static_bodies + (world.objects if include_objects else ())
    outlines = []
    for body in bodies:
        try:
            outline = _cross_section(body, z_lo, z_hi)
        except ModelError as exc:
            raise ModelError(f"world {world.name!r}, body {body.name!r}: {exc}") from None
        if outline is not None:
            outlines.append(outline)

    lo, hi = _extent(world, outlines, bounds, margin)
    origin = (
        round(float(np.floor(lo[0] / resolution) * resolution), 9),
        round(float(np.floor(lo[1] / resolution) * resolution), 9),
    )
    cols = int(np.ceil((hi[0] - origin[0]) / resolution - _EPS))
    rows = int(np.ceil((hi[1] - origin[1]) / resolution - _EPS))
    if rows * cols > MAX_CELLS:
        raise ModelError(
            f"world {world.name!r}: a {cols} x {rows} grid at {resolution} m is too large; "
            "use a coarser resolution or smaller bounds"
        )
    grid = GroundTruthGrid(np.zeros((max(rows, 1), max(cols, 1)), dtype=bool), origin, resolution)
    half = resolution / 2 if conservative else 0.0
    for outline in outlines:
        _rasterize(grid, outline, half)
    return grid


def _extent(world, outlines, bounds, margin) -> tuple[np.ndarray, np.ndarray]:
    if bounds is not None:
        lo, hi = np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float)
        if lo.shape != (2,) or hi.shape != (2,) or not np.all(hi > lo):
            raise ModelError(
                f"world_occupancy: bounds must be ((xmin, ymin), (xmax, ymax)), got {bounds}"
            )
        return lo, hi
    boxes = [_outline_bounds(o) for o in outlines]
    if world.interior is not None:
        boxes.append((np.asarray(world.interior[0]), np.asarray(world.interior[1])))
    if not boxes:
        c, s = np.asarray(world.floor.center), np.asarray(world.floor.size)
        boxes.append((c - s / 2, c + s / 2))
    lo = np.min([b[0] for b in boxes], axis=0) - margin
    hi = np.max([b[1] for b in boxes], axis=0) + margin
    return lo, hi


def _outline_bounds(outline: _Circle | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(outline, _Circle):
        c = np.array([outline.cx, outline.cy])
        return c - outline.r, c + outline.r
    return outline.min(axis=0), outline.max(axis=0)


# --- cross-sections --------------------------------------------------------------------


def _cross_section(body: Obstacle, z_lo: float, z_hi: float) -> _Circle | np.ndarray | None:
    """The body's footprint inside the band: a circle, a convex polygon (K, 2) or None."""
    shape, m = body.geometry, body.pose.matrix()
    centre = m[:3, 3]
    if isinstance(shape, Sphere):
        dz = max(z_lo - centre[2], centre[2] - z_hi, 0.0)
        if dz >= shape.radius:
            return None
        return _Circle(centre[0], centre[1], float(np.sqrt(shape.radius**2 - dz**2)))
    if isinstance(shape, Cylinder) and abs(m[2, 2]) > 1 - 1e-9:
        half = shape.length / 2
        if centre[2] + half <= z_lo or centre[2] - half >= z_hi:
            return None
        return _Circle(centre[0], centre[1], float(shape.radius))
    corners = _local_vertices(shape) @ m[:3, :3].T + centre
    return _band_polygon(corners, z_lo, z_hi)


def _local_vertices(shape) -> np.ndarray:
    """Points whose convex hull is the shape (a tilted cylinder: a circumscribed prism)."""
    if isinstance(shape, Box):
        half = np.asarray(shape.size) / 2
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        return signs * half
    if isinstance(shape, Cylinder):
        a = np.linspace(0, 2 * np.pi, _PRISM_SIDES, endpoint=False)
        r = shape.radius / np.cos(np.pi / _PRISM_SIDES)
        ring = np.stack([r * np.cos(a), r * np.sin(a)], axis=1)
        h = shape.length / 2
        return np.vstack([np.c_[ring, np.full(len(a), -h)], np.c_[ring, np.full(len(a), h)]])
    if isinstance(shape, Mesh):
        from robotrial.model.meshes import load_mesh

        return load_mesh(shape).vertices
    raise ModelError(f"cannot rasterize a {type(shape).__name__}")


def _band_polygon(points: np.ndarray, z_lo: float, z_hi: float) -> np.ndarray | None:
    """Floor projection of (convex hull of `points`) cut to z_lo <= z <= z_hi.

    The cut's vertices are the points inside the band and the crossings of the band's
    planes by segments between points; using every pair of points (not only hull edges)
    adds crossings inside the solid only, which the 2D hull then discards.
    """
    z = points[:, 2]
    if z.max() <= z_lo or z.min() >= z_hi:
        return None
    kept = [points[(z >= z_lo) & (z <= z_hi), :2]]
    i, j = np.triu_indices(len(points), k=1)
    a, b = points[i], points[j]
    for plane in (z_lo, z_hi):
        da, db = a[:, 2] - plane, b[:, 2] - plane
        cross = da * db < 0
        t = da[cross] / (da[cross] - db[cross])
        kept.append(a[cross, :2] + t[:, None] * (b[cross, :2] - a[cross, :2]))
    return _convex_hull(np.vstack(kept))


def _convex_hull(p: np.ndarray) -> np.ndarray:
    """Andrew's monotone chain: hull vertices counter-clockwise (a segment or a point when
    the points are collinear)."""
    p = np.unique(np.round(p, 12), axis=0)
    if len(p) <= 2:
        return p

    def half(points: np.ndarray) -> list[np.ndarray]:
        out: list[np.ndarray] = []
        for q in points:
            while len(out) >= 2:
                (ox, oy), (ax, ay) = out[-2], out[-1]
                if (ax - ox) * (q[1] - oy) - (ay - oy) * (q[0] - ox) > 1e-15:
                    break
                out.pop()
            out.append(q)
        return out

    lower, upper = half(p), half(p[::-1])
    return np.array(lower[:-1] + upper[:-1])


# --- rasterization ---------------------------------------------------------------------


def _rasterize(grid: GroundTruthGrid, outline: _Circle | np.ndarray, half: float) -> None:
    """Mark the cells the outline overlaps (`half` = half a cell) or whose centre it
    holds (`half` = 0)."""
    res, (ox, oy) = grid.resolution, grid.origin
    rows, cols = grid.occupied.shape
    lo, hi = _outline_bounds(outline)
    c0 = max(int(np.floor((lo[0] - ox) / res)) - 1, 0)
    c1 = min(int(np.ceil((hi[0] - ox) / res)) + 1, cols)
    r0 = max(int(np.floor((lo[1] - oy) / res)) - 1, 0)
    r1 = min(int(np.ceil((hi[1] - oy) / res)) + 1, rows)
    if c0 >= c1 or r0 >= r1:
        return
    xs = ox + (np.arange(c0, c1) + 0.5) * res
    ys = oy + (np.arange(r0, r1) + 0.5) * res
    x, y = np.meshgrid(xs, ys)
    if isinstance(outline, _Circle):
        dx = np.maximum(np.abs(x - outline.cx) - half, 0.0)
        dy = np.maximum(np.abs(y - outline.cy) - half, 0.0)
        hit = dx**2 + dy**2 < outline.r**2 - _EPS
    else:
        hit = (x + half > lo[0] + _EPS) & (x - half < hi[0] - _EPS)
        hit &= (y + half > lo[1] + _EPS) & (y - half < hi[1] - _EPS)
        for n in _edge_normals(outline):
            proj = outline @ n
            pc = x * n[0] + y * n[1]
            w = half * (abs(n[0]) + abs(n[1]))
            hit &= (pc + w > proj.min() + _EPS) & (pc - w < proj.max() - _EPS)
    grid.occupied[r0:r1, c0:c1] |= hit


def _edge_normals(polygon: np.ndarray) -> np.ndarray:
    """Unit normals of the polygon's edges (for a segment: its one normal)."""
    if len(polygon) < 2:
        return np.zeros((0, 2))
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
    lengths = np.linalg.norm(normals, axis=1)
    keep = lengths > 1e-12
    return normals[keep] / lengths[keep, None]


@dataclass(frozen=True)
class NavMap:
    """The map the robot navigates and localizes on: occupied and unknown cells (rows =
    y), the origin (x, y) of cell (0, 0)'s corner and the resolution (m); where known,
    the map frame's pose (x, y, yaw) in the world (a world's own grid: the world frame
    itself; a map file: what its YAML says, see `robotrial.model.mapfile`)."""

    occupied: np.ndarray
    unknown: np.ndarray
    origin: tuple[float, float]
    resolution: float
    source: str
    frame_in_world: tuple[float, float, float] | None = None

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) of the map in its frame (m), as matplotlib's
        `imshow(extent=...)` takes it."""
        rows, cols = self.occupied.shape
        x0, y0 = self.origin
        return (x0, x0 + cols * self.resolution, y0, y0 + rows * self.resolution)


def world_map(world: World, resolution: float = 0.05) -> NavMap:
    """The ground-truth grid of a world, cut at the scan's height band."""
    g = world_occupancy(world, resolution, z_band=(0.05, 1.5))
    return NavMap(
        g.occupied,
        np.zeros_like(g.occupied),
        g.origin,
        g.resolution,
        "ground truth",
        (0.0, 0.0, 0.0),
    )


def file_map(path: str | Path) -> NavMap:
    """A map_server map (PGM + YAML), e.g. one saved by `robotrial slam`."""
    from robotrial.model.mapfile import read_map

    m = read_map(path)
    if abs(m.origin[2]) > 1e-9:
        raise ValueError(f"map {path}: a rotated origin (yaw {m.origin[2]}) is not supported")
    data = np.asarray(m.data)
    return NavMap(
        data >= 65,
        data < 0,
        (m.origin[0], m.origin[1]),
        m.resolution,
        str(path),
        m.frame_in_world,
    )
