"""Time parameterization under joint velocity and acceleration limits.

Layer 3. The geometric path is densified (so the interpolating spline cannot stray from
the checked segments) and fitted with a clamped cubic spline q(s) (zero velocity at both
ends). Along it, the fastest admissible speed profile is found as TOPP-RA does (Pham and
Pham, 2018): with x = ds/dt squared and u = d2s/dt2, the limits are linear in (u, x) at
each grid point; a backward pass finds, per grid point, the largest x from which the end
can still be reached at rest, and a forward pass accelerates as hard as that allows.
The whole of it is compiled (the spline too); the result is sampled at a fixed period.
A straight motion (a path of two points, what most requests plan) needs none of it: its
time-optimal profile is a trapezoid in the line's parameter, written out exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from robotrial.planning.smoothing import arc_lengths, densify

ACCEL_MARGIN = 0.97  # the limits hold at grid points; the rest is scaled out below


@dataclass
class Trajectory:
    """Samples of a timed joint trajectory: times (n,), positions, velocities and
    accelerations (n, d)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1]) if len(self.t) else 0.0

    def tracked(self, step: float) -> np.ndarray:
        """Positions every `step` seconds as a tracker follows the samples: a cubic
        Hermite curve through their positions and velocities (the page's and the
        simulator's joint reference), ends included."""
        if len(self.t) < 2:
            return self.q.copy()
        return _hermite(self.t, self.q, self.qd, float(step))


@nb.njit(cache=True, nogil=True)
def _hermite(ts, q, qd, step):
    """`Trajectory.tracked`: positions every `step` s on the cubic Hermite curve through
    the samples (times `ts`, positions `q`, velocities `qd`)."""
    duration = ts[-1]
    n, d = q.shape
    t = np.linspace(0.0, duration, max(int(np.ceil(duration / step)), 1) + 1)
    out = np.empty((t.shape[0], d))
    for p in range(t.shape[0]):
        i = min(max(np.searchsorted(ts, t[p], side="right") - 1, 0), n - 2)
        h = ts[i + 1] - ts[i]
        s = (t[p] - ts[i]) / h
        s2 = s * s
        s3 = s2 * s
        a, b = 2.0 * s3 - 3.0 * s2 + 1.0, (s3 - 2.0 * s2 + s) * h
        c, e = 3.0 * s2 - 2.0 * s3, (s3 - s2) * h
        for j in range(d):
            out[p, j] = a * q[i, j] + b * qd[i, j] + c * q[i + 1, j] + e * qd[i + 1, j]
    return out


@nb.njit(cache=True)
def _u_range(x, dq, ddq, amax, two_ds) -> tuple[float, float]:
    """The accelerations u allowed at speed squared x on the stage from grid point i to
    i + 1 (rows 0 and 1 of dq, ddq): |dq u + ddq x| <= amax at both ends, with the speed
    squared at the far end x + two_ds u (TOPP-RA's interpolation scheme)."""
    lo, hi = -np.inf, np.inf
    for end in range(2):
        for j in range(dq.shape[1]):
            k = dq[end, j] + (two_ds * ddq[end, j] if end else 0.0)
            c = ddq[end, j] * x
            if abs(k) < 1e-12:
                if abs(c) > amax[j]:
                    return np.inf, -np.inf
                continue
            a = (-amax[j] - c) / k
            b = (amax[j] - c) / k
            if a > b:
                a, b = b, a
            lo = max(lo, a)
            hi = min(hi, b)
    return lo, hi


@nb.njit(cache=True)
def _reaches(x, target, dq, ddq, amax, two_ds) -> bool:
    """From speed squared x, does an allowed u lead to some y in [0, target]?"""
    ulo, uhi = _u_range(x, dq, ddq, amax, two_ds)
    return ulo <= uhi and max(x + two_ds * ulo, 0.0) <= min(x + two_ds * uhi, target)


