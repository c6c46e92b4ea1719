"""Scripted drives for the mobile base: velocity commands as a function of sim time (layer 2)."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class SquareDrive:
    """Drive `side` metres forward, turn left 90 degrees, repeat: a square, open loop.

    With symmetric acceleration limits the distance lost speeding up is won back slowing
    down, so the true path closes the square up to slip and contact effects."""

    side: float = 2.0
    speed: float = 0.5
    yaw_rate: float = 0.5

    def __post_init__(self) -> None:
        if not (self.side > 0 and self.speed > 0 and self.yaw_rate > 0):
            raise ValueError("square drive: side, speed and yaw_rate must be positive")

    @property
    def leg(self) -> float:
        """Seconds per side: the straight part, then the turn."""
        return self.side / self.speed + (math.pi / 2) / self.yaw_rate

    @property
    def lap(self) -> float:
        return 4 * self.leg

    def command(self, t: float) -> tuple[float, float]:
        """(v, w) at time `t` (s) since the drive began."""
        phase = t % self.leg
        if phase < self.side / self.speed:
            return self.speed, 0.0
        return 0.0, self.yaw_rate


@dataclass(frozen=True)
class StraightDrive:
    """Forward at `speed` for `distance` metres, then stop."""

    distance: float = 10.0
    speed: float = 0.5

    def command(self, t: float) -> tuple[float, float]:
        return (self.speed, 0.0) if t < self.distance / self.speed else (0.0, 0.0)
