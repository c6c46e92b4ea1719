"""Is a free region closed in by walls? (layer 3: arrays in, arrays out).

A home checked for a robot must be closed: if the free floor around the dock reaches the
edge of the map, a planner may route the robot out of one room, around the outside of
the house and in through another, and the verdict would be wrong. `way_out` answers
whether the region is open and, when it is, gives the shortest way from the start cell to
the edge, so that the caller can say where the walls leave a gap.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy import ndimage

_STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))


def way_out(occupied: np.ndarray, start: tuple[int, int]) -> np.ndarray | None:
    """The cells (row, col) of a shortest 4-connected way through free cells from `start`
    to the edge of the grid, or None when the free region holding `start` never touches
    the edge (or `start` is occupied or outside the grid).

    4-connected, so two wall cells that touch only at a corner still close the region."""
    occupied = np.asarray(occupied, dtype=bool)
    rows, cols = occupied.shape
    r0, c0 = int(start[0]), int(start[1])
    if not (0 <= r0 < rows and 0 <= c0 < cols) or occupied[r0, c0]:
        return None
    labels, _ = ndimage.label(~occupied)
    mine = labels == labels[r0, c0]
    if not (mine[0].any() or mine[-1].any() or mine[:, 0].any() or mine[:, -1].any()):
        return None
    parent = np.full((rows, cols, 2), -1, dtype=np.int64)
    parent[r0, c0] = (r0, c0)
    queue = deque([(r0, c0)])
    while queue:
        r, c = queue.popleft()
        if r in (0, rows - 1) or c in (0, cols - 1):
            path = [(r, c)]
            while (r, c) != (r0, c0):
                r, c = (int(v) for v in parent[r, c])
                path.append((r, c))
            return np.array(path[::-1], dtype=np.int64)
        for dr, dc in _STEPS:
            nr, nc = r + dr, c + dc
            if mine[nr, nc] and parent[nr, nc, 0] < 0:
                parent[nr, nc] = (r, c)
                queue.append((nr, nc))
    return None  # unreachable: the label said the region touches the edge