@nb.njit(cache=True)
def _largest_x(xmax, target, dq, ddq, amax, two_ds, scratch) -> float:
    """The largest speed squared x <= xmax at grid point i from which an allowed u leads
    to some y in [0, target] at i + 1 (0 when none). Every limit bounds u by a line in
    x, from below (lo_a + lo_b x <= u) or from above (u <= up_a + up_b x); eliminating u
    (Fourier-Motzkin) pairs each lower bound with each upper one and leaves bounds on x.
    `scratch` is (4, 2 d + 1) of room for the lines."""
    lo_a, lo_b, up_a, up_b = scratch[0], scratch[1], scratch[2], scratch[3]
    hi, lo = xmax, 0.0
    n = 0
    for end in range(2):
        for j in range(dq.shape[1]):
            k = dq[end, j] + (two_ds * ddq[end, j] if end else 0.0)
            g = ddq[end, j]
            # -amax <= k u + g x <= amax
            if abs(k) <= 1e-12:
                if abs(g) > 1e-12:
                    hi = min(hi, amax[j] / abs(g))
                continue
            low, up = -amax[j] / k, amax[j] / k
            if k < 0.0:
                low, up = up, low
            lo_a[n], up_a[n] = low, up
            lo_b[n] = up_b[n] = -g / k
            n += 1
    # 0 <= x + two_ds u <= target
    lo_a[n], lo_b[n] = 0.0, -1.0 / two_ds
    up_a[n], up_b[n] = target / two_ds, -1.0 / two_ds
    n += 1
    for p in range(n):
        for q in range(n):
            coef = lo_b[p] - up_b[q]
            rhs = up_a[q] - lo_a[p]
            if coef > 1e-15:
                hi = min(hi, rhs / coef)
            elif coef < -1e-15:
                lo = max(lo, rhs / coef)
            elif rhs < 0.0:
                return 0.0
    return hi if hi >= lo else 0.0


@nb.njit(cache=True)
def _profile(dq, ddq, vmax, amax, ds) -> np.ndarray:
    """Speed squared x (n,) along the grid: the time-optimal profile from rest to rest."""
    n, d = dq.shape
    xmax = np.empty(n)
    for i in range(n):
        m = np.inf
        for j in range(d):
            if abs(dq[i, j]) > 1e-12:
                m = min(m, (vmax[j] / abs(dq[i, j])) ** 2)
        xmax[i] = min(m, 1e12)
    xmax[0] = 0.0
    xmax[n - 1] = 0.0
    # backward: the largest x at i from which some allowed u reaches [0, k[i + 1]]
    k = np.empty(n)
    k[n - 1] = 0.0
    scratch = np.empty((4, 2 * d + 1))
    for i in range(n - 2, -1, -1):
        two_ds = 2.0 * (ds[i + 1] - ds[i])
        rows, rows2 = dq[i : i + 2], ddq[i : i + 2]
        if _reaches(xmax[i], k[i + 1], rows, rows2, amax, two_ds):
            k[i] = xmax[i]  # the speed limit binds, not the accelerations ahead
        else:
            k[i] = _largest_x(xmax[i], k[i + 1], rows, rows2, amax, two_ds, scratch)
    # forward: accelerate as hard as allowed while staying within the controllable set
    x = np.empty(n)
    x[0] = 0.0
    for i in range(n - 1):
        two_ds = 2.0 * (ds[i + 1] - ds[i])
        uhi = _u_range(x[i], dq[i : i + 2], ddq[i : i + 2], amax, two_ds)[1]
        x[i + 1] = max(min(k[i + 1], x[i] + two_ds * uhi), 0.0)
    return x


