"""Footprint-aware global planning: Hybrid-A* over (x, y, yaw) (layer 3).

The grid planners move a point that keeps the footprint's inscribed radius from every
obstacle; a rectangular base longer than it is wide may still not fit where that point
does (a corridor narrower than the base's turning circle). `HybridAStar` searches poses
instead. Its motions are short straight steps and arcs of the base's turning radius, plus
turns on the spot for a base that can make them (`turning_radius` 0, as a skid-steer
Husky-class base); the yaw stays on 72 bins, so each motion is precomputed per bin.
Each pose along a motion is checked with the oriented rectangle against the costmap's
lethal (and unknown) cells: per yaw bin (2.5 deg) and per quarter-cell position of the
centre, the cells a rectangle grown by `margin` could touch at any yaw of the bin are
listed once, so a check is a walk over that list (along a motion only over the cells
near the rectangle's edge: nothing reaches the inside without crossing it), and none at
all when the distance field already shows the circumscribed circle clear. A blocked cell
of the list is then tested exactly (separating axes of the cell square and the rectangle
at the pose's own yaw): the same answer for the planner's search, its start and every
controller and goal check (`footprint_hits`), with no rounding of the yaw, which would
move the corners of a 0.99 m base up to 1.4 cm and call a pose a few mm clear of a jamb
touching.

The search keeps one pose per (0.1 m cell, yaw bin); a step costs its length times
`1 + cost_weight * cost / 252` (as the grid planners do), a turn on the spot
`rotation_cost` m per rad. The heuristic is the weighted grid distance from the goal (a
Dijkstra sweep that keeps the centre just under the inscribed radius from obstacles),
times `heuristic_weight` (1.1: plans about as short as the cheapest, found with a
quarter of the expansions on the apartment's longest route).
A base that turns on the spot also tries, from poses within `shot_range` of the goal, to
turn towards the goal and drive straight to it. When every reachable pose has been
expanded without coming to the goal, `NoPath` says so: on this map, at these
resolutions, no motion of the rectangle gets there.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache

import numba
import numpy as np
from scipy import ndimage

from robotrial.nav.costmap import MAX_INFLATED, UNKNOWN, Costmap, Footprint
from robotrial.nav.planners import NoPath, StartBlocked, _heap_pop, _heap_push

YAW_BINS = 72
REVERSE_PENALTY = 3.0  # cost factor on backward steps of a plan that backs out of a pocket
CHECK_BINS = 2 * YAW_BINS
SUB = 4
SHOT_NEAR = 0.6  # m: within this of the goal a straight shot needs only the margin


@dataclass(frozen=True)
class HybridConfig:
    """`turning_radius` (m; 0: turns on the spot), `step` (m) of a motion, `margin` (m)
    the rectangle keeps from lethal cells, `cost_weight` of the inflation cost,
    `rotation_cost` (m per rad turned on the spot), `arc_penalty` (factor on arcs),
    `reverse_penalty` (factor on backward steps; None: no backward motion),
    `goal_tolerance` (m), `shot_range` (m), `reverse_shot` (a base that turns on the
    spot may also end in a straight drive backwards to the goal, as into a spot whose
    heading faces out of it), `tight_margin` (m) and `tight_penalty` (a step that
    ends with the rectangle nearer than `tight_margin` to something costs that much
    more, and a straight shot must keep it until near the goal: plans keep room for
    localization and tracking errors where there is room), `snug_margin` (m) and
    `snug_penalty` (one nearer than that costs that much more again: where every pose
    is tight, as in a doorway 10-15 cm wider than the base, the plan crosses it
    centred and square rather than at a slant), `max_expansions`,
    `wall_tolerance` (m:
    obstacle-layer cells this near the static map's are not blocking),
    `heuristic_weight` (>= 1; above 1 the search trades the cheapest plan for far fewer
    poses expanded: 1.1 takes the apartment's study route from 4,340 poses to about
    1,100, the path 1.4 % longer)."""

    turning_radius: float = 0.0
    step: float = 0.15
    margin: float = 0.03
    cost_weight: float = 1.0
    rotation_cost: float = 0.5
    arc_penalty: float = 1.05
    reverse_penalty: float | None = None
    goal_tolerance: float = 0.1
    shot_range: float = 3.0
    reverse_shot: bool = True
    tight_margin: float = 0.07
    tight_penalty: float = 2.0
    snug_margin: float = 0.05
    snug_penalty: float = 3.0
    max_expansions: int = 400_000
    allow_unknown: bool = False
    wall_tolerance: float = 0.1
    heuristic_weight: float = 1.1

    def __post_init__(self) -> None:
        if self.turning_radius < 0:
            raise ValueError(f"hybrid A*: turning_radius must be >= 0, got {self.turning_radius}")
        for k in ("step", "goal_tolerance", "rotation_cost"):
            if not getattr(self, k) > 0:
                raise ValueError(f"hybrid A*: {k} must be positive, got {getattr(self, k)}")
        if self.margin < 0:
            raise ValueError(f"hybrid A*: margin must be >= 0, got {self.margin}")
        if not self.heuristic_weight >= 1:
            raise ValueError(
                f"hybrid A*: heuristic_weight must be >= 1, got {self.heuristic_weight}"
            )


@lru_cache(maxsize=16)
def footprint_cells(
    footprint: Footprint, resolution: float, margin: float, band: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Cells the rectangle (grown by `margin`) may touch at any yaw within half a check
    bin of the bin's and any centre in a quarter cell, per check yaw bin and quarter-cell
    position: CSR start indices ((CHECK_BINS * SUB * SUB) + 1,) and (n, 3) rows of (row,
    col) offsets from the centre's cell and 1 where the rectangle surely overlaps that
    cell (those first), else 0. With `band` (m) > 0 only the cells within `band` of
    the edge of the rectangle at the bin's yaw: enough along a motion from a clear pose
    whose every point moves less than `band`, less the half bin's swing of the corners
    (1.4 cm), from one check to the next. Cached: a navigator's planners
    (with the margin and without) ask for eight of these by turns, and making one takes
    a few tenths of a second."""
    a0 = 0.5 * footprint.length + margin
    b0 = 0.5 * footprint.width + margin
    # turned by up to half a bin about its centre, no point moves further than this
    swing = np.hypot(a0, b0) * np.pi / CHECK_BINS
    a, b = a0 + swing, b0 + swing
    h = 0.5 * resolution + 0.5 * resolution / SUB  # cell square grown by the sub-cell
    reach = int(np.ceil((np.hypot(a, b) + 2 * resolution) / resolution))
    rr, cc = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    rr, cc = rr.ravel(), cc.ravel()
    starts, cells = [0], []
    for k in range(CHECK_BINS):
        th = 2 * np.pi * k / CHECK_BINS
        c, s = np.cos(th), np.sin(th)
        ac, as_ = abs(c), abs(s)
        for si in range(SUB):
            for sj in range(SUB):
                px = (cc + 0.5 - (sj + 0.5) / SUB) * resolution
                py = (rr + 0.5 - (si + 0.5) / SUB) * resolution
                hit = (
                    (np.abs(px) <= h + a * ac + b * as_)
                    & (np.abs(py) <= h + a * as_ + b * ac)
                    & (np.abs(px * c + py * s) <= a + h * (ac + as_))
                    & (np.abs(-px * s + py * c) <= b + h * (ac + as_))
                )
                if band > 0:
                    hit &= ~(
                        (np.abs(px * c + py * s) + h * (ac + as_) <= a0 - band)
                        & (np.abs(-px * s + py * c) + h * (ac + as_) <= b0 - band)
                    )
                # a cell whose centre lies inside the rectangle wherever the centre is
                # in the quarter cell and whatever the yaw in the bin: no test needed
                q = 0.5 * resolution / SUB * (ac + as_)
                sure = (np.abs(px * c + py * s) + q < a0 - swing) & (
                    np.abs(-px * s + py * c) + q < b0 - swing
                )
                order = np.argsort(~sure[hit], kind="stable")  # sure cells first
                found = np.stack([rr[hit], cc[hit], sure[hit]], axis=1)[order]
                cells.append(found)
                starts.append(starts[-1] + int(hit.sum()))
    return np.array(starts, dtype=np.int64), np.concatenate(cells).astype(np.int64)


def motions(config: HybridConfig) -> np.ndarray:
    """The motion primitives from yaw bin 0: rows of (kind, bins turned, length m, cost
    factor); kind 0 forward, 1 backward, 2 on the spot. Rotated to any bin at search time."""
    d = 2 * np.pi / YAW_BINS
    out = [(0, 0, config.step, 1.0)]
    if config.turning_radius > 0:
        # an arc of the turning radius itself, long enough to leave a search cell, and
        # a gentler one of the step's length
        r = config.turning_radius
        k = max(1, int(np.ceil(config.step / (r * d) - 1e-9)))
        arcs = sorted({(k, r * k * d), (1, max(config.step, r * d))})
    else:
        arcs = [(1, config.step), (2, config.step)]
    for k, length in arcs:
        out += [(0, k, length, config.arc_penalty), (0, -k, length, config.arc_penalty)]
    if config.turning_radius == 0:
        out += [(2, 1, 0.0, 1.0), (2, -1, 0.0, 1.0)]
    if config.reverse_penalty is not None:
        out.append((1, 0, config.step, config.reverse_penalty))
    return np.array(out, dtype=float)


@numba.njit(cache=True)
def _cost_to_go(weight, goal):
    """Weighted 8-connected distance (cells) from every cell to `goal` (inf: unreachable)."""
    rows, cols = weight.shape
    g = np.full(rows * cols, np.inf)
    keys = np.empty(8 * rows * cols + 1)
    vals = np.empty(8 * rows * cols + 1, dtype=np.int64)
    sq2 = np.sqrt(2.0)
    g[goal] = 0.0
    size = _heap_push(keys, vals, 0, 0.0, goal)
    while size > 0:
        k, cur, size = _heap_pop(keys, vals, size)
        if k > g[cur]:
            continue
        r, c = cur // cols, cur % cols
        wc = weight[r, c]
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                if dr == 0 and dc == 0:
                    continue
                nr, nc = r + dr, c + dc
                if nr < 0 or nr >= rows or nc < 0 or nc >= cols:
                    continue
                wn = weight[nr, nc]
                if wn == np.inf:
                    continue
                step = sq2 if dr != 0 and dc != 0 else 1.0
                cand = g[cur] + step * 0.5 * (wn + wc)
                nxt = nr * cols + nc
                if cand < g[nxt]:
                    g[nxt] = cand
                    size = _heap_push(keys, vals, size, cand, nxt)
    return g.reshape(rows, cols)


@numba.njit(cache=True)
def _collides(x, y, th, blocked, dist, free_dist, ox, oy, res, starts, cells, half):
    """Whether the rectangle of half sides `half` (a, b) at (x, y) facing `th` overlaps a
    blocked cell's square (cells outside the map count as blocked): the cells the check
    bin's list names, each tested exactly unless the list marks it sure."""
    rows, cols = blocked.shape
    fc = (x - ox) / res
    fr = (y - oy) / res
    c = int(np.floor(fc))
    r = int(np.floor(fr))
    if r < 0 or r >= rows or c < 0 or c >= cols:
        return True
    if dist[r, c] > free_dist:
        return False
    sj = min(SUB - 1, int((fc - c) * SUB))
    si = min(SUB - 1, int((fr - r) * SUB))
    kbin = int(np.round(th / (np.pi / YAW_BINS))) % CHECK_BINS
    i = (kbin * SUB + si) * SUB + sj
    co = sn = ta = tb = tx = ty = 0.0
    tested = False
    for j in range(starts[i], starts[i + 1]):
        rr = r + cells[j, 0]
        cc = c + cells[j, 1]
        if 0 <= rr < rows and 0 <= cc < cols and not blocked[rr, cc]:
            continue
        if cells[j, 2]:
            return True
        if not tested:
            # separating axes of the cell square and the rectangle: the rectangle's
            # own, then the map's
            co, sn = np.cos(th), np.sin(th)
            ac, as_ = abs(co), abs(sn)
            h = 0.5 * res
            ta = half[0] + h * (ac + as_)
            tb = half[1] + h * (ac + as_)
            tx = h + half[0] * ac + half[1] * as_
            ty = h + half[0] * as_ + half[1] * ac
            tested = True
        px = ox + (cc + 0.5) * res - x
        py = oy + (rr + 0.5) * res - y
        if (
            abs(px * co + py * sn) < ta
            and abs(py * co - px * sn) < tb
            and abs(px) < tx
            and abs(py) < ty
        ):
            return True
    return False


@numba.njit(cache=True)
def _motion_free(x, y, b, kind, turn, length, blocked, dist, free_dist, ox, oy, res, st, ce, half):
    """Whether a motion from (x, y, yaw bin b) stays clear; returns (free, x1, y1, b1)."""
    d = 2 * np.pi / YAW_BINS
    th0 = b * d
    b1 = (b + turn) % YAW_BINS
    if kind == 2:
        sgn = 1 if turn > 0 else -1
        for i in range(1, 2 * abs(turn) + 1):
            th = th0 + sgn * i * 0.5 * d
            if _collides(x, y, th, blocked, dist, free_dist, ox, oy, res, st, ce, half):
                return False, x, y, b1
        return True, x, y, b1
    direction = 1.0 if kind == 0 else -1.0
    n = max(2 * abs(turn), int(np.ceil(length / (0.5 * res))))
    if turn != 0 and n % (2 * abs(turn)) != 0:
        n = 2 * abs(turn) * int(np.ceil(n / (2 * abs(turn))))
    x1, y1 = x, y
    for i in range(1, n + 1):
        t = i / n
        s = direction * length * t
        if turn == 0:
            th = th0
            x1 = x + s * np.cos(th0)
            y1 = y + s * np.sin(th0)
        else:
            dth = turn * d * t
            rad = length / (turn * d)
            th = th0 + dth
            x1 = x + direction * rad * (np.sin(th) - np.sin(th0))
            y1 = y - direction * rad * (np.cos(th) - np.cos(th0))
        if _collides(x1, y1, th, blocked, dist, free_dist, ox, oy, res, st, ce, half):
            return False, x1, y1, b1
    return True, x1, y1, b1


@numba.njit(cache=True)
def _turn_free(x, y, k, kt, blocked, dist, free_dist, ox, oy, res, st, ce, half):
    """Whether turning on the spot at (x, y) from check bin `k` to `kt` (the shorter
    way) keeps the rectangle clear."""
    diff = (kt - k) % CHECK_BINS
    sgn = 1
    if diff > CHECK_BINS // 2:
        diff = CHECK_BINS - diff
        sgn = -1
    for i in range(1, diff + 1):
        th = (k + sgn * i) * np.pi / YAW_BINS
        if _collides(x, y, th, blocked, dist, free_dist, ox, oy, res, st, ce, half):
            return False
    return True


@numba.njit(cache=True)
def _shot(x, y, b, gx, gy, gk, reverse, blocked, dist, free_dist, ox, oy, res, st, ce, half):
    """Turn on the spot towards (gx, gy) (away from it with `reverse`), drive straight to
    it (backwards with `reverse`), then turn on the spot to check bin `gk` (-1: any
    heading): whether all of it is clear."""
    d = 0.5 * 2 * np.pi / YAW_BINS
    heading = np.arctan2(gy - y, gx - x) + (np.pi if reverse else 0.0)
    kt = int(np.round(heading / d)) % CHECK_BINS
    if not _turn_free(x, y, 2 * b, kt, blocked, dist, free_dist, ox, oy, res, st, ce, half):
        return False
    length = np.hypot(gx - x, gy - y)
    n = int(np.ceil(length / (0.5 * res)))
    for i in range(1, n + 1):
        t = i / n
        if _collides(
            x + t * (gx - x),
            y + t * (gy - y),
            heading,
            blocked,
            dist,
            free_dist,
            ox,
            oy,
            res,
            st,
            ce,
            half,
        ):
            return False
    return gk < 0 or _turn_free(gx, gy, kt, gk, blocked, dist, free_dist, ox, oy, res, st, ce, half)


@numba.njit(cache=True)
def _search(
    sx,
    sy,
    sb,
    gx,
    gy,
    gk,
    reverse_shot,
    blocked,
    dist,
    free_dist,
    weight,
    h,
    ox,
    oy,
    res,
    cell,
    st,
    ce,
    half,
    tight_dist,
    st2,
    ce2,
    half2,
    tight_penalty,
    snug_dist,
    st3,
    ce3,
    half3,
    snug_penalty,
    prims,
    rot_cost,
    tol,
    shot_range,
    spin,
    max_exp,
):
    """Hybrid-A* from (sx, sy, yaw bin sb) to within `tol` of (gx, gy), from where a turn
    on the spot at the goal to check bin `gk` is clear (-1: any heading will do). A step
    that ends where the rectangle is clear but not by the tight margin (cells `st2`,
    `ce2`) costs `tight_penalty` times more, and `snug_penalty` times more again where
    it is not clear by the snug margin (cells `st3`, `ce3`); a straight shot to the goal
    must keep the tight margin too, unless it starts within SHOT_NEAR of the goal.
    Returns the states' (x, y, bin, parent) arrays, the index of the final state (-1: no
    path, -2: expansion limit) and how the final state ends: 0 at the goal, 1 in a
    straight shot to it, 2 in a straight shot backwards (tried with `reverse_shot`)."""
    rows, cols = blocked.shape
    hr = int(np.ceil(rows * res / cell))
    hc = int(np.ceil(cols * res / cell))
    nstates = hr * hc * YAW_BINS
    best = np.full(nstates, np.inf)
    closed = np.zeros(nstates, dtype=np.bool_)
    cap = 1 << 16
    xs = np.empty(cap)
    ys = np.empty(cap)
    bs = np.empty(cap, dtype=np.int64)
    par = np.empty(cap, dtype=np.int64)
    gs = np.empty(cap)
    hcap = 1 << 16
    keys = np.empty(hcap)
    vals = np.empty(hcap, dtype=np.int64)
    n = 0
    xs[0], ys[0], bs[0], par[0], gs[0] = sx, sy, sb, -1, 0.0
    n = 1
    size = _heap_push(keys, vals, 0, 0.0, 0)
    expansions = 0
    while size > 0:
        _, cur, size = _heap_pop(keys, vals, size)
        x, y, b = xs[cur], ys[cur], bs[cur]
        key = (int((y - oy) / cell) * hc + int((x - ox) / cell)) * YAW_BINS + b
        if closed[key]:
            continue
        closed[key] = True
        expansions += 1
        if expansions > max_exp:
            return xs[:n], ys[:n], bs[:n], par[:n], -2, 0
        dgoal = np.hypot(gx - x, gy - y)
        if dgoal <= tol and (
            gk < 0
            or _turn_free(gx, gy, 2 * b, gk, blocked, dist, free_dist, ox, oy, res, st, ce, half)
        ):
            return xs[:n], ys[:n], bs[:n], par[:n], cur, 0
        if spin and dgoal <= shot_range and (expansions % 4 == 1 or dgoal < 1.0):
            # far from the goal a shot keeps the tight margin: one that squeezes through
            # a doorway at a slant would leave the base no room for error
            near = dgoal < SHOT_NEAR
            for rev in (False, True):
                if rev and not reverse_shot:
                    continue
                if _shot(
                    x,
                    y,
                    b,
                    gx,
                    gy,
                    gk,
                    rev,
                    blocked,
                    dist,
                    tight_dist,
                    ox,
                    oy,
                    res,
                    st2,
                    ce2,
                    half2,
                ):
                    return xs[:n], ys[:n], bs[:n], par[:n], cur, 2 if rev else 1
                if near and _shot(
                    x, y, b, gx, gy, gk, rev, blocked, dist, free_dist, ox, oy, res, st, ce, half
                ):
                    return xs[:n], ys[:n], bs[:n], par[:n], cur, 2 if rev else 1
        for p in range(prims.shape[0]):
            kind = int(prims[p, 0])
            turn = int(prims[p, 1])
            length = prims[p, 2]
            ok, x1, y1, b1 = _motion_free(
                x, y, b, kind, turn, length, blocked, dist, free_dist, ox, oy, res, st, ce, half
            )
            if not ok:
                continue
            c1 = int(np.floor((x1 - ox) / res))
            r1 = int(np.floor((y1 - oy) / res))
            hh = h[r1, c1]
            if hh == np.inf:
                continue
            k1 = (int((y1 - oy) / cell) * hc + int((x1 - ox) / cell)) * YAW_BINS + b1
            if closed[k1]:
                continue
            if kind == 2:
                step_cost = rot_cost * abs(turn) * 2 * np.pi / YAW_BINS
            else:
                step_cost = length * prims[p, 3] * weight[r1, c1]
            th1 = b1 * 2 * np.pi / YAW_BINS
            if tight_penalty > 1.0 and _collides(
                x1, y1, th1, blocked, dist, tight_dist, ox, oy, res, st2, ce2, half2
            ):
                step_cost *= tight_penalty
                if snug_penalty > 1.0 and _collides(
                    x1, y1, th1, blocked, dist, snug_dist, ox, oy, res, st3, ce3, half3
                ):
                    step_cost *= snug_penalty
            g1 = gs[cur] + step_cost
            if g1 >= best[k1]:
                continue
            best[k1] = g1
            if n >= xs.shape[0]:
                xs = _grow(xs)
                ys = _grow(ys)
                bs = _grow(bs)
                par = _grow(par)
                gs = _grow(gs)
            xs[n], ys[n], bs[n], par[n], gs[n] = x1, y1, b1, cur, g1
            if size >= keys.shape[0]:
                keys = _grow(keys)
                vals = _grow(vals)
            size = _heap_push(keys, vals, size, g1 + hh * res, n)
            n += 1
    return xs[:n], ys[:n], bs[:n], par[:n], -1, 0


@numba.njit(cache=True)
def _grow(a):
    out = np.empty(2 * a.shape[0], dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


@dataclass
class HybridAStar:
    """Hybrid-A* over (x, y, yaw) for a rectangular footprint (see the module docstring).
    `plan` has the grid planners' interface and returns (N, 2) points about a costmap
    cell apart; `plan_poses` returns the (N, 3) poses."""

    config: HybridConfig = field(default_factory=HybridConfig)
    name: str = "hybrid"
    expansions: int = 0

    def _footprint_cells(self, costmap: Costmap) -> tuple[np.ndarray, np.ndarray]:
        return footprint_cells(costmap.footprint, costmap.resolution, self.config.margin)

    def blocked(self, costmap: Costmap) -> np.ndarray:
        """Cells the footprint may not touch: the static map's, the obstacle layer's
        more than `wall_tolerance` from them (nearer ones are those walls seen from a
        pose a little off, which would narrow every doorway), and unknown ones unless
        allowed."""
        out = costmap.lethal & ~wall_marks(costmap, self.config.wall_tolerance)
        if not self.config.allow_unknown:
            out |= costmap.cost == UNKNOWN
        return out

    def collides(self, costmap: Costmap, poses: np.ndarray) -> np.ndarray:
        """Whether the rectangle (grown by `margin`) touches a blocked cell at each pose
        (N, 3), as the search and its start check test it."""
        return footprint_hits(
            costmap, np.asarray(poses, dtype=float), self.config.margin, self.blocked(costmap)
        )

    def reversing(self) -> HybridAStar:
        """This planner allowed to drive backwards too (at its `reverse_penalty`, else
        REVERSE_PENALTY): what a base that cannot turn where it stands backs out along."""
        penalty = self.config.reverse_penalty or REVERSE_PENALTY
        return HybridAStar(replace(self.config, reverse_penalty=penalty))

    def reverse_run(
        self, costmap: Costmap, start: tuple[float, ...], goal: tuple[float, ...]
    ) -> tuple[float, float]:
        """Where a plan that may also drive backwards (`reversing`) first backs up from
        `start`: the heading (rad) it turns to on the spot before, and how far (m) it
        backs up before it first drives forwards (0: it does not); raises NoPath."""
        poses = self.reversing().plan_poses(costmap, start, goal)
        d = np.diff(poses[:, :2], axis=0)
        along = d[:, 0] * np.cos(poses[1:, 2]) + d[:, 1] * np.sin(poses[1:, 2])
        moving = np.flatnonzero(np.abs(along) > 1e-9)
        if len(moving) == 0 or along[moving[0]] > 0.0:
            return float(poses[0, 2]), 0.0
        yaw = float(poses[moving[0], 2])
        run = 0.0
        for a in along[moving[0] :]:
            if a > 1e-9:
                break
            run -= a
        return yaw, float(run)

    def plan(
        self, costmap: Costmap, start: tuple[float, ...], goal: tuple[float, ...]
    ) -> np.ndarray:
        """(N, 2) world points from the start to the goal for the footprint; raises NoPath.
        `start` is (x, y) or (x, y, yaw); without a yaw the base starts facing the goal."""
        poses = self.plan_poses(costmap, start, goal)
        return resample(poses[:, :2], costmap.resolution)

    def plan_poses(
        self, costmap: Costmap, start: tuple[float, ...], goal: tuple[float, ...]
    ) -> np.ndarray:
        """(N, 3) poses from the start to the goal. With a goal (x, y, yaw) the plan ends
        turned to that heading, and only where that turn on the spot is clear; with (x, y)
        the final yaw is the last motion's."""
        c = self.config
        res = costmap.resolution
        s = np.asarray(start, dtype=float)
        g_full = np.asarray(goal, dtype=float)
        g = g_full[:2]
        if len(s) < 3:
            s = np.array([s[0], s[1], np.arctan2(g[1] - s[1], g[0] - s[0])])
        for what, xy in (("start", s[:2]), ("goal", g)):
            if not costmap.inside(costmap.world_to_cell(xy)):
                raise NoPath(f"the {what} {_fmt(xy)} lies outside the map")
        starts, cells = self._footprint_cells(costmap)
        # along motions (every point moves at most 2.6 cm per check) the edge suffices
        edge = footprint_cells(
            costmap.footprint, costmap.resolution, c.margin, 2 * costmap.resolution
        )
        # the tight and snug margins' edge bands reach past the margin: enough from a
        # clear pose
        tight, snug = (
            footprint_cells(
                costmap.footprint,
                costmap.resolution,
                max(m, c.margin),
                2 * costmap.resolution + max(m - c.margin, 0.0),
            )
            for m in (c.tight_margin, c.snug_margin)
        )
        blocked = self.blocked(costmap)
        fp = costmap.footprint
        free_dist = fp.circumscribed_radius + c.margin + 2 * res
        ox, oy = costmap.origin
        half, half2, half3 = (
            np.array([0.5 * fp.length + m, 0.5 * fp.width + m])
            for m in (c.margin, max(c.tight_margin, c.margin), max(c.snug_margin, c.margin))
        )
        args = (blocked, costmap.distance, free_dist, ox, oy, res, starts, cells, half)
        if _collides(s[0], s[1], s[2], *args):
            raise StartBlocked(f"the footprint at the start {_fmt(s)} touches an obstacle")
        sb = _start_bin(s, args)
        if sb < 0:
            raise StartBlocked(
                f"the footprint at the start {_fmt(s)} touches an obstacle turned to the "
                f"nearest {360 // YAW_BINS} deg heading either way"
            )
        gk = -1
        if len(g_full) >= 3:
            gk = int(np.round(g_full[2] / (np.pi / YAW_BINS))) % CHECK_BINS
            if _collides(g[0], g[1], g_full[2], *args):
                raise NoPath(
                    f"the goal {_fmt(g)}: the footprint facing {np.degrees(g_full[2]):.0f} deg "
                    "touches an obstacle there"
                )
        # a goal position is open if some yaw fits there
        elif all(
            _collides(g[0], g[1], k * np.pi / YAW_BINS, *args) for k in range(0, CHECK_BINS, 2)
        ):
            raise NoPath(
                f"the goal {_fmt(g)}: the footprint touches an obstacle there in every heading"
            )
        weight = 1.0 + c.cost_weight * np.minimum(costmap.cost, MAX_INFLATED) / MAX_INFLATED
        relaxed = weight.copy()
        relaxed[costmap.distance < fp.inscribed_radius - res] = np.inf
        relaxed[blocked] = np.inf
        gr, gc = costmap.world_to_cell(g)
        h = c.heuristic_weight * _cost_to_go(relaxed, int(gr * relaxed.shape[1] + gc))
        sr, sc = costmap.world_to_cell(s[:2])
        if not np.isfinite(h[sr, sc]):
            raise NoPath(
                f"the goal {_fmt(g)} cannot be reached from the start: no "
                "passage is as wide as the footprint"
            )
        xs, ys, bs, par, end, shot = _search(
            s[0],
            s[1],
            sb,
            g[0],
            g[1],
            gk,
            c.reverse_shot and c.turning_radius == 0,
            blocked,
            costmap.distance,
            free_dist,
            weight,
            h,
            ox,
            oy,
            res,
            2 * res,
            edge[0],
            edge[1],
            half,
            fp.circumscribed_radius + max(c.tight_margin, c.margin) + 2 * res,
            tight[0],
            tight[1],
            half2,
            c.tight_penalty,
            fp.circumscribed_radius + max(c.snug_margin, c.margin) + 2 * res,
            snug[0],
            snug[1],
            half3,
            c.snug_penalty,
            motions(c),
            c.rotation_cost,
            c.goal_tolerance,
            c.shot_range,
            c.turning_radius == 0,
            c.max_expansions,
        )
        self.expansions = len(xs)
        if end == -2:
            raise NoPath(
                f"the goal {_fmt(g)}: no pose sequence found within {c.max_expansions} expansions"
            )
        if end < 0:
            raise NoPath(
                f"the goal {_fmt(g)} cannot be reached from the start: no "
                f"motion of the {fp.length:.2f} x {fp.width:.2f} m footprint gets there"
            )
        chain = [end]
        while par[chain[-1]] >= 0:
            chain.append(int(par[chain[-1]]))
        chain.reverse()
        d = 2 * np.pi / YAW_BINS
        poses = np.column_stack([xs[chain], ys[chain], bs[chain] * d])
        poses[0] = s
        if shot:
            heading = np.arctan2(g[1] - poses[-1, 1], g[0] - poses[-1, 0])
            heading += np.pi if shot == 2 else 0.0
            poses = np.vstack([poses, [poses[-1, 0], poses[-1, 1], heading]])
        poses = np.vstack([poses, [g[0], g[1], poses[-1, 2]]])
        if gk >= 0:
            poses = np.vstack([poses, g_full[:3]])
        poses[:, 2] = (poses[:, 2] + np.pi) % (2 * np.pi) - np.pi
        return poses


def _start_bin(s: np.ndarray, args: tuple) -> int:
    """The yaw bin the search starts from at the start `s` (x, y, yaw): of the two the
    yaw lies between, the nearer that a turn on the spot from the yaw itself reaches
    clear, else the other; -1 where neither does."""
    d = 2 * np.pi / YAW_BINS
    lo = int(np.floor(s[2] / d))
    near_first = sorted((lo, lo + 1), key=lambda b: abs(b * d - s[2]))
    for b in near_first:
        turn = s[2] + np.linspace(0.0, b * d - s[2], 3)[1:]
        if not any(_collides(s[0], s[1], th, *args) for th in turn):
            return b % YAW_BINS
    return -1


def wall_marks(costmap: Costmap, tolerance: float) -> np.ndarray:
    """Obstacle-layer cells within `tolerance` (m) of the static map's: the walls seen
    from a pose a little off (localization error), not new obstacles."""
    if not costmap.obstacles.any() or tolerance <= 0.0:
        return np.zeros(costmap.shape, dtype=bool)
    near = ndimage.distance_transform_edt(~costmap.static) * costmap.resolution <= tolerance
    return costmap.obstacles & near & ~costmap.static


def footprint_hits(
    costmap: Costmap, poses: np.ndarray, margin: float, blocked: np.ndarray | None = None
) -> np.ndarray:
    """Whether the costmap's footprint, grown by `margin` (m), overlaps a blocked cell
    (default: lethal; cells outside the map count as blocked) at each of the poses
    (..., 3): the rectangle at the pose's own yaw, as the footprint planner checks it."""
    fp = costmap.footprint
    starts, cells = footprint_cells(fp, costmap.resolution, margin)
    p = np.asarray(poses, dtype=float)
    flat = p.reshape(-1, 3)
    free_dist = fp.circumscribed_radius + margin + 2 * costmap.resolution
    out = _hits(
        flat[:, 0].copy(),
        flat[:, 1].copy(),
        flat[:, 2].copy(),
        costmap.lethal if blocked is None else blocked,
        costmap.distance,
        free_dist,
        costmap.origin[0],
        costmap.origin[1],
        costmap.resolution,
        starts,
        cells,
        np.array([0.5 * fp.length + margin, 0.5 * fp.width + margin]),
    )
    return out.reshape(p.shape[:-1])


@numba.njit(cache=True)
def _hits(xs, ys, ths, blocked, dist, free_dist, ox, oy, res, starts, cells, half):
    out = np.zeros(xs.shape[0], dtype=np.bool_)
    for i in range(xs.shape[0]):
        out[i] = _collides(
            xs[i], ys[i], ths[i], blocked, dist, free_dist, ox, oy, res, starts, cells, half
        )
    return out


def _fmt(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{float(v):.2f}" for v in p) + ")"


def resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline through `points` (repeated points dropped) at about `spacing` m."""
    p = np.asarray(points, dtype=float)
    keep = np.concatenate([[True], np.hypot(*np.diff(p, axis=0).T) > 1e-9])
    p = p[keep]
    if len(p) < 2:
        return p
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    n = max(2, int(np.ceil(s[-1] / spacing)) + 1)
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])])
