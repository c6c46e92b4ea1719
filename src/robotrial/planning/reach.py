"""Reach maps: which points an arm's hand gets to, free of collision, many at a time
(layer 3).

`ReachBank` is what an arm contributes once: random configurations free of self-collision
and the points its tool reaches in them (the robot's root frame), in a k-d tree. To ask
whether the hand gets to a set of points in a scene, `reached` takes the bank's nearest
configurations to each point as seeds (those free in the scene first), refines them with
position-only damped least squares in one compiled call (`kinematics/ik.py`), and keeps a
point when a refined configuration is within the tolerance and free in the scene's
collision checker. A point with no bank configuration within `gap` of it is out of the
arm's reach without any IK.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from robotrial.collision.sphere_model import CollisionChecker
from robotrial.kinematics.chain import Kinematics
from robotrial.kinematics.ik import solve_positions


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
        self.points = kin.fk(qs)[:, kin.tip, :3, 3]
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
    gap: float = 0.12,
    tolerance: float = 0.01,
) -> np.ndarray:
    """(M,) bool: whether the hand gets within `tolerance` m of each target (M, 3; root
    frame) in a configuration that `checker` finds free. Up to `tries` seeds per target
    from its `neighbours` nearest bank configurations, the free ones first."""
    t = np.asarray(targets, dtype=float).reshape(-1, 3)
    out = np.zeros(len(t), dtype=bool)
    if len(t) == 0:
        return out
    idx, missing = bank.seeds(t, neighbours, gap)
    near = idx[:, 0] < missing
    if not near.any():
        return out
    t, idx = t[near], idx[near]
    used = np.unique(idx[idx < missing])
    free = np.zeros(missing + 1, dtype=bool)
    free[used] = checker.valid(bank.qs[used])
    # free seeds first, then the rest by distance; a missing neighbour sorts last
    rank = np.where(idx >= missing, 2, np.where(free[idx], 0, 1))
    order = np.argsort(rank, axis=1, kind="stable")[:, :tries]
    pick = np.take_along_axis(idx, order, axis=1)
    pick = np.where(pick >= missing, idx[:, :1], pick)  # at least the nearest is there
    qs, ok = solve_positions(bank.kin, t, bank.qs[pick], tol_pos=tolerance)
    good = np.zeros(ok.shape, dtype=bool)
    if ok.any():
        good[ok] = checker.valid(qs[ok])
    out[np.flatnonzero(near)] = good.any(axis=1)
    return out
