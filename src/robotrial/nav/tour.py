"""A tour of a home for a base that turns on the spot and drives straight: from the dock
through each room's most open spot and back, as straight legs (layer 3).

A mapping run needs a route before any map exists; built-in worlds come with one drawn
by hand. For any other home this makes one from the plan: the rooms are visited in the
order that keeps the way shortest (distances through the free space the base's centre
may use), each leg is planned by Hybrid-A* for the real footprint, and the plan is then
cut into as few straight legs as it can: consecutive waypoints are joined by a segment
the footprint (grown by a margin, for a driver that steers a little) sweeps without
touching anything, and the turn on the spot at each waypoint is clear too. So a driver
that turns towards the next point and drives to it (`trials.slam.RouteDrive`) follows
the tour as planned.
"""

from __future__ import annotations

from itertools import pairwise, permutations

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra

from robotrial.nav.costmap import Costmap
from robotrial.nav.hybrid import YAW_BINS, HybridAStar, HybridConfig, footprint_hits
from robotrial.nav.planners import NoPath, StartBlocked

EXACT_ORDER = 7
"""Up to this many rooms, every order is tried; beyond, the nearest room next."""
ARC_PENALTY = 4.0
"""Cost factor on the planner's arcs: a driver that turns on the spot and then drives
straight follows turns and straight steps, not arcs."""


def open_spot(clearance: np.ndarray, origin: np.ndarray, res: float, bounds) -> tuple[float, float]:
    """The point of a room rectangle `bounds` ((x0, y0), (x1, y1)) farthest from every
    obstacle, given the grid's `clearance` (m) to the nearest obstacle per cell."""
    (x0, y0), (x1, y1) = bounds
    c0, r0 = int(np.floor((x0 - origin[0]) / res)), int(np.floor((y0 - origin[1]) / res))
    c1, r1 = int(np.ceil((x1 - origin[0]) / res)), int(np.ceil((y1 - origin[1]) / res))
    rows, cols = clearance.shape
    c0, c1 = max(c0, 0), min(c1, cols)
    r0, r1 = max(r0, 0), min(r1, rows)
    window = clearance[r0:r1, c0:c1]
    if window.size == 0:
        raise ValueError(f"room {bounds} lies outside the map")
    r, c = np.unravel_index(int(np.argmax(window)), window.shape)
    return origin[0] + (c0 + c + 0.5) * res, origin[1] + (r0 + r + 0.5) * res


def free_graph(free: np.ndarray, resolution: float) -> tuple[csr_matrix, np.ndarray]:
    """The 8-connected graph of the `free` cells (edge weights in m) and each cell's node
    index (-1: not free)."""
    rows, cols = free.shape
    index = np.full(free.shape, -1, dtype=np.int64)
    index[free] = np.arange(int(free.sum()))
    src, dst, w = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = free[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)]
        b = free[max(0, dr) : rows - max(0, -dr), max(0, dc) : cols - max(0, -dc)]
        ia = index[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)]
        ib = index[max(0, dr) : rows - max(0, -dr), max(0, dc) : cols - max(0, -dc)]
        both = a & b
        src.append(ia[both])
        dst.append(ib[both])
        w.append(np.full(int(both.sum()), resolution * np.hypot(dr, dc)))
    n = int(free.sum())
    graph = coo_matrix(
        (np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)
    ).tocsr()
    return graph, index


def travel_distances(costmap: Costmap, points: np.ndarray) -> np.ndarray:
    """(K, K) lengths (m) of the shortest 8-connected ways between world points through
    the cells at least the footprint's inscribed radius from any obstacle (inf: none)."""
    free = costmap.distance >= costmap.footprint.inscribed_radius
    rows, cols = free.shape
    graph, index = free_graph(free, costmap.resolution)
    rc = costmap.world_to_cell(np.asarray(points, dtype=float).reshape(-1, 2))
    k = len(rc)
    out = np.full((k, k), np.inf)
    nodes = []
    for r, c in rc:
        inside = 0 <= r < rows and 0 <= c < cols
        nodes.append(int(index[r, c]) if inside else -1)
    known = [i for i, v in enumerate(nodes) if v >= 0]
    if known:
        d = dijkstra(graph, directed=False, indices=[nodes[i] for i in known])
        for row, i in enumerate(known):
            for j in known:
                out[i, j] = d[row, nodes[j]]
    return out


def visit_order(distances: np.ndarray) -> list[int]:
    """The order of points 1 .. K-1 for a closed tour from point 0 and back that keeps
    the way shortest (every order up to EXACT_ORDER points, else the nearest next);
    points no way reaches are left out."""
    k = len(distances)
    rest = [i for i in range(1, k) if np.isfinite(distances[0, i])]
    if len(rest) <= EXACT_ORDER:
        best, length = list(rest), np.inf
        for order in permutations(rest):
            stops = [0, *order, 0]
            total = sum(distances[a, b] for a, b in pairwise(stops))
            if total < length:
                best, length = list(order), total
        return best
    order, at, left = [], 0, set(rest)
    while left:
        at = min(left, key=lambda j: distances[at, j])
        order.append(at)
        left.remove(at)
    return order


