"""Wheel odometry: exact without slip, drifting like a skid-steer base with it."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.geometry import Pose
from robotrial.sim.odometry import OdometryNoise, WheelOdometry
from robotrial.sim.simulation import SimOptions


def drive_square(sim, side=2.0, v=0.8):
    for _ in range(4):
        sim.drive(v, 0.0)
        sim.advance(side / v)
        sim.drive(0.0, 1.0)
        sim.advance(np.pi / 2)


def odom_in_world(sim, start):
    o = sim.latest["odom"].data
    c, s = np.cos(start[2]), np.sin(start[2])
    return start[0] + c * o.x - s * o.y, start[1] + s * o.x + c * o.y


def test_odometry_without_slip_equals_ground_truth(boxroom):
    opts = SimOptions(cameras=False, odometry_noise=OdometryNoise.none())
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(-1.0, -1.0, 0.3), options=opts)
    sim.start()
    drive_square(sim, side=1.5)
    truth = sim.latest["ground_truth"].data
    ox, oy = odom_in_world(sim, (-1.0, -1.0, 0.3))
    assert ox == pytest.approx(truth.x, abs=1e-3)
    assert oy == pytest.approx(truth.y, abs=1e-3)


def straight_drift(noise: OdometryNoise, seed: int, distance: float = 10.0) -> float:
    """Position error of odometry after a straight drive (no simulator: poses fed in)."""
    odo = WheelOdometry(noise, seed=seed)
    steps = 1000
    for i in range(steps + 1):
        odo.update(distance * i / steps, 0.0, 0.0, 0.01)
    return float(np.hypot(odo.state.x - distance, odo.state.y))


def test_slip_makes_odometry_drift_and_is_configurable():
    default = [straight_drift(OdometryNoise(), seed) for seed in range(20)]
    double = OdometryNoise(trans_scale=0.02, rot_per_trans=8e-4)
    more = [straight_drift(double, seed) for seed in range(20)]
    # a 10 m drive: decimetres of error, like a real skid-steer base
    assert 0.05 < np.mean(default) < 0.6
    assert np.mean(more) > 1.5 * np.mean(default)
    assert straight_drift(OdometryNoise.none(), 0) < 1e-9


def test_odometry_drift_while_turning(boxroom):
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(-1.0, -1.0, 0.0))
    sim.start()
    drive_square(sim, side=1.5)
    truth = sim.latest["ground_truth"].data
    odom = sim.latest["odom"].data
    heading_error = abs((odom.yaw - truth.yaw + np.pi) % (2 * np.pi) - np.pi)
    assert 0.01 < heading_error < 0.6  # 3 % yaw scale error on 2 pi of turning, plus slip
