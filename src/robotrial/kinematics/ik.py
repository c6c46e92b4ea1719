"""Inverse kinematics: damped least squares from many seeds inside the joint limits (layer 2).

Position-only or full pose. The current joints are the first seed, random
configurations the rest; every seed runs a compiled damped-least-squares loop that
clips to the limits, and the converged solution nearest the current joints wins. When
no seed converges the result says how far the best attempt stayed from the target.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from robotrial.kinematics.chain import Kinematics, fk_single, jacobian_into

ROT_WEIGHT = 0.2  # metres per radian: balances orientation against position error
STALL_STEPS = 5
STALL_RATIO = 0.7
"""A seed whose squared error has not shrunk to 0.7 of itself in 5 iterations is given
up: one that converges takes 8 (median; desk arm), while one held at a joint limit or in
a local minimum would run all 150 at a few hundredths of a millimetre gained each. The
same rate as halving in 10 iterations, asked twice as often: a seed that stalls stops
up to 5 iterations sooner. Over 60 random reachable targets x 100 random seeds
(against halving in 10): desk arm 2 % fewer solutions at 16 % less time a solution for
positions, 4 % fewer at 22 % less for full poses; manipulator_h 3 % / 16 % and 5 % /
24 %."""


@nb.njit(cache=True)
def _rotation_error(r_target: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Rotation vector (world frame) that takes `r` to `r_target`."""
    e = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            e[i, j] = r_target[i, 0] * r[j, 0] + r_target[i, 1] * r[j, 1] + r_target[i, 2] * r[j, 2]
    tr = e[0, 0] + e[1, 1] + e[2, 2]
    # quaternion of e (Shepperd), then 2 * atan2(|v|, w) * v / |v|
    if tr > 0.0:
        s = np.sqrt(tr + 1.0) * 2.0
        w = 0.25 * s
        x = (e[2, 1] - e[1, 2]) / s
        y = (e[0, 2] - e[2, 0]) / s
        z = (e[1, 0] - e[0, 1]) / s
    elif e[0, 0] > e[1, 1] and e[0, 0] > e[2, 2]:
        s = np.sqrt(1.0 + e[0, 0] - e[1, 1] - e[2, 2]) * 2.0
        w = (e[2, 1] - e[1, 2]) / s
        x = 0.25 * s
        y = (e[0, 1] + e[1, 0]) / s
        z = (e[0, 2] + e[2, 0]) / s
    elif e[1, 1] > e[2, 2]:
        s = np.sqrt(1.0 + e[1, 1] - e[0, 0] - e[2, 2]) * 2.0
        w = (e[0, 2] - e[2, 0]) / s
        x = (e[0, 1] + e[1, 0]) / s
        y = 0.25 * s
        z = (e[1, 2] + e[2, 1]) / s
    else:
        s = np.sqrt(1.0 + e[2, 2] - e[0, 0] - e[1, 1]) * 2.0
        w = (e[1, 0] - e[0, 1]) / s
        x = (e[0, 2] + e[2, 0]) / s
        y = (e[1, 2] + e[2, 1]) / s
        z = 0.25 * s
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    n = np.sqrt(x * x + y * y + z * z)
    out = np.zeros(3)
    if n > 1e-12:
        angle = 2.0 * np.arctan2(n, w)
        out[0], out[1], out[2] = angle * x / n, angle * y / n, angle * z / n
    return out


@nb.njit(cache=True)
def _pose_error(q, target, r_target, with_rotation, kin_arrays, tip, poses, err):
    """Fill `err` with the (weighted) pose error at `q`; returns its squared norm."""
    parent, origin, jtype, axis, src, mult, offset, const = kin_arrays
    fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, poses)
    for i in range(3):
        err[i] = target[i, 3] - poses[tip, i, 3]
    if with_rotation:
        er = _rotation_error(r_target, np.ascontiguousarray(poses[tip, :3, :3]))
        for i in range(3):
            err[3 + i] = ROT_WEIGHT * er[i]
    e2 = 0.0
    for i in range(err.shape[0]):  # not err @ err: that is a BLAS call, which loads scipy
        e2 += err[i] * err[i]
    return e2


