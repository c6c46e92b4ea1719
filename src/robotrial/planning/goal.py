"""The goal configuration of a pose request: IK, its checks and the straight motion from
the start, one compiled call (layer 3).

Seeds are the start's joints, then a fixed Halton set taken in turns near the start (within
`NEAR` of it, where solutions a straight motion reaches lie) and over the whole joint range
(the same for every request, so that an answer does not hang on a random draw); once
`NEAR_BLOCKED` near ones end blocked from the start, only the others. Each seed
descends by damped least squares (`kinematics.ik.descend`); a converged one is kept when it
lies on the start's side of the checker's walls and the checker calls it free, and the search
stops at the first kept solutions the start reaches in a straight line (the motion check of
the planner's kernels): planning to it is then that line. Without one, the search stops
`AFTER_FREE` seeds after its first free solution, and every kept solution comes back,
nearest first, for the planner to aim at. The seeds, the checks and the line run inside one
call: no Python between seeds, no array made per seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from robotrial.collision.kernels import config_free, motion_free
from robotrial.collision.sphere_model import CollisionChecker
from robotrial.kinematics.chain import Kinematics, TreeArrays
from robotrial.kinematics.ik import descend, halton, scratch

SEEDS = 256  # Halton seeds after the start's joints, at most
NEAR = 0.6  # rad (or m): half the side of the box around the start that every other seed is in
AFTER_FREE = 48  # seeds tried after the first free solution, when none is reached straight
MAX_ITER = 150
MAX_STEP = 0.4  # rad (or m) per iteration
DIRECT_WANTED = 2  # the nearest of the first two solutions the start reaches straight
SAME = 1e-3  # solutions closer than this in every joint are one
NEAR_BLOCKED = 2
"""Once this many seeds near the start (the start's own joints among them) end free but
blocked from it, the other near seeds are left out: they mostly descend to solutions
beside those, blocked by the same obstacle (all 9 near seeds of the desk task's 17 did),
so the seeds over the whole range are tried instead."""

# what became of each seed
MISSED, PAST_WALL, COLLIDING, FREE, DIRECT = 0, 1, 2, 3, 4


@nb.njit(cache=True, nogil=True)
def _search(
    unit,
    target,
    with_rotation,
    lower,
    upper,
    kin_arrays,
    ancestors,
    tip,
    tol_pos,
    tol_rot,
    start,
    wanted,
    after_free,
    wall_joint,
    wall_low,
    wall_high,
    floats,
    ints,
    work,
    work_ints,
):
    """Descend from `start`, then from the `unit` seeds placed (`place`) in order, until
    `wanted` end free and in a straight line from `start`. Returns (q per seed, outcome per
    seed, position and orientation errors per seed, seeds tried)."""
    n, d = unit.shape[0] + 1, unit.shape[1]
    qs = np.empty((n, d))
    outcome = np.zeros(n, dtype=np.int8)
    perr = np.full(n, np.inf)
    rerr = np.full(n, np.inf)
    r_target = np.ascontiguousarray(target[:3, :3])
    ik_work = scratch(kin_arrays[0].shape[0], d, with_rotation)
    last = n
    blocked_near = 0  # near seeds (the start among them) that ended free but blocked
    for b in range(n):
        if b >= last:
            return qs, outcome, perr, rerr, b
        near = b == 0 or b % 2 == 1
        if near and blocked_near >= NEAR_BLOCKED:
            last = min(n, last + 1)  # a seed skipped is not one of `after_free`'s
            continue
        q = qs[b]
        if b == 0:
            q[:] = start
        else:
            place(unit[b - 1], near, start, lower, upper, q)
        perr[b], rerr[b], ok = descend(
            q,
            target,
            r_target,
            with_rotation,
            lower,
            upper,
            kin_arrays,
            ancestors,
            tip,
            MAX_ITER,
            tol_pos,
            tol_rot,
            MAX_STEP,
            ik_work,
        )
        if not ok:
            continue
        seen = False
        for c in range(b):
            if outcome[c] >= FREE:
                far = 0.0
                for j in range(d):
                    far = max(far, abs(qs[c, j] - q[j]))
                seen = seen or far <= SAME
        if seen:
            continue
        past = False
        for w in range(wall_joint.shape[0]):
            j = wall_joint[w]
            past = past or (
                min(q[j], start[j]) <= wall_high[w] and max(q[j], start[j]) >= wall_low[w]
            )
        if past:
            outcome[b] = PAST_WALL
        elif not config_free(floats, ints, work, work_ints, q):
            outcome[b] = COLLIDING
        elif motion_free(floats, ints, work, work_ints, start, q):
            outcome[b] = DIRECT
            wanted -= 1
            if wanted == 0:
                return qs, outcome, perr, rerr, b + 1
        else:
            outcome[b] = FREE
            last = min(last, b + 1 + after_free)
            blocked_near += near
    return qs, outcome, perr, rerr, n


@nb.njit(cache=True, nogil=True)
def _found(
    unit,
    target,
    with_rotation,
    lower,
    upper,
    parent,
    origin,
    jtype,
    axis,
    src,
    mult,
    offset,
    const,
    ancestors,
    tip,
    *rest,
):
    """`_search`, and what the caller keeps of it: the free solutions of the kind that
    ended the search (reached straight, else the others), nearest `start` first; whether
    they were reached straight; the attempt nearest the target with its errors; how many
    seeds converged; how many were tried; the solutions past a wall; how many collided.
    The tree's arrays come one by one: a tuple argument costs the call microseconds
    to type."""
    kin_arrays = TreeArrays(parent, origin, jtype, axis, src, mult, offset, const)
    start = rest[2]
    qs, outcome, perr, rerr, tried = _search(
        unit, target, with_rotation, lower, upper, kin_arrays, ancestors, tip, *rest
    )
    direct = False
    converged = 0
    colliding = 0
    best = 0
    for b in range(tried):
        direct = direct or outcome[b] == DIRECT
        converged += outcome[b] > MISSED
        colliding += outcome[b] == COLLIDING
        if perr[b] + 0.1 * rerr[b] < perr[best] + 0.1 * rerr[best]:
            best = b
    kind = DIRECT if direct else FREE
    rows = np.array([b for b in range(tried) if outcome[b] == kind], dtype=np.int64)
    far = np.empty(rows.shape[0])
    for r in range(rows.shape[0]):
        v = 0.0
        for j in range(start.shape[0]):
            v += (qs[rows[r], j] - start[j]) ** 2
        far[r] = v
    free = qs[rows[np.argsort(far, kind="mergesort")]]
    past = qs[np.array([b for b in range(tried) if outcome[b] == PAST_WALL], dtype=np.int64)]
    return (
        free,
        direct,
        qs[best].copy(),
        perr[best],
        rerr[best],
        converged,
        tried,
        past,
        colliding,
    )


_NO_WALLS = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))


def _wall_arrays(walls: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The walls' joints, lows and highs as the compiled search takes them."""
    if not walls:
        return _NO_WALLS
    return (
        np.array([w.joint for w in walls], dtype=np.int64),
        np.array([w.low for w in walls], dtype=float),
        np.array([w.high for w in walls], dtype=float),
    )


@dataclass
class GoalSearch:
    """What `search` found: `free`, the free solutions on the start's side of the walls,
    nearest the start first; `direct`, whether the start reaches the first of them in a
    straight line; `best`, the attempt nearest the target (for a message when nothing
    converged), with its errors in m and rad; `past_wall`, the solutions past a wall
    (not checked for collisions), and how many on the start's side collide."""

    free: np.ndarray
    direct: bool
    best: np.ndarray
    position_error: float
    orientation_error: float
    converged: int
    seeds_tried: int
    past_wall: np.ndarray
    colliding: int


def seeds(kin: Kinematics, n: int = SEEDS) -> np.ndarray:
    """The search's fixed seeds after the start: `n` Halton points in [0, 1) per joint, the
    even ones to be read near the start and the odd ones over the limits (`place`)."""
    return halton(n, kin.d)


@nb.njit(cache=True, nogil=True, inline="always")
def place(u, near, start, lower, upper, out) -> None:
    """A unit seed (`seeds`) as joints in `out`: within `NEAR` of `start` (inside the
    limits) when `near`, else over the whole range."""
    for j in range(u.shape[0]):
        lo, hi = lower[j], upper[j]
        if near:
            lo, hi = max(lo, start[j] - NEAR), min(hi, start[j] + NEAR)
        out[j] = lo + u[j] * (hi - lo)


def search(
    kin: Kinematics,
    target: np.ndarray,
    start: np.ndarray,
    checker: CollisionChecker,
    fixed_seeds: np.ndarray,
    wanted: int = DIRECT_WANTED,
    after_free: int = AFTER_FREE,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
) -> GoalSearch:
    """Goal configurations for `target` (4x4 pose, or (3,) position) from `start` (free,
    inside the limits), free in `checker` and on the start's side of its walls: the
    first the start reaches in a straight line, else all found (`GoalSearch`)."""
    t = np.eye(4)
    tgt = np.asarray(target, dtype=float)
    rotation = tgt.shape == (4, 4)
    if rotation:
        t = np.ascontiguousarray(tgt)
    else:
        t[:3, 3] = tgt
    chain, ancestors, tip = kin.tip_chain()
    free, direct, best, perr, rerr, converged, tried, past, colliding = _found(
        fixed_seeds,
        t,
        rotation,
        kin.lower,
        kin.upper,
        *chain,
        ancestors,
        tip,
        tol_pos,
        tol_rot,
        start,
        wanted,
        after_free,
        *_wall_arrays(checker.walls()),
        *checker.kernel_args(),
    )
    return GoalSearch(free, direct, best, perr, rerr, converged, tried, past, colliding)
