"""The local planner: the Dynamic Window Approach (dwa_local_planner's role) (layer 3).

Each control period, `DWAPlanner.compute` samples forward speeds and yaw rates the base
can reach within one period from its current velocity (the dynamic window, bounded by
the acceleration and speed limits), rolls each pair out for `sim_time` seconds as an
arc, and scores the arcs that keep the whole rectangular footprint clear of lethal
cells:

    cost = path_bias * (distance from the arc's end to the global path)
         - progress_bias * (path length gained: where the arc's end projects on the path)
         + heading_bias * (angle between the end heading and the way to a carrot
                           `lookahead` m further along the path)
         + obstacle_bias * (highest inflation cost along the arc) / 252
         + collision_penalty * (1 if the arc hits something after the stopping horizon)
         + goal_bias * (closest approach of the arc to the goal, once the goal is in reach)

The footprint is covered by circles (`Footprint.circles`); an arc is admissible when
every circle stays `margin` clear of obstacles in the costmap's distance field for as
long as the base needs to stop on it, plus a second. With `exact_footprint` the
rectangle itself, grown by `margin`, is checked against the lethal cells instead (the
circles reach 0.25 m past the ends of a 0.99 x 0.67 m base, too far to turn in a
corridor). Near the
goal the speed is capped so that the base can stop on it, and the path ahead caps it
too (`path_speed`): slow where the path is narrow or bends, braking in time. Where a
narrow stretch lies ahead the arcs are held closer to the path, so doorways are entered
along their axis. All arcs are scored at once with numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robotrial.nav.costmap import MAX_INFLATED, Costmap, Footprint
from robotrial.nav.hybrid import footprint_hits


@dataclass(frozen=True)
class DWAConfig:
    """Speed (m/s, rad/s) and acceleration (m/s^2, rad/s^2) limits, sampling and weights."""

    max_speed: float = 0.3
    min_speed: float = 0.0
    max_yaw_rate: float = 1.0
    acc_lim_v: float = 1.0
    acc_lim_w: float = 3.0
    period: float = 0.05
    sim_time: float = 1.5
    sim_dt: float = 0.1
    v_samples: int = 8
    w_samples: int = 21
    path_bias: float = 0.6
    progress_bias: float = 1.0
    heading_bias: float = 0.1
    goal_bias: float = 2.0
    obstacle_bias: float = 0.3
    collision_penalty: float = 1.0
    lookahead: float = 1.0
    margin: float = 0.03
    narrow_speed: float = 0.3
    narrow_clearance: float = 0.25
    open_clearance: float = 0.4
    curve_factor: float = 0.8
    narrow_path_gain: float = 5.0
    narrow_approach: float = 1.5
    narrow_lookahead: float = 0.8
    goal_heading_bias: float = 0.0
    goal_heading_range: float = 1.0
    footprint_speed: bool = False
    exact_footprint: bool = False
    tight_clearance: float = 0.0
    ample_clearance: float = 0.1

    def __post_init__(self) -> None:
        for k in ("max_speed", "max_yaw_rate", "acc_lim_v", "acc_lim_w", "period", "sim_time"):
            if not getattr(self, k) > 0:
                raise ValueError(f"DWA: {k} must be positive, got {getattr(self, k)}")
        if self.min_speed > self.max_speed:
            raise ValueError("DWA: min_speed is above max_speed")
        if self.v_samples < 2 or self.w_samples < 2:
            raise ValueError("DWA: need at least 2 samples of v and of w")


@dataclass
class DWAResult:
    """The chosen command, whether any arc was admissible, and the chosen arc (M, 3)."""

    v: float
    w: float
    ok: bool
    trajectory: np.ndarray
    candidates: int


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def rollout(
    pose: tuple[float, float, float], v: np.ndarray, w: np.ndarray, steps: int, dt: float
) -> np.ndarray:
    """Arcs of constant (v, w) from `pose`: (K, steps, 3) x, y, yaw after each `dt`."""
    x0, y0, th0 = pose
    t = dt * np.arange(1, steps + 1)[None, :]
    v = np.asarray(v, dtype=float)[:, None]
    w = np.asarray(w, dtype=float)[:, None]
    th = th0 + w * t
    small = np.abs(w) < 1e-6
    ws = np.where(small, 1.0, w)
    x = np.where(small, x0 + v * t * np.cos(th0), x0 + v / ws * (np.sin(th) - np.sin(th0)))
    y = np.where(small, y0 + v * t * np.sin(th0), y0 - v / ws * (np.cos(th) - np.cos(th0)))
    return np.stack([x, y, np.broadcast_to(th, x.shape)], axis=-1)


def footprint_clearance(costmap: Costmap, footprint: Footprint, poses: np.ndarray) -> np.ndarray:
    """Clearance (m) of the footprint at poses (..., 3): the smallest distance from any
    covering circle's edge to a lethal cell (negative: overlap)."""
    centres, radius = footprint.circles()
    th = poses[..., 2][..., None]
    c, s = np.cos(th), np.sin(th)
    px = poses[..., 0][..., None] + c * centres[:, 0] - s * centres[:, 1]
    py = poses[..., 1][..., None] + s * centres[:, 0] + c * centres[:, 1]
    d = costmap.distance_at(np.stack([px, py], axis=-1))
    return d.min(axis=-1) - radius


