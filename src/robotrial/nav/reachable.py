"""Every pose a rectangular base can get to from a start: the free component of its
(x, y, yaw) space (layer 3).

Hybrid-A* answers one goal at a time; a reach map asks about hundreds of base poses
around the furniture. This labels, once, the poses of the costmap's cell centres at the
planner's 72 yaw bins whose footprint (the same check as `HybridAStar.collides`) is
clear, joined to their neighbours one cell or one yaw bin away (the last bin wraps to
the first). A base that turns on the spot and drives straight (a skid-steer base) can
follow any path in that free space, so the component of the start is what it reaches,
to the grid's resolution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from robotrial.nav.costmap import Costmap
from robotrial.nav.hybrid import YAW_BINS, HybridAStar, footprint_hits


@dataclass
class ReachablePoses:
    """The free component of the start: `mask` (YAW_BINS, rows, cols) over the
    costmap's cells; `free` the same for every clear pose, reached or not."""

    costmap: Costmap
    mask: np.ndarray
    free: np.ndarray

    def index(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(bin, row, col) of world poses (N, 3); rows or columns may fall outside."""
        p = np.asarray(poses, dtype=float).reshape(-1, 3)
        rc = self.costmap.world_to_cell(p[:, :2])
        k = np.round(p[:, 2] / (2 * np.pi / YAW_BINS)).astype(np.int64) % YAW_BINS
        return k, rc[:, 0], rc[:, 1]

    def contains(self, poses: np.ndarray) -> np.ndarray:
        """(N,) bool: which world poses (N, 3) lie in the start's component."""
        return self._look_up(self.mask, poses)

    def clear(self, poses: np.ndarray) -> np.ndarray:
        """(N,) bool: where the footprint is clear at world poses (N, 3), reached or not."""
        return self._look_up(self.free, poses)

    def _look_up(self, grid: np.ndarray, poses: np.ndarray) -> np.ndarray:
        k, r, c = self.index(poses)
        rows, cols = self.costmap.shape
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        out = np.zeros(len(k), dtype=bool)
        out[inside] = grid[k[inside], r[inside], c[inside]]
        return out


def reachable_poses(
    costmap: Costmap, start: tuple[float, float, float], planner: HybridAStar | None = None
) -> ReachablePoses:
    """The poses the costmap's footprint reaches from `start` (x, y, yaw); the footprint
    check and blocked cells are `planner`'s (default: a `HybridAStar` as configured by
    default). Raises ValueError when no clear pose lies within a cell and a yaw bin of
    the start."""
    planner = planner or HybridAStar()
    rows, cols = costmap.shape
    ys, xs = np.mgrid[0:rows, 0:cols]
    centres = costmap.cell_to_world(np.stack([ys, xs], axis=-1))
    poses = np.empty((rows, cols, 3))
    poses[..., :2] = centres
    blocked = planner.blocked(costmap)
    free = np.empty((YAW_BINS, rows, cols), dtype=bool)
    for k in range(YAW_BINS):  # a bin at a time: not three floats for every pose at once
        poses[..., 2] = 2 * np.pi / YAW_BINS * k
        free[k] = ~footprint_hits(costmap, poses, planner.config.margin, blocked)
    labels, n = ndimage.label(free)
    # the yaw wraps: a component through the last bin continues in the first
    both = (labels[0] > 0) & (labels[-1] > 0)
    parent = np.arange(n + 1)

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in set(zip(labels[0][both].tolist(), labels[-1][both].tolist(), strict=True)):
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    found = ReachablePoses(costmap, np.zeros_like(free), free)
    k, r, c = (int(v[0]) for v in found.index(np.asarray(start, dtype=float)))
    for dk, dr, dc in sorted(
        ((dk, dr, dc) for dk in (0, -1, 1) for dr in (0, -1, 1) for dc in (0, -1, 1)),
        key=lambda t: abs(t[0]) + abs(t[1]) + abs(t[2]),
    ):
        kk, rr, cc = (k + dk) % YAW_BINS, r + dr, c + dc
        if 0 <= rr < rows and 0 <= cc < cols and labels[kk, rr, cc] > 0:
            target = root(int(labels[kk, rr, cc]))
            ours = np.array([i > 0 and root(i) == target for i in range(n + 1)])
            found.mask = ours[labels]  # a bool per pose: no second array of labels
            return found
    raise ValueError(
        f"the footprint at the start ({start[0]:.2f}, {start[1]:.2f}) touches an obstacle "
        "in every nearby pose"
    )
