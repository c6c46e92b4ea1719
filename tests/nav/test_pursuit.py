"""Regulated pure pursuit on footprint plans: it takes a corner the plan turns on the spot
at without touching the walls, keeps its speed through a doorway the rectangle passes
with room to spare, and drives the mobile manipulator into the apartment's study."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.nav.amcl import compose
from robotrial.nav.costmap import Costmap, Footprint, Inflation
from robotrial.nav.dwa import DWAConfig, DWAPlanner
from robotrial.nav.hybrid import HybridAStar, HybridConfig, footprint_hits
from robotrial.nav.planners import Dijkstra
from robotrial.nav.pursuit import PursuitConfig, PursuitController

FAST = DWAConfig(
    max_speed=1.0,
    max_yaw_rate=1.6,
    acc_lim_v=1.0,
    acc_lim_w=2.0,
    footprint_speed=True,
    exact_footprint=True,
)


def _arc(v: float, w: float, dt: float) -> np.ndarray:
    if abs(w) < 1e-9:
        return np.array([v * dt, 0.0, 0.0])
    return np.array([v / w * np.sin(w * dt), v / w * (1 - np.cos(w * dt)), w * dt])


def _drive(controller, cm: Costmap, path: np.ndarray, pose: np.ndarray, steps: int):
    """Follow `path` with commands applied exactly; the poses and commands."""
    vel = (0.0, 0.0)
    poses, cmds = [pose], []
    goal = path[-1]
    for _ in range(steps):
        dist = float(np.hypot(*(goal - pose[:2])))
        if dist < 0.1:
            break
        res = controller.compute(tuple(pose), vel, path, cm, goal_distance=dist)
        assert res.ok, f"blocked at {pose}"
        vel = (res.v, res.w)
        cmds.append(vel)
        pose = compose(pose, _arc(res.v, res.w, 0.05))
        poses.append(pose)
    return np.array(poses), np.array(cmds)


def test_pursuit_takes_a_tight_corner_as_planned_without_touching_the_walls():
    fp = Footprint(0.99, 0.67)
    res = 0.05
    occ = np.ones((140, 140), dtype=bool)  # 7 x 7 m
    occ[20:44, 4:110] = False  # east leg 1.2 m wide, y 1.0 .. 2.2
    occ[20:136, 86:110] = False  # north leg 1.2 m wide, x 4.3 .. 5.5
    cm = Costmap(occ, (0.0, 0.0), res, fp, Inflation(1.0, 3.0))
    start = np.array([1.0, 1.6, 0.0])
    # the cheapest plan turns on the spot in the corner
    path = HybridAStar(HybridConfig(heuristic_weight=1.0)).plan(cm, tuple(start), (4.9, 6.0))
    poses, cmds = _drive(PursuitController(fp, FAST), cm, path, start, 1200)
    assert np.hypot(*(poses[-1, :2] - (4.9, 6.0))) < 0.1, f"stopped at {poses[-1]}"
    assert not footprint_hits(cm, poses, 0.0).any()
    assert ((np.abs(cmds[:, 0]) < 0.06) & (np.abs(cmds[:, 1]) > 0.3)).any(), "turned on the spot"


def test_pursuit_keeps_speed_through_a_doorway_the_footprint_clears():
    fp = Footprint(0.99, 0.67)
    occ = np.zeros((100, 200), dtype=bool)  # 10 x 5 m
    occ[:, 99:101] = True  # a wall at x = 5 m ...
    occ[36:64, 99:101] = False  # ... with a 1.4 m doorway, y 1.8 .. 3.2
    cm = Costmap(occ, (0.0, 0.0), 0.05, fp, Inflation(1.0, 3.0))
    path = Dijkstra().plan(cm, (1.0, 2.5), (9.0, 2.5))
    start = np.array([1.0, 2.5, 0.0])
    poses, cmds = _drive(PursuitController(fp, FAST), cm, path, start, 600)
    at_door = np.abs(poses[1:, 0] - 5.0) < 0.5
    assert at_door.any() and cmds[at_door, 0].min() > 0.9
    # the centre's clearance rule slows to 0.3 m/s there: it sees 0.365 m beyond the
    # inscribed radius, under the 0.4 m it wants for the top speed
    centre_rule = DWAPlanner(fp, DWAConfig(max_speed=1.0, max_yaw_rate=1.6))
    assert centre_rule.path_speed((4.0, 2.5, 0.0), path, cm) < 0.9
    with pytest.raises(ValueError, match="min_lookahead"):
        PursuitConfig(min_lookahead=0.0)


def test_scan_marks_on_a_doorway_jamb_count_as_the_jamb_but_a_box_in_the_doorway_stops_the_base():
    """Localization a few cm off puts the scan's view of a jamb a cell into a 1.0 m
    doorway; the base passes 6.5 cm from the real jamb all the same, and is held short of
    a box standing in the doorway."""
    fp = Footprint(0.99, 0.67)
    occ = np.zeros((100, 200), dtype=bool)  # 10 x 5 m
    occ[:, 99:101] = True  # a wall at x = 5 m ...
    occ[40:60, 99:101] = False  # ... with a 1.0 m doorway, y 2.0 .. 3.0
    y = 2.43  # the plan passes 7 cm south of the doorway's middle
    path = np.column_stack([np.linspace(1.0, 9.0, 161), np.full(161, y)])
    start = np.array([1.0, y, 0.0])
    jamb = np.array([[4.975, 2.075], [5.025, 2.075]])  # the south jamb seen 5 cm north
    seen = Costmap(occ, (0.0, 0.0), 0.05, fp, Inflation(1.0, 3.0), marks=jamb)
    poses, _ = _drive(PursuitController(fp, FAST), seen, path, start, 600)
    assert poses[-1, 0] > 8.8
    assert not footprint_hits(Costmap(occ, (0.0, 0.0), 0.05, fp), poses, 0.06).any()
    # taken as an obstacle, the mark holds the base before the doorway
    strict = PursuitController(fp, FAST, PursuitConfig(wall_tolerance=0.0))
    held, _ = _drive(strict, seen, path, start, 300)
    assert held[:, 0].max() < 4.6

    box = Costmap(occ, (0.0, 0.0), 0.05, fp, Inflation(1.0, 3.0), marks=np.array([[5.0, 2.5]]))
    controller, pose, vel = PursuitController(fp, FAST), start, (0.0, 0.0)
    for _ in range(600):
        res = controller.compute(tuple(pose), vel, path, box, goal_distance=9.0 - pose[0])
        if not res.ok:
            break
        vel = (res.v, res.w)
        pose = compose(pose, _arc(res.v, res.w, 0.05))
        assert not footprint_hits(box, pose[None], 0.0).any()
    assert pose[0] < 4.6  # held before the box, never through it


@pytest.mark.slow
def test_mobile_manipulator_drives_into_the_apartment_study():
    from robotrial.model import load_world
    from robotrial.trials.nav import NavTrialSetup, run_once

    study = load_world("apartment").spawn("study")
    setup = NavTrialSetup(
        world="apartment",
        goal=(study.xyz[0], study.xyz[1], study.yaw),
        speed=1.0,
        planner="hybrid",
        controller="pursuit",
    )
    r = run_once(setup, seed=0)
    assert r.success, r.message
    assert not r.collision
