"""SimWorld: physics sanity, state get/set, reset, determinism with a seed, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.geometry import Pose
from robotrial.model.robot import ModelError
from robotrial.sim.simulation import SimOptions, Simulation, StreamSettings


def test_dropped_object_lands_on_floor(boxroom):
    sim = boxroom.make_sim()
    w = sim.world
    cube = w.body_id("object/cube")
    jadr = w.model.body_jntadr[cube]
    qa = w.model.jnt_qposadr[jadr]
    w.data.qpos[qa : qa + 3] = (2.0, 1.0, 1.0)
    w.forward()
    sim.advance(1.5)
    assert w.is_finite()
    assert w.data.xpos[cube][2] == pytest.approx(0.05, abs=2e-3)
    assert w.data.ncon >= 1


def test_state_round_trip_and_reset(boxroom):
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(1.0, -2.0, 0.5))
    w = sim.world
    assert w.base_pose2d() == pytest.approx((1.0, -2.0, 0.5))
    sim.drive(0.5, 0.3)
    sim.advance(1.0)
    saved = w.get_state()
    sim.advance(1.0)
    after = w.get_state()
    w.set_state(saved)
    sim.advance(1.0)
    assert np.allclose(w.get_state(), after)
    sim.reset()
    assert w.time == 0.0
    assert w.base_pose2d() == pytest.approx((1.0, -2.0, 0.5))
    with pytest.raises(ValueError, match="state has"):
        w.set_state(np.zeros(3))


def run(boxroom, seed: int) -> tuple[np.ndarray, list[float]]:
    opts = SimOptions(cameras=False, streams={"lidar": StreamSettings(noise=0.01)})
    sim = boxroom.make_sim(seed=seed, options=opts)
    sim.start()
    sim.drive(0.6, 0.4)
    readings = sim.advance(2.0)
    odom = [r.data for r in readings if r.stream == "odom"][-1]
    scan = [r.data for r in readings if r.stream == "scan"][-1]
    return scan.ranges, [odom.x, odom.y, odom.yaw, sim.world.time]


def test_same_seed_same_run_other_seed_other_noise(boxroom):
    a_scan, a_odom = run(boxroom, 7)
    b_scan, b_odom = run(boxroom, 7)
    c_scan, c_odom = run(boxroom, 8)
    assert np.array_equal(a_scan, b_scan)
    assert a_odom == b_odom
    assert not np.array_equal(a_scan, c_scan)
    assert a_odom != c_odom


def test_streams_come_at_their_rates(boxroom):
    opts = SimOptions(cameras=False, streams={"imu": StreamSettings(rate_hz=20.0)})
    sim = boxroom.make_sim(options=opts)
    sim.start()
    readings = sim.advance(2.0)
    count = {}
    for r in readings:
        count[r.stream] = count.get(r.stream, 0) + 1
    assert count == {
        "lidar": 20,
        "scan": 20,
        "imu": 40,
        "odom": 100,
        "ground_truth": 100,
        "joint_states": 100,
    }
    stamps = [r.data.stamp for r in readings if r.stream == "lidar"]
    assert np.allclose(np.diff(stamps), 0.1)


def test_bad_input_is_refused_clearly(boxroom):
    with pytest.raises(ModelError, match="unknown world 'room_z'"):
        Simulation.create("room_z", "husky")
    with pytest.raises(ModelError, match="unknown robot 'robby'"):
        Simulation.create("room_a", "robby")
    with pytest.raises(ValueError, match="rate must be positive"):
        StreamSettings(rate_hz=-10.0)
    with pytest.raises(ValueError, match="frame 'nowhere' is not in robot"):
        boxroom.make_sim(
            options=SimOptions(cameras=False, streams={"lidar": StreamSettings(frame="nowhere")})
        )
    with pytest.raises(ValueError, match="unknown streams \\['sonar'\\]"):
        boxroom.make_sim(options=SimOptions(cameras=False, streams={"sonar": StreamSettings()}))
    sim = boxroom.make_sim()
    with pytest.raises(ValueError, match="negative"):
        sim.advance(-1.0)
    with pytest.raises(ValueError, match="finite"):
        sim.drive(float("nan"), 0.0)


def test_spawn_restarts_the_run_at_a_pose(boxroom):
    sim = boxroom.make_sim()
    sim.start()
    sim.drive(0.5, 0.0)
    sim.step(50)
    sim.spawn(Pose.from_xy_yaw(-2.0, 2.0, 1.0))
    sim.start()
    assert sim.world.time == 0.0
    assert sim.world.base_pose2d() == pytest.approx((-2.0, 2.0, 1.0))
    odom = sim.latest["odom"].data
    assert (odom.x, odom.y, odom.yaw) == (0.0, 0.0, 0.0)
    readings = sim.step(10)
    assert {r.stream for r in readings} >= {"lidar", "scan", "odom"}


def test_reset_replays_the_same_run(boxroom):
    opts = SimOptions(cameras=False, streams={"lidar": StreamSettings(noise=0.01)})
    sim = boxroom.make_sim(seed=3, options=opts)

    def once():
        sim.start()
        sim.drive(0.6, -0.3)
        got = sim.advance(1.0)
        return [r.data.ranges for r in got if r.stream == "scan"], sim.latest["odom"].data

    scans_a, odom_a = once()
    sim.reset()
    scans_b, odom_b = once()
    assert all(np.array_equal(a, b) for a, b in zip(scans_a, scans_b, strict=True))
    assert odom_a == odom_b
