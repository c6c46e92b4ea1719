"""Sphere approximations of shapes: the planner's view of a robot's links (layer 2).

Every cover holds its whole shape (surface exactly, interior at grid points), so a
configuration the spheres call free is free for the exact shapes too; that keeps the
planner's answers valid under MuJoCo's exact check. Meshes are covered through their
convex hull (what MuJoCo collides with); boxes, cylinders and hulls go the same way.

The cover has a bounded bulge: a sphere centred at depth h inside a convex shape (h is
the distance to its surface) with radius h + b stays within b of the shape, since it is
the inscribed ball B(c, h) grown by b. Candidate centres lie on a grid inside the shape.
The surface is cut into small triangles gathered in patches, and a sphere holds a patch
when it holds the patch's corners (a ball is convex), so covering every patch covers
the whole surface, not just samples of it. A greedy set cover takes the hardest patch
first (the one the fewest candidates can hold) and the candidate holding it that holds
the most; the tolerance b starts at 5 mm and grows in steps of 10 % until the cover fits
the sphere budget. Then the centres move to lower the bulge (on the grid, then off it)
and every sphere shrinks to what its share of the surface needs. The shapes of one
link share one tolerance and one budget.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Collection, Sequence
from functools import lru_cache
from typing import NamedTuple

import numba as nb
import numpy as np

from robotrial.geometry import Box, Cylinder, Mesh, Shape, Sphere
from robotrial.model.robot import CollisionSphere, RobotModel

FIRST_BULGE = 0.005  # m: the tightest tolerance tried
BULGE_GROWTH = 1.1  # the tolerance grows by this factor until the cover fits the budget
CANDIDATES = 2000  # about this many grid points in the shape's bounding box
PATCHES = 1000  # cut the surface into about this many patches
INTERIOR = 500  # interior grid points the cover must hold too
REFINE_ROUNDS = 8  # rounds of moving the chosen centres to lower the bulge
POLISH_ROUNDS = 2  # rounds of moving the centres off the grid
POLISH_STEP = 2e-4  # m: the finest move when polishing a centre
SAG = 2e-4  # m: how far a cylinder's curved surface may stand off its polygon
FLAT = 2.5e-4  # m: a patch held through an octagon lies within this of its plane
# The fine cover (`link_fine_spheres`): what the checks ask only where the coarse cover
# touches something; tighter, so it takes more spheres and finer grids.
FINE_BULGE = 0.004  # m: its tolerance, at most
FINE_SPHERES = 160  # spheres per link, at most
FINE_CANDIDATES = 6000
FINE_PATCHES = 2500


class _Grid(NamedTuple):
    """How finely a cover is searched: candidate centres, surface patches, interior
    points, and the tolerance schedule (first tolerance, largest allowed)."""

    candidates: int = CANDIDATES
    patches: int = PATCHES
    interior: int = INTERIOR
    first_bulge: float = FIRST_BULGE


COARSE = _Grid()
FINE = _Grid(FINE_CANDIDATES, FINE_PATCHES, INTERIOR, FINE_BULGE)


class _Convex:
    """A convex shape as the cover needs it: its surface as small patches of triangles
    (each patch given by its corners; the true surface may stand off the triangles by
    `margin`), and candidate centres on a grid inside with their depths."""

    def __init__(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        margin: float,
        lo: np.ndarray,
        hi: np.ndarray,
        depth: _Solid,
        grid: _Grid = COARSE,
    ) -> None:
        tris = np.asarray(vertices, dtype=float)[np.asarray(faces)]
        area = 0.5 * np.linalg.norm(
            np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1
        )
        extent = np.maximum(hi - lo, 1e-9)
        edge = float(np.clip(np.sqrt(area.sum() / grid.patches), 0.002, 0.5 * extent.max()))
        tris = _split(tris[area > 0], edge)
        # patches: the triangles whose centroids share a cell of side `edge`; each patch
        # is held by its distinct corners
        cell = np.floor((tris.mean(axis=1) - lo) / edge).astype(np.int64)
        cell -= cell.min(axis=0)
        dims = cell.max(axis=0) + 1
        _, patch = np.unique(
            (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2], return_inverse=True
        )
        corners, owner = tris.reshape(-1, 3), np.repeat(patch.ravel(), 3)
        order = np.lexsort((corners[:, 2], corners[:, 1], corners[:, 0], owner))
        corners, owner = corners[order], owner[order]
        new = np.r_[True, np.any(np.diff(corners, axis=0) != 0, axis=1) | (np.diff(owner) != 0)]
        corners, owner = corners[new], owner[new]
        inner = corners.mean(axis=0)
        normal = np.zeros((int(patch.max()) + 1, 3))
        np.add.at(normal, patch.ravel(), np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]))
        self.vertices, owner, self.margins = _octagons(corners, owner, normal, margin)
        self.patch_start = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
        # per-axis odd counts put a grid plane through the middle of thin shapes
        step = float(np.cbrt(np.prod(extent) / grid.candidates))
        counts = 2 * np.ceil(extent / (2 * step)).astype(int) + 1
        axes = [np.linspace(lo[i], hi[i], counts[i]) for i in range(3)]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        # the corners' mean lies inside too, so a slab thinner than the grid still has
        # a candidate
        points = np.vstack([points, inner])
        h = np.maximum(depth(points), np.r_[np.full(len(points) - 1, -np.inf), 0.0])
        inside = h >= 0.0
        self.centres, self.depth = points[inside], h[inside]
        self.depth_of = depth
        self.step = step


def _octagons(
    corners: np.ndarray, owner: np.ndarray, normal: np.ndarray, margin: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The points each patch is held by, their patch and each patch's margin. A patch of
    more than 8 corners within `FLAT` of a plane (a patch of a finely meshed hull) is
    held through the octagon around them in that plane, at their middle height: a
    sphere holding its 8 corners, grown by half their spread in height, holds every
    corner. `corners` are sorted by `owner`; `normal` is each patch's summed face
    normal."""
    patches = len(normal)
    count = np.bincount(owner, minlength=patches)
    start = np.r_[0, np.cumsum(count)[:-1]]
    size = np.linalg.norm(normal, axis=1, keepdims=True)
    n = np.where(size > 0, normal / np.where(size > 0, size, 1.0), [[0.0, 0.0, 1.0]])
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(n, u)
    a, b, h = (np.einsum("ij,ij->i", corners, w[owner]) for w in (u, v, n))
    lo, hi = np.minimum.reduceat, np.maximum.reduceat
    h0, h1 = lo(h, start), hi(h, start)
    swap = (count > 8) & (h1 - h0 <= 2 * FLAT)
    margins = np.full(patches, margin)
    margins[swap] += 0.5 * (h1 - h0)[swap]
    if not swap.any():
        return corners, owner, margins
    a0, a1, b0, b1 = lo(a, start)[swap], hi(a, start)[swap], lo(b, start)[swap], hi(b, start)[swap]
    s0, s1 = lo(a + b, start)[swap], hi(a + b, start)[swap]
    d0, d1 = lo(a - b, start)[swap], hi(a - b, start)[swap]
    # the octagon's corners: where the lines a = a0, a1 and b = b0, b1 leave it
    octagon = np.stack(
        [
            np.stack(c, axis=-1)
            for c in (
                (a1, np.maximum.reduce([b0, a1 - d1, s0 - a1])),
                (a1, np.minimum.reduce([b1, a1 - d0, s1 - a1])),
                (a0, np.maximum.reduce([b0, a0 - d1, s0 - a0])),
                (a0, np.minimum.reduce([b1, a0 - d0, s1 - a0])),
                (np.maximum.reduce([a0, b1 + d0, s0 - b1]), b1),
                (np.minimum.reduce([a1, b1 + d1, s1 - b1]), b1),
                (np.maximum.reduce([a0, b0 + d0, s0 - b0]), b0),
                (np.minimum.reduce([a1, b0 + d1, s1 - b0]), b0),
            )
        ],
        axis=1,
    )  # (swapped, 8, 2)
    u, v, n, mid = u[swap, None], v[swap, None], n[swap, None], 0.5 * (h0 + h1)[swap, None, None]
    points = octagon[..., :1] * u + octagon[..., 1:] * v + mid * n
    keep = ~swap[owner]
    owner = np.r_[owner[keep], np.repeat(np.flatnonzero(swap), 8)]
    corners = np.vstack([corners[keep], points.reshape(-1, 3)])
    order = np.argsort(owner, kind="stable")
    return corners[order], owner[order], margins