@nb.njit(cache=True, inline="always")
def _damped_step(jac, rows, lam, err, a, y, dq) -> None:
    """dq = J^T (J J^T + lam I)^-1 err for the first `rows` rows of `jac`, in place: the
    matrix is symmetric positive definite, so a Cholesky factorisation in `a` solves it
    without LAPACK's call overhead or a new array (a few microseconds per iteration)."""
    d = jac.shape[1]
    for i in range(rows):
        for j in range(i + 1):
            v = 0.0
            for k in range(d):
                v += jac[i, k] * jac[j, k]
            a[i, j] = v + (lam if i == j else 0.0)
    for i in range(rows):  # L L^T in the lower triangle
        for j in range(i + 1):
            v = a[i, j]
            for k in range(j):
                v -= a[i, k] * a[j, k]
            a[i, j] = np.sqrt(v) if i == j else v / a[j, j]
    for i in range(rows):  # L z = err
        v = err[i]
        for k in range(i):
            v -= a[i, k] * y[k]
        y[i] = v / a[i, i]
    for i in range(rows - 1, -1, -1):  # L^T y = z
        v = y[i]
        for k in range(i + 1, rows):
            v -= a[k, i] * y[k]
        y[i] = v / a[i, i]
    for k in range(d):
        v = 0.0
        for i in range(rows):
            v += jac[i, k] * y[i]
        dq[k] = v


@nb.njit(cache=True)
def scratch(links: int, d: int, with_rotation: bool) -> tuple:
    """The working arrays of `descend` for a tree of `links` frames and `d` joints,
    made once per search so that no seed allocates."""
    rows = 6 if with_rotation else 3
    return (
        np.empty((links, 4, 4)),
        np.empty((links, 4, 4)),
        np.zeros(rows),
        np.zeros(rows),
        np.empty(d),
        np.empty((rows, rows)),
        np.empty(rows),
        np.empty(d),
        np.empty(3),
        np.empty((6, d)),
    )


@nb.njit(cache=True)
def descend(
    q,
    target,
    r_target,
    with_rotation,
    lower,
    upper,
    kin_arrays,
    ancestors,
    tip,
    max_iter,
    tol_pos,
    tol_rot,
    max_step,
    work,
):
    """Levenberg-Marquardt damped least squares from `q`, in place, clipped to the
    limits (a joint at a limit that a step would push past is left out of that step);
    `work` from `scratch`. Returns (position error, orientation error,
    converged)."""
    _parent, _origin, jtype, axis, src, mult, _offset, _const = kin_arrays
    # two sets of poses and errors, the current configuration's and the trial's, swapped
    # when a step is taken: a refused step leaves the current ones as they were
    poses, poses_new, err, err_new, q_new, a, y, dq, p, jac = work
    d = q.shape[0]
    rows = 6 if with_rotation else 3
    lam = 0.01
    pe, re = np.inf, np.inf
    e2 = _pose_error(q, target, r_target, with_rotation, kin_arrays, tip, poses, err)
    e2_before = e2
    for it in range(max_iter):
        pe = np.sqrt(err[0] ** 2 + err[1] ** 2 + err[2] ** 2)
        re = np.sqrt(e2 - pe * pe) / ROT_WEIGHT if with_rotation and e2 > pe * pe else 0.0
        if pe < tol_pos and re < tol_rot:
            return pe, re, True
        if it % STALL_STEPS == STALL_STEPS - 1:
            if e2 > STALL_RATIO * e2_before:
                break
            e2_before = e2
        for i in range(3):
            p[i] = poses[tip, i, 3]
        jacobian_into(poses, tip, p, ancestors, jtype, axis, src, mult, jac)
        if with_rotation:
            for i in range(3, 6):
                for k in range(d):
                    jac[i, k] *= ROT_WEIGHT
        _damped_step(jac, rows, lam, err, a, y, dq)
        # a joint held at a limit that the step pushes further out takes no part in it:
        # the other joints make up for it (clipped, it would shorten every later step)
        pinned = False
        for k in range(d):
            if (q[k] <= lower[k] and dq[k] < 0.0) or (q[k] >= upper[k] and dq[k] > 0.0):
                for i in range(rows):
                    jac[i, k] = 0.0
                pinned = True
        if pinned:
            _damped_step(jac, rows, lam, err, a, y, dq)
        step = 0.0
        for i in range(d):
            step = max(step, abs(dq[i]))
        if step > max_step:
            for i in range(d):
                dq[i] *= max_step / step
        for i in range(d):
            q_new[i] = min(max(q[i] + dq[i], lower[i]), upper[i])
        e2_new = _pose_error(
            q_new, target, r_target, with_rotation, kin_arrays, tip, poses_new, err_new
        )
        if e2_new < e2:
            q[:] = q_new
            poses, poses_new = poses_new, poses
            err, err_new = err_new, err
            e2 = e2_new
            lam = max(lam * 0.3, 1e-6)
        else:
            lam = min(lam * 5.0, 1e3)
            if lam >= 1e3:
                break
    return pe, re, False


