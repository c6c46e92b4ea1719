"""Hybrid-A* with the rectangular footprint: it refuses corners the rectangle cannot
take (where the inscribed-radius grid planners see a way), finds poses that really clear
every obstacle, keeps a minimum turning radius, and settles the apartment's reachability."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from robotrial.nav.costmap import Costmap, Footprint, Inflation
from robotrial.nav.hybrid import HybridAStar, HybridConfig, footprint_hits
from robotrial.nav.navigator import Navigator, NavigatorConfig, Status
from robotrial.nav.planners import AStar, NoPath
from robotrial.nav.profile import rectangle_clearance


def _overlaps(poses: np.ndarray, cm: Costmap, fp: Footprint) -> int:
    """How many poses, interpolated 12 times between consecutive ones, put a point of the
    rectangle (sampled every 1-2 cm) on an occupied cell: checked apart from the planner."""
    u, v = np.meshgrid(
        np.linspace(-fp.length / 2, fp.length / 2, 60), np.linspace(-fp.width / 2, fp.width / 2, 40)
    )
    u, v = u.ravel(), v.ravel()
    bad = 0
    for a, b in itertools.pairwise(poses):
        turn = (b[2] - a[2] + np.pi) % (2 * np.pi) - np.pi
        for t in np.linspace(0.0, 1.0, 12):
            x, y = a[:2] + t * (b[:2] - a[:2])
            th = a[2] + t * turn
            px = x + np.cos(th) * u - np.sin(th) * v
            py = y + np.sin(th) * u + np.cos(th) * v
            rc = cm.world_to_cell(np.stack([px, py], axis=1))
            bad += bool(cm.static[rc[:, 0], rc[:, 1]].any())
    return bad


def _corner(width: float) -> Costmap:
    """An L-shaped corridor `width` m wide: east along y 1..1+width, then north."""
    res = 0.05
    occ = np.ones((120, 120), dtype=bool)  # 6 x 6 m
    n = round(width / res)
    occ[20 : 20 + n, 4:100] = False  # the east leg, x 0.2 .. 5.0
    occ[20:116, 100 - n : 100] = False  # the north leg, ends at x = 5.0
    return Costmap(occ, (0.0, 0.0), res, Footprint(1.0, 0.4), Inflation(0.3, 3.0))


def test_a_corner_the_rectangle_cannot_turn_is_refused_though_the_grid_sees_a_way():
    # legs 0.55 m wide: the inscribed circle (0.2 m) passes, a 1.0 x 0.4 m rectangle
    # cannot (the longest rectangle of width w that turns a corner of two legs a wide
    # is 2 (a sqrt(2) - w) long: 0.76 m here)
    cm = _corner(0.55)
    start, goal = (0.8, 1.275, 0.0), (4.725, 5.2)
    assert len(AStar().plan(cm, start[:2], goal)) > 10
    with pytest.raises(NoPath, match=r"no motion of the 1\.00 x 0\.40 m footprint"):
        HybridAStar().plan(cm, start, goal)


def test_a_wide_enough_corner_is_planned_with_poses_clear_of_the_walls():
    cm = _corner(1.0)
    start, goal = (0.8, 1.5, 0.0), (4.5, 5.2)
    hy = HybridAStar()
    poses = hy.plan_poses(cm, start, goal)
    assert np.hypot(*(poses[-1, :2] - goal)) < 1e-9
    assert _overlaps(poses, cm, cm.footprint) == 0
    assert not hy.collides(cm, poses).any()
    path = hy.plan(cm, start, goal)
    assert np.hypot(*np.diff(path, axis=0).T).max() <= 0.051


def test_a_minimum_turning_radius_is_kept_and_the_base_never_turns_on_the_spot():
    occ = np.zeros((100, 100), dtype=bool)
    occ[[0, -1], :] = occ[:, [0, -1]] = True
    cm = Costmap(occ, (0.0, 0.0), 0.05, Footprint(0.6, 0.4), Inflation(0.3, 3.0))
    radius = 1.0
    hy = HybridAStar(HybridConfig(turning_radius=radius))
    # the goal lies behind the start: the base has to drive round
    poses = hy.plan_poses(cm, (2.5, 2.5, 0.0), (1.5, 2.5))
    step = np.hypot(*np.diff(poses[:-1, :2], axis=0).T)
    turn = np.abs((np.diff(poses[:-1, 2]) + np.pi) % (2 * np.pi) - np.pi)
    assert (step > 0.1).all(), "no turns on the spot"
    assert (turn / step <= 1.01 / radius).all()  # chords are a little shorter than arcs
    assert turn.sum() > np.pi / 2
    spin = HybridAStar().plan_poses(cm, (2.5, 2.5, 0.0), (1.5, 2.5))
    assert len(spin) < len(poses), "a base that turns on the spot has the shorter way"


def test_bad_starts_and_goals_are_named():
    cm = _corner(1.0)
    hy = HybridAStar()
    with pytest.raises(NoPath, match="outside the map"):
        hy.plan(cm, (0.8, 1.5, 0.0), (40.0, 1.5))
    with pytest.raises(NoPath, match="touches an obstacle there in every heading"):
        hy.plan(cm, (0.8, 1.5, 0.0), (3.0, 3.0))
    with pytest.raises(NoPath, match="at the start"):
        hy.plan(cm, (0.8, 1.5, np.pi / 2), (4.5, 5.2))
    with pytest.raises(ValueError, match="turning_radius"):
        HybridConfig(turning_radius=-1.0)


def test_navigator_with_the_footprint_planner_aborts_where_only_the_grid_sees_a_way():
    cm = _corner(0.55)
    navs = {}
    for planner in ("astar", "hybrid"):
        nav = Navigator(
            cm.static, cm.origin, cm.resolution, cm.footprint, NavigatorConfig(planner=planner)
        )
        nav.set_goal(4.725, 5.2, np.pi / 2)  # facing up the north leg, where it fits
        for t in np.arange(0.0, 3.0, 0.05):
            nav.step(float(t), (0.8, 1.275, 0.0), (0.0, 0.0))
            if nav.status is not Status.ACTIVE:
                break
        navs[planner] = nav
    assert navs["astar"].plans_by and "no path" not in navs["astar"].message
    assert navs["hybrid"].status is Status.ABORTED
    assert "no motion of the 1.00 x 0.40 m footprint" in navs["hybrid"].message


@pytest.mark.parametrize("room", ["kitchen", "corridor", "bedroom", "study"])
def test_every_apartment_room_is_reachable_from_the_living_room_for_the_footprint(room):
    from robotrial.model import load_world
    from robotrial.model.gridmap import world_map

    world = load_world("apartment")
    m = world_map(world)
    fp = Footprint(0.99, 0.67)  # the mobile manipulator's
    cm = Costmap(m.occupied, m.origin, m.resolution, fp)
    s, g = world.spawn("default"), world.spawn(room)
    poses = HybridAStar().plan_poses(cm, (*s.xyz[:2], s.yaw), g.xyz[:2])
    assert _overlaps(poses, cm, fp) == 0


def test_a_base_past_the_study_doorway_is_told_to_turn_before_it_backs_up():
    """In the 1.1 m corridor, slanted past the study's doorway, the base finds no forward
    way in; backing straight up at its slant would scrape the corridor wall, so the plan
    that may reverse first turns the base on the spot, then backs it up clear."""
    from robotrial.model import load_world
    from robotrial.model.gridmap import world_map

    m = world_map(load_world("apartment"))
    cm = Costmap(m.occupied, m.origin, m.resolution, Footprint(0.99, 0.67))
    planner, pose, goal = HybridAStar(), (6.53, 4.95, 0.93), (6.5, 6.6)
    with pytest.raises(NoPath):
        planner.plan(cm, pose, goal)
    heading, run = planner.reverse_run(cm, pose, goal)
    assert run > 0.05 and abs(heading - pose[2]) > 0.3

    def backed(yaw: float) -> np.ndarray:
        d = np.linspace(0.0, run + 0.1, 8)[:, None]
        return np.column_stack(
            [pose[0] - d * np.cos(yaw), pose[1] - d * np.sin(yaw), np.full_like(d, yaw)]
        )

    assert planner.collides(cm, backed(pose[2])).any()
    assert not planner.collides(cm, backed(heading)).any()
    assert planner.plan(cm, tuple(backed(heading)[-1]), goal)[-1] == pytest.approx(goal, abs=0.1)


def _drive(nav, start, occupied, origin, res, done, steps, shift=(0.0, 0.0)) -> np.ndarray:
    """The poses of a base driven from `start` by the navigator's commands (within the
    base's own rate limits, 1 m/s^2 and 3 rad/s^2, at 100 Hz), scans marking the map's
    occupied cells within 3 m, moved by `shift`, at 10 Hz; until `done(pose)`, the
    navigator stops, or `steps` control periods."""
    from robotrial.nav.amcl import compose
    from tests.nav.test_profile import _arc

    rows, cols = np.nonzero(occupied)
    walls = np.column_stack([origin[0] + (cols + 0.5) * res, origin[1] + (rows + 0.5) * res])
    pose, vel, period = np.array(start, dtype=float), np.zeros(2), nav.config.dwa.period
    poses = [pose]
    for k in range(steps):
        if k % 2 == 0:
            near = np.hypot(*(walls - pose[:2]).T) <= 3.0
            nav.observe(tuple(pose[:2]), walls[near] + shift)
        cmd = nav.step(k * period, tuple(pose), tuple(vel))
        for _ in range(5):
            vel += np.clip(np.array(cmd) - vel, [-0.01, -0.03], [0.01, 0.03])
            pose = compose(pose, _arc(vel[0], vel[1], period / 5))
        poses.append(pose)
        if nav.status is not Status.ACTIVE or done(pose):
            break
    return np.array(poses)


def test_a_base_wedged_askew_in_a_doorway_gets_clear_and_drives_through():
    """A generated home's 0.8 m doorway: the base stopped at its entrance 0.12 rad askew,
    its front corner on the jamb as mapped (the scan, from a pose 4 cm off, marks the
    jamb nearer still), where neither a drive on nor a turn on the spot is clear. It
    gets clear (backs out or turns away from the jamb, never into it) and then drives
    through."""
    from robotrial.nav.navigator import Recovery
    from robotrial.trials.nav import navigator_config
    from robotrial.trials.nav_goals import goal_world

    _, m = goal_world("home:2000")
    fp = Footprint(0.99, 0.67)
    config = navigator_config(1.0, 2.0, 1.0, "hybrid", 3.0)
    nav = Navigator(m.occupied, m.origin, m.resolution, fp, config, m.unknown)
    start = np.array([2.12, 3.935, -0.119])
    jamb_x = 2.6  # the doorway's wall; the goal room lies east of it
    cm = Costmap(m.occupied, m.origin, m.resolution, fp)
    assert footprint_hits(cm, start[None], 0.0).any(), "the start touches the jamb as mapped"
    nav.set_goal(4.347, 3.995, -2.378)
    poses = _drive(
        nav,
        start,
        m.occupied,
        m.origin,
        m.resolution,
        lambda p: p[0] > jamb_x + 0.6,
        400,
        (-0.04, 0.0),
    )
    pose = poses[-1]
    assert nav.status is Status.ACTIVE, nav.message
    assert pose[0] > jamb_x + 0.6, f"stopped at {pose.round(2)}"
    assert {Recovery.BACK_UP.value, Recovery.ESCAPE.value} & set(nav.recoveries)
    room = rectangle_clearance(cm, poses)
    assert room.min() >= room[0] - 1e-3, "it went nearer the jamb than it started"


def test_a_replan_that_finds_nothing_mid_swing_leaves_the_base_on_its_plan():
    """Swinging into a generated home's 0.8 m doorway 0.14 rad askew, the base stands
    where the footprint planner (its turns on the spot) finds no way to the goal; it
    drives on along the plan it follows instead of stopping to back up."""
    from robotrial.trials.nav import navigator_config
    from robotrial.trials.nav_goals import goal_world

    _, m = goal_world("home:2001")
    config = navigator_config(1.0, 2.0, 1.0, "hybrid", 3.0)
    nav = Navigator(m.occupied, m.origin, m.resolution, Footprint(0.99, 0.67), config, m.unknown)
    nav.set_goal(3.937, 0.868, -2.712)
    nav.step(0.0, (2.024, 1.878, 0.268), (0.76, 0.22))
    swing = (2.546, 2.103, 0.143)
    with pytest.raises(NoPath):
        nav.hybrid.plan(nav.global_costmap, swing, tuple(nav.goal))
    v, _ = nav.step(1.0, swing, (0.30, -1.31))  # a replan is due
    assert v > 0.05
    assert nav.status is Status.ACTIVE and nav.recoveries == []
    assert nav.phase() == ("driving", "")


def _touching_the_jamb(cm: Costmap, yaw: float, gap: float) -> np.ndarray:
    """A pose facing `yaw` in the first room of `two_rooms`, slid towards the doorway's
    southern jamb until the rectangle keeps only `gap` (m) from it as mapped."""
    near, far = 0.0, 1.0
    for _ in range(40):  # bisection along the way to the jamb (3.0, 1.1)
        mid = 0.5 * (near + far)
        pose = np.array([1.9 + 1.1 * mid, 0.6 + 0.5 * mid, yaw])
        if rectangle_clearance(cm, pose[None])[0] > gap:
            near = mid
        else:
            far = mid
    return np.array([1.9 + 1.1 * near, 0.6 + 0.5 * near, yaw])


def test_a_base_the_map_shows_nearly_touching_a_jamb_gets_clear_and_drives_on():
    """After exploring, the base may stand where SLAM's map puts a doorway's jamb within
    a few mm of its rectangle, nearer than the footprint planner's margin, askew, so no
    plan starts there. It is not in the jamb: the goal is judged (and driven) from where
    the least turn on the spot gets it clear, never nearer the jamb on the way."""
    from robotrial.model.gridmap import world_map
    from robotrial.model.world import load_world_text
    from robotrial.nav.goals import check_goal
    from robotrial.nav.navigator import Recovery
    from robotrial.trials.nav import navigator_config
    from tests.trials.test_verdict import two_rooms

    m = world_map(load_world_text(two_rooms(0.8)))
    fp = Footprint(0.99, 0.67)
    cm = Costmap(m.occupied, m.origin, m.resolution, fp)
    start = _touching_the_jamb(cm, 0.75, 0.004)
    config = navigator_config(0.3, 2.0, 1.0, "hybrid", 3.0)
    hybrid = replace(config.hybrid, margin=0.01)
    config = replace(config, costmap_resolution=None, hybrid=hybrid)
    goal = (4.5, 1.5, 0.0)
    assert HybridAStar(hybrid).collides(cm, start[None])[0], "within the planner's margin"
    verdict = check_goal(cm, goal, tuple(start), HybridAStar(hybrid))
    assert verdict.ok, verdict.reason
    nav = Navigator(m.occupied, m.origin, m.resolution, fp, config, m.unknown)
    nav.set_goal(*goal)
    poses = _drive(nav, start, m.occupied, m.origin, m.resolution, lambda p: p[0] > 3.6, 600)
    pose = poses[-1]
    assert pose[0] > 3.6, f"{nav.status.value} at {pose.round(2)}: {nav.message}"
    assert nav.recoveries[0] == Recovery.ESCAPE.value
    room = rectangle_clearance(cm, poses)
    assert room.min() >= room[0] - 1e-3, "it went nearer the jamb than it started"


def test_a_base_in_a_pocket_too_narrow_to_turn_in_backs_out_to_its_goal():
    """Exploring may drive the base forwards into a pocket as wide as a doorway and too
    narrow to turn in (between a sofa and a round table). No forward plan leaves it; the
    goal behind the base is judged reachable and the base backs out to it, touching
    nothing."""
    from robotrial.nav.goals import check_goal
    from robotrial.trials.nav import navigator_config

    res = 0.05
    occ = np.zeros((80, 120), dtype=bool)
    occ[[0, -1], :] = occ[:, [0, -1]] = True
    occ[:, 90:] = True  # x >= 4.5 is solid but for a pocket 1.0 m wide, 1.5 m deep
    occ[30:50, 90:119] = False
    fp = Footprint(0.99, 0.67)
    cm = Costmap(occ, (0.0, 0.0), res, fp)
    start, goal = np.array([5.3, 2.0, 0.0]), (1.5, 2.0, np.pi)
    config = navigator_config(0.3, 2.0, 1.0, "hybrid", 3.0)
    config = replace(config, costmap_resolution=None)
    with pytest.raises(NoPath):
        HybridAStar(config.hybrid).plan_poses(cm, tuple(start), goal)
    verdict = check_goal(cm, goal, tuple(start), HybridAStar(config.hybrid))
    assert verdict.ok, verdict.reason
    nav = Navigator(occ, (0.0, 0.0), res, fp, config)
    nav.set_goal(*goal)
    poses = _drive(nav, start, occ, (0.0, 0.0), res, lambda p: p[0] < 3.8, 900)
    pose = poses[-1]
    assert pose[0] < 3.8, f"{nav.status.value} at {pose.round(2)}: {nav.message}"
    assert rectangle_clearance(cm, poses).min() > 0.0


def test_a_goal_just_past_a_doorway_is_not_turned_to_where_the_rear_sweeps_the_jamb():
    """Exploring's goal may lie a few cm past a 0.8 m doorway, facing back at it: the
    base comes within the goal's tolerance with its rear still in the doorway, where a
    turn on the spot to the goal's heading sweeps a jamb (home 33's contact). It follows
    its footprint plan instead, which turns where there is room, and touches nothing."""
    from robotrial.model.gridmap import world_map
    from robotrial.model.world import load_world_text
    from robotrial.trials.nav import navigator_config
    from tests.trials.test_verdict import two_rooms

    m = world_map(load_world_text(two_rooms(0.8)))
    fp = Footprint(0.99, 0.67)
    cm = Costmap(m.occupied, m.origin, m.resolution, fp)
    config = navigator_config(0.3, 2.0, 1.0, "hybrid", 3.0)
    hybrid = replace(config.hybrid, margin=0.01)
    config = replace(config, costmap_resolution=None, hybrid=hybrid, yaw_tolerance=0.6)
    start, goal = np.array([3.41, 1.53, 0.0]), (3.47, 1.5, -2.7)
    turn = np.column_stack([np.full((50, 2), start[:2]), np.linspace(0.0, goal[2], 50)])
    assert rectangle_clearance(cm, start[None])[0] > 0.03
    assert rectangle_clearance(cm, turn).min() < 0.0, "turning where it stands sweeps the jamb"
    nav = Navigator(m.occupied, m.origin, m.resolution, fp, config, m.unknown)
    nav.set_goal(*goal)
    poses = _drive(nav, start, m.occupied, m.origin, m.resolution, lambda p: False, 1500)
    assert nav.status is Status.SUCCEEDED, nav.message
    assert rectangle_clearance(cm, poses).min() > 0.0


def _askew_in_the_doorway(cm: Costmap) -> np.ndarray:
    """In the 0.8 m doorway of `two_rooms`, 18 deg off square facing the first room, its
    rear in the doorway, slid north until the rectangle keeps 5 mm from the jamb."""
    yaw, low, high = np.pi - 0.31, 1.5, 1.9
    for _ in range(40):
        mid = 0.5 * (low + high)
        if rectangle_clearance(cm, np.array([[2.83, mid, yaw]]))[0] > 0.005:
            low = mid
        else:
            high = mid
    return np.array([2.83, low, yaw])


def test_a_base_askew_in_a_doorway_a_few_mm_off_a_jamb_drives_on_out_of_it():
    """After exploring, the search's first drive may leave the base in a 0.8 m doorway
    18 deg off square, its rectangle 5 mm clear of a jamb as mapped (a generated home's
    search, 0 looks from 0 places). Cell masks that take the yaw to the nearest 2.5 deg
    (up to 1 cm at the corners of a 0.99 m base) called that pose and every motion from
    it touching; the exact rectangle decides, so the base drives on through the doorway,
    touching nothing on the map, instead of giving up stuck."""
    from robotrial.model.gridmap import world_map
    from robotrial.model.world import load_world_text
    from robotrial.trials.nav import navigator_config
    from tests.trials.test_verdict import two_rooms

    m = world_map(load_world_text(two_rooms(0.8)))
    fp = Footprint(0.99, 0.67)
    cm = Costmap(m.occupied, m.origin, m.resolution, fp)
    start = _askew_in_the_doorway(cm)
    config = navigator_config(0.3, 2.0, 1.0, "hybrid", 3.0)
    hybrid = replace(config.hybrid, margin=0.01)
    config = replace(config, costmap_resolution=None, hybrid=hybrid)
    nav = Navigator(m.occupied, m.origin, m.resolution, fp, config, m.unknown)
    goal = np.array([1.2, 1.8, np.pi / 2])
    nav.set_goal(*goal)

    def near(p: np.ndarray) -> bool:
        return bool(np.hypot(*(p[:2] - goal[:2])) < 0.3)

    poses = _drive(nav, start, m.occupied, m.origin, m.resolution, near, 600)
    pose = poses[-1]
    assert np.hypot(*(pose[:2] - goal[:2])) < 0.3, (
        f"{nav.status.value} at {pose.round(2)}: {nav.message}"
    )
    assert rectangle_clearance(cm, poses).min() >= 0.0


def test_a_pose_a_few_mm_off_a_jamb_is_free_alike_for_the_planner_and_the_controller():
    """The footprint test of the planner's search and start check, the controllers'
    checks and the goal and frontier checks (`footprint_hits`) is the exact rectangle
    grown by the margin, at the pose's own yaw: around a 0.8 m doorway it answers as
    the rectangle's measured clearance does, for any yaw. A base askew 5 mm off the
    jamb is free to plan from (with no margin) and to drive from."""
    from robotrial.model.gridmap import world_map
    from robotrial.model.world import load_world_text
    from robotrial.nav.profile import ProfileConfig, ProfileController
    from tests.trials.test_verdict import two_rooms

    m = world_map(load_world_text(two_rooms(0.8)))
    fp = Footprint(0.99, 0.67)
    cm = Costmap(m.occupied, m.origin, m.resolution, fp)
    rng = np.random.default_rng(0)
    poses = np.column_stack(
        [rng.uniform(2.3, 3.7, 3000), rng.uniform(0.9, 2.1, 3000), rng.uniform(-np.pi, np.pi, 3000)]
    )
    room = rectangle_clearance(cm, poses, cap=0.1)
    for margin in (0.0, 0.03):
        sure = np.abs(room - margin) > 1e-6
        hits = footprint_hits(cm, poses, margin)
        assert np.array_equal(hits[sure], room[sure] < margin), f"margin {margin}"
        assert 0 < hits.sum() < len(poses)

    start = _askew_in_the_doorway(cm)  # masks rounding the yaw called it touching
    assert not footprint_hits(cm, start[None], 0.0)[0]
    assert footprint_hits(cm, start[None], 0.006)[0], "5 mm clear, not more"
    planner = HybridAStar(HybridConfig(margin=0.0))
    assert not planner.collides(cm, start[None])[0]
    goal = (1.2, 1.8, np.pi / 2)
    plan = planner.plan_poses(cm, tuple(start), goal)
    assert rectangle_clearance(cm, plan).min() >= 0.0
    controller = ProfileController(fp, ProfileConfig(max_speed=0.3))
    assert controller.set_path(plan, cm, tuple(start))
    command = controller.compute(tuple(start), (0.0, 0.0), plan[:, :2], cm)
    assert command.ok and abs(command.v) + abs(command.w) > 0.0