def _split(tris: np.ndarray, edge: float) -> np.ndarray:
    """Cut triangles (T, 3, 3) in two across their longest side until no side is longer
    than `edge`; the pieces tile the same surface."""
    done = []
    while len(tris):
        sides = np.linalg.norm(tris - np.roll(tris, -1, axis=1), axis=2)  # side i: corner i to i+1
        longest = np.argmax(sides, axis=1)
        big = sides[np.arange(len(tris)), longest] > edge
        done.append(tris[~big])
        tris, longest = tris[big], longest[big]
        # rotate corners so the longest side runs from corner 0 to corner 1
        order = (longest[:, None] + np.arange(3)[None, :]) % 3
        t = np.take_along_axis(tris, order[:, :, None], axis=1)
        mid = 0.5 * (t[:, 0] + t[:, 1])
        tris = np.concatenate(
            [np.stack([t[:, 0], mid, t[:, 2]], 1), np.stack([mid, t[:, 1], t[:, 2]], 1)]
        )
    return np.concatenate(done)


class _Solid(NamedTuple):
    """A convex solid as its depth function needs it: the polyhedron {x : normals @ x <=
    offsets}, cut by the cylinder along z of `cyl` (radius, half length) when its radius
    is positive. Called with points (N, 3), gives their depths (negative outside)."""

    normals: np.ndarray
    offsets: np.ndarray
    cyl: np.ndarray

    def __call__(self, p: np.ndarray) -> np.ndarray:
        out = np.empty(len(p))
        _depth_into(*self, np.ascontiguousarray(p, dtype=np.float64), out)
        return out


