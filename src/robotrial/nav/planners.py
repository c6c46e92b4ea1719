"""Global planners on a costmap: Dijkstra (navfn, as in the platform paper) and A* (layer 3).

A planner takes a costmap, a start and a goal (world x, y) and returns a path of world
points from start to goal, or raises `NoPath` saying why. Both search the 8-connected
grid with a compiled binary heap; a step costs its length times
`1 + cost_weight * cost / 252`, so paths keep away from obstacles where there is room.
Cells at or above INSCRIBED (and unknown ones unless `allow_unknown`) cannot be entered;
the start cell always can, so a robot that starts too close to a wall can leave it.

`shortest_path` is the yardstick of the trials: the shortest path a robot of a given
clearance can take (8-connected search, then pulled taut along lines of sight).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage

from robotrial.nav.costmap import INSCRIBED, MAX_INFLATED, UNKNOWN, Costmap


class NoPath(RuntimeError):
    """No path exists (the message says why: start or goal blocked, or unreachable)."""


class StartBlocked(NoPath):
    """The robot's footprint already touches an obstacle where the search would start."""


@numba.njit(cache=True)
def _heap_push(keys, vals, size, key, val):
    i = size
    keys[i] = key
    vals[i] = val
    while i > 0:
        p = (i - 1) >> 1
        if keys[p] <= keys[i]:
            break
        keys[p], keys[i] = keys[i], keys[p]
        vals[p], vals[i] = vals[i], vals[p]
        i = p
    return size + 1


@numba.njit(cache=True)
def _heap_pop(keys, vals, size):
    key, val = keys[0], vals[0]
    size -= 1
    keys[0], vals[0] = keys[size], vals[size]
    i = 0
    while True:
        left = 2 * i + 1
        if left >= size:
            break
        m = left
        if left + 1 < size and keys[left + 1] < keys[left]:
            m = left + 1
        if keys[i] <= keys[m]:
            break
        keys[m], keys[i] = keys[i], keys[m]
        vals[m], vals[i] = vals[i], vals[m]
        i = m
    return key, val, size


