"""The time-optimal profile along footprint plans and the controller that tracks it: the
profile keeps the base's limits and times simple motions exactly, the base turns while
it drives where the rectangle clears a curve, passes a 1.0 m doorway without touching
it and sooner than the regulated pure pursuit, stops short of a box in the doorway, and
drives the mobile manipulator to the apartment's kitchen in MuJoCo sooner too."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robotrial.nav.amcl import compose
from robotrial.nav.costmap import Costmap, Footprint, Inflation
from robotrial.nav.dwa import DWAConfig
from robotrial.nav.hybrid import HybridAStar, footprint_hits
from robotrial.nav.profile import (
    ProfileConfig,
    ProfileController,
    densify,
    minimum_time,
    plan_profile,
    rectangle_clearance,
    smooth_poses,
)
from robotrial.nav.pursuit import PursuitController

BASE = ProfileConfig(max_speed=1.0, max_yaw_rate=2.0, max_accel=1.0, max_yaw_accel=3.0)
FP = Footprint(0.99, 0.67)


def test_a_straight_drive_and_a_half_turn_take_the_textbook_times():
    # 4 m from rest to rest at 1 m/s and 1 m/s^2: 1 s up, 3 s at the top speed, 1 s down
    drive = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0]])
    assert minimum_time(drive, BASE) == pytest.approx(5.0, abs=1e-6)
    # a half turn at 2 rad/s and 3 rad/s^2: 2/3 s up, (pi - 4/3) / 2 s, 2/3 s down
    assert minimum_time(drive[:1], BASE, goal_yaw=np.pi) == pytest.approx(
        np.pi / 2 + 2 / 3, abs=1e-6
    )
    # a drive, a quarter turn on the spot, a drive: the base stops to turn
    corner = np.array([[0, 0, 0], [2, 0, 0], [2, 0, np.pi / 2], [2, 2, np.pi / 2]], float)
    quarter = (np.pi / 2) / 2 + 2 / 3  # the top yaw rate reached, as in the half turn
    assert minimum_time(corner, BASE) == pytest.approx(2 * 3.0 + quarter, abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["drive", "arc", "spin"]),
            st.floats(0.05, 1.5),
            st.floats(-1.5, 1.5),
        ),
        min_size=1,
        max_size=8,
    ),
    st.floats(0.0, 1.0),
)
def test_the_profile_never_asks_for_more_than_the_limits(moves, start_rate):
    pose, chain = np.zeros(3), [np.zeros(3)]
    for kind, length, turn in moves:
        for _ in range(10):
            if kind == "spin":
                pose = pose + np.array([0.0, 0.0, turn / 10])
            else:
                dth = turn / 10 if kind == "arc" else 0.0
                mid = pose[2] + dth / 2
                step = length / 10
                pose = pose + np.array([step * np.cos(mid), step * np.sin(mid), dth])
            chain.append(pose)
    prof = plan_profile(densify(np.array(chain)), BASE, start_rate=start_rate)
    c = BASE
    v = prof.rate[:-1] * np.abs(prof.ds) / np.maximum(prof.dsig, 1e-12)
    w = prof.rate[:-1] * np.abs(prof.dtheta) / np.maximum(prof.dsig, 1e-12)
    v1 = prof.rate[1:] * np.abs(prof.ds) / np.maximum(prof.dsig, 1e-12)
    w1 = prof.rate[1:] * np.abs(prof.dtheta) / np.maximum(prof.dsig, 1e-12)
    tol = 1e-9
    assert (np.maximum(v, v1) <= c.max_speed + tol).all()
    assert (np.maximum(w, w1) <= c.max_yaw_rate + tol).all()
    # the rate changes within each piece at most as fast as the accelerations allow
    du2 = np.abs(prof.rate[1:] ** 2 - prof.rate[:-1] ** 2)
    a_sig = du2 / np.maximum(2 * prof.dsig, 1e-12)  # d(rate)/dt within the piece
    a_v = a_sig * np.abs(prof.ds) / np.maximum(prof.dsig, 1e-12)
    a_w = a_sig * np.abs(prof.dtheta) / np.maximum(prof.dsig, 1e-12)
    assert (a_v <= c.accel_use * c.max_accel + 1e-6).all()
    assert (a_w <= c.accel_use * c.max_yaw_accel + 1e-6).all()
    # where a drive meets a turn on the spot, the base is at rest; it stops at the end
    meet = np.flatnonzero(prof.spin[1:] != prof.spin[:-1]) + 1
    assert (prof.rate[meet] == 0).all()
    assert prof.rate[-1] == 0
    assert np.isfinite(prof.duration)


def _room(door: float | None = None) -> np.ndarray:
    """10 x 5 m, walls around; with `door`, a wall at x = 5 m with a doorway that wide
    centred on y = 2.5."""
    occ = np.zeros((100, 200), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    if door is not None:
        occ[:, 99:101] = True
        half = round(door / 0.05 / 2)
        occ[50 - half : 50 + half, 99:101] = False
    return occ


def test_the_base_turns_while_driving_where_the_rectangle_clears_a_curve():
    cm = Costmap(_room(), (0.0, 0.0), 0.05, FP, Inflation(1.0, 3.0))
    # facing east, the goal to the north-east: the plan turns on the spot first
    plan = HybridAStar().plan_poses(cm, (2.0, 1.2, 0.0), (5.0, 4.0))
    chain = smooth_poses(cm, plan, BASE)
    steps = np.hypot(*np.diff(chain[:, :2], axis=0).T)
    assert not (steps < 1e-6).any(), "no turn on the spot left"
    assert (rectangle_clearance(cm, chain) >= BASE.smooth_margin - 1e-9).all()
    assert minimum_time(plan, BASE, costmap=cm) < minimum_time(plan, BASE) - 0.3


def _run(controller, cm: Costmap, plan, start, steps: int, period: float = 0.05):
    """Drive a base that follows its command within 1 m/s^2 and 3 rad/s^2 (as the
    simulator's base controller does); the poses and the time (s) to the goal."""
    pose, cmd, vel = np.array(start, float), (0.0, 0.0), np.zeros(2)
    goal = np.asarray(plan)[-1, :2]
    poses = [pose]
    for k in range(steps):
        dist = float(np.hypot(*(goal - pose[:2])))
        if dist < 0.15:
            return np.array(poses), k * period
        res = controller.compute(tuple(pose), cmd, plan, cm, goal_distance=dist)
        cmd = (res.v, res.w) if res.ok else (0.0, 0.0)
        for _ in range(5):  # the base's own rate limits, at 100 Hz
            vel += np.clip(np.array(cmd) - vel, [-0.01, -0.03], [0.01, 0.03])
            pose = compose(pose, _arc(vel[0], vel[1], period / 5))
        poses.append(pose)
    return np.array(poses), np.inf


def _arc(v: float, w: float, dt: float) -> np.ndarray:
    if abs(w) < 1e-9:
        return np.array([v * dt, 0.0, 0.0])
    return np.array([v / w * np.sin(w * dt), v / w * (1 - np.cos(w * dt)), w * dt])


def test_the_base_passes_a_doorway_without_contact_and_sooner_than_pure_pursuit():
    cm = Costmap(_room(door=1.0), (0.0, 0.0), 0.05, FP, Inflation(1.0, 3.0))
    start = (1.5, 2.4, 0.0)
    plan = HybridAStar().plan_poses(cm, start, (8.5, 2.5))
    profile = ProfileController(FP, BASE)
    profile.set_path(plan, cm, start)
    poses, t_profile = _run(profile, cm, plan, start, 600)
    assert np.isfinite(t_profile), f"stopped at {poses[-1]}"
    assert not footprint_hits(cm, poses, 0.0).any()
    limits = DWAConfig(
        max_speed=1.0,
        max_yaw_rate=1.6,
        acc_lim_v=1.0,
        acc_lim_w=2.0,
        footprint_speed=True,
        exact_footprint=True,
    )
    pursuit_poses, t_pursuit = _run(PursuitController(FP, limits), cm, plan[:, :2], start, 600)
    assert not footprint_hits(cm, pursuit_poses, 0.0).any()
    assert t_profile < t_pursuit - 1.0, (t_profile, t_pursuit)
    # through the doorway itself it kept most of the top speed
    at_door = np.abs(poses[:, 0] - 5.0) < 0.3
    speed = np.hypot(*np.diff(poses[:, :2], axis=0).T) / 0.05
    assert speed[at_door[1:]].min() > 0.7


def test_a_box_in_the_doorway_stops_the_base_short_of_it():
    occ = _room(door=1.0)
    plan_map = Costmap(occ, (0.0, 0.0), 0.05, FP)
    start = (1.5, 2.5, 0.0)
    plan = HybridAStar().plan_poses(plan_map, start, (8.5, 2.5))
    controller = ProfileController(FP, BASE)
    controller.set_path(plan, plan_map, start)
    seen = Costmap(occ, (0.0, 0.0), 0.05, FP, marks=np.array([[5.0, 2.5]]))
    poses, t = _run(controller, seen, plan, start, 300)
    assert not np.isfinite(t)
    assert poses[:, 0].max() < 4.6
    assert not footprint_hits(seen, poses, 0.0).any()
    assert not controller.compute(tuple(poses[-1]), (0.0, 0.0), plan, seen).ok


def test_bad_plans_and_settings_are_named():
    cm = Costmap(_room(), (0.0, 0.0), 0.05, FP)
    with pytest.raises(ValueError, match=r"profile: a plan is \(N, 2\) points or \(N, 3\) poses"):
        ProfileController(FP).set_path(np.zeros((4, 5)), cm, (1.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="accel_use"):
        ProfileConfig(accel_use=0.0)
    with pytest.raises(ValueError, match="max_yaw_rate"):
        ProfileConfig(max_yaw_rate=-1.0)
    with pytest.raises(ValueError, match="tight_clearance < ample_clearance"):
        ProfileConfig(tight_clearance=0.2, ample_clearance=0.1)


@pytest.mark.slow
def test_mobile_manipulator_reaches_the_kitchen_sooner_than_with_pure_pursuit():
    from robotrial.model import load_world
    from robotrial.trials.nav import NavTrialSetup, run_once

    spawn = load_world("apartment").spawn("kitchen")
    goal = (float(spawn.xyz[0]), float(spawn.xyz[1]), float(spawn.yaw))
    runs = {
        controller: run_once(
            NavTrialSetup(
                world="apartment", goal=goal, speed=1.0, planner="hybrid", controller=controller
            ),
            seed=0,
        )
        for controller in ("profile", "pursuit")
    }
    for r in runs.values():
        assert r.success and not r.collision, r.message
    assert runs["profile"].time < 0.9 * runs["pursuit"].time


def test_the_navigator_drives_hybrid_plans_with_the_profile_within_its_top_speed():
    from robotrial.nav.navigator import Navigator, NavigatorConfig, Status

    occ = _room()
    nav = Navigator(occ, (0.0, 0.0), 0.05, FP, NavigatorConfig(planner="hybrid"))
    assert isinstance(nav.controller, ProfileController)  # the default for Hybrid-A*
    pose, t, top = np.array([1.5, 2.5, 0.0]), 0.0, 0.0
    nav.set_goal(6.0, 2.5, 0.0)
    while nav.status is Status.ACTIVE and t < 40.0:
        nav.observe((float(pose[0]), float(pose[1])), np.zeros((0, 2)))  # an empty scan
        v, w = nav.step(t, tuple(pose), (0.0, 0.0))
        top = max(top, v)
        pose = compose(pose, _arc(v, w, 0.05))
        t += 0.05
    assert nav.status is Status.SUCCEEDED, nav.message
    # the navigator's top speed is the DWA's (0.3 m/s by default): the profile keeps it
    assert 0.25 < top <= 0.3 + 1e-9


def test_the_footprint_yardstick_counts_the_turns_the_rectangle_needs():
    from robotrial.model.gridmap import NavMap
    from robotrial.sim.controllers import DriveLimits
    from robotrial.trials.nav import footprint_time

    occ = _room()
    nav_map = NavMap(occ, np.zeros_like(occ), (0.0, 0.0), 0.05, "test")
    limits = DriveLimits(max_speed=1.0, max_yaw_rate=2.0, max_accel=1.0, max_yaw_accel=3.0)
    # 4 m straight ahead, facing the goal: 5 s, as for a point
    best, planned = footprint_time(nav_map, FP, (2.0, 2.5, 0.0), (6.0, 2.5, 0.0), 1.0, limits)
    assert best == pytest.approx(5.0, abs=0.05) and planned == pytest.approx(5.0, abs=0.05)
    # the same drive to a goal that faces back: the half turn at the end is counted
    back, _ = footprint_time(nav_map, FP, (2.0, 2.5, 0.0), (6.0, 2.5, np.pi), 1.0, limits)
    assert back == pytest.approx(5.0 + np.pi / 2 + 2 / 3, abs=0.05)