def _polyhedron(normals: np.ndarray, offsets: np.ndarray) -> _Solid:
    return _Solid(
        np.ascontiguousarray(normals, dtype=np.float64),
        np.ascontiguousarray(offsets, dtype=np.float64),
        np.zeros(2),
    )


@nb.njit(cache=True)
def _depth_at(normals, offsets, cyl, x, y, z) -> float:
    """The depth of one point in a `_Solid` (min over its planes and its cylinder)."""
    best = np.inf
    for f in range(offsets.shape[0]):
        best = min(best, offsets[f] - (normals[f, 0] * x + normals[f, 1] * y + normals[f, 2] * z))
    if cyl[0] > 0.0:
        best = min(best, cyl[0] - math.hypot(x, y), cyl[1] - abs(z))
    return best


@nb.njit(cache=True)
def _depth_into(normals, offsets, cyl, points, out) -> None:
    # point by point, without the (points, planes) matrix: a hull has thousands of faces
    for i in range(points.shape[0]):
        out[i] = _depth_at(normals, offsets, cyl, points[i, 0], points[i, 1], points[i, 2])


@nb.njit(cache=True)
def _bulge(normals, offsets, cyl, pts, pad, x, y, z) -> float:
    """How far a sphere at (x, y, z) holding `pts` (each grown by its `pad`) stands out
    of the solid: its radius less the centre's depth; infinite outside."""
    h = _depth_at(normals, offsets, cyl, x, y, z)
    if h < 0.0:
        return np.inf
    far = -np.inf
    for j in range(pts.shape[0]):
        dx, dy, dz = pts[j, 0] - x, pts[j, 1] - y, pts[j, 2] - z
        far = max(far, np.sqrt(dx * dx + dy * dy + dz * dz) + pad[j])
    return far - h


@nb.njit(cache=True)
def _polish(normals, offsets, cyl, centres, owner, points, start, margin, step, finest):
    """Pattern search for each centre k: from where it is, the point inside the solid
    where a sphere holding the groups `owner` gives it bulges least (moves of `step`
    along the axes, halved when none helps, down to `finest`)."""
    out = centres.copy()
    for k in range(centres.shape[0]):
        m = 0
        for g in range(owner.shape[0]):
            if owner[g] == k:
                m += start[g + 1] - start[g]
        if m == 0:
            continue
        pts = np.empty((m, 3))
        pad = np.empty(m)
        n = 0
        for g in range(owner.shape[0]):
            if owner[g] == k:
                for j in range(start[g], start[g + 1]):
                    pts[n] = points[j]
                    pad[n] = margin[g]
                    n += 1
        c = out[k].copy()
        best = _bulge(normals, offsets, cyl, pts, pad, c[0], c[1], c[2])
        s = step
        while s > finest:
            move, score = -1, np.inf
            for i in range(6):
                t = c.copy()
                t[i % 3] += s if i < 3 else -s
                b = _bulge(normals, offsets, cyl, pts, pad, t[0], t[1], t[2])
                if b < score:
                    move, score = i, b
            if score < best:
                c[move % 3] += s if move < 3 else -s
                best = score
            else:
                s *= 0.5
        out[k] = c
    return out