@numba.njit(cache=True)
def _search(weight, start, goal, heuristic):
    """Best-first search over cells with step cost length * mean weight (inf = blocked).
    Returns the parent array over flat cell indices (-1 where unreached)."""
    rows, cols = weight.shape
    pc = cols + 2
    # a border of blocked cells spares the bounds checks in the inner loop
    w = np.full((rows + 2) * pc, np.inf)
    for r in range(rows):
        for c in range(cols):
            w[(r + 1) * pc + c + 1] = weight[r, c]
    n = w.shape[0]
    offs = np.array([-pc - 1, -pc, -pc + 1, -1, 1, pc - 1, pc, pc + 1])
    sq2 = np.sqrt(2.0)
    lens = np.array([sq2, 1.0, sq2, 1.0, 1.0, sq2, 1.0, sq2])
    g = np.full(n, np.inf)
    ppar = np.full(n, -1, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    cap = 4 * n + 1
    keys = np.empty(cap)
    vals = np.empty(cap, dtype=np.int64)
    ps = (start // cols + 1) * pc + start % cols + 1
    pg = (goal // cols + 1) * pc + goal % cols + 1
    gr, gc = goal // cols + 1, goal % cols + 1
    g[ps] = 0.0
    ppar[ps] = ps
    size = _heap_push(keys, vals, 0, 0.0, ps)
    while size > 0:
        _, cur, size = _heap_pop(keys, vals, size)
        if closed[cur]:
            continue
        closed[cur] = True
        if cur == pg:
            break
        gcur = g[cur]
        wcur = w[cur]
        for k in range(8):
            nxt = cur + offs[k]
            wn = w[nxt]
            if wn == np.inf or closed[nxt]:
                continue
            cand = gcur + lens[k] * 0.5 * (wn + wcur)
            if cand < g[nxt]:
                g[nxt] = cand
                ppar[nxt] = cur
                h = 0.0
                if heuristic:
                    ar, ac = abs(nxt // pc - gr), abs(nxt % pc - gc)
                    lo = min(ar, ac)
                    h = (max(ar, ac) - lo) + sq2 * lo
                if size >= cap:
                    break
                size = _heap_push(keys, vals, size, cand + h, nxt)
    parent = np.full(rows * cols, -1, dtype=np.int64)
    for r in range(rows):
        for c in range(cols):
            p = ppar[(r + 1) * pc + c + 1]
            if p >= 0:
                parent[r * cols + c] = (p // pc - 1) * cols + p % pc - 1
    return parent


def _trace(parent: np.ndarray, start: int, goal: int, cols: int) -> np.ndarray:
    out = [goal]
    cur = goal
    while cur != start:
        cur = int(parent[cur])
        out.append(cur)
    idx = np.array(out[::-1])
    return np.stack([idx // cols, idx % cols], axis=1)


@dataclass
class GridPlanner:
    """Shared machinery of the grid planners; `heuristic` switches Dijkstra to A*."""

    cost_weight: float = 1.0
    allow_unknown: bool = False
    heuristic: bool = False
    name: str = "grid"

    def weights(self, costmap: Costmap) -> np.ndarray:
        """Per-cell step weight (inf where the robot's centre may not go)."""
        cost = costmap.cost.astype(float)
        w = 1.0 + self.cost_weight * np.minimum(cost, MAX_INFLATED) / MAX_INFLATED
        blocked = (costmap.cost >= INSCRIBED) & (costmap.cost != UNKNOWN)
        if not self.allow_unknown:
            blocked |= costmap.cost == UNKNOWN
        w[blocked] = np.inf
        return w

    def plan(
        self, costmap: Costmap, start: tuple[float, float], goal: tuple[float, float]
    ) -> np.ndarray:
        """(N, 2) world points from the start cell's centre to the goal; raises NoPath.

        Inscribed (not lethal) cells near the start stay open at a high price, so a
        robot that has come too close to an obstacle can still plan its way out."""
        w = self.weights(costmap)
        s = costmap.world_to_cell(np.asarray(start, dtype=float))
        if costmap.inside(s) and not np.isfinite(w[s[0], s[1]]):
            reach = int(np.ceil(costmap.footprint.circumscribed_radius / costmap.resolution))
            r0, c0 = max(0, s[0] - reach), max(0, s[1] - reach)
            win = costmap.cost[r0 : s[0] + reach + 1, c0 : s[1] + reach + 1]
            sub = w[r0 : s[0] + reach + 1, c0 : s[1] + reach + 1]
            sub[win == INSCRIBED] = 1.0 + 2.0 * self.cost_weight
        return plan_on_weights(w, costmap, start, goal, self.heuristic)


def plan_on_weights(
    weight: np.ndarray,
    costmap: Costmap,
    start: tuple[float, float],
    goal: tuple[float, float],
    heuristic: bool,
) -> np.ndarray:
    """Search a weight grid laid over `costmap`'s cells; the path ends exactly at `goal`."""
    s = costmap.world_to_cell(np.asarray(start, dtype=float))
    g = costmap.world_to_cell(np.asarray(goal, dtype=float))
    for what, rc in (("start", s), ("goal", g)):
        if not costmap.inside(rc):
            raise NoPath(
                f"the {what} {tuple(np.round(start if what == 'start' else goal, 3))} "
                "lies outside the map"
            )
    if not np.isfinite(weight[g[0], g[1]]):
        raise NoPath(f"the goal {tuple(np.round(goal, 3))} is in or too close to an obstacle")
    w = weight.copy()
    if not np.isfinite(w[s[0], s[1]]):
        w[s[0], s[1]] = float(np.max(w[np.isfinite(w)], initial=1.0))
    cols = w.shape[1]
    si, gi = int(s[0] * cols + s[1]), int(g[0] * cols + g[1])
    parent = _search(w, si, gi, heuristic)
    if parent[gi] < 0:
        raise NoPath(f"the goal {tuple(np.round(goal, 3))} cannot be reached from the start")
    pts = costmap.cell_to_world(_trace(parent, si, gi, cols))
    pts[-1] = np.asarray(goal, dtype=float)
    return pts


@dataclass
class Dijkstra(GridPlanner):
    """navfn's algorithm: uniform-cost search, no heuristic."""

    heuristic: bool = False
    name: str = "dijkstra"


@dataclass
class AStar(GridPlanner):
    """A* with the octile distance (admissible: every step weight is >= 1)."""

    heuristic: bool = True
    name: str = "astar"


PLANNERS: dict[str, type[GridPlanner]] = {"dijkstra": Dijkstra, "astar": AStar}


def make_planner(name: str, **kwargs) -> GridPlanner:
    """A planner by name: 'dijkstra' or 'astar'."""
    try:
        return PLANNERS[name](**kwargs)
    except KeyError:
        raise ValueError(
            f"unknown global planner {name!r}; choose from {sorted(PLANNERS)}"
        ) from None


def smooth(path: np.ndarray, costmap: Costmap, window: float = 0.5) -> np.ndarray:
    """The path with its grid stair-steps averaged out over `window` m; the ends stay,
    and a point whose average would enter an inscribed cell keeps its place."""
    p = np.asarray(path, dtype=float)
    k = round(window / costmap.resolution) | 1
    if len(p) < 3 or k < 3:
        return p
    pad = k // 2
    padded = np.vstack([np.repeat(p[:1], pad, 0), p, np.repeat(p[-1:], pad, 0)])
    kernel = np.ones(k) / k
    out = np.column_stack([np.convolve(padded[:, i], kernel, mode="valid") for i in range(2)])
    bad = costmap.cost_at(out) >= INSCRIBED
    out[bad] = p[bad]
    out[0], out[-1] = p[0], p[-1]
    return out


def path_length(path: np.ndarray) -> float:
    """Length (m) of a polyline of world points."""
    p = np.asarray(path, dtype=float)
    return float(np.hypot(*np.diff(p, axis=0).T).sum()) if len(p) > 1 else 0.0


@numba.njit(cache=True)
def _line_free(free, r0, c0, r1, c1):
    """True if every cell the segment between two cell centres touches is free."""
    n = int(2 * max(abs(r1 - r0), abs(c1 - c0)) + 1)
    for i in range(n + 1):
        t = i / n
        r = int(np.floor(r0 + 0.5 + t * (r1 - r0)))
        c = int(np.floor(c0 + 0.5 + t * (c1 - c0)))
        if not free[r, c]:
            return False
    return True


@numba.njit(cache=True)
def _string_pull(free, cells):
    """Indices of the waypoints kept when each is joined to the farthest one in sight."""
    keep = [0]
    i = 0
    n = cells.shape[0]
    while i < n - 1:
        j = n - 1
        while j > i + 1 and not _line_free(
            free, cells[i, 0], cells[i, 1], cells[j, 0], cells[j, 1]
        ):
            j -= 1
        keep.append(j)
        i = j
    return np.array(keep)


def shortest_path(
    occupied: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    clearance: float,
    start: tuple[float, float],
    goal: tuple[float, float],
) -> np.ndarray:
    """The shortest path (world points) whose every point keeps `clearance` (m) from all
    occupied cells: an 8-connected search pulled taut along lines of sight."""
    occ = np.asarray(occupied, dtype=bool)
    dist = (
        ndimage.distance_transform_edt(~occ) * resolution
        if occ.any()
        else np.full(occ.shape, np.inf)
    )
    free = dist > clearance
    weight = np.where(free, 1.0, np.inf)
    grid = _GridFrame(origin, resolution, occ.shape)
    path = plan_on_weights(weight, grid, start, goal, heuristic=True)  # type: ignore[arg-type]
    cells = grid.world_to_cell(path)
    free_s = free.copy()
    free_s[cells[0, 0], cells[0, 1]] = True
    keep = _string_pull(free_s, cells.astype(np.int64))
    out = path[keep]
    out[0] = np.asarray(start, dtype=float)
    return out


class _GridFrame:
    """The coordinate part of a Costmap, for searching plain weight grids."""

    def __init__(self, origin: tuple[float, float], resolution: float, shape: tuple[int, int]):
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        self.shape = shape

    world_to_cell = Costmap.world_to_cell
    cell_to_world = Costmap.cell_to_world
    inside = Costmap.inside
