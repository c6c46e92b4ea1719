"""Scan-to-map matching by Gauss-Newton on a smoothed occupancy grid, Hector style
(layer 3).

The map is read as a continuous function M(x, y) in [0, 1]: occupancy probabilities
bilinearly interpolated between cell centres. Matching finds the pose that puts the scan's
end points where M is 1, minimising sum (1 - M(S_i(pose)))^2 with Gauss-Newton steps
(Kohlbrecher et al. 2011). Coarse levels read the grid through blocks of 2^k x 2^k
cells, each block as occupied as its most occupied cell (a smoothed, lower-resolution
view in which thin walls stay walls), which widens the basin of convergence; matching
runs coarse to fine. The same kernels score a pose with a
likelihood field (GMapping's particle weights): each end point looks for the nearest
occupied cell in a small window.

Grids are log-odds arrays (LogOddsGrid.logodds); a cell's occupancy for matching is the
monotone map l -> 0.5 + 0.5 l / (1 + |l|), which needs no exp in the inner loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numba
import numpy as np

from robotrial.slam import cells
from robotrial.slam.grid import LogOddsGrid

if TYPE_CHECKING:
    from robotrial.slam.tiled import TiledGrid


@numba.njit(cache=True, nogil=True, inline="always")
def _occ(view: np.ndarray | tuple, r: int, c: int) -> float:
    v = cells.logodds(view, r, c)
    return 0.5 + 0.5 * v / (1.0 + abs(v))


@numba.njit(cache=True, nogil=True, inline="always")
def _coarse(view: np.ndarray | tuple, r: int, c: int, block: int) -> float:
    # A cell of a view `block` times coarser: as occupied as the most occupied cell it
    # covers.
    if block == 1:
        return _occ(view, r, c)
    best = 0.0
    for i in range(block):
        for j in range(block):
            v = _occ(view, r * block + i, c * block + j)
            if v > best:
                best = v
    return best


@numba.njit(cache=True, nogil=True, inline="always")
def _sample(
    view: np.ndarray | tuple, ox: float, oy: float, res: float, block: int, x: float, y: float
) -> tuple[float, float, float]:
    cres = res * block
    u = (x - ox) / cres - 0.5
    v = (y - oy) / cres - 0.5
    c0 = int(np.floor(u))
    r0 = int(np.floor(v))
    fu = u - c0
    fv = v - r0
    m00 = _coarse(view, r0, c0, block)
    m01 = _coarse(view, r0, c0 + 1, block)
    m10 = _coarse(view, r0 + 1, c0, block)
    m11 = _coarse(view, r0 + 1, c0 + 1, block)
    m = (1 - fv) * ((1 - fu) * m00 + fu * m01) + fv * ((1 - fu) * m10 + fu * m11)
    du = (1 - fv) * (m01 - m00) + fv * (m11 - m10)
    dv = (1 - fu) * (m10 - m00) + fu * (m11 - m01)
    return m, du / cres, dv / cres


@numba.njit(cache=True, nogil=True, inline="always")
def _solve3(
    a00: float,
    a01: float,
    a02: float,
    a11: float,
    a12: float,
    a22: float,
    b0: float,
    b1: float,
    b2: float,
) -> tuple[float, float, float]:
    # A symmetric positive definite 3x3 system by Cholesky (no allocation, no LAPACK call).
    l00 = np.sqrt(a00)
    l10 = a01 / l00
    l20 = a02 / l00
    l11 = np.sqrt(max(a11 - l10 * l10, 1e-300))
    l21 = (a12 - l20 * l10) / l11
    l22 = np.sqrt(max(a22 - l20 * l20 - l21 * l21, 1e-300))
    y0 = b0 / l00
    y1 = (b1 - l10 * y0) / l11
    y2 = (b2 - l20 * y0 - l21 * y1) / l22
    x2 = y2 / l22
    x1 = (y1 - l21 * x2) / l11
    x0 = (y0 - l10 * x1 - l20 * x2) / l00
    return x0, x1, x2


@numba.njit(cache=True, nogil=True)
def _gauss_newton(
    view: np.ndarray | tuple,
    ox: float,
    oy: float,
    res: float,
    block: int,
    pts: np.ndarray,
    stride: int,
    pose: np.ndarray,
    iterations: int,
    prior: np.ndarray,
    prior_weight: np.ndarray,
    tol: float = 1e-2,
) -> tuple[np.ndarray, np.ndarray, float]:
    # On a map (a `cells` view) read through blocks of `block` cells: (pose, Hessian,
    # cost). Steps are capped at one block; it stops when a step moves less than `tol`
    # cells and 1e-3 rad.
    p0, p1, p2 = pose[0], pose[1], pose[2]
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    cost = 0.0
    max_step = res * block
    pose_tol = tol * res
    for _ in range(iterations):
        h00 = h01 = h02 = h11 = h12 = h22 = 0.0
        g0 = g1 = g2 = 0.0
        cost = 0.0
        c = np.cos(p2)
        s = np.sin(p2)
        for i in range(0, pts.shape[0], stride):
            px = pts[i, 0]
            py = pts[i, 1]
            wx = p0 + c * px - s * py
            wy = p1 + s * px + c * py
            m, dx, dy = _sample(view, ox, oy, res, block, wx, wy)
            r = 1.0 - m
            cost += r * r
            j2 = dx * (-s * px - c * py) + dy * (c * px - s * py)
            h00 += dx * dx
            h01 += dx * dy
            h02 += dx * j2
            h11 += dy * dy
            h12 += dy * j2
            h22 += j2 * j2
            g0 += dx * r
            g1 += dy * r
            g2 += j2 * r
        h00 += prior_weight[0]
        h11 += prior_weight[1]
        h22 += prior_weight[2]
        g0 += prior_weight[0] * (prior[0] - p0)
        g1 += prior_weight[1] * (prior[1] - p1)
        g2 += prior_weight[2] * ((prior[2] - p2 + np.pi) % (2 * np.pi) - np.pi)
        tr = h00 + h11 + h22
        if tr <= 1e-12:
            break
        damp = 1e-6 * tr
        d0, d1, d2 = _solve3(h00 + damp, h01, h02, h11 + damp, h12, h22 + damp, g0, g1, g2)
        lin = np.hypot(d0, d1)
        if lin > max_step:
            d0 *= max_step / lin
            d1 *= max_step / lin
        if abs(d2) > 0.2:
            d2 = 0.2 * np.sign(d2)
        p0 += d0
        p1 += d1
        p2 += d2
        if lin < pose_tol and abs(d2) < 1e-3:
            break
    out = np.empty(3)
    out[0], out[1], out[2] = p0, p1, (p2 + np.pi) % (2 * np.pi) - np.pi
    hess = np.empty((3, 3))
    hess[0, 0], hess[0, 1], hess[0, 2] = h00, h01, h02
    hess[1, 0], hess[1, 1], hess[1, 2] = h01, h11, h12
    hess[2, 0], hess[2, 1], hess[2, 2] = h02, h12, h22
    return out, hess, cost


@numba.njit(cache=True, nogil=True)
def _likelihood(
    view: np.ndarray | tuple,
    ox: float,
    oy: float,
    res: float,
    pts: np.ndarray,
    stride: int,
    pose: np.ndarray,
    kernel: int,
    sigma: float,
    lsigma: float,
    null_likelihood: float,
) -> tuple[float, float, int]:
    c = np.cos(pose[2])
    s = np.sin(pose[2])
    score = 0.0
    loglik = 0.0
    found = 0
    for i in range(0, pts.shape[0], stride):
        wx = pose[0] + c * pts[i, 0] - s * pts[i, 1]
        wy = pose[1] + s * pts[i, 0] + c * pts[i, 1]
        cc = int(np.floor((wx - ox) / res))
        rr = int(np.floor((wy - oy) / res))
        best = 1e30
        for dr in range(-kernel, kernel + 1):
            for dc in range(-kernel, kernel + 1):
                if cells.logodds(view, rr + dr, cc + dc) <= 0.0:
                    continue
                ex = ox + (cc + dc + 0.5) * res - wx
                ey = oy + (rr + dr + 0.5) * res - wy
                d2 = ex * ex + ey * ey
                if d2 < best:
                    best = d2
        if best < 1e29:
            found += 1
            score += np.exp(-best / sigma)
            loglik += -best / lsigma
        else:
            loglik += null_likelihood / lsigma
    return score, loglik, found


# A coarse level only brings the pose into the finer level's reach: it stops at steps
# under a tenth of its cell.
COARSE_TOL = 0.1


@dataclass(frozen=True)
class MatchResult:
    """The matched pose (x, y, yaw), the Gauss-Newton Hessian at the finest level (its
    inverse approximates the pose covariance) and the final mean squared residual."""

    pose: np.ndarray
    hessian: np.ndarray
    residual: float


class ScanMatcher:
    """Multi-resolution Gauss-Newton scan-to-map matcher.

    `levels` coarse views (block sizes 2^(levels-1) .. 1 cells), `iterations` Gauss-Newton
    steps at each; coarse levels use every `block`-th point (they see no finer detail).
    """

    def __init__(self, levels: int = 3, iterations: int = 5) -> None:
        if levels < 1 or iterations < 1:
            raise ValueError(
                f"scan matcher: levels and iterations must be >= 1, got {levels}, {iterations}"
            )
        self.levels = int(levels)
        self.iterations = int(iterations)

    def match(
        self,
        grid: LogOddsGrid | TiledGrid,
        points: np.ndarray,
        guess: np.ndarray,
        pyramid: list[np.ndarray] | None = None,
        prior_sigma: tuple[float, float, float] | None = None,
        prior_mean: np.ndarray | None = None,
    ) -> MatchResult:
        """Refine `guess` so that `points` ((N, 2), base frame) fall on the map's
        occupied cells. With `pyramid` (LogOddsGrid.pyramid, computed once a map update)
        coarse levels read precomputed arrays. With `prior_sigma` (x, y, yaw standard
        deviations of a motion model) the cost adds sum ((pose - guess) / sigma)^2, so
        along directions the scan cannot tell apart (a corridor, a wall seen alone) the
        pose stays at the guess instead of sliding: the proposal of GMapping combines
        the scan and the motion model this way. The prior is centred on `prior_mean`
        (x, y, yaw) when given, else on the guess."""
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        pose = np.asarray(guess, dtype=np.float64).copy()
        if pts.shape[0] == 0 or min(grid.shape) == 0:
            return MatchResult(pose, np.zeros((3, 3)), 0.0)
        hess = np.zeros((3, 3))
        cost = 0.0
        ox, oy = grid.origin
        start = pose.copy() if prior_mean is None else np.asarray(prior_mean, np.float64).copy()
        weight = np.zeros(3)
        if prior_sigma is not None:
            weight = 1.0 / np.maximum(np.asarray(prior_sigma, dtype=np.float64), 1e-3) ** 2
        for level in range(self.levels - 1, -1, -1):
            block = 1 << level
            if pyramid is not None and level < len(pyramid):
                view, res, read = pyramid[level], grid.resolution * block, 1
            else:
                view, res, read = grid.view, grid.resolution, block
            pose, hess, cost = _gauss_newton(
                view, ox, oy, res, read, pts, block, pose, self.iterations, start, weight
            )
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        return MatchResult(pose, hess, cost / max(1, pts.shape[0]))


def likelihood(
    grid: LogOddsGrid,
    points: np.ndarray,
    pose: np.ndarray,
    kernel: int = 1,
    sigma: float = 0.05,
    lsigma: float = 0.075,
    null_likelihood: float = -0.5,
    stride: int = 1,
) -> tuple[float, float, int]:
    """(score, log-likelihood, beams matched) of a scan at `pose` on the grid's likelihood
    field: each end point takes the nearest occupied cell within `kernel` cells at
    distance d; score adds exp(-d^2 / sigma), the log-likelihood -d^2 / lsigma (or
    null_likelihood / lsigma when no occupied cell is near), GMapping's formulas."""
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    if pts.shape[0] == 0 or grid.logodds.size == 0:
        return 0.0, 0.0, 0
    ox, oy = grid.origin
    return _likelihood(
        grid.view,
        ox,
        oy,
        grid.resolution,
        pts,
        max(1, stride),
        np.asarray(pose, dtype=np.float64),
        kernel,
        sigma,
        lsigma,
        null_likelihood,
    )