@nb.njit(cache=True)
def _excess(coef, knots, grid, x, u, vmax, amax) -> float:
    """How much faster than its limits the profile (x, u) drives some joint, at nine
    points inside every grid interval (1 when never): the largest of |qd| / vmax and
    sqrt(|qdd| / amax), with qd and qdd from the cubic pieces `coef` (4, m, d) between
    `knots` (the spline's own; every knot is a grid point, so one piece per interval)."""
    d = coef.shape[2]
    inv_v = 1.0 / vmax
    inv_a = 1.0 / amax
    worst2 = 1.0  # the largest of (|qd| / vmax)^2 and |qdd| / amax: one square root at the end
    piece = 0
    for i in range(len(grid) - 1):
        while piece < len(knots) - 2 and knots[piece + 1] <= grid[i]:
            piece += 1
        step = grid[i + 1] - grid[i]
        for f in range(9):
            t = f / 8.0
            xs = max(x[i] + t * (x[i + 1] - x[i]), 0.0)  # x is linear in s on an interval
            v = np.sqrt(xs)
            h = grid[i] + t * step - knots[piece]
            for j in range(d):
                c0, c1 = coef[0, piece, j], coef[1, piece, j]
                d1 = (3.0 * c0 * h + 2.0 * c1) * h + coef[2, piece, j]
                d2 = 6.0 * c0 * h + 2.0 * c1
                speed = d1 * v * inv_v[j]
                worst2 = max(worst2, speed * speed, abs(d2 * xs + d1 * u[i]) * inv_a[j])
    return np.sqrt(worst2)


STALL = 10.0  # an interval slower than this many rest-to-rest times is a stalled profile


@nb.njit(cache=True, inline="always")
def _interval_time(step, sd0, sd1, dq, amax) -> float:
    """Seconds over one grid interval at constant u: 2 ds / (sd_i + sd_i+1). Where the
    profile stalls near rest at both ends (a sharp turn just before the end can leave no
    speed the discretised limits allow), that would be an endless wait: the interval then
    takes the rest-to-rest time at the largest path acceleration the joints allow there
    (rows 0 and 1 of `dq`), the time a profile that did not stall would take at most."""
    accel = np.inf
    for end in range(2):
        for j in range(dq.shape[1]):
            if abs(dq[end, j]) > 1e-12:
                accel = min(accel, amax[j] / abs(dq[end, j]))
    rest = 2.0 * np.sqrt(step / accel) if np.isfinite(accel) else 0.0
    if sd0 + sd1 > 0.0 and 2.0 * step < STALL * rest * (sd0 + sd1):
        return 2.0 * step / (sd0 + sd1)
    return rest


@nb.njit(cache=True, nogil=True)
def _densify(path, step):
    """`smoothing.densify`, compiled, without repeated points."""
    n, d = path.shape
    counts = np.empty(n - 1, dtype=np.int64)
    total = 1
    for i in range(n - 1):
        s2 = 0.0
        for j in range(d):
            s2 += (path[i + 1, j] - path[i, j]) ** 2
        counts[i] = max(int(np.ceil(np.sqrt(s2) / step)), 1)
        total += counts[i]
    out = np.empty((total, d))
    out[0] = path[0]
    m = 1
    for i in range(n - 1):
        for k in range(counts[i]):
            f = (k + 1) / counts[i]
            s2 = 0.0
            for j in range(d):
                out[m, j] = path[i, j] + f * (path[i + 1, j] - path[i, j])
                s2 += (out[m, j] - out[m - 1, j]) ** 2
            if s2 > 1e-18:  # a point on top of the last one would make a flat knot
                m += 1
    return out[:m]


@nb.njit(cache=True, nogil=True)
def _clamped_spline(x, y):
    """The clamped cubic spline (zero slope at both ends) through `y` (n, d) at knots
    `x` (n,), as scipy's CubicSpline(x, y, bc_type="clamped") makes it: coefficients
    (4, n - 1, d), highest power first, in the local coordinate x - x[k]."""
    n, d = y.shape
    dx = np.diff(x)
    slope = np.empty((n - 1, d))
    for i in range(n - 1):
        for j in range(d):
            slope[i, j] = (y[i + 1, j] - y[i, j]) / dx[i]
    s = np.zeros((n, d))  # the slopes at the knots: a tridiagonal system inside
    if n > 2:
        m = n - 2
        diag = np.empty(m)
        rhs = np.empty((m, d))
        for r in range(m):
            i = r + 1
            diag[r] = 2.0 * (dx[i - 1] + dx[i])
            for j in range(d):
                rhs[r, j] = 3.0 * (dx[i] * slope[i - 1, j] + dx[i - 1] * slope[i, j])
        for r in range(1, m):  # Thomas: lower of row r is dx[r + 1], upper of r - 1 is dx[r - 1]
            w = dx[r + 1] / diag[r - 1]
            diag[r] -= w * dx[r - 1]
            for j in range(d):
                rhs[r, j] -= w * rhs[r - 1, j]
        for j in range(d):
            s[m, j] = rhs[m - 1, j] / diag[m - 1]
        for r in range(m - 2, -1, -1):
            for j in range(d):
                s[r + 1, j] = (rhs[r, j] - dx[r] * s[r + 2, j]) / diag[r]
    c = np.empty((4, n - 1, d))
    for i in range(n - 1):
        for j in range(d):
            t = (s[i, j] + s[i + 1, j] - 2.0 * slope[i, j]) / dx[i]
            c[0, i, j] = t / dx[i]
            c[1, i, j] = (slope[i, j] - s[i, j]) / dx[i] - t
            c[2, i, j] = s[i, j]
            c[3, i, j] = y[i, j]
    return c


