"""Time parameterization under joint velocity and acceleration limits, with toppra.

Layer 3. The geometric path is densified (so the interpolating spline cannot stray from
the checked segments), fitted with a clamped cubic spline (zero velocity at both ends),
and retimed time-optimally by TOPP-RA; the result is sampled at a fixed period. On the
rare path where TOPP-RA finds no parameterization (a numerical corner of its grid), the
path is timed rest to rest, waypoint by waypoint, instead: slower, within the same limits.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from robotrial.planning.smoothing import densify

ACCEL_MARGIN = 0.85


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


def time_parameterize(
    path: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    period: float = 0.02,
    max_gap: float = 0.05,
) -> Trajectory:
    """A time-optimal trajectory along `path` with |qd| <= vmax and |qdd| <= amax."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    path = np.asarray(path, dtype=float)
    vmax = np.asarray(vmax, dtype=float)
    amax = np.asarray(amax, dtype=float)
    d = path.shape[1]
    if len(path) < 2 or (np.allclose(path[0], path[-1]) and len(path) == 2):
        q = path[:1]
        return Trajectory(np.zeros(1), q.copy(), np.zeros((1, d)), np.zeros((1, d)))
    way = densify(path, max_gap)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(way, axis=0), axis=1) > 1e-9])
    way = way[keep]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(way, axis=0), axis=1))])
    spline = ta.SplineInterpolator(s / s[-1], way, bc_type="clamped")
    vel = constraint.JointVelocityConstraint(np.stack([-vmax, vmax], axis=1))
    # TOPP-RA holds the limits at grid points; the spline between them may exceed the
    # acceleration limit slightly, so it is given a margin
    acc = constraint.JointAccelerationConstraint(np.stack([-amax, amax], axis=1) * ACCEL_MARGIN)
    gridpoints = np.linspace(0, 1, int(np.clip(4 * len(way), 200, 1500)))
    instance = algo.TOPPRA(
        [vel, acc], spline, gridpoints=gridpoints, parametrizer="ParametrizeConstAccel"
    )
    traj = instance.compute_trajectory()
    if traj is None:
        return rest_to_rest(path, vmax, amax * ACCEL_MARGIN, period)
    n = max(int(np.ceil(traj.duration / period)), 1)
    t = np.linspace(0.0, traj.duration, n + 1)
    q = traj(t)
    q[0], q[-1] = path[0], path[-1]
    return Trajectory(t, q, traj(t, 1), traj(t, 2))


def rest_to_rest(
    path: np.ndarray, vmax: np.ndarray, amax: np.ndarray, period: float = 0.02
) -> Trajectory:
    """The path's straight segments one after the other, each from rest to rest on a
    trapezoidal speed profile that its slowest joint sets (the others follow in step)."""
    path = np.asarray(path, dtype=float)
    rest = np.zeros((1, path.shape[1]))
    ts, qs, qds, qdds = [np.zeros(1)], [path[:1]], [rest], [rest]
    t0 = 0.0
    for a, b in pairwise(path):
        d = b - a
        # per joint: the time to cover |d| from rest to rest at vmax, amax
        cruise = np.abs(d) > vmax**2 / amax
        times = np.where(cruise, np.abs(d) / vmax + vmax / amax, 2.0 * np.sqrt(np.abs(d) / amax))
        j = int(np.argmax(times))
        T = float(times[j])
        if T <= 0.0:
            continue
        # the slowest joint's profile, as a fraction of the segment: accelerate for ta
        ta = vmax[j] / amax[j] if cruise[j] else T / 2.0
        peak = 1.0 / (T - ta)  # fraction per second at the top speed
        t = np.linspace(0.0, T, max(int(np.ceil(T / period)), 1) + 1)[1:]
        acc = peak / ta
        u = np.where(
            t < ta,
            0.5 * acc * t**2,
            np.where(
                t <= T - ta,
                0.5 * acc * ta**2 + peak * (t - ta),
                1.0 - 0.5 * acc * (T - t) ** 2,
            ),
        )
        du = np.where(t < ta, acc * t, np.where(t <= T - ta, peak, acc * (T - t)))
        ddu = np.where(t < ta, acc, np.where(t <= T - ta, 0.0, -acc))
        ts.append(t0 + t)
        qs.append(a + u[:, None] * d)
        qds.append(du[:, None] * d)
        qdds.append(ddu[:, None] * d)
        t0 += T
    return Trajectory(np.concatenate(ts), np.vstack(qs), np.vstack(qds), np.vstack(qdds))
