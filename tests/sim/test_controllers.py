"""Arm tracking and base velocity control with limits (the gripper: test_gripper.py)."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.geometry import Pose
from robotrial.sim.controllers import JointReference


def smooth_reference(names, q0, duration=3.0, amplitude=0.6):
    t = np.linspace(0.0, duration, 61)
    shape = 0.5 * (1 - np.cos(2 * np.pi * t / duration))  # 0 -> 1 -> 0, at rest at both ends
    dshape = 0.5 * (2 * np.pi / duration) * np.sin(2 * np.pi * t / duration)
    signs = np.resize([1.0, -1.0], len(names))
    q = q0 + amplitude * signs * shape[:, None]
    qd = amplitude * signs * dshape[:, None]
    return JointReference(names, t, q, qd)


def test_arm_tracks_smooth_reference(boxroom):
    sim = boxroom.make_sim()
    names = ["j1", "j2"]
    q0 = np.array([sim.joint_values()[n] for n in names])
    ref = smooth_reference(names, q0)
    sim.follow(ref)
    errors = []
    for _ in range(300):
        sim.control_step()
        q_ref, _, _ = ref.sample(sim.world.time)
        q = np.array([sim.joint_values()[n] for n in names])
        errors.append(q - q_ref)
    rms = float(np.sqrt(np.mean(np.square(errors))))
    assert rms < 0.01
    assert np.max(np.abs(errors)) < 0.03


def test_base_follows_twist_within_limits(boxroom):
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(-2.5, 0.0, 0.0))
    sim.start()
    sim.drive(3.0, 0.0)  # asks for more than the 1 m/s top speed
    sim.advance(0.5)
    v_half = sim.latest["ground_truth"].data.v
    assert v_half == pytest.approx(0.5, abs=0.05)  # 1 m/s^2 acceleration limit
    sim.advance(2.0)
    truth = sim.latest["ground_truth"].data
    assert truth.v == pytest.approx(1.0, abs=0.02)
    assert abs(truth.vy) < 0.01
    sim.drive(0.0, 1.0)
    sim.advance(1.5)
    truth = sim.latest["ground_truth"].data
    assert truth.w == pytest.approx(1.0, abs=0.05)
    assert abs(truth.v) < 0.05


def test_wall_stops_the_base_without_nan(boxroom):
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(2.5, 0.0, 0.0))
    sim.start()
    sim.drive(1.0, 0.0)
    sim.advance(3.0)
    x, _, _ = sim.world.base_pose2d()
    assert sim.world.is_finite()
    assert x == pytest.approx(boxroom.half_x - 0.4, abs=0.005)  # 0.8 m body stalls at the wall
    assert sim.world.data.ncon > 0