@nb.njit(cache=True, nogil=True)
def _evaluate(c, knots, at, nu):
    """The spline's `nu`-th derivative (0-2) at the points `at` (the piece to the right
    of a knot, the last piece at the end, as scipy's PPoly)."""
    m, d = c.shape[1], c.shape[2]
    out = np.empty((at.shape[0], d))
    for p in range(at.shape[0]):
        k = min(max(np.searchsorted(knots, at[p], side="right") - 1, 0), m - 1)
        h = at[p] - knots[k]
        for j in range(d):
            if nu == 0:
                out[p, j] = ((c[0, k, j] * h + c[1, k, j]) * h + c[2, k, j]) * h + c[3, k, j]
            elif nu == 1:
                out[p, j] = (3.0 * c[0, k, j] * h + 2.0 * c[1, k, j]) * h + c[2, k, j]
            else:
                out[p, j] = 6.0 * c[0, k, j] * h + 2.0 * c[1, k, j]
    return out


@nb.njit(cache=True, nogil=True)
def _straight(a, b, vmax, amax, period):
    """The time-optimal motion from rest at `a` to rest at `b` along the line between them:
    q = a + s (b - a) with s accelerating at the largest rate every joint allows, then
    coasting at the largest speed (if it gets there), then braking (a trapezoid in s; a
    triangle when the line is too short to reach that speed). `a` alone when `b` is on it."""
    d = a.shape[0]
    top, acc = np.inf, np.inf  # ds/dt and d2s/dt2 the joints allow
    for j in range(d):
        step = abs(b[j] - a[j])
        if step > 1e-8:
            top = min(top, vmax[j] / step)
            acc = min(acc, amax[j] / step)
    if acc == np.inf:
        return np.zeros(1), a.reshape((1, d)).copy(), np.zeros((1, d)), np.zeros((1, d))
    if top * top >= acc:  # no coasting: accelerate over half the line, brake over the rest
        ramp = np.sqrt(1.0 / acc)
        top = acc * ramp
        coast = 0.0
    else:
        ramp = top / acc
        coast = (1.0 - top * ramp) / top
    duration = 2.0 * ramp + coast
    samples = max(int(np.ceil(duration / period)), 1)
    t = np.linspace(0.0, duration, samples + 1)
    q = np.empty((samples + 1, d))
    qd = np.empty((samples + 1, d))
    qdd = np.empty((samples + 1, d))
    for p in range(samples + 1):
        if t[p] < ramp:
            s, v, u = 0.5 * acc * t[p] * t[p], acc * t[p], acc
        elif t[p] <= ramp + coast:
            s, v, u = 0.5 * top * ramp + top * (t[p] - ramp), top, 0.0
        else:
            left = max(duration - t[p], 0.0)
            s, v, u = 1.0 - 0.5 * acc * left * left, acc * left, -acc
        for j in range(d):
            q[p, j] = a[j] + s * (b[j] - a[j])
            qd[p, j] = v * (b[j] - a[j])
            qdd[p, j] = u * (b[j] - a[j])
    q[0], q[-1] = a, b
    return t, q, qd, qdd


