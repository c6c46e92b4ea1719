"""The local controller for footprint plans: regulated pure pursuit (layer 3).

A Hybrid-A* path already says how the rectangle gets through a doorway or round a corner;
what the base must do is follow it closely. `PursuitController.compute` steers towards a
carrot on the path a speed-dependent lookahead ahead (the arc through it: curvature
`2 y / d^2` in the base frame), or towards a corner of the path before it (where the
plan turns on the spot), turns on the spot first where the carrot lies more than
`rotate_angle` off the heading (the path turns on the spot there), and regulates the
speed: the top speed where the footprint has room (`DWAPlanner.path_speed` with the
footprint's clearance along the path), slower where the path bends, and such that the base
can stop on the goal. Before a command is given, its arc is rolled out over the stopping
distance and the rectangle (grown by `margin`, or not at all where the base already is
within it) checked against the local costmap; if it would touch something, slower
commands are tried, then a turn on the spot, then `ok` is False (the navigator stops and
recovers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.dwa import DWAConfig, DWAPlanner, DWAResult, carrot, rollout
from robotrial.nav.hybrid import footprint_hits, wall_marks


@dataclass(frozen=True)
class PursuitConfig:
    """Lookahead (m) = `lookahead_time` (s) x speed, within [`min_lookahead`,
    `max_lookahead`]; `rotate_angle` (rad) beyond which the base turns on the spot;
    `rotate_speed` (rad/s) of that turn; a path point where the heading changes by more
    than `corner_angle` (rad) from one stretch to the next is a corner (a turn on the
    spot in the plan), driven to until within `corner_reach` (m); `creep_speed` (m/s)
    forwards or backwards while turning where a turn on the spot is blocked;
    scan marks within `wall_tolerance` (m; two 5 cm cells, diagonally too) of the map's
    walls are those walls seen from a pose a little off, and do not block."""

    lookahead_time: float = 1.0
    min_lookahead: float = 0.3
    max_lookahead: float = 1.0
    rotate_angle: float = 0.6
    rotate_speed: float = 1.2
    corner_angle: float = 0.3
    corner_reach: float = 0.08
    creep_speed: float = 0.05
    wall_tolerance: float = 0.12

    def __post_init__(self) -> None:
        if not 0 < self.min_lookahead <= self.max_lookahead:
            raise ValueError(
                f"pursuit: need 0 < min_lookahead <= max_lookahead, got "
                f"{self.min_lookahead}, {self.max_lookahead}"
            )


class PursuitController:
    """Turns a pose, the previous command, a path and a local costmap into (v, w), with
    the speed and acceleration limits of a `DWAConfig`."""

    def __init__(
        self, footprint: Footprint, limits: DWAConfig, config: PursuitConfig = PursuitConfig()
    ) -> None:
        self.footprint = footprint
        self.limits = limits
        self.config = config
        self._speed = DWAPlanner(footprint, limits)

    def _target(
        self, pose: tuple[float, float, float], path: np.ndarray, look: float
    ) -> np.ndarray:
        """The carrot `look` m along the path, or the first corner before it that is more
        than `corner_reach` m away: the base drives to a corner and turns there, as the
        plan does, rather than cut it."""
        c = self.config
        xy = np.asarray(pose[:2], dtype=float)
        target, i0 = carrot(path, xy, look)
        ahead = path[i0:]
        d = np.diff(ahead, axis=0)
        keep = np.hypot(d[:, 0], d[:, 1]) > 1e-9
        if keep.sum() < 2:
            return target
        pts, d = ahead[1:][keep], d[keep]
        heading = np.arctan2(d[:, 1], d[:, 0])
        turn = np.abs((np.diff(heading) + np.pi) % (2 * np.pi) - np.pi)
        s = np.cumsum(np.hypot(d[:, 0], d[:, 1]))
        corner = (turn > c.corner_angle) & (s[:-1] <= look)
        corner &= np.hypot(*(pts[:-1] - xy).T) > c.corner_reach
        if corner.any():
            return pts[:-1][int(np.argmax(corner))]
        return target

    def compute(
        self,
        pose: tuple[float, float, float],
        velocity: tuple[float, float],
        path: np.ndarray,
        costmap: Costmap,
        goal_distance: float | None = None,
        goal_yaw: float | None = None,
    ) -> DWAResult:
        """The command (v, w); `ok` False when every candidate would touch something.
        `goal_yaw` is accepted for the DWA's interface and not used."""
        lim, c = self.limits, self.config
        path = np.asarray(path, dtype=float).reshape(-1, 2)
        if len(path) == 0:
            raise ValueError("pursuit: the global path is empty")
        v0, w0 = float(velocity[0]), float(velocity[1])
        dv, dw = lim.acc_lim_v * lim.period, lim.acc_lim_w * lim.period
        look = float(np.clip(c.lookahead_time * abs(v0), c.min_lookahead, c.max_lookahead))
        target = self._target(pose, path, look)
        dx, dy = target[0] - pose[0], target[1] - pose[1]
        cos, sin = np.cos(pose[2]), np.sin(pose[2])
        x, y = cos * dx + sin * dy, -sin * dx + cos * dy
        alpha = float(np.arctan2(y, x))
        v_cap = min(lim.max_speed, self._speed.path_speed(pose, path, costmap))
        if goal_distance is not None:
            v_cap = min(v_cap, max(0.05, np.sqrt(2 * 0.8 * lim.acc_lim_v * max(goal_distance, 0))))
        candidates = []
        if abs(alpha) > c.rotate_angle or np.hypot(x, y) < 1e-6:
            # brake, then turn on the spot towards the carrot
            w = float(np.clip(np.sign(alpha) * c.rotate_speed, w0 - dw, w0 + dw))
            candidates.append((max(0.0, v0 - dv), w))
        else:
            kappa = 2.0 * y / max(x * x + y * y, 1e-9)
            v = min(v_cap, lim.curve_factor * lim.max_yaw_rate / max(abs(kappa), 1e-6))
            v = float(np.clip(v, v0 - dv, v0 + dv))
            v = max(v, 0.0)
            w = v * kappa
            if not w0 - dw <= w <= w0 + dw or abs(w) > lim.max_yaw_rate:
                w = float(
                    np.clip(np.clip(w, w0 - dw, w0 + dw), -lim.max_yaw_rate, lim.max_yaw_rate)
                )
            candidates += [(v, w), (max(0.0, v0 - dv), w)]
        turn = float(np.clip(np.sign(alpha) * c.rotate_speed, w0 - dw, w0 + dw))
        # where a turn on the spot is blocked, turning while creeping forwards or
        # backwards may not be
        candidates += [
            (max(0.0, v0 - dv), 0.0),
            (0.0, turn),
            (c.creep_speed, turn),
            (-c.creep_speed, turn),
        ]
        # a base already within the margin (localization moved it there) may still move
        # as long as it touches nothing
        blocked = costmap.lethal & ~wall_marks(costmap, c.wall_tolerance)
        here = np.asarray(pose, dtype=float)[None]
        margin = lim.margin if not footprint_hits(costmap, here, lim.margin, blocked).any() else 0.0
        for v, w in candidates:
            if v == 0.0 and w == 0.0:
                continue
            horizon = abs(v) / lim.acc_lim_v + 0.5
            steps = max(2, int(np.ceil(horizon / lim.sim_dt)))
            traj = rollout(pose, np.array([v]), np.array([w]), steps, lim.sim_dt)[0]
            if goal_distance is not None:
                travelled = abs(v) * lim.sim_dt * np.arange(steps)
                traj = traj[travelled <= goal_distance + 0.2]
            if not footprint_hits(costmap, traj, margin, blocked).any():
                return DWAResult(v, w, True, traj, len(candidates))
        return DWAResult(0.0, 0.0, False, np.zeros((0, 3)), len(candidates))