def carrot(path: np.ndarray, xy: np.ndarray, lookahead: float) -> tuple[np.ndarray, int]:
    """The point `lookahead` m along `path` past its point nearest to `xy`, and the index
    of that nearest point."""
    d = np.hypot(*(path - xy).T)
    i = int(np.argmin(d))
    seg = np.hypot(*np.diff(path[i:], axis=0).T)
    acc = np.concatenate([[0.0], np.cumsum(seg)])
    j = int(np.searchsorted(acc, lookahead))
    if j == 0:
        return path[i], i
    if j >= len(acc):
        return path[-1], i
    a = (lookahead - acc[j - 1]) / max(seg[j - 1], 1e-9)
    return path[i + j - 1] + a * (path[i + j] - path[i + j - 1]), i


def _extend(path: np.ndarray, length: float, step: float) -> np.ndarray:
    """The path continued straight past its end by `length` m, so arcs that would carry
    the base beyond the goal are not scored as detours (the speed cap stops it there)."""
    if len(path) < 2:
        return path
    d = path[-1] - path[-2]
    n = float(np.hypot(*d))
    if n < 1e-9:
        return path
    k = max(1, int(length / step))
    extra = path[-1] + (d / n) * step * np.arange(1, k + 1)[:, None]
    return np.vstack([path, extra])


