"""Objects on surfaces from an RGB-D point cloud (layer 4; plain arrays in and out).

The classic tabletop pipeline: support surfaces first, then what stands on them.

1. Surfaces: with gravity known (points in the base frame, z up), a support surface is a
   horizontal plane. Heights of the points are binned; a bin that holds many more
   points than its neighbourhood is a plane's height; its points are split into
   connected patches on a grid (the table top, the bed, the floor), and each patch gets
   a least-squares plane fit z = a x + b y + c (its tilt and spread say whether it is
   one).
2. Objects: the points a few millimetres to 45 cm above a patch, inside the patch's
   outline (its convex hull and its cells grown by 6 cm: where objects hide the surface
   from the camera, even up to its far edge, is still the surface), clustered by 3D grid
   connectivity. A cluster must reach down to its surface (it stands on it).
3. Classification against the catalogue by size (height, width across the view, a box's
   sides from its top face) and colour (chromaticity: the share of red, green and blue,
   which shading scales alike); of the kinds within tolerance the best, its height
   counted twice (measured more closely than a top face's sides), else unknown ("").
4. Pose: a cylinder's axis by a circle of the catalogue's radius fitted to the points of
   its side (the half that faces the camera; the middle of the top face, seen from
   above, would lean 5-6 mm toward the camera: the side's rim joins it); a box's centre
   and yaw from its top face; a sphere's centre by a fit of its radius; the height from
   the surface and the catalogue's size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull, Delaunay

from robotrial.onboard.catalogue import Catalogue, ObjectKind

HEIGHT_BIN = 0.01  # m, the histogram of point heights
SURFACE_BAND = 0.015  # m, a surface's points lie this close to its height
SURFACE_CELL = 0.02  # m, the grid that splits a plane's points into patches
MIN_SURFACE_AREA = 0.03  # m^2, smaller patches are not surfaces
MAX_TILT = np.deg2rad(5.0)  # a support surface is level within this
ABOVE = (0.006, 0.45)  # m, heights above a surface where objects are looked for
OUTLINE_MARGIN = 0.06  # m, a surface's outline grows by this before holes are filled
OBJECT_CELL = 0.012  # m, the clustering grid
MIN_OBJECT_POINTS = 20
STANDS_ON = 0.03  # m, a cluster's lowest point is at most this above its surface
TOP_BAND = 0.006  # m, points this close to a cluster's top are its top face
SIDE_BELOW_TOP = 0.01  # m: a cylinder's side points start this far below its top...
SIDE_ABOVE_SURFACE = 0.01  # m: ...and end this far above its surface
MIN_SIDE_POINTS = 20  # fewer, and the top face's middle stands for the axis
SIZE_TOLERANCE = (0.1, 0.012)  # relative and absolute (m): a size within either matches
# Of the kinds within tolerance, the best is chosen with the height's error counted this
# many times: the height (two level planes, the surface's and the top face's) comes out
# within 4 mm from any side, a top face's sides seen at a slant up to 1 cm off, so a
# 6 cm cube may show a 7 cm cube's top but never its height
HEIGHT_WEIGHT = 2.0
COLOUR_TOLERANCE = 0.09  # chromaticity distance that still matches
BLUR_PIXELS = 2.5  # pixels a size may be off where the object is (edges, noise)
# a top face whose second moments differ less than this way to that is square-ish: its
# sides' direction comes from its fourth moments (`_face_yaw`)
SQUARE = 1.5
MIN_SLANT = 0.1  # sine of the flattest view of a top face whose sides are still measured


@dataclass(frozen=True)
class Surface:
    """A level patch: `height` (m) at its `centre` (x, y), the plane's `normal`, its
    outline on a grid (`origin` of cell (0, 0), `cells` True where it supports things),
    the number of points and the fit's rms residual (m)."""

    height: float
    centre: tuple[float, float]
    normal: tuple[float, float, float]
    origin: tuple[float, float]
    cells: np.ndarray
    points: int
    residual: float

    @property
    def area(self) -> float:
        return float(self.cells.sum()) * SURFACE_CELL**2

    def covers(self, xy: np.ndarray) -> np.ndarray:
        """(N,) True where points (N, 2) lie inside the outline."""
        ij = np.floor((np.asarray(xy) - self.origin) / SURFACE_CELL).astype(int)
        rows, cols = self.cells.shape
        ok = (ij[:, 0] >= 0) & (ij[:, 0] < rows) & (ij[:, 1] >= 0) & (ij[:, 1] < cols)
        out = np.zeros(len(ij), dtype=bool)
        out[ok] = self.cells[ij[ok, 0], ij[ok, 1]]
        return out

    def height_at(self, xy: np.ndarray) -> np.ndarray:
        """The plane's height (m) under points (N, 2)."""
        nx, ny, nz = self.normal
        d = np.asarray(xy) - np.asarray(self.centre)
        return self.height - (nx * d[:, 0] + ny * d[:, 1]) / nz


