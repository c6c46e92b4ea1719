"""Wheel odometry of a skid-steer base, with slip that makes it drift (layer 2).

A skid-steer base turns by making its wheels slide, so its encoders overstate some
motions and understate others. `WheelOdometry` integrates the base's true planar motion
increments after corrupting them the way a real base does: a systematic scale error on
distance and on heading (the effective track width is not the nominal one), and a random
slip whose variance grows with the distance travelled and the angle turned (the
odometry motion model of Probabilistic Robotics, ch. 5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class OdometryNoise:
    """Slip parameters. Scale errors are fractions (0.02 = 2 % too long); the random parts
    are variances per unit of motion: rad^2 of heading per m driven (`rot_per_trans`),
    rad^2 per rad turned (`rot_per_rot`), m^2 per m driven (`trans_per_trans`)."""

    trans_scale: float = 0.01
    rot_scale: float = 0.03
    trans_per_trans: float = 1e-4
    rot_per_trans: float = 2e-4
    rot_per_rot: float = 2e-3

    def __post_init__(self) -> None:
        for name in ("trans_per_trans", "rot_per_trans", "rot_per_rot"):
            if getattr(self, name) < 0:
                raise ValueError(f"odometry noise: {name} is a variance and must be >= 0")

    @staticmethod
    def none() -> OdometryNoise:
        return OdometryNoise(0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass
class OdometryState:
    """Odometry estimate in the odom frame: x, y (m), yaw (rad), body velocities."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    v: float = 0.0
    vy: float = 0.0
    w: float = 0.0


def wrap_angle(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


class WheelOdometry:
    """Dead reckoning from true planar poses with slip noise.

    Call `update(x, y, yaw, dt)` with the base's true pose each odometry period; the
    estimate starts at the odom origin, so odom = the pose at the first update.
    """

    def __init__(self, noise: OdometryNoise = OdometryNoise(), seed: int | None = 0) -> None:
        self.noise = noise
        self.rng = np.random.default_rng(seed)
        self.state = OdometryState()
        self._last: tuple[float, float, float] | None = None
        self.distance = 0.0

    def reset(self) -> None:
        self.state = OdometryState()
        self._last = None
        self.distance = 0.0

    def update(self, x: float, y: float, yaw: float, dt: float) -> OdometryState:
        """Advance the estimate by the (noisy) motion since the last true pose."""
        if self._last is None:
            self._last = (x, y, yaw)
            return self.state
        lx, ly, lyaw = self._last
        self._last = (x, y, yaw)
        c, s = np.cos(lyaw), np.sin(lyaw)
        dxw, dyw = x - lx, y - ly
        fwd = c * dxw + s * dyw
        side = -s * dxw + c * dyw
        dth = wrap_angle(yaw - lyaw)
        n = self.noise
        dist = float(np.hypot(fwd, side))
        fwd_m = fwd * (1 + n.trans_scale)
        side_m = side * (1 + n.trans_scale)
        dth_m = dth * (1 + n.rot_scale)
        var_t = n.trans_per_trans * dist
        var_r = n.rot_per_trans * dist + n.rot_per_rot * abs(dth)
        if var_t > 0:
            fwd_m += self.rng.normal(0.0, np.sqrt(var_t))
        if var_r > 0:
            dth_m += self.rng.normal(0.0, np.sqrt(var_r))
        st = self.state
        mid = st.yaw + 0.5 * dth_m
        cm, sm = np.cos(mid), np.sin(mid)
        st.x += cm * fwd_m - sm * side_m
        st.y += sm * fwd_m + cm * side_m
        st.yaw = wrap_angle(st.yaw + dth_m)
        if dt > 0:
            st.v, st.vy, st.w = fwd_m / dt, side_m / dt, dth_m / dt
        self.distance += dist
        return st