def _turn_clear(
    costmap: Costmap, xy: np.ndarray, h0: float, h1: float, margin: float, blocked: np.ndarray
) -> bool:
    """Whether the footprint turning on the spot at `xy` from heading h0 to h1 (the
    shorter way) stays clear."""
    delta = (h1 - h0 + np.pi) % (2 * np.pi) - np.pi
    n = max(2, int(np.ceil(abs(delta) / (np.pi / YAW_BINS))) + 1)
    yaws = h0 + np.linspace(0.0, delta, n)
    poses = np.column_stack([np.full(n, xy[0]), np.full(n, xy[1]), yaws])
    return not footprint_hits(costmap, poses, margin, blocked).any()


def _segment_clear(
    costmap: Costmap, a: np.ndarray, b: np.ndarray, margin: float, blocked: np.ndarray
) -> bool:
    """Whether the footprint driving straight from a to b, facing b, stays clear."""
    length = float(np.hypot(*(b - a)))
    if length < 1e-9:
        return True
    n = max(2, int(np.ceil(length / (costmap.resolution / 2))) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    heading = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
    poses = np.column_stack([a + t * (b - a), np.full(n, heading)])
    return not footprint_hits(costmap, poses, margin, blocked).any()


def straight_legs(
    costmap: Costmap,
    poses: np.ndarray,
    heading: float,
    margin: float,
    planner: HybridAStar | None = None,
) -> list[tuple[float, float]]:
    """The plan `poses` (N, 3), entered facing `heading`, as waypoints joined by straight
    segments clear for the footprint grown by `margin` (m), with clear turns on the spot
    where the heading changes (each waypoint chosen so that the drive can go on from
    it); where no segment is clear at that margin, at the planner's margin, and failing
    that the plan's own next step. The first pose is not repeated."""
    planner = planner or HybridAStar()
    blocked = planner.blocked(costmap)
    pts = np.asarray(poses, dtype=float)[:, :2]
    keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-9])
    pts = pts[keep]
    last = len(pts) - 1

    def towards(i: int, j: int) -> float:
        return float(np.arctan2(pts[j, 1] - pts[i, 1], pts[j, 0] - pts[i, 0]))

    def options(i: int, heading: float, m: float, first: bool = False) -> list[int]:
        """The points j > i a turn at i and a straight drive reach clear (ascending);
        with `first`, only the first such point."""
        out = []
        for j in range(i + 1, len(pts)):
            if not _segment_clear(costmap, pts[i], pts[j], m, blocked):
                break
            if _turn_clear(costmap, pts[i], heading, towards(i, j), m, blocked):
                out.append(j)
                if first:
                    break
        return out

    out: list[tuple[float, float]] = []
    i = 0
    while i < last:
        best = None
        for m in (margin, min(margin, planner.config.margin)):  # a doorway may need less
            # the farthest point from which the drive can go on (one leg of lookahead)
            for j in reversed(options(i, heading, m)):
                if j == last or options(j, towards(i, j), m, first=True):
                    best = j
                    break
            if best is not None:
                break
        best = i + 1 if best is None else best  # the plan's own step (an arc, steered)
        heading = towards(i, best)
        out.append((float(pts[best, 0]), float(pts[best, 1])))
        i = best
    return out


def room_tour(
    costmap: Costmap,
    dock: tuple[float, float, float],
    goals: list[tuple[float, float]],
    margin: float = 0.08,
    planner: HybridAStar | None = None,
) -> tuple[list[tuple[float, float]], list[int]]:
    """Waypoints (world x, y) from `dock` (x, y, yaw) through the `goals` and back to the
    dock, as straight legs clear for the costmap's footprint grown by `margin` (m), and
    the indices of the goals visited, in order (goals no motion of the footprint reaches
    are left out). Raises StartBlocked when the footprint does not fit at the dock.
    The default planner all but avoids arcs, so that its plans are already turns on the
    spot and straight steps; it never ends in a drive backwards (the driver only drives
    forwards) and does not pay extra near obstacles (the legs keep their own margin, and
    detours for room would only add short arcs to steer)."""
    planner = planner or HybridAStar(
        HybridConfig(arc_penalty=ARC_PENALTY, reverse_shot=False, tight_penalty=1.0)
    )
    start = np.asarray(dock, dtype=float)
    points = np.vstack([start[:2], np.asarray(goals, dtype=float).reshape(-1, 2)])
    order = [i - 1 for i in visit_order(travel_distances(costmap, points))]
    route: list[tuple[float, float]] = []
    visited: list[int] = []
    at, heading = start[:2], float(start[2])
    for g in [*order, None]:
        target = start[:2] if g is None else np.asarray(goals[g], dtype=float)
        try:
            poses = planner.plan_poses(costmap, (at[0], at[1], heading), tuple(target))
        except StartBlocked:
            raise
        except NoPath:
            continue  # the distance graph is coarser than the planner: skip this room
        legs = straight_legs(costmap, poses, heading, margin, planner)
        if not legs:
            continue
        route.extend(legs)
        if g is not None:
            visited.append(g)
        prev = np.array(route[-2]) if len(route) > 1 else at
        end = np.array(route[-1])
        if np.hypot(*(end - prev)) > 1e-9:
            heading = float(np.arctan2(end[1] - prev[1], end[0] - prev[0]))
        at = end
    return route, visited
