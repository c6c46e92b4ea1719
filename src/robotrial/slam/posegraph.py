"""Pose-graph SLAM, Karto / slam_toolbox style (layer 3).

Front end: every scan is predicted from the last pose by the odometry (when there is
some) and matched against a local map, the scans of the last few nodes (a rolling window,
`scan_buffer_size` nodes within `scan_buffer_maximum_scan_distance` m of path). The match
is a brute correlative search over a window as wide as the prediction is uncertain (the
odometry motion model; without odometry, `correlation_search_space` m and rad), then
multi-resolution Gauss-Newton from the best pose with the prediction as a prior. Every
`minimum_travel_distance` or `minimum_travel_heading` the scan becomes a node, joined to
the previous one by two constraints: the odometry's motion with the motion model's
covariance, and the matched motion with the covariance of the match (its Hessian scaled
by the fit's residual: along a corridor the match knows little and the odometry rules).

Loop closure (the back end): for each new node, the earlier nodes not recent in the chain
whose estimate lies within reach are candidates; the reach grows with the graph distance
between the two nodes (the path length along the constraints, a loop closure as short
as it is certain), since the estimates drift apart with it. The scan is matched correlatively
against a likelihood field of the candidate's neighbouring scans, coarse to fine, over a
window as wide as that reach, and refined by Gauss-Newton on the same field, then
once more on an occupancy map of those scans at the map's resolution, as the front end
matches (on the field's own cells the fit pulls walls onto cell centres, the same way
for every closure over them). The match's
covariance is set per direction: open along a corridor longer than the search window
(where the coarse level's near-best poses reach half the window), long along the offset
to any other place the scan fits nearly as well (kept through the levels and scored at
the finest), and otherwise the fine search's spread plus the refinement's fit: tight
across a corridor and in heading, so a right closure pulls there. A match is
verified before it enters the graph: its response must be high, the refinement must stay
by the peak, and a second closure from a nearby node must imply the same correction of
the graph (two wrong matches rarely agree). In the graph, loop closures carry a Cauchy
kernel, so one that slipped through pulls little; after each optimisation a closure
whose error is still too large for its covariance is taken out and the graph optimised
again. Optimisation is sparse Levenberg-Marquardt over the SE(2) node poses, run when the
closures waiting disagree with the estimate (or after `optimize_every` of them); scans
between nodes keep their pose relative to the node before them, so the whole trajectory
follows.

The map (`grid`) is built from the node scans at their current poses when it is asked for
(and kept, scans added as nodes come, until an optimisation moves the nodes).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numba
import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra
from scipy.sparse.linalg import splu

from robotrial.slam.grid import LogOddsGrid, LogOddsModel
from robotrial.slam.matcher import ScanMatcher
from robotrial.slam.params import PoseGraphParams
from robotrial.slam.scan import Beams, compose, motion_sigma, relative, transform_points, wrap
from robotrial.slam.tiled import TiledGrid


@dataclass(frozen=True)
class Edge:
    """A constraint: node j seen from node i at `z` (x, y, yaw in i's frame), with
    information `info` (3 x 3, in i's frame); `loop` marks a loop closure (robust)."""

    i: int
    j: int
    z: np.ndarray
    info: np.ndarray
    loop: bool = False


def _errors(poses: np.ndarray, ii: np.ndarray, jj: np.ndarray, z: np.ndarray) -> np.ndarray:
    pi, pj = poses[ii], poses[jj]
    c, s = np.cos(pi[:, 2]), np.sin(pi[:, 2])
    dx, dy = pj[:, 0] - pi[:, 0], pj[:, 1] - pi[:, 1]
    e = np.empty((len(ii), 3))
    e[:, 0] = c * dx + s * dy - z[:, 0]
    e[:, 1] = -s * dx + c * dy - z[:, 1]
    e[:, 2] = (pj[:, 2] - pi[:, 2] - z[:, 2] + np.pi) % (2 * np.pi) - np.pi
    return e


def edge_chi2(poses: np.ndarray, edges: list[Edge]) -> np.ndarray:
    """e' info e of every edge at `poses`: about 3 on average for an edge whose
    covariance is right, far more for one that does not fit the others."""
    if not edges:
        return np.zeros(0)
    ii = np.array([e.i for e in edges])
    jj = np.array([e.j for e in edges])
    z = np.array([e.z for e in edges], dtype=np.float64)
    info = np.array([e.info for e in edges], dtype=np.float64)
    err = _errors(np.asarray(poses, dtype=np.float64), ii, jj, z)
    return np.einsum("ei,eij,ej->e", err, info, err)


def graph_cost(poses: np.ndarray, edges: list[Edge]) -> float:
    """Sum over edges of e' info e: zero when every constraint holds exactly."""
    return float(edge_chi2(poses, edges).sum())


def _robust(chi2: np.ndarray, loop: np.ndarray, width: float | None) -> tuple[float, np.ndarray]:
    """The cost and the weights of the edges: loop closures under a Cauchy kernel of
    `width` (in units of their standard deviation), the others squared."""
    w = np.ones_like(chi2)
    if width is None or not loop.any():
        return float(chi2.sum()), w
    c2 = width * width
    w[loop] = 1.0 / (1.0 + chi2[loop] / c2)
    cost = chi2[~loop].sum() + (c2 * np.log1p(chi2[loop] / c2)).sum()
    return float(cost), w


class _Pattern:
    """The sparsity of a pose graph's normal equations, worked out once per optimisation:
    where each edge's four 3 x 3 blocks (i,i), (i,j), (j,i), (j,j) and each diagonal entry
    land among the matrix's stored entries (column by column), so that every iteration
    adds its blocks into the entries in place and factorises without re-sorting."""

    def __init__(self, n: int, ii: np.ndarray, jj: np.ndarray) -> None:
        size = 3 * n
        k = np.arange(3)
        rows = np.concatenate(
            [np.broadcast_to(3 * r[:, None, None] + k[None, :, None], (len(ii), 3, 3))
             for r in (ii, ii, jj, jj)]
        ).ravel()  # fmt: skip
        cols = np.concatenate(
            [np.broadcast_to(3 * c[:, None, None] + k[None, None, :], (len(ii), 3, 3))
             for c in (ii, jj, ii, jj)]
        ).ravel()  # fmt: skip
        every = np.arange(size)
        flat_cols = np.concatenate([cols, every]).astype(np.int64)
        keys = flat_cols * size + np.concatenate([rows, every])
        unique, slot = np.unique(keys, return_inverse=True)
        self.size = size
        self.slots = slot[: len(rows)]
        self.count = len(unique)
        self.diagonal = slot[len(rows) :]
        self.indices = (unique % size).astype(np.int32)
        self.indptr = np.searchsorted(unique // size, np.arange(size + 1)).astype(np.int32)

    def solve(self, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """Solve the symmetric positive definite system of entries `data` for `rhs`."""
        h = sparse.csc_matrix((data, self.indices, self.indptr), shape=(self.size, self.size))
        lu = splu(
            h,
            permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
        return lu.solve(rhs)


@numba.njit(cache=True, nogil=True)
def _normal_equations(
    x: np.ndarray,
    ii: np.ndarray,
    jj: np.ndarray,
    z: np.ndarray,
    info0: np.ndarray,
    weights: np.ndarray,
    slots: np.ndarray,
    count: int,
) -> tuple[np.ndarray, np.ndarray]:
    # The Gauss-Newton system at poses x: the stored entries of J' W J (each edge's
    # blocks (i,i), (i,j), (j,i), (j,j) added at `slots`, in _Pattern's order) and J' W e.
    m = ii.shape[0]
    data = np.zeros(count)
    g = np.zeros(3 * x.shape[0])
    a = np.zeros((3, 3))
    b = np.zeros((3, 3))
    info = np.empty((3, 3))
    err = np.empty(3)
    for e in range(m):
        i, j = ii[e], jj[e]
        c, s = np.cos(x[i, 2]), np.sin(x[i, 2])
        dx, dy = x[j, 0] - x[i, 0], x[j, 1] - x[i, 1]
        err[0] = c * dx + s * dy - z[e, 0]
        err[1] = -s * dx + c * dy - z[e, 1]
        err[2] = (x[j, 2] - x[i, 2] - z[e, 2] + np.pi) % (2 * np.pi) - np.pi
        a[0, 0], a[0, 1], a[0, 2] = -c, -s, -s * dx + c * dy
        a[1, 0], a[1, 1], a[1, 2] = s, -c, -c * dx - s * dy
        a[2, 2] = -1.0
        b[0, 0], b[0, 1], b[1, 0], b[1, 1], b[2, 2] = c, s, -s, c, 1.0
        for r in range(3):
            for q in range(3):
                info[r, q] = info0[e, r, q] * weights[e]
        for blk in range(4):
            left = a if blk < 2 else b
            right = a if blk == 0 or blk == 2 else b
            base = (blk * m + e) * 9
            for r in range(3):
                for q in range(3):
                    v = 0.0
                    for u in range(3):
                        for w in range(3):
                            v += left[u, r] * info[u, w] * right[w, q]
                    data[slots[base + 3 * r + q]] += v
        for r in range(3):
            ga = 0.0
            gb = 0.0
            for u in range(3):
                oe = info[u, 0] * err[0] + info[u, 1] * err[1] + info[u, 2] * err[2]
                ga += a[u, r] * oe
                gb += b[u, r] * oe
            g[3 * i + r] += ga
            g[3 * j + r] += gb
    return data, g


def optimize_graph(
    poses: np.ndarray,
    edges: list[Edge],
    iterations: int = 20,
    fixed: int = 0,
    loop_kernel: float | None = None,
) -> tuple[np.ndarray, float, float]:
    """Sparse Levenberg-Marquardt over SE(2) poses (N, 3) with `fixed` held where it is
    (the gauge); loop closures under a Cauchy kernel of width `loop_kernel` (standard
    deviations) when given, by reweighting. Returns (optimised poses, cost before, cost
    after)."""
    x = np.asarray(poses, dtype=np.float64).copy()
    n = x.shape[0]
    if not edges or n < 2:
        c = graph_cost(x, edges)
        return x, c, c
    for e in edges:
        if not (0 <= e.i < n and 0 <= e.j < n) or e.i == e.j:
            raise ValueError(f"pose graph: edge ({e.i}, {e.j}) is not between two of {n} nodes")
    ii = np.array([e.i for e in edges])
    jj = np.array([e.j for e in edges])
    z = np.array([e.z for e in edges], dtype=np.float64)
    info0 = np.array([e.info for e in edges], dtype=np.float64)
    loop = np.array([e.loop for e in edges], dtype=bool)
    pattern = _Pattern(n, ii, jj)

    def cost_of(p: np.ndarray) -> tuple[float, np.ndarray]:
        err = _errors(p, ii, jj, z)
        return _robust(np.einsum("ei,eij,ej->e", err, info0, err), loop, loop_kernel)

    start, weights = cost_of(x)
    cost = start
    lam = 1e-4
    anchor = np.zeros(3 * n)
    anchor[3 * fixed : 3 * fixed + 3] = 1e12
    for _ in range(iterations):
        data, g = _normal_equations(x, ii, jj, z, info0, weights, pattern.slots, pattern.count)
        diag = data[pattern.diagonal]
        while True:
            damped = data.copy()
            damped[pattern.diagonal] += lam * (diag + 1e-9) + anchor
            step = pattern.solve(damped, -g).reshape(n, 3)
            step[fixed] = 0.0
            trial = x + step
            trial[:, 2] = (trial[:, 2] + np.pi) % (2 * np.pi) - np.pi
            new, new_weights = cost_of(trial)
            if new <= cost:
                x, lam, weights = trial, max(lam / 10, 1e-9), new_weights
                break
            lam *= 10
            if lam > 1e6:
                return x, start, cost
        done = cost - new < 1e-9 * max(cost, 1e-12) or np.abs(step).max() < 1e-7
        cost = new
        if done:
            break
    return x, start, cost


def optimize_pruned(
    poses: np.ndarray, edges: list[Edge], kernel: float, max_chi2: float, rounds: int
) -> tuple[np.ndarray, list[Edge]]:
    """`optimize_graph` with loop closures under a Cauchy kernel of width `kernel`; then,
    while a closure's chi-square stays above `max_chi2` (it does not fit the rest of the
    graph), the worst is taken out and the graph optimised again, `rounds` times at
    most. Returns the poses and the closures taken out."""
    after, _, _ = optimize_graph(poses, edges, loop_kernel=kernel)
    removed: list[Edge] = []
    for _ in range(rounds):
        loops = [e for e in edges if e.loop]
        if not loops:
            break
        chi = edge_chi2(after, loops)
        worst = int(np.argmax(chi))
        if chi[worst] <= max_chi2:
            break
        removed.append(loops[worst])
        edges = [e for e in edges if e is not loops[worst]]
        after, _, _ = optimize_graph(after, edges, loop_kernel=kernel)
    return after, removed


@numba.njit(cache=True, nogil=True)
def _stamp(field: np.ndarray, ox: float, oy: float, res: float, pts: np.ndarray, sigma: float):
    rows, cols = field.shape
    k = int(np.ceil(3.0 * sigma / res))
    for i in range(pts.shape[0]):
        c0 = int(np.floor((pts[i, 0] - ox) / res))
        r0 = int(np.floor((pts[i, 1] - oy) / res))
        for r in range(max(0, r0 - k), min(rows, r0 + k + 1)):
            dy = oy + (r + 0.5) * res - pts[i, 1]
            for c in range(max(0, c0 - k), min(cols, c0 + k + 1)):
                dx = ox + (c + 0.5) * res - pts[i, 0]
                v = np.exp(-(dx * dx + dy * dy) / (2.0 * sigma * sigma))
                if v > field[r, c]:
                    field[r, c] = v


def point_field(
    points: np.ndarray, resolution: float, sigma: float, box: tuple[float, float, float, float]
) -> tuple[np.ndarray, tuple[float, float]]:
    """A likelihood field over `box` (xmin, ymin, xmax, ymax, m): each cell the highest
    exp(-d^2 / 2 sigma^2) over the (N, 2) points, d its distance to the point (1 on a
    point, Olson's field); with its origin. Only the box is computed, whatever the
    points' extent."""
    x0 = np.floor(box[0] / resolution) * resolution
    y0 = np.floor(box[1] / resolution) * resolution
    cols = max(1, int(np.ceil((box[2] - x0) / resolution)))
    rows = max(1, int(np.ceil((box[3] - y0) / resolution)))
    field = np.zeros((rows, cols), dtype=np.float32)
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    _stamp(field, x0, y0, resolution, pts, sigma)
    return field, (float(x0), float(y0))


@numba.njit(cache=True, nogil=True)
def _max_pool(field: np.ndarray, block: int) -> np.ndarray:
    """Each `block` x `block` cell of a coarser field holds the highest of the cells it
    covers: a bound, at the coarse level, of what any pose in it can score."""
    rows, cols = field.shape
    out = np.zeros(((rows + block - 1) // block, (cols + block - 1) // block), field.dtype)
    for r in range(rows):
        for c in range(cols):
            v = field[r, c]
            if v > out[r // block, c // block]:
                out[r // block, c // block] = v
    return out


@numba.njit(cache=True, nogil=True)
def _correlate_peaks(
    field: np.ndarray,
    ox: float,
    oy: float,
    res: float,
    pts: np.ndarray,
    gx: float,
    gy: float,
    yaws: np.ndarray,
    steps: int,
    step_cells: int,
    occupancy: bool,
) -> np.ndarray:
    # The score (mean field value at the points) of every pose of the window, as an
    # array (angles, 2 steps + 1, 2 steps + 1); translations move by `step_cells` cells.
    # With `occupancy` the field holds log-odds, read as occupancy in [0, 1].
    rows, cols = field.shape
    n = pts.shape[0]
    out = np.zeros((yaws.shape[0], 2 * steps + 1, 2 * steps + 1))
    rr = np.empty(n, np.int64)
    cc = np.empty(n, np.int64)
    for a in range(yaws.shape[0]):
        c, s = np.cos(yaws[a]), np.sin(yaws[a])
        for k in range(n):
            cc[k] = int(np.floor((gx + c * pts[k, 0] - s * pts[k, 1] - ox) / res))
            rr[k] = int(np.floor((gy + s * pts[k, 0] + c * pts[k, 1] - oy) / res))
        for i in range(-steps, steps + 1):
            for j in range(-steps, steps + 1):
                total = 0.0
                for k in range(n):
                    r = rr[k] + i * step_cells
                    q = cc[k] + j * step_cells
                    if 0 <= r < rows and 0 <= q < cols:
                        v = field[r, q]
                        if occupancy:
                            total += 0.5 + 0.5 * v / (1.0 + abs(v))
                        else:
                            total += v
                    elif occupancy:
                        total += 0.5
                out[a, i + steps, j + steps] = total / max(1, n)
    return out


@dataclass(frozen=True)
class Search:
    """What a correlative search found: the best pose, its score, and the covariance of
    the poses that score nearly as well (within `SPREAD` of the best), weighted by their
    scores: long along a corridor, where the scan cannot tell the places apart (Karto's
    covariance of a correlative match)."""

    pose: np.ndarray
    response: float
    cov: np.ndarray
    # The best poses that are local peaks (apart by more than a step), best first.
    peaks: tuple[np.ndarray, ...] = ()


# The poses within this share of the best score make a search's spread.
SPREAD = 0.9
# A loop closure's search: the places kept from each level for the next, and the share
# of the best match's score at which another of them is a place the scan fits as well.
LOOP_PLACES = 8
AMBIGUOUS = 0.8


def search(
    field: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    points: np.ndarray,
    guess: np.ndarray,
    space: float,
    angle: float,
    angle_step: float,
    step_cells: int = 1,
    occupancy: bool = False,
    peaks: int = 0,
) -> Search:
    """The pose within +-`space` m (in steps of `step_cells` cells) and +-`angle` rad (in
    steps of `angle_step`) of `guess` that puts `points` ((N, 2), base frame) on the
    highest mean of `field`, by brute force (Olson's correlative matching, one
    resolution), with the spread of the near-best poses and the `peaks` best local
    peaks; with `occupancy`, `field` is a log-odds grid read as occupancy."""
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    g = np.asarray(guess, dtype=np.float64)
    step = resolution * step_cells
    floor = np.diag([step * step / 12, step * step / 12, angle_step * angle_step / 12])
    if pts.shape[0] == 0 or field.size == 0:
        return Search(g.copy(), 0.0, floor)
    if not (space >= 0 and angle >= 0 and angle_step > 0):
        raise ValueError("correlative search: need space >= 0, angle >= 0, angle_step > 0")
    offsets = np.arange(-angle, angle + 1e-9, angle_step)
    yaws = g[2] + offsets
    steps = max(0, round(space / step))
    scores = _correlate_peaks(
        np.ascontiguousarray(field),
        origin[0],
        origin[1],
        resolution,
        pts,
        float(g[0]),
        float(g[1]),
        yaws,
        steps,
        step_cells,
        occupancy,
    )
    a, i, j = np.unravel_index(int(np.argmax(scores)), scores.shape)
    best = float(scores[a, i, j])
    pose = np.array([g[0] + (j - steps) * step, g[1] + (i - steps) * step, wrap(float(yaws[a]))])
    near = np.argwhere(scores >= SPREAD * best) if best > 0 else np.zeros((0, 3), int)
    cov = floor
    if len(near) > 1:
        w = scores[near[:, 0], near[:, 1], near[:, 2]]
        d = np.stack(
            [(near[:, 2] - j) * step, (near[:, 1] - i) * step, offsets[near[:, 0]] - offsets[a]],
            axis=1,
        )
        cov = (w[:, None, None] * d[:, :, None] * d[:, None, :]).sum(axis=0) / w.sum() + floor
        cov = _unbounded(cov, space, angle)
    return Search(pose, best, cov, _peaks(scores, g, yaws, steps, step, peaks) if peaks else ())


def _unbounded(cov: np.ndarray, space: float, angle: float) -> np.ndarray:
    """A search's spread with the directions it reached the window's edge along made
    wide open: there the window, not the scan, bounded it (a corridor longer than the
    window), so the match says nothing along them."""
    out = cov.copy()
    vals, vecs = np.linalg.eigh(out[:2, :2])
    if 2.0 * np.sqrt(max(vals[-1], 0.0)) > 0.5 * space > 0:
        vals[-1] = max(vals[-1], (10.0 * space) ** 2)
        out[:2, :2] = (vecs * vals) @ vecs.T
        out[:2, 2] = out[2, :2] = 0.0
    if 2.0 * np.sqrt(max(out[2, 2], 0.0)) > 0.5 * angle > 0:
        out[2, 2] = max(out[2, 2], (10.0 * angle) ** 2)
    return out


def _peaks(
    scores: np.ndarray, g: np.ndarray, yaws: np.ndarray, steps: int, step: float, k: int
) -> tuple[np.ndarray, ...]:
    """The `k` best poses of a search's scores that lie more than a step apart, as poses
    (x, y, yaw) with their scores in a fourth column."""
    flat = np.argsort(scores, axis=None)[::-1][: 64 * k]
    chosen: list[tuple[int, int, int]] = []
    out = []
    for f in flat:
        a, i, j = np.unravel_index(int(f), scores.shape)
        if any(abs(a - x) <= 1 and abs(i - y) <= 1 and abs(j - z) <= 1 for x, y, z in chosen):
            continue
        chosen.append((a, i, j))
        x, y = g[0] + (j - steps) * step, g[1] + (i - steps) * step
        out.append(np.array([x, y, wrap(float(yaws[a])), float(scores[a, i, j])]))
        if len(chosen) == k:
            break
    return tuple(out)


def coarse_to_fine(
    field: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    points: np.ndarray,
    guess: np.ndarray,
    space: float,
    angle: float,
    angle_step: float,
    coarse_space: float,
    keep: int = 4,
) -> tuple[Search, list[Search]]:
    """A correlative search over a wide window, coarse to fine: first on cells `block`
    times larger, each the best of the cells it covers (an upper bound of what the poses
    in it score), with `block` the power of two that leaves about +-`coarse_space` /
    resolution steps, in angle steps as many times larger; then, level by level with
    cells half as large, around the `keep` best poses of the level above. Returns the
    coarsest level's search (its spread says how far along a corridor the scan could
    lie) and the finest level's searches around those poses, best first (the places in
    the window the scan fits nearly as well as the best are among them)."""
    block = 1
    while space > coarse_space * block and block < 64:
        block *= 2
    fields = {1: field}
    b = 2
    while b <= block:
        fields[b] = _max_pool(fields[b // 2], 2)
        b *= 2
    steps = max(1.0, angle / angle_step)
    first = search(fields[block], origin, resolution * block, points, guess, space, angle,
                   angle / max(1.0, np.ceil(steps / block)), peaks=keep)  # fmt: skip
    level_angle = angle / max(1.0, np.ceil(steps / block))
    seeds = [q[:3] for q in first.peaks[:keep]] or [first.pose]
    tried = [first]
    while block > 1:
        block //= 2
        tried = [
            search(fields[block], origin, resolution * block, points, q,
                   2 * block * resolution, level_angle, max(angle_step, level_angle / 2))
            for q in seeds
        ]  # fmt: skip
        level_angle = max(angle_step, level_angle / 2)
        tried.sort(key=lambda s: -s.response)
        seeds = [s.pose for s in tried[:keep]]
    return first, tried


def open_axis(coarse: Search, space: float) -> np.ndarray:
    """The covariance (3 x 3) along the one direction in which a coarse search's
    near-best poses reached half its window (+-`space` m): a corridor longer than the
    window, along which the match says nothing (10 windows of standard deviation); zero
    across it and in heading, and zero when the spread stayed within the window."""
    out = np.zeros((3, 3))
    vals, vecs = np.linalg.eigh(0.5 * (coarse.cov[:2, :2] + coarse.cov[:2, :2].T))
    if space > 0 and vals[-1] >= 0.99 * (10.0 * space) ** 2:  # opened by `_unbounded`
        out[:2, :2] = vals[-1] * np.outer(vecs[:, -1], vecs[:, -1])
    return out


def ambiguity(found: list[Search], share: float = AMBIGUOUS) -> np.ndarray:
    """The covariance (3 x 3, x y yaw) a match takes from the other places it fits: the
    sum of d d' over the poses among `found` (best first) that score at least `share` of
    the best, d their offset from it. Long along a corridor where the scan fits a few
    metres further on as well, nothing across it; zero when no other place fits."""
    best = found[0]
    out = np.zeros((3, 3))
    for other in found[1:]:
        if other.response >= share * best.response:
            d = other.pose - best.pose
            d[2] = wrap(float(d[2]))
            out += np.outer(d, d)
    return out


@dataclass(frozen=True)
class _Solution:
    """What a back-end pass hands to the scan path: the optimised poses `after` of the
    first len(after) nodes, the poses `before` they had when the pass began, the local
    map of the window's nodes among them at `after` (with those nodes), and the map of
    them all (when one is kept)."""

    before: np.ndarray
    after: np.ndarray
    local: LogOddsGrid
    window: list[int]
    map: TiledGrid | None


@dataclass
class _Closure:
    """A verified match waiting for a second one that agrees: the loop edge, the node it
    closes from, where it says that node is (x, y, yaw, in the map frame) and how
    uncertain that is (3 x 3, map frame)."""

    edge: Edge
    node: int
    target: np.ndarray
    cov: np.ndarray


def _information(cov: np.ndarray, floor: tuple[float, float, float]) -> np.ndarray:
    """The information of a covariance whose standard deviations are held at least at
    `floor` (x, y, yaw) along every direction."""
    cov = 0.5 * (cov + cov.T)
    scale = np.array(floor)
    unit = cov / np.outer(scale, scale)
    vals, vecs = np.linalg.eigh(unit)
    vals = np.maximum(vals, 1.0)
    return (vecs / vals) @ vecs.T / np.outer(scale, scale)


def _span(edge: Edge) -> float:
    """Three standard deviations of a constraint's position, along its least certain
    direction (m)."""
    return float(3.0 / np.sqrt(max(np.linalg.eigvalsh(edge.info[:2, :2])[0], 1e-12)))


def _rotate(m: np.ndarray, yaw: float) -> np.ndarray:
    """A 3 x 3 information matrix over a world pose, in the frame of a pose at `yaw`."""
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.eye(3)
    rot[:2, :2] = [[c, -s], [s, c]]
    return rot.T @ m @ rot


class PoseGraphSlam:
    """Feed scans with `process`; read `pose`, `grid`, `trajectory` and `closures`.

    The scan path (`process`) matches every scan against the local map and adds the
    nodes. The back end (loop-closure searches and the optimisation) runs in one worker
    thread when `params.background` (its heavy parts, the compiled correlative search and
    the sparse solve, release the GIL), otherwise inline. Its result is swapped in at the
    start of the next `process`: the optimised poses and the nodes added meanwhile carried
    along with the last optimised one. When `backend_max_backlog` nodes wait for the
    worker, adding the next one waits for the pass it runs. `settle` waits for the back
    end and optimises what is still pending; `close` stops the worker."""

    uses_odometry = False

    def __init__(self, params: PoseGraphParams | None = None) -> None:
        self.params = p = params or PoseGraphParams()
        self._model = LogOddsModel.from_probabilities(0.4, 0.9)
        # The local map sums the window's scans unclamped, so a scan leaving it can be
        # taken back exactly.
        self._local_model = LogOddsModel(
            self._model.free, self._model.occupied, -1e9, 1e9, self._model.hit_margin
        )
        self._local = LogOddsGrid(p.resolution, model=self._local_model)
        self._window: deque[tuple[int, np.ndarray]] = deque()
        self.matcher = ScanMatcher(p.match_levels, p.iterations)
        self.pose = np.zeros(3)
        self.nodes: list[np.ndarray] = []
        self.scans: list[Beams] = []
        self.edges: list[Edge] = []
        # The loop closures among `edges` (the back end reads them at every pass), and
        # how certain each is (`_span`, computed once).
        self._loops: list[Edge] = []
        self._spans: dict[tuple[int, int, int], float] = {}
        self.closures = 0
        self.rejected = 0
        self.removed = 0
        self.loop_attempts = 0
        self.optimizations = 0
        self.optimize_time = 0.0
        self.backend_time = 0.0
        self.map_updates = 0
        self.searches = 0
        self._pending: list[_Closure] = []
        self._unoptimised = 0
        self._last_closure = -1 << 30
        self._last_info = np.eye(3)
        self._residual = 0.1
        self._last_odom: np.ndarray | None = None
        # How fast the last match found the robot turning (rad/s).
        self._turn_rate = 0.0
        self._node_odom: list[np.ndarray | None] = []
        self._node_stamps: list[float] = []
        self._path = [0.0]
        self.stamps: list[float] = []
        # Every scan's pose as (node index, pose relative to that node).
        self._anchors: list[int] = []
        self._offsets: list[np.ndarray] = []
        # The map kept for `grid`: built from the first `_map_nodes` nodes at version
        # `_map_version` of their poses.
        self._map: TiledGrid | None = None
        self._map_nodes = 0
        self._version = 0
        self._map_version = -1
        # Shared with the back end: nodes, scans and edges grow under the lock; `_queue`
        # holds the nodes still to be searched for a loop; `_solution` waits to be
        # swapped in. A pass is only started when none runs and no solution waits, so
        # the first len(solution.after) nodes do not move while a pass runs.
        self._lock = threading.Lock()
        self._queue: list[int] = []
        self._solution: _Solution | None = None
        self._job: Future[None] | None = None
        self._executor: ThreadPoolExecutor | None = None

    def range_limits(self, range_max: float) -> tuple[float, float, float]:
        """(min, maximum, usable) range: readings past max_laser_range (or the scanner's
        range_max) are left out, as Karto does."""
        p = self.params
        top = min(p.max_laser_range, range_max - 0.01) if range_max > 0 else p.max_laser_range
        return p.laser_min_dist, top, top

    @property
    def grid(self) -> TiledGrid:
        """The map: the node scans at their current poses (call `settle` first for the
        final map). Built when asked for after the nodes moved; else the newer nodes'
        scans are added to the map kept."""
        with self._lock:
            nodes = [q.copy() for q in self.nodes]
            scans = self.scans[: len(nodes)]
        if self._map is None or self._map_version != self._version:
            self._map = TiledGrid(self.params.resolution, self._model)
            self._map_nodes, self._map_version = 0, self._version
        for q, s in zip(nodes[self._map_nodes :], scans[self._map_nodes :], strict=True):
            self._write(self._map, q, s)
        self._map_nodes = len(nodes)
        return self._map

    @property
    def busy(self) -> bool:
        """Whether a back-end pass is running in the worker now."""
        return self._job is not None and not self._job.done()

    # --- the scan path ---------------------------------------------------------------

    def process(self, scan: Beams, stamp: float, odom: np.ndarray | None = None) -> np.ndarray:
        """Match one scan from the odometry's prediction (odometry optional), add a node
        when the robot has moved enough and hand it to the back end; return the pose."""
        if not self.params.lockstep:
            self._adopt()
        odom = None if odom is None else np.asarray(odom, dtype=np.float64)
        guess, sigma = self._predict(odom, float(stamp))
        self._last_odom = odom
        before, self.pose = self.pose, guess
        if self.nodes and scan.hit.any():
            self.pose, self._last_info = self._match(scan.hits, guess, sigma)
            if self.stamps and stamp != self.stamps[-1]:
                turned = abs(float(wrap(self.pose[2] - before[2])))
                self._turn_rate = turned / abs(float(stamp) - self.stamps[-1])
        if self._moved_enough():
            self._add_node(scan, odom, float(stamp))
        self.stamps.append(float(stamp))
        self._anchors.append(len(self.nodes) - 1)
        self._offsets.append(relative(self.nodes[-1], self.pose))
        return self.pose.copy()

    def _motion_sigma(self, d: np.ndarray, dt: float) -> np.ndarray:
        """The standard deviations of an odometry motion `d` over `dt` s: the motion
        model's, plus the turn the robot makes in `odom_time_sigma` s at the rate it
        turns (by the odometry, or by the last match when that was faster: a stale
        odometry pose shows no turn). The odometry pose that comes with a scan may not
        be the one at the scan's instant; a heading off spoils a match far more than a
        position off."""
        p = self.params
        s = np.array(motion_sigma(d, p.odom_trans_per_trans, p.odom_trans_per_rot,
                                  p.odom_rot_per_trans, p.odom_rot_per_rot))  # fmt: skip
        if abs(dt) > 1e-6:
            s[2] += p.odom_time_sigma * max(abs(float(d[2])) / abs(dt), self._turn_rate)
        return np.maximum(s, [p.odom_min_sigma_xy, p.odom_min_sigma_xy, p.odom_min_sigma_yaw])

    def _predict(
        self, odom: np.ndarray | None, stamp: float
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Where the odometry puts the robot now, and how uncertain that is (x, y, yaw
        standard deviations, in the frame of the last pose); None without odometry."""
        if odom is None or self._last_odom is None:
            return self.pose.copy(), None
        d = relative(self._last_odom, odom)
        return compose(self.pose, d), self._motion_sigma(d, stamp - self.stamps[-1])

    def _match(
        self, pts: np.ndarray, guess: np.ndarray, sigma: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The pose of the scan on the local map, and the information of that match
        (over the world pose): a correlative search over the prediction's uncertainty
        when that exceeds what Gauss-Newton reaches, then Gauss-Newton with the
        prediction as a prior."""
        p = self.params
        grid = self._local
        if sigma is None:
            space, angle = p.correlation_search_space, p.correlation_search_angle
        else:
            space = min(3.0 * float(max(sigma[0], sigma[1])), p.correlation_search_space)
            angle = min(3.0 * float(sigma[2]), p.correlation_search_angle)
        start = guess
        reach = p.resolution * (1 << (p.match_levels - 1))
        if space > reach or angle > p.gauss_newton_reach_angle:
            sub = pts[:: max(1, pts.shape[0] // p.correlation_points)]
            far = float(np.percentile(np.hypot(sub[:, 0], sub[:, 1]), 90)) if len(sub) else 1.0
            step = max(p.resolution * 2, 1e-3)
            found = search(
                grid.logodds,
                grid.origin,
                grid.resolution,
                sub,
                guess,
                space,
                angle,
                max(step / max(far, 1.0), 0.002),
                step_cells=2,
                occupancy=True,
            )
            self.searches += 1
            start = found.pose
        prior = None
        if sigma is not None:
            # The matcher's cost is the sum of squared residuals; a residual's variance
            # is the match's (its mean square, scaled): the prior is weighed as much
            # heavier as that variance is smaller than 1.
            k = np.sqrt(p.match_variance_scale * max(self._residual, 1e-3))
            sxy = float(max(sigma[0], sigma[1])) / k
            prior = (sxy, sxy, float(sigma[2]) / k)
        res = self.matcher.match(grid, pts, start, None, prior, guess)
        self._residual = res.residual
        hess = res.hessian.copy()
        if prior is not None:
            # The prior's part of the Hessian belongs to the odometry edge, not the match.
            hess -= np.diag(1.0 / np.maximum(np.asarray(prior), 1e-3) ** 2)
        floor = (p.match_min_sigma_xy, p.match_min_sigma_xy, p.match_min_sigma_yaw)
        return res.pose, _information(self._match_cov(hess, res.residual), floor)

    def _match_cov(self, hess: np.ndarray, residual: float) -> np.ndarray:
        """A match's covariance: the inverse of its Hessian, scaled by the fit's mean
        squared residual (a direction the scan cannot see comes out very uncertain)."""
        h = 0.5 * (hess + hess.T)
        h = h + np.eye(3) * 1e-6 * max(float(np.trace(h)), 1.0)
        return np.linalg.inv(h) * self.params.match_variance_scale * max(residual, 1e-3)

    def _moved_enough(self) -> bool:
        if not self.nodes:
            return True
        d = relative(self.nodes[-1], self.pose)
        p = self.params
        return bool(
            np.hypot(d[0], d[1]) >= p.minimum_travel_distance
            or abs(d[2]) >= p.minimum_travel_heading
        )

    def _add_node(self, scan: Beams, odom: np.ndarray | None, stamp: float) -> None:
        p = self.params
        behind = p.lockstep or len(self._queue) >= p.backend_max_backlog
        if behind and self._job is not None:
            job, self._job = self._job, None
            job.result()
            self._adopt()
        k = len(self.nodes)
        with self._lock:
            self.nodes.append(self.pose.copy())
            self.scans.append(scan)
            self._node_odom.append(None if odom is None else odom.copy())
            self._node_stamps.append(stamp)
            if k > 0:
                prev = self.nodes[k - 1]
                self._path.append(self._path[-1] + float(np.hypot(*(self.pose - prev)[:2])))
                self.edges.append(
                    Edge(k - 1, k, relative(prev, self.pose), _rotate(self._last_info, prev[2]))
                )
                before = self._node_odom[k - 1]
                if odom is not None and before is not None:
                    d = relative(before, odom)
                    dt = stamp - self._node_stamps[k - 1]
                    info = np.diag(1.0 / self._motion_sigma(d, dt) ** 2)
                    self.edges.append(Edge(k - 1, k, d, info))
                self._queue.append(k)
        self._window.append((k, self.pose.copy()))
        self._local_write(self.pose, scan, 1.0)
        keep = len(self._in_window([j for j, _ in self._window]))
        while len(self._window) > keep:
            old, at = self._window.popleft()
            self._local_write(at, self.scans[old], -1.0)
        self._recentre()
        self.map_updates += 1
        if k > 0:
            self._start_pass()

    def _local_write(
        self, pose: np.ndarray, scan: Beams, weight: float, grid: LogOddsGrid | None = None
    ) -> None:
        """Add a scan to the local map (or `grid`) at `pose` (weight 1) or take it back
        (-1). The map grows by a quarter of the laser's range at a time: each growth
        copies it."""
        grid = self._local if grid is None else grid
        origin = transform_points(pose, np.array([scan.origin]))[0]
        ends = transform_points(pose, scan.ends)
        if len(ends):
            lo = np.minimum(ends.min(axis=0), origin)
            hi = np.maximum(ends.max(axis=0), origin)
            grid.ensure(lo[0], lo[1], hi[0], hi[1], 0.25 * self.params.max_laser_range)
        grid.integrate(origin, ends, scan.hit, scan.angle_step, weight)

    def _in_window(self, nodes: list[int]) -> list[int]:
        """The last of `nodes` (increasing) that the local map holds: at most
        `scan_buffer_size`, within `scan_buffer_maximum_scan_distance` m of path of the
        newest."""
        p = self.params
        out: list[int] = []
        for k in reversed(nodes):
            if len(out) >= p.scan_buffer_size or (
                out and self._path[out[0]] - self._path[k] > p.scan_buffer_maximum_scan_distance
            ):
                break
            out.insert(0, k)
        return out

    def _recentre(self) -> None:
        """Build the local map anew when it has grown far past the window's scans (the
        grid only ever grows as the robot moves on)."""
        reach = 2.0 * self.params.max_laser_range + 4.0
        x0, y0, x1, y1 = self._local.extent()
        if (x1 - x0) * (y1 - y0) > 2.0 * reach * reach:
            self._local = self._local_map(
                [k for k, _ in self._window], [self.nodes[k] for k, _ in self._window]
            )
            self._window = deque((k, self.nodes[k].copy()) for k, _ in self._window)

    def _local_map(self, ids: list[int], poses: list[np.ndarray]) -> LogOddsGrid:
        """A local map of the scans of nodes `ids` at `poses`."""
        grid = LogOddsGrid(self.params.resolution, model=self._local_model)
        for k, q in zip(ids, poses, strict=True):
            self._local_write(q, self.scans[k], 1.0, grid)
        return grid

    @staticmethod
    def _write(grid: TiledGrid, pose: np.ndarray, scan: Beams) -> None:
        origin = transform_points(pose, np.array([scan.origin]))[0]
        grid.integrate(origin, transform_points(pose, scan.ends), scan.hit)

    # --- the back end ----------------------------------------------------------------

    def _start_pass(self, flush: bool = False) -> None:
        """Run a back-end pass (in the worker, or here) if there is work and none runs."""
        if self._job is not None and self._job.done():
            job, self._job = self._job, None
            job.result()  # a failure in the back end surfaces here, on the scan path
        if self.busy or self._solution is not None:
            return
        if not self._queue and not (flush and self._unoptimised):
            return
        # the pass's input is taken here, on the scan path: what it sees does not
        # depend on when the worker starts
        with self._lock:
            todo, self._queue = self._queue, []
            nodes = np.array(self.nodes)
            scans = self.scans[: len(nodes)]
            loops = list(self._loops)
        if not self.params.background:
            self._backend_pass(flush, todo, nodes, scans, loops)
            self._adopt()
            return
        if self._executor is None:
            self._executor = ThreadPoolExecutor(1, thread_name_prefix="posegraph-backend")
        self._job = self._executor.submit(self._backend_pass, flush, todo, nodes, scans, loops)

    def _backend_pass(
        self,
        flush: bool,
        todo: list[int],
        nodes: np.ndarray,
        scans: list[Beams],
        loops: list[Edge],
    ) -> None:
        """Search the nodes `todo` for loop closures and verify them; optimise when the
        accepted closures disagree with the estimate (or at a flush), leaving the result
        in `_solution`. Runs in the worker on a snapshot of the nodes, their scans and the
        loop closures; touches no state of the scan path but the shared lists (under the lock)."""
        t0 = time.perf_counter()
        p = self.params
        graph = None
        for k in todo:
            if k <= p.loop_min_chain or k - self._last_closure <= p.loop_cooldown:
                continue
            if graph is None:
                graph = self._graph_distances(len(nodes), loops)
            found = self._close_loop(k, nodes, scans, graph)
            if found is not None:
                accepted = self._confirm(found, nodes)
                if accepted:
                    loops.extend(accepted)
                    graph = None
                    with self._lock:
                        self.edges.extend(accepted)
                        self._loops.extend(accepted)
        chi = edge_chi2(nodes, loops)
        surprise = bool(len(chi)) and float(chi.max()) > p.loop_optimize_chi2
        if self._unoptimised and (flush or surprise or self._unoptimised >= p.optimize_every):
            self._solution = self._optimise(nodes, scans)
        self.backend_time += time.perf_counter() - t0

    def _graph_distances(self, n: int, closures: list[Edge]) -> sparse.csr_matrix:
        """The graph of the first `n` nodes as a sparse matrix of path lengths: the chain
        between consecutive nodes as long as the motion; a loop closure as long as the
        path over which the search window grows by 3 of its standard deviations (a
        closure along a corridor, open along it, is no short cut)."""
        steps = np.asarray(self._path[:n])
        chain = np.diff(steps)
        loops = [e for e in closures if e.i < n and e.j < n]
        growth = max(self.params.loop_search_growth, 1e-9)
        spans = [self._spans.setdefault((id(e), e.i, e.j), _span(e)) for e in loops]
        rows = np.concatenate([np.arange(n - 1), np.array([e.i for e in loops], dtype=int)])
        cols = np.concatenate([np.arange(1, n), np.array([e.j for e in loops], dtype=int)])
        length = np.concatenate(
            [np.maximum(chain, 1e-3), np.maximum(np.array(spans) / growth, 0.1)]
        )
        return sparse.coo_matrix((length, (rows, cols)), shape=(n, n)).tocsr()

    def _close_loop(
        self, k: int, nodes: np.ndarray, scans: list[Beams], graph: sparse.csr_matrix
    ) -> _Closure | None:
        """A verified match of node k against an earlier node within reach, or None."""
        p = self.params
        here = nodes[k]
        last = k - p.loop_min_chain
        if last < 0:
            return None
        # Graph distances beyond the widest window need not be known exactly.
        limit = (p.loop_search_space_max - p.loop_search_space) / max(p.loop_search_growth, 1e-9)
        gd = dijkstra(graph, directed=False, indices=k, limit=limit)[: last + 1]
        window = np.minimum(
            p.loop_search_space + p.loop_search_growth * gd, p.loop_search_space_max
        )
        window[~np.isfinite(gd)] = p.loop_search_space_max
        d = np.hypot(nodes[: last + 1, 0] - here[0], nodes[: last + 1, 1] - here[1])
        reach = p.loop_search_maximum_distance + window
        near = d <= reach
        if not near.any():
            return None
        # The place least known from here is the one to close: among the nodes within
        # reach, those at least half as far along the graph as the farthest, and of
        # those the nearest (a node just behind in the chain adds nothing).
        far = np.where(np.isfinite(gd), gd, 2.0 * limit)
        near &= far >= 0.5 * far[near].max()
        cand = int(np.argmin(np.where(near, d, np.inf)))
        space = float(window[cand])
        hits = scans[k].hits
        if hits.shape[0] < 20:
            return None
        self.loop_attempts += 1
        lo, hi = max(0, cand - p.loop_neighbours), min(last, cand + p.loop_neighbours)
        sub = hits[:: max(1, hits.shape[0] // p.loop_points)]
        angle = p.loop_search_angle_max
        if np.isfinite(gd[cand]):
            grown = p.loop_search_angle + p.loop_search_angle_growth * float(gd[cand])
            angle = min(grown, angle)
        # The field covers where the scan can land (its points at the estimate, widened
        # by the window) and where the candidate's scans saw something.
        at = transform_points(here, sub)
        pad = space + 0.5 + angle * float(np.percentile(np.hypot(*sub.T), 90))
        old_hits = np.concatenate(
            [transform_points(nodes[n], scans[n].hits) for n in range(lo, hi + 1)]
        )
        box = (
            max(at[:, 0].min() - pad, old_hits[:, 0].min() - 0.5),
            max(at[:, 1].min() - pad, old_hits[:, 1].min() - 0.5),
            min(at[:, 0].max() + pad, old_hits[:, 0].max() + 0.5),
            min(at[:, 1].max() + pad, old_hits[:, 1].max() + 0.5),
        )
        if box[2] <= box[0] or box[3] <= box[1]:
            return None
        res = p.loop_resolution
        field, origin = point_field(old_hits, res, res, box)
        coarse, tried = coarse_to_fine(
            field, origin, res, sub, here, space, angle, p.loop_search_angle_step,
            p.loop_search_space, LOOP_PLACES,
        )  # fmt: skip
        found = tried[0]
        if found.response < p.loop_match_minimum_response:
            return None
        # Gauss-Newton on the same field, read as occupancy 0.5 + 0.5 f.
        smooth = LogOddsGrid(res, origin, field.shape)
        smooth.logodds = (field / (1.0001 - field)).astype(np.float32)
        refined = self.matcher.match(smooth, hits, found.pose)
        # Consistency: the Gauss-Newton refinement stays by the search's peak.
        shift = relative(found.pose, refined.pose)
        if np.hypot(shift[0], shift[1]) > 2 * res or abs(shift[2]) > 0.02:
            self.rejected += 1
            return None
        where = self._sub_cell(refined.pose, hits, list(range(lo, hi + 1)), nodes)
        anchor = nodes[cand]
        # As uncertain as the other places the scan fits nearly as well (per direction:
        # along a corridor, not across it), the fine search's spread and the fit's.
        fit = self._match_cov(refined.hessian, refined.residual)
        cov = open_axis(coarse, space) + ambiguity(tried) + found.cov + fit
        floor = (p.loop_min_sigma_xy, p.loop_min_sigma_xy, p.loop_min_sigma_yaw)
        world = _information(cov, floor)
        edge = Edge(cand, k, relative(anchor, where), _rotate(world, anchor[2]), True)
        return _Closure(edge, k, where, np.linalg.inv(world))

    def _sub_cell(
        self, pose: np.ndarray, hits: np.ndarray, ids: list[int], nodes: np.ndarray
    ) -> np.ndarray:
        """A loop closure's pose refined below the search field's cells: Gauss-Newton
        from `pose` on an occupancy map of the candidate's scans (nodes `ids`) at the
        map's resolution, as the front end matches. On the field's own cells, as wide as
        its peaks, the bilinear fit pulls each wall onto a cell centre: up to half a cell
        off, the same way for every closure over the same walls, and the graph follows.
        The result is kept within a field cell and 0.01 rad of `pose` (else `pose`): the
        closure is still the one verified."""
        p = self.params
        grid = self._local_map(ids, [nodes[n] for n in ids])
        out = ScanMatcher(2, p.iterations).match(grid, hits, pose).pose
        shift = relative(pose, out)
        if np.hypot(shift[0], shift[1]) > p.loop_resolution or abs(shift[2]) > 0.01:
            return pose
        return out

    def _confirm(self, found: _Closure, nodes: np.ndarray) -> list[Edge]:
        """The closures that enter the graph now: `found` once a closure from a nearby
        node implies the same correction (where its node should be, carried to `found`'s
        node along the current estimate, within their covariances and the tolerances:
        two closures along a corridor agree across it), and with it any that agreed;
        closures too old to be confirmed are dropped."""
        p = self.params
        k = found.node
        self._pending = [c for c in self._pending if k - c.node <= p.loop_confirm_nodes]
        agree = []
        for c in self._pending:
            # Where c says found's node is: c's correction applied to found's estimate.
            moved = compose(c.target, relative(nodes[c.node], nodes[k]))
            off = np.array([*(found.target[:2] - moved[:2]), wrap(found.target[2] - moved[2])])
            tol = p.loop_confirm_distance + 0.02 * float(np.hypot(*(nodes[k] - nodes[c.node])[:2]))
            spread = found.cov + c.cov + np.diag([tol**2, tol**2, p.loop_confirm_angle**2])
            if float(off @ np.linalg.solve(spread, off)) <= 9.0:
                agree.append(c)
        if not agree:
            self._pending.append(found)
            return []
        accepted = [found, *agree]
        self._pending = [c for c in self._pending if c not in agree]
        self._last_closure = k
        self.closures += len(accepted)
        self._unoptimised += len(accepted)
        return [c.edge for c in accepted]

    def _optimise(self, nodes: np.ndarray, scans: list[Beams]) -> _Solution:
        """Optimise the graph over `nodes` (a snapshot); take out the loop closure whose
        error stays far beyond its covariance and optimise again, while there is one."""
        t0 = time.perf_counter()
        p = self.params
        n = len(nodes)
        with self._lock:
            edges = [e for e in self.edges if e.i < n and e.j < n]
        after, bad = optimize_pruned(
            nodes, edges, p.loop_kernel_width, p.loop_max_chi2, p.loop_removal_rounds
        )
        if bad:
            with self._lock:
                self.edges = [e for e in self.edges if not any(e is b for b in bad)]
                self._loops = [e for e in self._loops if not any(e is b for b in bad)]
            self.removed += len(bad)
            self.closures -= len(bad)
        # The maps at the new poses, built here off the scan path: the local window's,
        # and the whole map when one is kept (a live node publishes it).
        window = self._in_window(list(range(n)))
        local = self._local_map(window, [after[k] for k in window])
        full = None
        if self._map is not None:
            full = TiledGrid(p.resolution, self._model)
            for q, s in zip(after, scans, strict=True):
                self._write(full, q, s)
        self._unoptimised = 0
        self.optimizations += 1
        self.optimize_time += time.perf_counter() - t0
        return _Solution(nodes, after, local, window, full)

    def _adopt(self) -> None:
        """Swap in a finished back-end pass: the optimised nodes, the nodes added since
        moved with the last optimised one, the current pose likewise, and the local map
        rebuilt at the new poses."""
        sol = self._solution
        if sol is None:
            return
        n = len(sol.after)

        def carried(q: np.ndarray) -> np.ndarray:
            return compose(sol.after[-1], relative(sol.before[-1], q))

        with self._lock:
            newer = [carried(q) for q in self.nodes[n:]]
            moved = [q.copy() for q in sol.after] + newer
            shift = max(
                (
                    float(np.hypot(*(a - b)[:2]) + 5.0 * abs(wrap(float(a[2] - b[2]))))
                    for a, b in zip(moved, self.nodes, strict=True)
                ),
                default=0.0,
            )
            self.nodes = moved
        self.pose = carried(self.pose)
        if shift > self.params.map_rebuild_shift:
            # The pass's maps, with the scans of the nodes added since it began.
            ids = list(sol.window) + [k for k, _ in self._window if k >= n]
            for k in ids[len(sol.window) :]:
                self._local_write(moved[k], self.scans[k], 1.0, sol.local)
            self._local = sol.local
            self._window = deque((k, moved[k].copy()) for k in ids)
            self._version += 1
            if sol.map is not None:
                for q, scan in zip(moved[n:], self.scans[n : len(moved)], strict=True):
                    self._write(sol.map, q, scan)
                self._map, self._map_nodes, self._map_version = sol.map, len(moved), self._version
        self._solution = None
        # Nodes queued while the pass ran wait for the next one.
        self._start_pass()

    def settle(self) -> None:
        """Wait for the back end, search what is queued, optimise the closures still
        pending and swap the result in: afterwards `grid` and `trajectory` are final."""
        while True:
            if self._job is not None:
                self._job.result()
                self._job = None
            self._adopt()
            self._start_pass(flush=True)
            if self._job is None and self._solution is None:
                return

    def close(self) -> None:
        """Stop the worker thread (after the pass it runs, if any)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True)
            self._executor = None
            self._job = None

    def map_to_odom(self, odom: np.ndarray) -> np.ndarray:
        """The map -> odom transform that puts `odom` (the odometry pose now) at the
        estimated pose."""
        return compose(self.pose, relative(odom, np.zeros(3)))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (N,), poses (N, 3)) of every scan processed, moved with the optimised
        nodes they hang from."""
        poses = [
            compose(self.nodes[a], o) for a, o in zip(self._anchors, self._offsets, strict=True)
        ]
        return np.asarray(self.stamps), np.asarray(poses).reshape(-1, 3)