class DWAPlanner:
    """Turns a pose, a velocity, a global path and a local costmap into (v, w)."""

    def __init__(self, footprint: Footprint, config: DWAConfig = DWAConfig()) -> None:
        self.footprint = footprint
        self.config = config

    def window(self, v0: float, w0: float, v_cap: float) -> tuple[np.ndarray, np.ndarray]:
        """The sampled (v, w) pairs reachable within one period."""
        c = self.config
        hi_v = min(c.max_speed, v_cap, v0 + c.acc_lim_v * c.period)
        lo_v = max(c.min_speed, v0 - c.acc_lim_v * c.period)
        if lo_v > hi_v:
            lo_v = hi_v = min(max(c.min_speed, v0 - c.acc_lim_v * c.period), hi_v)
        lo_w = max(-c.max_yaw_rate, w0 - c.acc_lim_w * c.period)
        hi_w = min(c.max_yaw_rate, w0 + c.acc_lim_w * c.period)
        vs = np.linspace(lo_v, hi_v, c.v_samples)
        ws = np.unique(
            np.concatenate([np.linspace(lo_w, hi_w, c.w_samples), np.clip([0.0], lo_w, hi_w)])
        )
        vv, ww = np.meshgrid(vs, ws, indexing="ij")
        return vv.ravel(), ww.ravel()

    def path_speed(
        self,
        pose: tuple[float, float, float],
        path: np.ndarray,
        costmap: Costmap,
        footprint_speed: bool | None = None,
    ) -> float:
        """The speed (m/s) from which the base can still slow down, at `acc_lim_v`, to
        what each point of the path ahead allows: `narrow_speed` where the path's
        clearance (distance to the nearest obstacle beyond the inscribed radius) is
        below `narrow_clearance`, rising to the top speed at `open_clearance`, and no faster than
        `curve_factor * max_yaw_rate / curvature` where the path bends. With
        `footprint_speed` the clearance is the footprint's, facing along the path, and the
        speed rises from `narrow_speed` at `tight_clearance` to the top at `ample_clearance`
        (a straight doorway the rectangle passes with room to spare is no reason to slow);
        `footprint_speed` given here overrides the configuration's."""
        c = self.config
        _, i0 = carrot(path, np.asarray(pose[:2], dtype=float), 0.0)
        ahead = path[i0:]
        if len(ahead) < 2:
            return c.max_speed
        seg = np.hypot(*np.diff(ahead, axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        reach = c.max_speed**2 / (2 * 0.8 * c.acc_lim_v) + 0.5
        n = int(np.searchsorted(s, reach)) + 1
        ahead, s = ahead[:n], s[:n]
        if c.footprint_speed if footprint_speed is None else footprint_speed:
            d = np.diff(ahead, axis=0)
            yaw = np.arctan2(d[:, 1], d[:, 0])
            poses = np.column_stack([ahead, np.append(yaw, yaw[-1])])
            if c.exact_footprint:
                # the largest of a few margins the rectangle keeps at each point
                clear = np.zeros(len(poses))
                for m in np.linspace(c.tight_clearance, c.ample_clearance, 3):
                    clear[~footprint_hits(costmap, poses, float(m))] = m
            else:
                clear = footprint_clearance(costmap, self.footprint, poses)
            lo, hi = c.tight_clearance, c.ample_clearance
        else:
            clear = costmap.distance_at(ahead) - self.footprint.inscribed_radius
            lo, hi = c.narrow_clearance, c.open_clearance
        frac = np.clip((clear - lo) / max(hi - lo, 1e-6), 0.0, 1.0)
        # a path point inside the inscribed radius is an obstacle newly in the way, which
        # the arcs' scoring steers around, not a passage to hold to
        frac[clear < 0.0] = 1.0
        allowed = c.narrow_speed + (c.max_speed - c.narrow_speed) * frac
        # slow already `narrow_approach` m before a narrow stretch, to line up with it
        within = (s[None, :] >= s[:, None]) & (s[None, :] <= s[:, None] + c.narrow_approach)
        allowed = np.where(within, allowed[None, :], np.inf).min(axis=1)
        k = max(1, round(0.15 / max(float(np.median(seg)), 1e-3)))
        idx = np.arange(k, len(ahead) - k)
        if len(idx):
            # heading change between the path's stretches k points before and after
            before = ahead[idx] - ahead[idx - k]
            after = ahead[idx + k] - ahead[idx]
            turn = np.abs(
                _wrap(np.arctan2(after[:, 1], after[:, 0]) - np.arctan2(before[:, 1], before[:, 0]))
            )
            kappa = turn / np.maximum(0.5 * (s[idx + k] - s[idx - k]), 1e-3)
            v_curve = c.curve_factor * c.max_yaw_rate / np.maximum(kappa, 1e-6)
            allowed[idx] = np.minimum(allowed[idx], v_curve)
        allowed = np.maximum(allowed, c.narrow_speed * 0.5)
        return float(np.min(np.sqrt(allowed**2 + 2 * 0.8 * c.acc_lim_v * s)))

    def path_passable(
        self, pose: tuple[float, float, float], path: np.ndarray, costmap: Costmap
    ) -> bool:
        """Whether the footprint, facing along the path, fits everywhere on the next
        `narrow_approach + lookahead` m of it (False: something new blocks the path and
        the arcs must leave it)."""
        c = self.config
        _, i0 = carrot(path, np.asarray(pose[:2], dtype=float), 0.0)
        ahead = path[i0:]
        if len(ahead) < 2:
            return True
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ahead, axis=0).T))])
        n = int(np.searchsorted(s, c.narrow_approach + c.lookahead)) + 1
        ahead = ahead[: max(n, 2)]
        d = np.diff(ahead, axis=0)
        poses = np.column_stack([ahead[1:], np.arctan2(d[:, 1], d[:, 0])])
        if c.exact_footprint:
            return not footprint_hits(costmap, poses, 0.0).any()
        return bool(footprint_clearance(costmap, self.footprint, poses).min() >= 0.0)

    def compute(
        self,
        pose: tuple[float, float, float],
        velocity: tuple[float, float],
        path: np.ndarray,
        costmap: Costmap,
        goal_distance: float | None = None,
        goal_yaw: float | None = None,
    ) -> DWAResult:
        """The best admissible (v, w); `ok` is False (and the command a stop) when every
        sampled arc would hit something. `goal_distance` (m) caps the speed so the base
        can stop at the goal; `goal_yaw` (rad) lets the base turn toward the goal's
        heading on its way in."""
        c = self.config
        path = np.asarray(path, dtype=float).reshape(-1, 2)
        if len(path) == 0:
            raise ValueError("DWA: the global path is empty")
        v_path = self.path_speed(pose, path, costmap)
        v_cap = min(c.max_speed, v_path)
        if c.footprint_speed:
            # how narrow the way ahead is still follows the centre's clearance
            v_path = self.path_speed(pose, path, costmap, footprint_speed=False)
        # where the path ahead is narrow, hold to it more tightly (doorways are entered
        # along their axis, not at a slant)
        narrow = 0.0
        if c.max_speed > c.narrow_speed and self.path_passable(pose, path, costmap):
            narrow = 1.0 - float(
                np.clip((v_path - c.narrow_speed) / (c.max_speed - c.narrow_speed), 0.0, 1.0)
            )
        path_bias = c.path_bias * (1.0 + c.narrow_path_gain * narrow)
        if goal_distance is not None:
            v_cap = min(v_cap, max(0.05, np.sqrt(2 * 0.8 * c.acc_lim_v * max(goal_distance, 0.0))))
        v, w = self.window(float(velocity[0]), float(velocity[1]), v_cap)
        steps = max(1, round(c.sim_time / c.sim_dt))
        traj = rollout(pose, v, w, steps, c.sim_dt)
        # an arc must stay clear for as long as the base needs to stop on it, plus a
        # second; what lies beyond is seen again in later periods
        # (and no further than just past the goal, where the base will stop)
        horizon = np.abs(v) / c.acc_lim_v + 1.0
        t = c.sim_dt * np.arange(1, steps + 1)
        relevant = np.ones((len(v), steps), dtype=bool)
        if goal_distance is not None:
            relevant = np.abs(v)[:, None] * (t[None, :] - c.sim_dt) <= goal_distance + 0.2
        if c.exact_footprint:
            hit = footprint_hits(costmap, traj, c.margin)
            clear_all = np.where(hit, -np.inf, np.inf)
        else:
            clear_all = footprint_clearance(costmap, self.footprint, traj)
        clear_all = np.where(relevant, clear_all, np.inf)
        clear = np.where(t[None, :] <= horizon[:, None], clear_all, np.inf).min(axis=1)
        ok = clear >= c.margin
        late_hit = clear_all.min(axis=1) < c.margin
        if not ok.any():
            return DWAResult(0.0, 0.0, False, traj[:0, 0], len(v))
        end = traj[:, -1, :2]
        _, i0 = carrot(path, np.asarray(pose[:2], dtype=float), 0.0)
        reach = c.max_speed * c.sim_time + c.lookahead + 0.5
        local = _extend(path[i0:], reach, costmap.resolution)
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(local, axis=0).T))])
        keep = int(np.searchsorted(along, reach)) + 1
        local, along = local[:keep], along[:keep]
        d = np.hypot(end[:, None, 0] - local[None, :, 0], end[:, None, 1] - local[None, :, 1])
        j = np.argmin(d, axis=1)
        dpath = d[np.arange(len(j)), j]
        progress = along[j]
        lookahead = c.lookahead - narrow * max(c.lookahead - c.narrow_lookahead, 0.0)
        tj = np.minimum(np.searchsorted(along, along[j] + lookahead), len(local) - 1)
        target = local[tj]
        to_target = np.arctan2(target[:, 1] - end[:, 1], target[:, 0] - end[:, 0])
        heading = np.abs(_wrap(to_target - traj[:, -1, 2]))
        heading[np.hypot(*(target - end).T) < 0.05] = 0.0
        obst = costmap.cost_at(traj[..., :2]).max(axis=1).astype(float)
        obst = np.minimum(obst, MAX_INFLATED) / MAX_INFLATED
        score = (
            path_bias * dpath
            - c.progress_bias * progress
            + c.heading_bias * heading
            + c.obstacle_bias * obst
            + c.collision_penalty * late_hit
        )
        if goal_distance is not None and goal_distance < reach:
            # near the goal: pass through it, not beside it (the speed cap stops the base)
            gp = path[-1]
            closest = np.hypot(traj[..., 0] - gp[0], traj[..., 1] - gp[1]).min(axis=1)
            score += c.goal_bias * closest
        if goal_yaw is not None and goal_distance is not None and c.goal_heading_bias > 0:
            # on the way in, turn toward the goal's heading so less is left to do there
            near = max(0.0, 1.0 - goal_distance / c.goal_heading_range)
            score += c.goal_heading_bias * near * np.abs(_wrap(goal_yaw - traj[:, -1, 2]))
        score[~ok] = np.inf
        k = int(np.argmin(score))
        return DWAResult(float(v[k]), float(w[k]), True, traj[k], len(v))
