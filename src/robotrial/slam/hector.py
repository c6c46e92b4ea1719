"""Hector-class SLAM: scan matching alone, no odometry (layer 3).

Each scan is matched against the map built so far (multi-resolution Gauss-Newton,
starting from the previous pose: there is no motion prediction) and, once the robot has
moved `map_update_distance_thresh` or turned `map_update_angle_thresh` since the last
update, written into the map. This is hector_mapping's loop; it needs a scan rich in
structure, and drifts where scans look alike along the motion (long corridors, large
empty rooms with a short-range laser).
"""

from __future__ import annotations

import numpy as np

from robotrial.slam.grid import LogOddsGrid, LogOddsModel
from robotrial.slam.matcher import ScanMatcher
from robotrial.slam.params import HectorParams
from robotrial.slam.scan import Beams, compose, relative, transform_points


class HectorSlam:
    """Feed scans with `process`; read `pose`, `grid` and `trajectory`."""

    uses_odometry = False

    def __init__(self, params: HectorParams | None = None) -> None:
        self.params = p = params or HectorParams()
        self.grid = LogOddsGrid(
            p.map_resolution,
            model=LogOddsModel.from_probabilities(p.update_factor_free, p.update_factor_occupied),
        )
        self.matcher = ScanMatcher(p.map_multi_res_levels, p.iterations)
        self.pose = np.zeros(3)
        self._last_update: np.ndarray | None = None
        self._pyramid: list[np.ndarray] | None = None
        self.stamps: list[float] = []
        self.poses: list[np.ndarray] = []
        self.map_updates = 0

    @property
    def usable_range(self) -> float:
        return self.params.laser_max_dist

    @property
    def min_range(self) -> float:
        return self.params.laser_min_dist

    def process(self, scan: Beams, stamp: float, odom: np.ndarray | None = None) -> np.ndarray:
        """Match one scan (odometry, if given, is ignored) and return the pose (x, y, yaw)
        of the base in the map frame."""
        if self._last_update is not None and scan.hit.any():
            self.pose = self.matcher.match(self.grid, scan.hits, self.pose, self._pyramid).pose
        if self._moved_enough():
            self._integrate(scan)
        self.stamps.append(float(stamp))
        self.poses.append(self.pose.copy())
        return self.pose.copy()

    def _moved_enough(self) -> bool:
        if self._last_update is None:
            return True
        d = relative(self._last_update, self.pose)
        p = self.params
        return bool(
            np.hypot(d[0], d[1]) >= p.map_update_distance_thresh
            or abs(d[2]) >= p.map_update_angle_thresh
        )

    def _integrate(self, scan: Beams) -> None:
        origin = transform_points(self.pose, np.array([scan.origin]))[0]
        self.grid.integrate(origin, transform_points(self.pose, scan.ends), scan.hit)
        self._last_update = self.pose.copy()
        self._pyramid = self.grid.pyramid(self.params.map_multi_res_levels)
        self.map_updates += 1

    def map_to_odom(self, odom: np.ndarray) -> np.ndarray:
        """The map -> odom transform that puts `odom` (the odometry pose now) at the
        estimated pose."""
        return compose(self.pose, relative(odom, np.zeros(3)))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (N,), poses (N, 3)) of every scan processed."""
        return np.asarray(self.stamps), np.asarray(self.poses).reshape(-1, 3)