@dataclass(frozen=True)
class Detection:
    """One object seen: its kind ("" when no kind of the catalogue fits), its centre
    (m) and yaw (rad; a box's: a side's direction) in the points' frame, what was
    measured (height, width across the view, mean colour), how many points it had, the
    height of the surface it stands on, and `error`: how far its size and colour were
    from the kind's (0 a perfect match, 1 the tolerance)."""

    kind: str
    position: tuple[float, float, float]
    yaw: float
    height: float
    width: float
    rgb: tuple[float, float, float]
    points: int
    surface: float
    error: float


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """Colour as shares of red, green and blue (sums to 1; shading scales all alike)."""
    c = np.asarray(rgb, dtype=float)
    return c / max(float(c.sum()), 1e-9)


class ObjectDetector:
    """Finds the surfaces in a point cloud and classifies what stands on them."""

    def __init__(self, catalogue: Catalogue) -> None:
        self.catalogue = catalogue

    # --- surfaces ----------------------------------------------------------------------

    def surfaces(self, points: np.ndarray) -> list[Surface]:
        """Level patches in `points` (N, 3; z up), largest first."""
        z = points[:, 2]
        lo, hi = float(np.min(z, initial=0.0)) - HEIGHT_BIN, float(np.max(z, initial=0.0))
        edges = np.arange(lo, hi + 2 * HEIGHT_BIN, HEIGHT_BIN)
        if len(edges) < 3:
            return []
        counts, _ = np.histogram(z, edges)
        around = ndimage.median_filter(counts.astype(float), size=21, mode="constant")
        peaks = [
            i
            for i in range(len(counts))
            if counts[i] >= max(80, 4 * around[i])
            and counts[i] == counts[max(0, i - 2) : i + 3].max()
        ]
        out: list[Surface] = []
        taken = np.zeros(len(points), dtype=bool)
        for i in sorted(peaks, key=lambda i: -counts[i]):
            z0 = 0.5 * (edges[i] + edges[i + 1])
            near = ~taken & (np.abs(z - z0) < SURFACE_BAND)
            if near.sum() < 30:
                continue
            z0 = float(np.median(z[near]))
            near = ~taken & (np.abs(z - z0) < SURFACE_BAND)
            for patch in self._patches(points[near]):
                if patch is not None:
                    out.append(patch)
            taken |= near
        out.sort(key=lambda s: -s.area)
        return out

    def _patches(self, pts: np.ndarray) -> list[Surface | None]:
        origin = pts[:, :2].min(axis=0) - 3 * SURFACE_CELL
        ij = np.floor((pts[:, :2] - origin) / SURFACE_CELL).astype(int)
        shape = ij.max(axis=0) + 4
        count = np.zeros(shape, dtype=int)
        np.add.at(count, (ij[:, 0], ij[:, 1]), 1)
        labels, n = ndimage.label(count >= 2, structure=np.ones((3, 3)))
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        out: list[Surface | None] = []
        grow = int(np.ceil(OUTLINE_MARGIN / SURFACE_CELL))
        for k in np.nonzero(sizes * SURFACE_CELL**2 >= MIN_SURFACE_AREA)[0]:
            if k == 0:
                continue
            cells = labels == k
            mine = cells[ij[:, 0], ij[:, 1]]
            p = pts[mine]
            a = np.column_stack([p[:, 0], p[:, 1], np.ones(len(p))])
            coef, *_ = np.linalg.lstsq(a, p[:, 2], rcond=None)
            normal = np.array([-coef[0], -coef[1], 1.0])
            normal /= np.linalg.norm(normal)
            if np.arccos(normal[2]) > MAX_TILT:
                continue
            residual = float(np.sqrt(np.mean((a @ coef - p[:, 2]) ** 2)))
            centre = p[:, :2].mean(axis=0)
            outline = ndimage.binary_fill_holes(ndimage.binary_dilation(cells, iterations=grow))
            outline |= _hull(cells)
            out.append(
                Surface(
                    height=float(coef[0] * centre[0] + coef[1] * centre[1] + coef[2]),
                    centre=(float(centre[0]), float(centre[1])),
                    normal=tuple(float(v) for v in normal),  # type: ignore[arg-type]
                    origin=(float(origin[0]), float(origin[1])),
                    cells=outline,
                    points=len(p),
                    residual=residual,
                )
            )
        return out

    # --- objects -----------------------------------------------------------------------

    def detect(
        self,
        points: np.ndarray,
        colours: np.ndarray | None,
        viewpoint: np.ndarray,
        surfaces: list[Surface] | None = None,
        spacing: float = 0.0,
    ) -> list[Detection]:
        """The objects standing on the surfaces of `points` (N, 3; z up), seen from
        `viewpoint` (the camera's position, same frame); `colours` (N, 3) uint8 or None;
        `spacing` (rad): the angle between neighbouring points (pixel stride / focal
        length), which widens the size tolerance with range (BLUR_PIXELS pixels)."""
        pts = np.asarray(points, dtype=float)
        if surfaces is None:
            surfaces = self.surfaces(pts)
        out = []
        owner = np.full(len(pts), -1)
        above = np.full(len(pts), np.nan)
        # each point belongs to the highest surface under it that covers it
        for s_i, s in sorted(enumerate(surfaces), key=lambda e: e[1].height):
            h = pts[:, 2] - s.height_at(pts[:, :2])
            inside = (h > ABOVE[0]) & (h < ABOVE[1]) & s.covers(pts[:, :2])
            owner[inside] = s_i
            above[inside] = h[inside]
        for s_i, s in enumerate(surfaces):
            mine = np.nonzero(owner == s_i)[0]
            if len(mine) < MIN_OBJECT_POINTS:
                continue
            for idx in self._clusters(pts[mine]):
                sel = mine[idx]
                if np.min(above[sel]) > STANDS_ON:
                    continue
                rgb = None if colours is None else colours[sel]
                out.append(self._describe(pts[sel], above[sel], rgb, viewpoint, s, spacing))
        return out

    def _clusters(self, pts: np.ndarray) -> list[np.ndarray]:
        ijk = np.floor((pts - pts.min(axis=0)) / OBJECT_CELL).astype(int)
        grid = np.zeros(ijk.max(axis=0) + 1, dtype=bool)
        grid[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = True
        labels, n = ndimage.label(grid, structure=np.ones((3, 3, 3)))
        lab = labels[ijk[:, 0], ijk[:, 1], ijk[:, 2]]
        order = np.argsort(lab, kind="stable")
        bounds = np.searchsorted(lab[order], np.arange(1, n + 2))
        return [
            order[bounds[k] : bounds[k + 1]]
            for k in range(n)
            if bounds[k + 1] - bounds[k] >= MIN_OBJECT_POINTS
        ]

    def _describe(
        self,
        pts: np.ndarray,
        above: np.ndarray,
        colours: np.ndarray | None,
        viewpoint: np.ndarray,
        surface: Surface,
        spacing: float = 0.0,
    ) -> Detection:
        height = float(np.percentile(above, 99))
        eye = np.asarray(viewpoint, dtype=float)
        distance = float(np.linalg.norm(pts.mean(axis=0) - eye))
        blur = BLUR_PIXELS * spacing * distance
        xy = pts[:, :2]
        view = xy.mean(axis=0) - eye[:2]
        view /= max(float(np.linalg.norm(view)), 1e-9)
        across = xy @ np.array([-view[1], view[0]])
        width = float(np.percentile(across, 99) - np.percentile(across, 1))
        top = above >= height - TOP_BAND
        sides = _box_sides(xy[top]) if top.sum() >= 8 else (width, width, 0.0, xy.mean(axis=0))
        # the top face seen from above at a slant: along the view its pixels lie 1 / slant
        # farther apart than across it (a 7 cm top 2 m off and 0.5 m down: 4 rows of pixels)
        slant = max((eye[2] - surface.height - height) / max(distance, 1e-9), MIN_SLANT)
        along = abs(float(np.cos(sides[2] - np.arctan2(view[1], view[0]))))
        top_blur = (
            blur * float(np.hypot(along, np.sqrt(1 - along**2) / slant)),  # the shorter side
            blur * float(np.hypot(np.sqrt(1 - along**2), along / slant)),  # the longer side
        )
        rgb = (
            np.zeros(3)
            if colours is None or len(colours) == 0
            else np.mean(np.asarray(colours, dtype=float), axis=0) / 255.0
        )
        kind, best_err, best_score = None, np.inf, np.inf
        for k in self.catalogue:
            errs = _mismatch(
                k, height, width, sides[:2], None if colours is None else rgb, blur, top_blur
            )
            err = float(errs.max())
            errs[0] *= HEIGHT_WEIGHT
            if err <= 1.0 and errs.max() < best_score:
                kind, best_err, best_score = k, err, float(errs.max())
            elif kind is None:
                best_err = min(best_err, err)
        position, yaw = _pose(kind, pts, above, top, view, sides, surface)
        return Detection(
            kind=kind.name if kind is not None else "",
            position=tuple(float(v) for v in position),  # type: ignore[arg-type]
            yaw=float(yaw),
            height=height,
            width=width,
            rgb=tuple(float(v) for v in rgb),  # type: ignore[arg-type]
            points=len(pts),
            surface=float(surface.height_at(position[None, :2])[0]),
            error=float(best_err),
        )


def _hull(cells: np.ndarray) -> np.ndarray:
    """The cells inside the convex hull of the True cells: a table's top where the
    objects on it hide it from the camera, even up to its far edge."""
    ij = np.argwhere(cells)
    out = np.zeros_like(cells)
    if len(ij) < 4 or np.linalg.matrix_rank(ij - ij.mean(axis=0)) < 2:
        return out
    lo, hi = ij.min(axis=0), ij.max(axis=0) + 1
    box = np.argwhere(np.ones(hi - lo, dtype=bool)) + lo
    inside = Delaunay(ij[ConvexHull(ij).vertices]).find_simplex(box) >= 0
    out[box[inside, 0], box[inside, 1]] = True
    return out


def _box_sides(xy: np.ndarray) -> tuple[float, float, float, np.ndarray]:
    """The shorter and longer side (m) of the rectangle around points (N, 2) along their
    principal axes (a square-ish one's: along its sides), the longer side's direction
    (rad) and the rectangle's centre."""
    c = xy.mean(axis=0)
    d = xy - c
    vals, vecs = np.linalg.eigh(d.T @ d)
    major = vecs[:, 1]
    if vals[1] < SQUARE * vals[0]:  # a square-ish top: its principal axes say nothing
        yaw = _face_yaw(xy)
        major = np.array([np.cos(yaw), np.sin(yaw)])
    u, v = d @ major, d @ np.array([-major[1], major[0]])
    # the 5th to 95th percentile of a side's points spans 90 % of it; farther out the
    # depth noise blurs the edges outward
    lu = np.percentile(u, 5), np.percentile(u, 95)
    lv = np.percentile(v, 5), np.percentile(v, 95)
    centre = c + major * (lu[0] + lu[1]) / 2 + np.array([-major[1], major[0]]) * (lv[0] + lv[1]) / 2
    a, b = (lu[1] - lu[0]) / 0.9, (lv[1] - lv[0]) / 0.9
    longer = major if a >= b else np.array([-major[1], major[0]])
    return float(min(a, b)), float(max(a, b)), float(np.arctan2(longer[1], longer[0])), centre


def _face_yaw(xy: np.ndarray) -> float:
    """The direction (rad, 0 to pi/2, in 1-degree steps) of a side of a square of points
    (N, 2): where the fourth moments of the points along it and across it sum to the
    least (along a diagonal they are 4/3 of that). A square's second moments, and so its
    principal axes, are the same every way; its outermost points are the noisiest."""
    d = xy - xy.mean(axis=0)
    angles = np.deg2rad(np.arange(90.0))
    c, s = np.cos(angles), np.sin(angles)
    moments = ((d @ np.vstack([c, s])) ** 4).mean(axis=0) + ((d @ np.vstack([-s, c])) ** 4).mean(
        axis=0
    )
    return float(angles[int(np.argmin(moments))])


def _off(measured: float, want: float, blur: float = 0.0) -> float:
    """How far a measured size is from the wanted one, in tolerances (the absolute one
    at least `blur`, m: what a pixel spans where the object is)."""
    return abs(measured - want) / max(SIZE_TOLERANCE[0] * want, SIZE_TOLERANCE[1], blur)


def _mismatch(
    kind: ObjectKind,
    height: float,
    width: float,
    top_sides: tuple[float, float],
    rgb: np.ndarray | None,
    blur: float = 0.0,
    top_blur: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """The size and colour mismatches, in tolerances (all <= 1 matches), the height's
    first; `blur` (m): what a pixel's blur spans at the object, `top_blur` along the top
    face's shorter and longer side (more where a side lies along a slanted view)."""
    errs = [_off(height, kind.height, blur)]
    if kind.shape == "box":
        small, large = sorted(kind.size[:2])
        errs += [
            _off(top_sides[0], small, max(blur, top_blur[0])),
            _off(top_sides[1], large, max(blur, top_blur[1])),
        ]
    else:
        errs.append(_off(width, kind.width, blur))
    if rgb is not None and rgb.sum() > 0.05:
        diff = np.linalg.norm(chromaticity(rgb) - chromaticity(np.asarray(kind.rgb)))
        errs.append(float(diff) / COLOUR_TOLERANCE)
    return np.array(errs)


def _pose(
    kind: ObjectKind | None,
    pts: np.ndarray,
    above: np.ndarray,
    top: np.ndarray,
    view: np.ndarray,
    sides: tuple[float, float, float, np.ndarray],
    surface: Surface,
) -> tuple[np.ndarray, float]:
    """Centre (3,) and yaw of a cluster, as its kind's shape says (unknown: the middle
    of its points)."""
    xy = pts[:, :2]
    if kind is None:
        c = xy.mean(axis=0)
        return np.array([c[0], c[1], float(np.mean(pts[:, 2]))]), 0.0
    base = float(surface.height_at(xy.mean(axis=0)[None])[0])
    if kind.shape == "box":
        c = sides[3]
        return np.array([c[0], c[1], base + kind.height / 2]), sides[2]
    r = kind.width / 2
    if kind.shape == "sphere":
        c = _fit_sphere(pts, r, view)
        return c, 0.0
    side = (above < above.max() - SIDE_BELOW_TOP) & (above > SIDE_ABOVE_SURFACE)
    if side.sum() >= MIN_SIDE_POINTS:
        c = fit_circle(xy[side], r, view)
    else:
        c = xy[top].mean(axis=0) if top.sum() else xy.mean(axis=0)
    return np.array([c[0], c[1], base + kind.height / 2]), 0.0


def fit_circle(xy: np.ndarray, r: float, view: np.ndarray) -> np.ndarray:
    """Centre of a circle of radius `r` through points (N, 2) seen along `view` (the
    visible arc faces the camera, so the centre starts behind the points)."""
    c = xy.mean(axis=0) + view * r * 0.5
    for _ in range(10):
        d = xy - c
        n = np.maximum(np.linalg.norm(d, axis=1), 1e-9)
        res = n - r
        jac = -d / n[:, None]
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        c = c + step
        if np.linalg.norm(step) < 1e-5:
            break
    return c


def _fit_sphere(pts: np.ndarray, r: float, view: np.ndarray) -> np.ndarray:
    """Centre of a sphere of radius `r` through points (N, 3) seen along `view`."""
    c = pts.mean(axis=0) + np.array([view[0], view[1], 0.0]) * r * 0.5
    c[2] -= r * 0.3
    for _ in range(10):
        d = pts - c
        n = np.maximum(np.linalg.norm(d, axis=1), 1e-9)
        step, *_ = np.linalg.lstsq(-d / n[:, None], -(n - r), rcond=None)
        c = c + step
        if np.linalg.norm(step) < 1e-5:
            break
    return c
