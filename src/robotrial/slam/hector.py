"""Hector-class SLAM: scan matching, with odometry as its prior where there is some
(layer 3).

Each scan is matched against the map built so far (multi-resolution Gauss-Newton) and,
once the robot has moved `map_update_distance_thresh` or turned `map_update_angle_thresh`
since the last update, written into the map. This is hector_mapping's loop. Without
odometry the match starts from the previous pose, as hector_mapping does by default: it
needs a scan rich in structure, scans close together (a high-rate scanner: its reach is
about the coarsest map cell per scan), and drifts where scans look alike along the motion
(long corridors, large empty rooms with a short-range laser). With odometry
(`use_odometry`, as hector_mapping's start estimate from tf) the match starts where the
odometry puts the robot and keeps to it, within the odometry motion model's standard
deviations (`odom_*`, per m or rad moved), where the scan says little.
"""

from __future__ import annotations

import numpy as np

from robotrial.slam.grid import LogOddsModel
from robotrial.slam.matcher import ScanMatcher
from robotrial.slam.params import HectorParams
from robotrial.slam.scan import Beams, compose, motion_sigma, relative, transform_points
from robotrial.slam.tiled import TiledGrid


class HectorSlam:
    """Feed scans with `process`; read `pose`, `grid` and `trajectory`."""

    uses_odometry = False

    def __init__(self, params: HectorParams | None = None) -> None:
        self.params = p = params or HectorParams()
        # In tiles: a large site costs the cells seen, not its bounding box.
        self.grid = TiledGrid(
            p.map_resolution,
            model=LogOddsModel.from_probabilities(p.update_factor_free, p.update_factor_occupied),
        )
        self.matcher = ScanMatcher(p.map_multi_res_levels, p.iterations)
        self.pose = np.zeros(3)
        self._last_update: np.ndarray | None = None
        self._last_odom: np.ndarray | None = None
        self.stamps: list[float] = []
        self.poses: list[np.ndarray] = []
        self.map_updates = 0

    def range_limits(self, range_max: float) -> tuple[float, float, float]:
        """(min, maximum, usable) range: hector_mapping leaves out every reading outside
        [laser_min_dist, laser_max_dist] (and past the scanner's range_max)."""
        p = self.params
        top = min(p.laser_max_dist, range_max - 0.01) if range_max > 0 else p.laser_max_dist
        return p.laser_min_dist, top, top

    def process(self, scan: Beams, stamp: float, odom: np.ndarray | None = None) -> np.ndarray:
        """Match one scan (from the odometry's prediction, when given and `use_odometry`)
        and return the pose (x, y, yaw) of the base in the map frame."""
        p = self.params
        guess, prior = self.pose, None
        if odom is not None and p.use_odometry:
            odom = np.asarray(odom, dtype=np.float64)
            if self._last_odom is not None:
                d = relative(self._last_odom, odom)
                guess = compose(self.pose, d)
                sx, sy, sth = motion_sigma(d, p.odom_trans_per_trans, p.odom_trans_per_rot,
                                           p.odom_rot_per_trans, p.odom_rot_per_rot)  # fmt: skip
                sxy = max(sx, sy, p.odom_min_sigma_xy)
                prior = (sxy, sxy, max(sth, p.odom_min_sigma_yaw))
            self._last_odom = odom
        self.pose = guess
        if self._last_update is not None and scan.hit.any():
            # Coarse levels are read from the grid as the match goes (only where the scan
            # lands): a precomputed pyramid of a large map costs more than the match.
            self.pose = self.matcher.match(self.grid, scan.hits, guess, None, prior).pose
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
        self.map_updates += 1

    def map_to_odom(self, odom: np.ndarray) -> np.ndarray:
        """The map -> odom transform that puts `odom` (the odometry pose now) at the
        estimated pose."""
        return compose(self.pose, relative(odom, np.zeros(3)))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (N,), poses (N, 3)) of every scan processed."""
        return np.asarray(self.stamps), np.asarray(self.poses).reshape(-1, 3)