@nb.njit(cache=True, nogil=True)
def _timed(path, vmax, amax, period, max_gap):
    """The whole of `time_parameterize` for a path of at least two distinct points."""
    if path.shape[0] == 2:
        return _straight(path[0], path[1], vmax, amax, period)
    way = _densify(path, max_gap)
    n, d = way.shape
    knots = arc_lengths(way)
    knots /= knots[-1]
    c = _clamped_spline(knots, way)
    # the spline's knots are grid points too: between two grid points the path is then
    # one cubic, and the limits' excess inside an interval a low-order polynomial
    points = min(max(4 * n, 200), 1500)
    grid = np.unique(np.concatenate((np.linspace(0.0, 1.0, points), knots)))
    dq, ddq = _evaluate(c, knots, grid, 1), _evaluate(c, knots, grid, 2)
    x = _profile(dq, ddq, vmax, amax * ACCEL_MARGIN, grid)
    g = grid.shape[0]
    sd = np.sqrt(np.maximum(x, 0.0))
    dt = np.empty(g - 1)
    u = np.empty(g - 1)
    for i in range(g - 1):
        step = grid[i + 1] - grid[i]
        dt[i] = _interval_time(step, sd[i], sd[i + 1], dq[i : i + 2], amax)
        u[i] = (x[i + 1] - x[i]) / (2.0 * step)
    # the limits hold at the grid points; between them the path's curvature may push a
    # joint past them: slow the whole trajectory down uniformly by the largest excess
    # (speeds scale with 1/c, accelerations with 1/c^2), measured inside every interval
    scale = _excess(c, knots, grid, x, u, vmax, amax)
    times = np.zeros(g)
    for i in range(g - 1):
        times[i + 1] = times[i] + dt[i] * scale
    duration = times[-1]
    samples = max(int(np.ceil(duration / period)), 1)
    t = np.linspace(0.0, duration, samples + 1)
    pos = np.empty(samples + 1)
    v = np.empty(samples + 1)
    ui = np.empty(samples + 1)
    for p in range(samples + 1):
        i = min(max(np.searchsorted(times, t[p], side="right") - 1, 0), g - 2)
        tau = (t[p] - times[i]) / scale  # in the unscaled time of the profile
        v[p] = sd[i] + u[i] * tau
        pos[p] = min(grid[i] + sd[i] * tau + 0.5 * u[i] * tau * tau, grid[i + 1])
        ui[p] = u[i]
    pos[-1] = 1.0
    v[-1] = 0.0
    q = _evaluate(c, knots, pos, 0)
    d1 = _evaluate(c, knots, pos, 1)
    d2 = _evaluate(c, knots, pos, 2)
    qd = np.empty_like(q)
    qdd = np.empty_like(q)
    over = 1.0
    for p in range(samples + 1):
        for j in range(d):
            qd[p, j] = d1[p, j] * (v[p] / scale)
            qdd[p, j] = (d2[p, j] * v[p] * v[p] + d1[p, j] * ui[p]) / (scale * scale)
    q[0], q[-1] = path[0], path[-1]
    qd[0], qd[-1] = 0.0, 0.0
    # the excess was measured at nine points an interval; a sample between them may still
    # pass a limit by a few parts in ten thousand: stretch time by what is left
    for p in range(samples + 1):
        for j in range(d):
            over = max(over, abs(qd[p, j]) / vmax[j], np.sqrt(abs(qdd[p, j]) / amax[j]))
    return t * over, q, qd / over, qdd / (over * over)


def time_parameterize(
    path: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    period: float = 0.02,
    max_gap: float = 0.05,
) -> Trajectory:
    """A time-optimal trajectory along `path` with |qd| <= vmax and |qdd| <= amax (one
    compiled call: densify, spline, profile, samples; a path of two points, a straight
    motion, is timed exactly without a spline, `_straight`)."""
    path = np.ascontiguousarray(path, dtype=float)
    if len(path) < 2:
        d = path.shape[1]
        return Trajectory(np.zeros(1), path[:1].copy(), np.zeros((1, d)), np.zeros((1, d)))
    vmax = np.ascontiguousarray(vmax, dtype=float)
    amax = np.ascontiguousarray(amax, dtype=float)
    return Trajectory(*_timed(path, vmax, amax, float(period), float(max_gap)))


