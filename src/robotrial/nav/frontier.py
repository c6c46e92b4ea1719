"""Frontier-based exploration: where to drive next to map more of an unknown home
(layer 3).

A frontier is a known free cell next to an unknown one (the edge of what the map has
seen). `find_frontiers` finds them on an occupancy grid and groups them (8-connected,
small groups dropped). `FrontierPlanner.choose` picks a goal pose for each group and
scores it:

- a goal pose is a pose of the real footprint (a rectangle, grown by the planner's
  margin) clear of occupied and unknown cells, a short way from the frontier, facing
  it, and joined to the robot through cells its centre may use (the inscribed radius
  from everything not known free);
- its gain is the unknown area (m2) a 360-degree range sensor would see from there:
  rays cast over the grid, passing unknown cells and stopping at occupied ones;
- its travel cost is the length (m) of the shortest way to it through those cells;
- its utility is gain * exp(-travel_weight * travel) (information gain discounted by
  the way there, as in next-best-view exploration).

Goals whose gain falls under `min_gain` are not worth a drive. Places the navigator
could not reach, or that left their frontier unseen once reached, are given to
`blacklist`, and no goal is chosen within `blacklist_radius` of them again. Exploration
is over when `choose` returns nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.hybrid import HybridAStar, footprint_hits
from robotrial.nav.tour import free_graph

EIGHT = np.ones((3, 3), dtype=bool)
FOUR = ndimage.generate_binary_structure(2, 1)


@dataclass(frozen=True)
class FrontierConfig:
    """Frontier groups shorter than `min_size` (m) are dropped; a goal stands `near` to
        `far` m from its frontier and is worth a drive when a sensor of `view_range` m
        (`rays` rays) would see at least `min_gain` m2 of unknown there; `travel_weight`
        (1/m) discounts the gain by the way there; `candidates` poses are tried a group and
    the `per_group` best kept;
        `blacklist_radius` (m) around a failed place keeps goals away."""

    min_size: float = 0.3
    near: float = 0.3
    far: float = 1.8
    view_range: float = 4.0
    rays: int = 120
    min_gain: float = 0.4
    travel_weight: float = 0.15
    candidates: int = 24
    per_group: int = 8
    blacklist_radius: float = 0.4

    def __post_init__(self) -> None:
        if not 0 <= self.near < self.far:
            raise ValueError(f"frontier: need 0 <= near < far, got {self.near}, {self.far}")
        for k in ("view_range", "rays", "candidates", "blacklist_radius"):
            if not getattr(self, k) > 0:
                raise ValueError(f"frontier: {k} must be positive, got {getattr(self, k)}")


@dataclass
class Frontier:
    """One group of frontier cells: its cells (K, 2) as (row, col), its centre (world
    x, y), its length (m); once scored, the goal pose (x, y, yaw), the gain (m2), the
    travel (m) and the utility."""

    cells: np.ndarray
    centre: np.ndarray
    size: float
    goal: np.ndarray | None = None
    gain: float = 0.0
    travel: float = np.inf
    utility: float = 0.0


def frontier_mask(free: np.ndarray, unknown: np.ndarray) -> np.ndarray:
    """Free cells with an unknown 4-neighbour (cells past the grid's edge are unknown)."""
    padded = np.pad(np.asarray(unknown, dtype=bool), 1, constant_values=True)
    near = ndimage.binary_dilation(padded, FOUR)[1:-1, 1:-1]
    return np.asarray(free, dtype=bool) & near


def find_frontiers(
    free: np.ndarray,
    unknown: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    min_size: float = 0.3,
) -> list[Frontier]:
    """The frontier groups of a grid (rows = y), 8-connected, each at least `min_size` m
    long (counted as cells times the resolution), largest first."""
    labels, _ = ndimage.label(frontier_mask(free, unknown), EIGHT)
    out = []
    for k, sl in enumerate(ndimage.find_objects(labels), start=1):
        if sl is None:
            continue
        rr, cc = np.nonzero(labels[sl] == k)
        cells = np.column_stack([rr + sl[0].start, cc + sl[1].start])
        size = len(cells) * resolution
        if size < min_size:
            continue
        rc = cells.mean(axis=0)
        centre = np.array(
            [origin[0] + (rc[1] + 0.5) * resolution, origin[1] + (rc[0] + 0.5) * resolution]
        )
        out.append(Frontier(cells, centre, size))
    out.sort(key=lambda f: -f.size)
    return out


def view_gain(
    occupied: np.ndarray,
    unknown: np.ndarray,
    origin: tuple[float, float],
    resolution: float,
    xy: np.ndarray,
    view_range: float,
    rays: int,
) -> float:
    """The unknown area (m2) seen from `xy` by `rays` rays of `view_range` m that pass
    unknown cells and stop at occupied ones (past the grid's edge all is unknown)."""
    angles = np.linspace(0.0, 2 * np.pi, rays, endpoint=False)
    steps = np.arange(0.5, view_range / resolution * 2) * (resolution / 2)
    px = xy[0] + np.cos(angles)[:, None] * steps[None, :]
    py = xy[1] + np.sin(angles)[:, None] * steps[None, :]
    col = np.floor((px - origin[0]) / resolution).astype(np.int64)
    row = np.floor((py - origin[1]) / resolution).astype(np.int64)
    rows, cols = occupied.shape
    inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    r_in, c_in = np.where(inside, row, 0), np.where(inside, col, 0)
    occ = inside & occupied[r_in, c_in]
    open_ray = np.cumsum(occ, axis=1) == 0
    unk = ~inside | unknown[r_in, c_in]
    seen = open_ray & unk
    keys = (row[seen] + 1_000_000) * 4_000_000 + col[seen]
    return float(len(np.unique(keys)) * resolution**2)


@dataclass
class FrontierPlanner:
    """Chooses where to look next on a growing map (see the module docstring)."""

    footprint: Footprint
    config: FrontierConfig = field(default_factory=FrontierConfig)
    planner: HybridAStar = field(default_factory=HybridAStar)
    blacklisted: list[np.ndarray] = field(default_factory=list)

    def blacklist(self, xy: np.ndarray) -> None:
        """No goal within `blacklist_radius` of `xy` again."""
        self.blacklisted.append(np.asarray(xy, dtype=float)[:2].copy())

    def _banned(self, xy: np.ndarray) -> np.ndarray:
        """(N,) whether points (N, 2) lie near a blacklisted place."""
        if not self.blacklisted:
            return np.zeros(len(xy), dtype=bool)
        d = np.hypot(*(xy[:, None, :] - np.array(self.blacklisted)[None, :, :]).transpose(2, 0, 1))
        return (d < self.config.blacklist_radius).any(axis=1)

    def costmap(
        self,
        occupied: np.ndarray,
        unknown: np.ndarray,
        origin: tuple[float, float],
        resolution: float,
    ) -> Costmap:
        """The costmap goals are checked on: the occupied cells, the unknown ones apart."""
        return Costmap(occupied, origin, resolution, self.footprint, unknown=unknown)

    def travel(self, costmap: Costmap, pose: np.ndarray) -> np.ndarray:
        """Length (m) of the shortest way from the robot at `pose` to every cell through
        the cells its centre may use (inf: no way); the robot joins them at the nearest
        such cell within the footprint's half length."""
        blocked = costmap.lethal | costmap.unknown
        clear = ndimage.distance_transform_edt(~blocked) * costmap.resolution
        passable = clear >= self.footprint.inscribed_radius
        out = np.full(passable.shape, np.inf)
        if not passable.any():
            return out
        graph, index = free_graph(passable, costmap.resolution)
        rc = costmap.world_to_cell(np.asarray(pose, dtype=float)[:2])
        nearest = ndimage.distance_transform_edt(
            ~passable, return_distances=False, return_indices=True
        )
        r = int(np.clip(rc[0], 0, passable.shape[0] - 1))
        c = int(np.clip(rc[1], 0, passable.shape[1] - 1))
        jr, jc = int(nearest[0][r, c]), int(nearest[1][r, c])
        join = np.hypot(jr - rc[0], jc - rc[1]) * costmap.resolution
        if join > 0.5 * max(self.footprint.length, self.footprint.width):
            return out
        d = dijkstra(graph, directed=False, indices=int(index[jr, jc]))
        out[passable] = d + join
        return out

    def choose(
        self,
        occupied: np.ndarray,
        free: np.ndarray,
        origin: tuple[float, float],
        resolution: float,
        pose: np.ndarray,
    ) -> list[Frontier]:
        """Goals worth a drive, up to `per_group` a frontier group, best utility first
        (empty: nothing reachable is left to see). `occupied` and `free` are the map's cells
        (rows = y); the rest is unknown."""
        occupied = np.asarray(occupied, dtype=bool)
        free = np.asarray(free, dtype=bool) & ~occupied
        unknown = ~(occupied | free)
        cfg = self.config
        groups = find_frontiers(free, unknown, origin, resolution, cfg.min_size)
        if not groups:
            return []
        cm = self.costmap(occupied, unknown, origin, resolution)
        travel = self.travel(cm, pose)
        reachable = np.isfinite(travel)
        blocked = self.planner.blocked(cm)
        out = []
        pad = int(np.ceil(cfg.far / resolution)) + 1
        rows, cols = occupied.shape
        for f in groups:
            r0, c0 = np.maximum(f.cells.min(axis=0) - pad, 0)
            r1, c1 = np.minimum(f.cells.max(axis=0) + pad + 1, (rows, cols))
            window = np.ones((r1 - r0, c1 - c0), dtype=bool)
            window[f.cells[:, 0] - r0, f.cells[:, 1] - c0] = False
            dist = ndimage.distance_transform_edt(window) * resolution
            ok = reachable[r0:r1, c0:c1] & (dist >= cfg.near) & (dist <= cfg.far)
            rr, cc = np.nonzero(ok)
            if len(rr) == 0:
                continue
            xy = cm.cell_to_world(np.column_stack([rr + r0, cc + c0]))
            keep = ~self._banned(xy)
            rr, cc, xy = rr[keep], cc[keep], xy[keep]
            if len(rr) == 0:
                continue
            # the nearest to the frontier first, spread over the whole band
            order = np.argsort(dist[rr, cc], kind="stable")
            pick = order[np.unique(np.linspace(0, len(order) - 1, cfg.candidates).astype(int))]
            found: list[Frontier] = []
            for i in pick:
                goal = self._clear_pose(cm, blocked, xy[i], f.centre)
                if goal is None:
                    continue
                gain = view_gain(
                    occupied, unknown, origin, resolution, xy[i], cfg.view_range, cfg.rays
                )
                if gain < cfg.min_gain:
                    continue
                t = float(travel[rr[i] + r0, cc[i] + c0])
                utility = gain * float(np.exp(-cfg.travel_weight * t))
                found.append(Frontier(f.cells, f.centre, f.size, goal, gain, t, utility))
            found.sort(key=lambda g: -g.utility)
            out.extend(found[: cfg.per_group])
        out.sort(key=lambda f: -f.utility)
        return out

    def _clear_pose(
        self, cm: Costmap, blocked: np.ndarray, xy: np.ndarray, towards: np.ndarray
    ) -> np.ndarray | None:
        """A pose at `xy` whose footprint is clear: facing `towards` if it can, else
        across, else away."""
        facing = float(np.arctan2(towards[1] - xy[1], towards[0] - xy[0]))
        yaws = facing + np.array([0.0, np.pi / 2, -np.pi / 2, np.pi])
        poses = np.column_stack([np.full(4, xy[0]), np.full(4, xy[1]), yaws])
        hits = footprint_hits(cm, poses, self.planner.config.margin, blocked)
        for p, hit in zip(poses, hits, strict=True):
            if not hit:
                p[2] = (p[2] + np.pi) % (2 * np.pi) - np.pi
                return p
        return None
