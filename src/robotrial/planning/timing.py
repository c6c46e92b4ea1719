"""Time parameterization under joint velocity and acceleration limits, with toppra.

Layer 3. The geometric path is densified (so the interpolating spline cannot stray from
the checked segments), fitted with a clamped cubic spline (zero velocity at both ends),
and retimed time-optimally by TOPP-RA; the result is sampled at a fixed period.
"""

from __future__ import annotations

from dataclasses import dataclass

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
        raise RuntimeError("toppra found no feasible time parameterization for the path")
    n = max(int(np.ceil(traj.duration / period)), 1)
    t = np.linspace(0.0, traj.duration, n + 1)
    q = traj(t)
    q[0], q[-1] = path[0], path[-1]
    return Trajectory(t, q, traj(t, 1), traj(t, 2))