def _group_need(centres, points, start, margin, dtype=np.float64) -> np.ndarray:
    """(groups, centres): the radius a sphere at each centre needs to hold each group of
    points (points[start[g]:start[g + 1]]) plus that group's margin. In single
    precision for the search over many candidates (the final radii are recomputed in
    double)."""
    out = np.empty((len(start) - 1, len(centres)), dtype=dtype)
    _group_need_into(centres, points, start, margin, out)
    return out


@nb.njit(cache=True)
def _group_need_into(centres, points, start, margin, out) -> None:
    # the candidates innermost, one axis per array: the loop compiles to vector code
    n, g = len(centres), len(start) - 1
    cx, cy, cz = centres[:, 0].copy(), centres[:, 1].copy(), centres[:, 2].copy()
    far = np.empty(n)
    for k in range(g):
        far[:] = 0.0
        for j in range(start[k], start[k + 1]):
            px, py, pz = points[j, 0], points[j, 1], points[j, 2]
            for i in range(n):
                dx, dy, dz = px - cx[i], py - cy[i], pz - cz[i]
                far[i] = max(far[i], dx * dx + dy * dy + dz * dz)
        for i in range(n):
            out[k, i] = np.sqrt(far[i]) + margin[k]


@nb.njit(cache=True)
def _greedy(need, reach, budget):
    """Centres (indices) whose spheres of radius `reach` hold every group; empty if more
    than `budget` are needed or some group fits no sphere. `need` is (groups, centres).
    Hardest first: take the uncovered group the fewest spheres can hold, and of those
    spheres the one that holds the most uncovered groups (corners before faces, as one
    covers a line from its end)."""
    g, n = need.shape
    counts = np.zeros(n, dtype=np.int64)
    holders = np.zeros(g, dtype=np.int64)
    for k in range(g):
        for i in range(n):
            if need[k, i] <= reach[i]:
                counts[i] += 1
                holders[k] += 1
        if holders[k] == 0:
            return np.empty(0, dtype=np.int64)
    order = np.argsort(holders, kind="mergesort")
    uncovered = np.ones(g, dtype=np.bool_)
    chosen = np.empty(budget, dtype=np.int64)
    m = 0
    for hard in order:
        if not uncovered[hard]:
            continue
        if m == budget:
            return np.empty(0, dtype=np.int64)
        best, most = -1, -1
        for i in range(n):
            if need[hard, i] <= reach[i] and counts[i] > most:
                best, most = i, counts[i]
        chosen[m] = best
        m += 1
        for k in range(g):
            if uncovered[k] and need[k, best] <= reach[best]:
                uncovered[k] = False
                for i in range(n):
                    if need[k, i] <= reach[i]:
                        counts[i] -= 1
    return chosen[:m]


@nb.njit(cache=True)
def _refine(need, h, chosen, rounds):
    """Move the chosen centres to lower the worst bulge: give every group to the sphere
    that holds it with the least bulge, then move each sphere to the candidate whose
    bulge over its groups is least; repeat. Returns the centres and each group's owner."""
    g, n = need.shape
    k = len(chosen)
    cur = chosen.copy()
    owner = np.zeros(g, dtype=np.int64)
    for _ in range(rounds):
        _assign(need, h, cur, owner)
        moved = False
        for j in range(k):
            worst = np.full(n, -np.inf)
            for q in range(g):
                if owner[q] == j:
                    for i in range(n):
                        worst[i] = max(worst[i], need[q, i])
            best_i, best = cur[j], np.inf
            for i in range(n):
                if worst[i] > -np.inf and worst[i] - h[i] < best - 1e-12:
                    best_i, best = i, worst[i] - h[i]
            if best_i != cur[j]:
                cur[j] = best_i
                moved = True
        if not moved:
            break
    _assign(need, h, cur, owner)
    return cur, owner


@nb.njit(cache=True)
def _assign(need, h, cur, owner) -> None:
    """Give every group q to the chosen centre that holds it with the least bulge."""
    for q in range(need.shape[0]):
        best, who = np.inf, 0
        for j in range(cur.shape[0]):
            v = need[q, cur[j]] - h[cur[j]]
            if v < best:
                best, who = v, j
        owner[q] = who