def time_parameterize_reference(
    path: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    period: float = 0.02,
    max_gap: float = 0.05,
) -> Trajectory:
    """`time_parameterize` in NumPy and scipy (the spline by CubicSpline): the code the
    compiled one replaced, kept as its reference in tests and benchmarks."""
    from scipy.interpolate import CubicSpline

    path = np.asarray(path, dtype=float)
    vmax = np.asarray(vmax, dtype=float)
    amax = np.asarray(amax, dtype=float)
    d = path.shape[1]
    if len(path) < 2 or (len(path) == 2 and np.allclose(path[0], path[-1])):
        q = path[:1]
        return Trajectory(np.zeros(1), q.copy(), np.zeros((1, d)), np.zeros((1, d)))
    way = densify(path, max_gap)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(way, axis=0), axis=1) > 1e-9])
    way = way[keep]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(way, axis=0), axis=1))])
    spline = CubicSpline(s / s[-1], way, bc_type="clamped")
    # the spline's knots are grid points too: between two grid points the path is then
    # one cubic, and the limits' excess inside an interval a low-order polynomial
    grid = np.union1d(np.linspace(0, 1, int(np.clip(4 * len(way), 200, 1500))), s / s[-1])
    dq, ddq = spline(grid, 1), spline(grid, 2)
    x = _profile(dq, ddq, vmax, amax * ACCEL_MARGIN, grid)
    # constant u on each interval: dt = 2 ds / (sd_i + sd_{i+1})
    sd = np.sqrt(np.maximum(x, 0.0))
    step = np.diff(grid)
    # as _interval_time: a stalled interval takes its rest-to-rest time
    with np.errstate(divide="ignore"):
        accel = np.min(np.where(np.abs(dq) > 1e-12, amax / np.abs(dq), np.inf), axis=1)
    rest = 2.0 * np.sqrt(step / np.minimum(accel[:-1], accel[1:]))
    both = sd[:-1] + sd[1:]
    moving = (both > 0.0) & (2.0 * step < STALL * rest * both)
    dt = np.where(moving, 2.0 * step / np.where(moving, both, 1.0), rest)
    u = (x[1:] - x[:-1]) / (2.0 * step)
    # the limits hold at the grid points; between them the path's curvature may push a
    # joint past them: slow the whole trajectory down uniformly by the largest excess
    # (speeds scale with 1/c, accelerations with 1/c^2), measured inside every interval
    c = _excess(spline.c, spline.x, grid, x, u, vmax, amax)
    dt *= c
    times = np.concatenate([[0.0], np.cumsum(dt)])
    duration = float(times[-1])
    n = max(int(np.ceil(duration / period)), 1)
    t = np.linspace(0.0, duration, n + 1)
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(step) - 1)
    tau = t - times[i]
    tau = tau / c  # in the unscaled time of the profile
    v = sd[i] + u[i] * tau
    pos = np.minimum(grid[i] + sd[i] * tau + 0.5 * u[i] * tau**2, grid[i + 1])
    pos[-1] = 1.0
    v[-1] = 0.0
    d1 = spline(pos, 1)
    q = spline(pos)
    qd = d1 * (v / c)[:, None]
    qdd = (spline(pos, 2) * (v**2)[:, None] + d1 * u[i][:, None]) / c**2
    q[0], q[-1] = path[0], path[-1]
    qd[0], qd[-1] = 0.0, 0.0
    # the excess was measured at nine points an interval; a sample between them may still
    # pass a limit by a few parts in ten thousand: stretch time by what is left
    over = max(1.0, float(np.max(np.abs(qd) / vmax)), float(np.sqrt(np.max(np.abs(qdd) / amax))))
    t, qd, qdd = t * over, qd / over, qdd / over**2
    return Trajectory(t, q, qd, qdd)
