"""Reach maps: which points an arm's hand gets to, free of collision, many at a time
(layer 3).

`ReachBank` is what an arm contributes once: random configurations free of self-collision
and the points its tool reaches in them (the robot's root frame), in a k-d tree. To ask
whether the hand gets to a set of points in a scene, `reached` takes the bank's nearest
configurations to each point as seeds (those free in the scene first), refines them with
position-only damped least squares in one compiled call (`kinematics/ik.py`), and keeps a
point when a refined configuration is within the tolerance and free in the scene's
collision checker. A point with no bank configuration within `SEED_GAP` of it is out of
the arm's reach without any IK.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from robotrial.collision.sphere_model import CollisionChecker
from robotrial.kinematics.chain import Kinematics
from robotrial.kinematics.ik import solve_positions

SEED_GAP = 0.12  # m: a target with no bank configuration this near is out of reach
CHUNK = 10_000  # configurations whose forward kinematics are computed at once


class ReachBank:
    """`samples` random arm configurations free of self-collision (checked by `free`, a
    checker of the arm with no obstacles) and their tool points in the root frame."""

    def __init__(
        self, kin: Kinematics, free: CollisionChecker, samples: int = 40_000, seed: int = 0
    ) -> None:
        rng = np.random.default_rng(seed)
        qs = kin.random(rng, samples)
        qs = qs[free.valid(qs)]
        if len(qs) == 0:
            raise ValueError(
                f"robot {kin.model.name!r}: no configuration of its arm is free of "
                f"self-collision in {samples} samples"
            )
        self.kin = kin
        self.qs = qs
        # a chunk at a time (each tool point copied out, so that the chunk's poses of every
        # link go): all of them at once would be 160 MB
        self.points = np.concatenate(
            [
                kin.fk(chunk)[:, kin.tip, :3, 3].copy()
                for chunk in np.array_split(qs, -(-len(qs) // CHUNK))
            ]
        )
        self.tree = cKDTree(self.points)

    def seeds(self, targets: np.ndarray, k: int, gap: float) -> tuple[np.ndarray, int]:
        """For each target (M, 3): the indices (M, k) of the k nearest bank configurations
        within `gap` m, nearest first, and the index that stands for none (len(qs))."""
        _, idx = self.tree.query(targets, k=k, distance_upper_bound=gap)
        return np.asarray(idx, dtype=np.int64).reshape(len(targets), k), len(self.qs)


def reached(
    bank: ReachBank,
    checker: CollisionChecker,
    targets: np.ndarray,
    tries: int = 3,
    neighbours: int = 12,
    gap: float = SEED_GAP,
    tolerance: float = 0.01,
    wide: tuple[int, int, float] = (6, 96, 0.3),
) -> np.ndarray:
    """(M,) bool: whether the hand gets within `tolerance` m of each target (M, 3; root
    frame) in a configuration that `checker` finds free. First up to `tries` seeds per
    target from its `neighbours` nearest bank configurations, the free ones first; then,
    for the targets the hand got to only in colliding configurations, `wide` = (tries,
    neighbours, gap): free seeds spread over a wider neighbourhood (the nearest ones may
    all reach round the wrong side of an obstacle)."""
    t = np.asarray(targets, dtype=float).reshape(-1, 3)
    out = np.zeros(len(t), dtype=bool)
    if len(t) == 0:
        return out
    near = np.flatnonzero(bank.seeds(t, 1, gap)[0][:, 0] < len(bank.qs))
    if len(near) == 0:
        return out
    hit, blocked = _refine(bank, checker, t[near], tries, neighbours, gap, tolerance, False)
    out[near[hit]] = True
    missed = near[blocked]
    if len(missed) and wide[0] > 0:
        out[missed] = _refine(bank, checker, t[missed], *wide, tolerance, True)[0]
    return out


def _refine(
    bank: ReachBank,
    checker: CollisionChecker,
    t: np.ndarray,
    tries: int,
    neighbours: int,
    gap: float,
    tolerance: float,
    spread: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """One pass of `reached` over targets that have bank configurations near them: seeds
    from the `neighbours` nearest within `gap` m, free ones first (nearest first, or
    every few of them with `spread`), refined and checked. Returns which targets were
    reached, and which the hand got to only in configurations that collide."""
    idx, missing = bank.seeds(t, neighbours, gap)
    used = np.unique(idx[idx < missing])
    free = np.zeros(missing + 1, dtype=bool)
    free[used] = checker.valid(bank.qs[used])
    # free seeds first, then the rest by distance; a missing neighbour sorts last
    rank = np.where(idx >= missing, 2, np.where(free[idx], 0, 1))
    order = np.argsort(rank, axis=1, kind="stable")
    if spread:  # among the free seeds, every few: different ways of reaching in
        n_free = np.maximum((rank == 0).sum(axis=1), 1)
        step = np.maximum(n_free // tries, 1)
        cols = np.minimum(np.arange(tries)[None, :] * step[:, None], neighbours - 1)
        order = np.take_along_axis(order, cols, axis=1)
    else:
        order = order[:, :tries]
    pick = np.take_along_axis(idx, order, axis=1)
    pick = np.where(pick >= missing, idx[:, :1], pick)  # at least the nearest is there
    qs, ok = solve_positions(bank.kin, t, bank.qs[pick], tol_pos=tolerance, max_iter=60)
    good = np.zeros(ok.shape, dtype=bool)
    if ok.any():
        good[ok] = checker.valid(qs[ok])
    reached_ = good.any(axis=1)
    return reached_, ok.any(axis=1) & ~reached_