class _Fit:
    """One shape's cover problem: the radius each candidate centre needs for each group
    (a surface patch, or an interior grid point, so the cover is solid as well)."""

    def __init__(self, shape: _Convex, grid: _Grid) -> None:
        cand, h = shape.centres, shape.depth
        deep = np.flatnonzero(h > 0)
        interior = cand[deep[:: max(len(deep) // grid.interior, 1)]]
        points = np.vstack([shape.vertices, interior])
        start = np.concatenate(
            [shape.patch_start, len(shape.vertices) + np.arange(len(interior) + 1)]
        )
        margin = np.r_[shape.margins, np.zeros(len(interior))]
        self.shape, self.points, self.start, self.margin = shape, points, start, margin
        self.centres, self.depth = cand, h
        self.first_bulge = grid.first_bulge
        self.need = _group_need(cand, points, start, margin, np.float32)
        self._tried: dict[tuple[int, int], np.ndarray] = {}

    def greedy(self, step: int, budget: int) -> np.ndarray:
        """Chosen centres at tolerance step `step` (empty if over `budget`)."""
        key = (step, budget)
        if key not in self._tried:
            reach = self.depth + self.first_bulge * BULGE_GROWTH**step
            self._tried[key] = _greedy(self.need, reach, budget)
        return self._tried[key]

    def finish(self, chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centres and radii: the chosen grid centres moved to lower the bulge, then off
        the grid (each sphere to the centre of least bulge over its own groups), every
        sphere shrunk to what its groups need."""
        idx, _ = _refine(self.need, self.depth, chosen, REFINE_ROUNDS)
        centres = self.centres[idx]
        solid = self.shape.depth_of
        for _ in range(POLISH_ROUNDS):
            need = _group_need(centres, self.points, self.start, self.margin)
            owner = np.argmin(need - solid(centres)[None, :], axis=1)
            centres = _polish(
                *solid,
                centres,
                owner,
                self.points,
                self.start,
                self.margin,
                0.5 * self.shape.step,
                POLISH_STEP,
            )
        need = _group_need(centres, self.points, self.start, self.margin)
        owner = np.argmin(need - solid(centres)[None, :], axis=1)
        radii = np.array([np.max(need[owner == k, k], initial=0.0) for k in range(len(centres))])
        keep = radii > 0.0
        return centres[keep], radii[keep]


def _shared_cover(
    shapes: list[_Convex], budget: int, grid: _Grid = COARSE
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Covers of several shapes (one link's) with one tolerance: the smallest step of the
    schedule at which all of them together need at most `budget` spheres (or one sphere
    each, if there are more shapes than that)."""
    fits = [_Fit(s, grid) for s in shapes]
    widest = max(float(np.max(s.vertices.max(0) - s.vertices.min(0))) for s in shapes)
    first = grid.first_bulge
    # past this step one sphere holds any of the shapes
    last = int(np.ceil(np.log(max(widest, first) / first) / np.log(BULGE_GROWTH)))
    last = max(last, 0) + 1

    def attempt(step: int) -> list[np.ndarray] | None:
        out, used = [], 0
        for f in fits:
            chosen = f.greedy(step, budget)
            if not len(chosen) or used + len(chosen) > budget:
                return None
            used += len(chosen)
            out.append(chosen)
        return out

    # the count falls as the tolerance grows: find the first step that fits by doubling
    # the step index, then bisecting
    lo, hi = -1, 0
    found = attempt(hi)
    while found is None and hi < last:
        lo, hi = hi, min(2 * hi + 1, last)
        found = attempt(hi)
    if found is None:
        found = [f.greedy(last, 1) for f in fits]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        trial = attempt(mid)
        if trial is None:
            lo = mid
        else:
            hi, found = mid, trial
    return [f.finish(chosen) for f, chosen in zip(fits, found, strict=True)]


def _box(size: tuple[float, float, float], grid: _Grid) -> _Convex:
    import trimesh

    extent = np.asarray(size, dtype=float)
    half = extent / 2
    tm = trimesh.creation.box(extents=extent)
    return _Convex(tm.vertices, tm.faces, 0.0, -half, half, _solid(("box", size)), grid)


def _cylinder(radius: float, length: float, grid: _Grid) -> _Convex:
    import trimesh

    # a polygon with its corners on the circle: the true surface stands off its flat
    # sides by at most the sagitta, which every sphere keeps in hand as a margin
    sections = int(np.clip(np.ceil(np.pi / np.arccos(1.0 - min(SAG / radius, 1.0))), 8, 256))
    sag = radius * (1.0 - np.cos(np.pi / sections))
    tm = trimesh.creation.cylinder(radius=radius, height=length, sections=sections)

    half = np.array([radius, radius, length / 2])
    solid = _solid(("cylinder", radius, length))
    return _Convex(tm.vertices, tm.faces, float(sag), -half, half, solid, grid)


def _hull(mesh: Mesh, grid: _Grid) -> _Convex:
    """The (scaled) convex hull of a mesh: what MuJoCo collides with."""
    key = _key(mesh)
    vertices, faces, _, _ = _hull_planes(key)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    return _Convex(vertices, faces, 0.0, lo, hi, _solid(key), grid)


def _solid(key: tuple) -> _Solid:
    """The solid of a box, cylinder or mesh (its convex hull) by its `_key`."""
    if key[0] == "box":
        half = np.asarray(key[1], dtype=float) / 2
        return _polyhedron(np.vstack([np.eye(3), -np.eye(3)]), np.concatenate([half, half]))
    if key[0] == "cylinder":
        return _Solid(np.zeros((0, 3)), np.zeros(0), np.array([key[1], key[2] / 2]))
    return _polyhedron(*_hull_planes(key)[2:])


@lru_cache(maxsize=64)
def _hull_planes(key: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A mesh's convex hull (vertices, faces) and its face planes (normals, offsets):
    made once for the coarse and the fine cover."""
    import trimesh

    mesh = _MESHES[key]

    if mesh.data is not None:
        tm = trimesh.Trimesh(mesh.data.vertices, mesh.data.faces, process=False)
    else:
        try:
            loaded = trimesh.load(mesh.filename, force="mesh")
        except (OSError, ValueError) as err:
            raise ValueError(f"cannot read mesh {mesh.filename!r}: {err}") from err
        tm = loaded if isinstance(loaded, trimesh.Trimesh) else loaded.to_mesh()
    tm.apply_scale(np.asarray(mesh.scale))
    if len(tm.vertices) < 4:
        raise ValueError(f"mesh {mesh.filename or '(in memory)'} has fewer than 4 vertices")
    name = mesh.filename or "(in memory)"
    try:
        hull = tm.convex_hull
    except Exception as err:  # qhull refuses flat or degenerate point sets
        raise ValueError(f"mesh {name}: no convex hull ({err})") from err
    if not float(hull.volume) > 1e-12:
        raise ValueError(f"mesh {name} is flat: its convex hull encloses no volume")
    normals = np.asarray(hull.face_normals)
    offsets = np.einsum("ij,ij->i", normals, hull.triangles[:, 0])
    return np.asarray(hull.vertices), np.asarray(hull.faces), normals, offsets


_MESHES: dict[tuple, Mesh] = {}  # a mesh by its key, so covers can be cached by key


def _key(shape: Shape) -> tuple:
    """A hashable description of a box, cylinder or mesh (bad dimensions rejected)."""
    if isinstance(shape, Box):
        size = tuple(float(s) for s in shape.size)
        if len(size) != 3 or min(size) <= 0:
            raise ValueError(f"box size must be three positive lengths, got {shape.size!r}")
        return ("box", size)
    if isinstance(shape, Cylinder):
        if shape.radius <= 0 or shape.length <= 0:
            raise ValueError(
                f"cylinder needs positive radius and length, got {shape.radius}, {shape.length}"
            )
        return ("cylinder", float(shape.radius), float(shape.length))
    if isinstance(shape, Mesh):
        if shape.data is not None:
            raw = shape.data.vertices.tobytes() + shape.data.faces.tobytes()
            source = hashlib.sha1(raw).hexdigest()
        else:
            source = shape.filename
        key = ("mesh", source, tuple(shape.scale))
        _MESHES.setdefault(key, shape)
        return key
    raise TypeError(f"no sphere cover for shape {shape!r}")


@lru_cache(maxsize=64)
def _convex(key: tuple, grid: _Grid = COARSE) -> _Convex:
    if key[0] == "box":
        return _box(key[1], grid)
    if key[0] == "cylinder":
        return _cylinder(key[1], key[2], grid)
    return _hull(_MESHES[key], grid)


@lru_cache(maxsize=256)
def _covers(
    keys: tuple[tuple, ...], budget: int, grid: _Grid = COARSE
) -> list[tuple[np.ndarray, np.ndarray]]:
    return _shared_cover([_convex(k, grid) for k in keys], budget, grid)


def _spheres_of(
    shapes: list[Shape], budget: int, grid: _Grid = COARSE
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Covers (centres in each shape's frame, radii) of shapes sharing one tolerance and
    at most `budget` spheres (spheres are themselves and count one each)."""
    solid = [i for i, s in enumerate(shapes) if not isinstance(s, Sphere)]
    out = [(np.zeros((1, 3)), np.array([float(getattr(s, "radius", 0.0))])) for s in shapes]
    if solid:
        keys = tuple(_key(shapes[i]) for i in solid)
        left = max(int(budget) - (len(shapes) - len(solid)), 1)
        for i, (c, r) in zip(solid, _covers(keys, left, grid), strict=True):
            out[i] = (c.copy(), r.copy())
    return out


def shape_spheres(shape: Shape, max_spheres: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Spheres (centres in the shape's frame, radii) that cover `shape`; a mesh is
    covered through its convex hull."""
    return _spheres_of([shape], max_spheres)[0]


def link_spheres(model: RobotModel, max_per_shape: int = 12) -> list[CollisionSphere]:
    """Spheres covering every collision shape of every link, in the links' frames.

    The shapes of one link share one tolerance and `max_per_shape` spheres between them,
    so a link of many small parts (a finger) costs no more than a link of one."""
    return _link_covers(model, max_per_shape, COARSE)


def link_fine_spheres(
    model: RobotModel, links: Collection[str] | None = None
) -> list[CollisionSphere]:
    """A tighter cover of every link (within `FINE_BULGE` of its shapes where
    `FINE_SPHERES` suffice): many more spheres than `link_spheres`, asked only where
    the coarse cover touches something, so that a link passing a board a centimetre
    away is not called colliding. Only of `links` when given."""
    return _link_covers(model, FINE_SPHERES, FINE, links)


def inscribed_radii(model: RobotModel, spheres: Sequence[CollisionSphere]) -> np.ndarray:
    """(n,) the radius of the ball each sphere's link surely holds around its centre: the
    centre's depth in the deepest of the link's collision shapes (a mesh through its
    convex hull, as MuJoCo collides it), at most the sphere's radius, 0 outside them all.
    Where that ball reaches into something by d, the link surely does; the sphere itself
    may reach in by up to its bulge (radius less this) where the link does not."""
    links = {link.name: link for link in model.links}
    centres = np.array([s.center for s in spheres], dtype=float).reshape(-1, 3)
    radii = np.array([s.radius for s in spheres], dtype=float)
    owner = np.array([s.link for s in spheres])
    depth = np.zeros(len(spheres))
    for name in set(owner.tolist()) & set(links):
        mine = np.flatnonzero(owner == name)
        for col in links[name].collisions:
            m = np.linalg.inv(col.origin.matrix())
            p = centres[mine] @ m[:3, :3].T + m[:3, 3]
            if isinstance(col.geometry, Sphere):
                h = col.geometry.radius - np.linalg.norm(p, axis=1)
            else:
                h = _solid(_key(col.geometry))(p)
            depth[mine] = np.maximum(depth[mine], h)
    return np.minimum(depth, radii)


def _link_covers(
    model: RobotModel, budget: int, grid: _Grid, links: Collection[str] | None = None
) -> list[CollisionSphere]:
    out: list[CollisionSphere] = []
    for link in model.links:
        if not link.collisions or (links is not None and link.name not in links):
            continue
        try:
            covers = _spheres_of([c.geometry for c in link.collisions], budget, grid)
        except ValueError as err:
            raise ValueError(f"link {link.name!r}: {err}") from err
        for col, (centres, radii) in zip(link.collisions, covers, strict=True):
            m = col.origin.matrix()
            world = centres @ m[:3, :3].T + m[:3, 3]
            out.extend(
                CollisionSphere(link.name, tuple(map(float, c)), float(r))  # type: ignore[arg-type]
                for c, r in zip(world, radii, strict=True)
            )
    return out