@nb.njit(cache=True)
def _dls(
    seeds,
    target,
    with_rotation,
    lower,
    upper,
    kin_arrays,
    ancestors,
    tip,
    max_iter,
    tol_pos,
    tol_rot,
    max_step,
):
    """`descend` from every seed. Returns (q, position error, orientation error,
    converged) per seed."""
    n, d = seeds.shape
    qs = seeds.copy()
    perr = np.full(n, np.inf)
    rerr = np.full(n, np.inf)
    ok = np.zeros(n, dtype=np.bool_)
    r_target = np.ascontiguousarray(target[:3, :3])
    work = scratch(kin_arrays[0].shape[0], d, with_rotation)
    for b in range(n):
        perr[b], rerr[b], ok[b] = descend(
            qs[b],
            target,
            r_target,
            with_rotation,
            lower,
            upper,
            kin_arrays,
            ancestors,
            tip,
            max_iter,
            tol_pos,
            tol_rot,
            max_step,
            work,
        )
    return qs, perr, rerr, ok


@dataclass
class IKResult:
    """The answer of `solve_ik`: `q` is the converged solution nearest the current joints
    (or the best attempt when `success` is False); errors in m and rad."""

    success: bool
    q: np.ndarray
    position_error: float
    orientation_error: float
    solutions: list[np.ndarray] = field(default_factory=list)
    seeds_tried: int = 0


def solve_ik(
    kin: Kinematics,
    target: np.ndarray,
    current: np.ndarray,
    orientation: bool = True,
    rng: np.random.Generator | None = None,
    restarts: int = 64,
    batch: int = 8,
    wanted: int = 4,
    accept: Callable[[np.ndarray], np.ndarray] | None = None,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
) -> IKResult:
    """Joint values that put the end effector at `target` (4x4 pose, or (3,) position).

    Seeds run in batches (the current joints first) until `wanted` distinct solutions
    are found or `restarts` seeds are spent. `accept(qs) -> bool mask` filters
    solutions (for example, collision-free ones). Solutions are sorted by their distance
    to `current`; the first is returned.
    """
    rng = rng if rng is not None else np.random.default_rng()
    current = np.clip(kin.check_q(current), kin.lower, kin.upper)
    t = np.eye(4)
    tgt = np.asarray(target, dtype=float)
    if tgt.shape == (3,):
        t[:3, 3] = tgt
        orientation = False
    elif tgt.shape == (4, 4):
        t = tgt
    else:
        raise ValueError(f"IK target must be a 4x4 pose or an xyz position, got shape {tgt.shape}")
    sols: list[np.ndarray] = []
    best_q, best_err, best_rot = current, np.inf, np.inf
    tried = 0
    while tried < restarts and len(sols) < wanted:
        k = min(batch, restarts - tried)
        seeds = kin.random(rng, k)
        if tried == 0:
            seeds[0] = current
        qs, perr, rerr, ok = _dls(
            seeds,
            t,
            orientation,
            kin.lower,
            kin.upper,
            kin._args(),
            kin.ancestors,
            kin.tip,
            150,
            tol_pos,
            tol_rot,
            0.4,
        )
        tried += k
        score = perr + 0.1 * rerr
        i = int(np.argmin(score))
        if score[i] < best_err + 0.1 * best_rot:
            best_q, best_err, best_rot = qs[i], float(perr[i]), float(rerr[i])
        good = qs[ok]
        if accept is not None and len(good):
            good = good[np.asarray(accept(good), dtype=bool)]
        for q in good:
            if all(np.max(np.abs(q - s)) > 1e-3 for s in sols):
                sols.append(q)
    if not sols:
        return IKResult(False, best_q, best_err, best_rot, [], tried)
    sols.sort(key=lambda s: float(np.linalg.norm(s - current)))
    q = sols[0]
    pose = kin.link_pose(q)
    perr = float(np.linalg.norm(pose[:3, 3] - t[:3, 3]))
    rerr = 0.0
    if orientation:
        rerr = float(np.linalg.norm(_rotation_error(t[:3, :3], pose[:3, :3].copy())))
    return IKResult(True, q, perr, rerr, sols, tried)


