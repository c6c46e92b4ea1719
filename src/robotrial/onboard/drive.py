"""Driving the base through waypoints, as a careful teleoperator would (layer 4).

The mapping run of a trial drives a route given in advance this way, localized by SLAM
as the map grows; `trials.slam.record_drive` drives it to record scans.
"""

from __future__ import annotations

import numpy as np

from robotrial.slam.scan import wrap


class RouteDrive:
    """Drives through waypoints like a careful teleoperator who sees the robot: turn on
    the spot towards the next point, then drive at `speed` while steering onto it."""

    def __init__(self, waypoints: list[tuple[float, float]], speed: float = 0.3) -> None:
        if not waypoints:
            raise ValueError("route: give at least one waypoint")
        self.waypoints = list(waypoints)
        self.speed = speed
        self.index = 0

    @property
    def done(self) -> bool:
        return self.index >= len(self.waypoints)

    def command(self, x: float, y: float, yaw: float) -> tuple[float, float]:
        while not self.done:
            tx, ty = self.waypoints[self.index]
            if np.hypot(tx - x, ty - y) > 0.15:
                break
            self.index += 1
        if self.done:
            return 0.0, 0.0
        err = wrap(float(np.arctan2(ty - y, tx - x)) - yaw)
        if abs(err) > 0.25:
            return 0.0, float(np.clip(1.5 * err, -0.5, 0.5))
        return self.speed, float(np.clip(1.5 * err, -0.3, 0.3))