@nb.njit(cache=True)
def _dls_many(
    seeds, targets, lower, upper, kin_arrays, ancestors, tip, max_iter, tol_pos, max_step
):
    """Position-only damped least squares for many targets, each from its own seeds:
    seeds (M, k, d), targets (M, 3). Returns (q (M, k, d), converged (M, k))."""
    m, k, d = seeds.shape
    qs = np.empty((m, k, d))
    ok = np.zeros((m, k), dtype=np.bool_)
    t = np.eye(4)
    for i in range(m):
        t[0, 3], t[1, 3], t[2, 3] = targets[i, 0], targets[i, 1], targets[i, 2]
        q, _p, _r, good = _dls(
            seeds[i],
            t,
            False,
            lower,
            upper,
            kin_arrays,
            ancestors,
            tip,
            max_iter,
            tol_pos,
            1.0,
            max_step,
        )
        qs[i] = q
        ok[i] = good
    return qs, ok


def solve_positions(
    kin: Kinematics,
    targets: np.ndarray,
    seeds: np.ndarray,
    tol_pos: float = 0.01,
    max_iter: int = 60,
) -> tuple[np.ndarray, np.ndarray]:
    """Joint values that put the end effector at each of many points, position only:
    `targets` (M, 3) in the robot's root frame, `seeds` (M, k, d) tried for each (seeds
    near a solution converge in a few steps: see `planning/reach.py`). Returns the
    configurations (M, k, d) and which converged within `tol_pos` m (M, k). One compiled
    call for all targets: reach maps ask thousands of points at a time."""
    t = np.ascontiguousarray(np.asarray(targets, dtype=float).reshape(-1, 3))
    s = np.ascontiguousarray(np.asarray(seeds, dtype=float))
    if s.ndim != 3 or s.shape[0] != len(t) or s.shape[2] != kin.d:
        raise ValueError(
            f"seeds must be (targets, k, {kin.d}) for {len(t)} targets, got shape {s.shape}"
        )
    s = np.clip(s, kin.lower, kin.upper)
    return _dls_many(
        s, t, kin.lower, kin.upper, kin._args(), kin.ancestors, kin.tip, max_iter, tol_pos, 0.4
    )


def halton(n: int, d: int) -> np.ndarray:
    """The first `n` points of the `d`-dimensional Halton sequence in [0, 1) (the
    radical inverses of 1..n in the first d primes): seeds spread evenly over the joint
    space, the same every time, so that an answer does not depend on a random draw."""
    primes: list[int] = []
    k = 2
    while len(primes) < d:
        if all(k % p for p in primes):
            primes.append(k)
        k += 1
    out = np.zeros((n, d))
    for j, base in enumerate(primes):
        for i in range(n):
            x, f, v = i + 1, 1.0, 0.0
            while x:
                f /= base
                v += f * (x % base)
                x //= base
            out[i, j] = v
    return out
