"""Planners on known problems, dense MuJoCo validation, the PlanTask service and its
explicit failures, random obstacles (hypothesis), and the `robotrial plan` command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from robotrial.cli import main
from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import CollisionChecker, Environment
from robotrial.geometry import Box
from robotrial.geometry import Pose as GeoPose
from robotrial.model import load_robot, load_world
from robotrial.msgs.geometry_msgs import Point, Pose, Quaternion, Vector3
from robotrial.msgs.robotrial_msgs import Box as BoxMsg
from robotrial.msgs.robotrial_msgs import PlanTaskRequest, PlanTaskResponse
from robotrial.msgs.sensor_msgs import JointState
from robotrial.planning import PLANNERS, Problem, planner_class
from robotrial.planning.problems import desk_task
from robotrial.planning.smoothing import round_corners, shortcut, shortcut_and_round
from robotrial.planning.task import TaskPlanner
from robotrial.planning.timing import time_parameterize, time_parameterize_reference
from robotrial.ros.plan_task import answer

START = [-0.785, 0.80, 1.57, 0.0, 0.76, 0.0]  # the hand near (0.15, -0.15, 0.02)


@pytest.fixture(scope="module")
def desk():
    return desk_task(load_robot("desk_arm"), load_world("desk"))


@pytest.fixture(scope="module")
def planner():
    return TaskPlanner(load_robot("desk_arm"), load_world("desk"))


def _request(
    goal=(0.18, 0.2, 0.02), start=START, obstacles=None, obj=None, **kw
) -> PlanTaskRequest:
    if obstacles is None:
        obstacles = [
            BoxMsg(
                id="C", size=Vector3(0.1, 0.1, 0.2), pose=Pose(Point(0.2, 0, 0.15), Quaternion())
            )
        ]
    return PlanTaskRequest(
        current_joints=JointState(
            name=["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"], position=list(start)
        ),
        obstacles=obstacles,
        object=obj or BoxMsg(),
        ee_goal=Pose(Point(*goal), Quaternion(0, 0, 0, 0)),
        **kw,
    )


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_every_planner_solves_the_desk_task(desk, name: str) -> None:
    checker = desk.checker()
    exact = desk.exact(checker)
    assert not checker.motion_valid(desk.start, desk.goal)  # the box is in the way
    res = PLANNERS[name]().solve(
        Problem(desk.start, desk.goal[None], 5.0 if name != "rrt_star" else 0.3, 7), checker
    )
    assert res.success, res.stats
    np.testing.assert_allclose(res.path[0], desk.start)
    np.testing.assert_allclose(res.path[-1], desk.goal)
    assert bool(np.all(checker.motions_valid(res.path[:-1], res.path[1:])))
    assert exact.path_valid(res.path)[0]
    assert res.stats["planning_time"] > 0 and res.stats["nodes"] >= 2


def test_planner_names_in_ompl_spelling() -> None:
    assert planner_class("RRTConnectkConfigDefault") is PLANNERS["rrt_connect"]
    assert planner_class("RRT*") is PLANNERS["rrt_star"]
    assert planner_class("") is PLANNERS["rrt_connect"]
    with pytest.raises(ValueError, match="unknown planner"):
        planner_class("chomp")


def test_compiled_and_python_rrt_connect_agree_on_validity(desk) -> None:
    """Any checker works (here MuJoCo itself, through the Python loop)."""
    exact = desk.exact()

    class MuJoCoChecker:
        d, lower, upper = desk.kin.d, desk.kin.lower, desk.kin.upper

        def valid(self, qs):
            return np.array([exact.valid(q) for q in np.atleast_2d(qs)])

        def motions_valid(self, a, b):
            return np.array(
                [exact.path_valid(np.array([x, y]))[0] for x, y in zip(a, b, strict=True)]
            )

    res = PLANNERS["rrt_connect"]().solve(
        Problem(desk.start, desk.goal[None], 20.0, 3), MuJoCoChecker()
    )
    assert res.success and exact.path_valid(res.path)[0]


def test_a_start_or_goal_in_contact_is_named_wherever_it_stands_among_the_ends(desk) -> None:
    """The start and the first goals are checked together: a goal in contact is left
    out, a start in contact or no free goal is named, and goals past the first block
    count too."""
    checker = desk.checker()
    rng = np.random.default_rng(0)
    qs = rng.uniform(checker.lower, checker.upper, (400, checker.d))
    blocked = qs[~checker.valid(qs)][:3]
    planner = PLANNERS["rrt_connect"]()
    goals = np.vstack([blocked[0], desk.goal, blocked[1]])
    res = planner.solve(Problem(desk.start, goals, 5.0, 0), checker)
    assert res.success and np.allclose(res.path[-1], desk.goal)
    assert planner.solve(Problem(blocked[2], goals, 5.0, 0), checker).status == "invalid_start"
    assert planner.solve(Problem(desk.start, blocked, 5.0, 0), checker).status == "invalid_goal"
    many = np.vstack([blocked, blocked, blocked, desk.goal])  # the free goal is the tenth
    res = planner.solve(Problem(desk.start, many, 5.0, 0), checker)
    assert res.success and np.allclose(res.path[-1], desk.goal)


def test_a_goal_inside_a_shelf_takes_fewer_nodes_with_balanced_trees() -> None:
    """The goal tree, boxed in by the shelf, keeps its turns: half the nodes (and checks)
    of OMPL's strict alternation, and every path still free under MuJoCo."""
    from robotrial.planning.problems import scene_problem
    from robotrial.planning.rrt_connect import RRTConnect

    shelf = scene_problem(load_robot("manipulator_h"), "shelf")
    checker, exact = shelf.checker(), None
    nodes = {}
    for label, planner in (
        ("ours", RRTConnect()),
        ("alternating", RRTConnect(balance=False, dynamic_domain=False, unstick=False)),
    ):
        nodes[label] = []
        for seed in range(20):
            res = planner.solve(Problem(shelf.start, shelf.goal[None], 5.0, seed), checker)
            assert res.success
            nodes[label].append(res.stats["nodes"])
            if label == "ours" and seed < 3:
                exact = exact or shelf.exact(checker)
                assert exact.path_valid(res.path)[0]
    assert np.median(nodes["ours"]) <= 0.5 * np.median(nodes["alternating"])


def test_shortcut_keeps_validity_and_shortens(desk) -> None:
    checker = desk.checker()
    res = PLANNERS["rrt"]().solve(Problem(desk.start, desk.goal[None], 5.0, 1), checker)
    short = shortcut(res.path, checker, np.random.default_rng(0))
    assert res.stats["path_length"] >= np.sum(np.linalg.norm(np.diff(short, axis=0), axis=1)) - 1e-9
    assert bool(np.all(checker.motions_valid(short[:-1], short[1:])))


def test_compiled_shortcut_and_rounding_equal_the_numpy_ones(desk) -> None:
    checker = desk.checker()
    for seed in range(3):
        res = PLANNERS["rrt"]().solve(Problem(desk.start, desk.goal[None], 5.0, seed), checker)
        short = shortcut(res.path, checker, np.random.default_rng(seed))
        rounded = round_corners(short, checker)
        fast_short, fast_rounded = shortcut_and_round(
            res.path, checker, np.random.default_rng(seed)
        )
        np.testing.assert_allclose(fast_short, short, atol=1e-12)
        np.testing.assert_allclose(fast_rounded, rounded, atol=1e-12)


# a desk path whose profile came to rest one grid point before the end: the last
# interval then took 2e12 s
STALLING = [
    [-0.785, 0.8, 1.57, 0.0, 0.76, 0.0],
    [-0.66434563, 0.55144892, 0.90104886, 0.77740836, 1.02055083, 0.2127185],
    [-0.37310116, 0.44079338, 0.69879893, 1.0522512, 1.06893685, 0.25746029],
    [0.37997787, 0.35737781, 0.76100027, 1.09937139, 0.95354409, 0.17896716],
    [0.59007733, 0.79253003, 1.15763506, 0.9265254, 0.76417619, 0.05310235],
    [0.66026567, 0.94978049, 1.29996725, 0.86396313, 0.6968411, 0.00836056],
    [0.66073122, 0.98637964, 1.33032901, 0.84912232, 0.68420374, 0.0],
]


def test_compiled_timing_equals_the_reference_and_ends_where_the_profile_stalls() -> None:
    vmax = np.array([3.0, 3.0, 3.0, 4.0, 4.0, 5.0])
    amax = 2 * vmax
    rng = np.random.default_rng(4)
    for path in [np.array(STALLING), *(np.cumsum(rng.normal(0, 0.4, (5, 6)), 0) for _ in range(3))]:
        fast = time_parameterize(path, vmax, amax, period=0.1)
        ref = time_parameterize_reference(path, vmax, amax, period=0.1)
        assert fast.duration < 10.0
        np.testing.assert_allclose(fast.t, ref.t, atol=1e-9)
        np.testing.assert_allclose(fast.q, ref.q, atol=1e-9)
        np.testing.assert_allclose(fast.qd, ref.qd, atol=1e-9)
        assert np.all(np.abs(fast.qd) <= vmax * (1 + 1e-9))
        assert np.all(np.abs(fast.qdd) <= amax * (1 + 1e-9))


def test_a_straight_motion_is_timed_exactly_on_its_line() -> None:
    vmax = np.array([3.0, 3.0, 3.0, 4.0, 4.0, 5.0])
    amax = 2 * vmax
    rng = np.random.default_rng(5)
    for length in (0.05, 4.0):  # a triangle and a trapezoid in the line's parameter
        a = rng.uniform(-1, 1, 6)
        b = a + length * rng.normal(size=6) / np.sqrt(6)
        path = np.array([a, b])
        traj = time_parameterize(path, vmax, amax, period=0.1)
        s = (traj.q - a) @ (b - a) / ((b - a) @ (b - a))
        np.testing.assert_allclose(traj.q, a + s[:, None] * (b - a), atol=1e-12)  # on the line
        assert np.all(np.diff(s) > 0) and s[0] == 0 and s[-1] == pytest.approx(1.0)
        assert np.all(np.abs(traj.qd) <= vmax * (1 + 1e-9))
        assert np.all(np.abs(traj.qdd) <= amax * (1 + 1e-9))
        np.testing.assert_allclose(traj.qd[[0, -1]], 0.0, atol=1e-12)
        # time-optimal: some joint at its acceleration limit; no slower than the spline's
        assert np.max(np.abs(traj.qdd) / amax) == pytest.approx(1.0)
        assert traj.duration <= time_parameterize_reference(path, vmax, amax).duration
        tracked = traj.tracked(0.01)
        s = (tracked - a) @ (b - a) / ((b - a) @ (b - a))
        assert s.min() >= -1e-12 and s.max() <= 1 + 1e-12  # the tracker stays on the segment


def test_validation_hands_the_samples_near_a_contact_to_mujoco(desk) -> None:
    checker = desk.checker()
    exact = desk.exact(checker)
    rng = np.random.default_rng(0)
    qs = desk.kin.random(rng, 400)
    free = qs[checker.valid(qs)]
    through = 0
    for a, b in zip(free[:40:2], free[1:40:2], strict=True):
        path = np.array([a, b])
        screened = exact.path_valid(path, screen=checker)
        # the same verdict and the same first colliding sample as MuJoCo on every sample
        assert screened == exact.path_valid(path)
        through += not screened[0]
    assert through > 0  # some of these motions pass through the desk or obstacle C


def test_time_parameterization_respects_limits() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.5], [1.5, -0.5]])
    vmax, amax = np.array([1.0, 2.0]), np.array([2.0, 3.0])
    traj = time_parameterize(path, vmax, amax)
    assert np.all(np.diff(traj.t) > 0)
    assert np.all(np.abs(traj.qd) <= vmax * 1.02)
    assert np.all(np.abs(traj.qdd) <= amax * 1.05)
    np.testing.assert_allclose(traj.q[0], path[0])
    np.testing.assert_allclose(traj.q[-1], path[-1])
    np.testing.assert_allclose(traj.qd[[0, -1]], 0.0, atol=1e-6)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 8))
def test_compiled_timing_keeps_the_limits_and_is_as_fast_as_toppra(seed, n) -> None:
    from robotrial.benchmarks.planning import _toppra_time

    rng = np.random.default_rng(seed)
    path = np.cumsum(rng.uniform(-1, 1, (n, 6)), axis=0)
    vmax = rng.uniform(0.5, 3.0, 6)
    amax = rng.uniform(1.0, 3.0, 6) * vmax
    traj = time_parameterize(path, vmax, amax)
    assert np.all(np.diff(traj.t) > 0)
    assert np.all(np.abs(traj.qd) <= vmax * (1 + 1e-6))
    assert np.all(np.abs(traj.qdd) <= amax * (1 + 1e-6))
    np.testing.assert_allclose(traj.q[[0, -1]], path[[0, -1]])
    np.testing.assert_allclose(traj.qd[[0, -1]], 0.0, atol=1e-9)
    # near time-optimal under the same limits: 0.94 of toppra's duration on the desk
    # paths, up to 1.035 on random ones (the uniform slow-down that keeps the limits
    # between grid points costs a few per cent on some paths)
    assert traj.duration <= 1.06 * _toppra_time(path, vmax, amax)[1]
    # the tracked curve passes through the samples
    np.testing.assert_allclose(traj.tracked(traj.duration / (len(traj.t) - 1))[-1], path[-1])


def test_plan_task_answers_the_g2rviewer_request(planner) -> None:
    resp, result = answer(planner, _request(), seed=0)
    assert isinstance(resp, PlanTaskResponse)
    assert resp.success, resp.message
    traj = resp.trajectory
    assert traj.joint_names == planner.joint_names
    times = [p.time_from_start.to_sec() for p in traj.points]
    assert times[0] == 0 and np.all(np.diff(times) > 0)
    np.testing.assert_allclose(traj.points[-1].positions, resp.goal_joints)
    np.testing.assert_allclose(traj.points[0].positions, START, atol=1e-9)
    tcp = planner.kin.link_pose(np.array(resp.goal_joints))[:3, 3]
    np.testing.assert_allclose(tcp, [0.18, 0.2, 0.02], atol=1e-3)
    q = np.array([p.positions for p in traj.points])
    assert result.exact is not None and result.exact.path_valid(q)[0]
    qd = np.array([p.velocities for p in traj.points])
    assert np.all(np.abs(qd) <= planner.vmax * 1.02)
    assert resp.planning_time > 0 and resp.error_code == 1 and not resp.object_held
    assert answer(planner, _request(), seed=2)[0].success  # a second plan, another seed


def test_the_answer_is_written_as_the_generic_encoder_writes_it(planner) -> None:
    from robotrial.msgs.core import _encode

    for dialect in ("ros2", "ros1"):
        resp = answer(planner, _request(), seed=0)[0]
        written = json.dumps(resp.to_dict(dialect))  # from the arrays: no point read yet
        assert resp.success and len(resp.trajectory.points) > 2
        assert written == json.dumps(_encode(resp, dialect, False))
    resp.trajectory.points[1].positions[0] += 0.5  # a point read and changed is written so
    assert resp.to_dict()["trajectory"]["points"][1]["positions"][0] == pytest.approx(
        resp.trajectory.points[1].positions[0]
    )
    resp.trajectory.points[1].velocities[0] = float("nan")  # written as null, as before
    assert resp.to_dict()["trajectory"]["points"][1]["velocities"][0] is None
    resp = answer(planner, _request(), seed=0)[0]
    resp.trajectory.timed.qd[1, 0] = float("nan")  # in the arrays, before any point is read
    assert resp.to_dict()["trajectory"]["points"][1]["velocities"][0] is None


def test_the_desk_goal_is_one_the_start_reaches_straight_whatever_the_seed(planner) -> None:
    # the nearest IK solution of the desk request is blocked from the start; the search
    # goes on to free solutions reached in a straight line, from fixed seeds, so every
    # seed plans the same straight motion to the same goal
    answers = [answer(planner, _request(), seed=s)[1] for s in (0, 7)]
    for res in answers:
        assert res.success, res.message
        assert len(res.path) == 2 and "planner_nodes" not in res.stats
        assert res.checker.motion_valid(res.start, res.goal_joints)
    np.testing.assert_array_equal(answers[0].goal_joints, answers[1].goal_joints)


def test_plan_task_carries_an_object_in_the_hand(planner) -> None:
    tcp = planner.kin.link_pose(np.array(START))
    held = tcp.copy()
    held[2, 3] += 0.03  # between the fingers, above the table
    obj = BoxMsg(
        id="cup", size=Vector3(0.03, 0.03, 0.05), pose=Pose.from_pose(GeoPose.from_matrix(held))
    )
    resp, result = answer(planner, _request(obj=obj, goal=(0.18, 0.2, 0.06)), seed=1)
    assert resp.success, resp.message
    assert resp.object_held
    assert resp.error_code == PlanTaskResponse.SUCCESS
    assert "finger_left_link" in result.checker.touch_links
    # the object travels with the hand and stays clear of the box and the table
    q = np.array([p.positions for p in resp.trajectory.points])
    assert result.exact.path_valid(q)[0]


def test_an_object_away_from_the_hand_is_not_held(planner) -> None:
    far = BoxMsg(id="cup", size=Vector3(0.04, 0.04, 0.1), pose=Pose(Point(0.3, -0.3, 0.05)))
    response = answer(planner, _request(obj=far), seed=1)[0]
    assert response.success, response.message
    assert not response.object_held and "treated as an obstacle" in response.message


def test_goal_out_of_reach_says_how_far(planner) -> None:
    resp, _ = answer(planner, _request(goal=(1.0, 0.2, 0.02)))
    assert not resp.success
    assert "out of reach" in resp.message and " m " in resp.message
    assert resp.error_code == PlanTaskResponse.NO_IK_SOLUTION


def test_start_in_collision_names_what_touches(planner) -> None:
    inside = [
        BoxMsg(
            id="crate",
            size=Vector3(0.2, 0.2, 0.2),
            pose=Pose(Point(0.15, -0.15, 0.05), Quaternion()),
        )
    ]
    resp, res = answer(planner, _request(obstacles=inside))
    assert res.failure == "start_in_collision"
    assert resp.error_code == PlanTaskResponse.START_STATE_IN_COLLISION
    assert "crate" in resp.message and "touches" in resp.message


def test_a_start_just_above_a_board_is_planned_from() -> None:
    """The Panda's forearm 8 mm above a board: the first sphere cover calls the start
    touching, the fine covers (asked there) do not, as MuJoCo; the request is planned and
    validated instead of being refused as a start in collision."""
    import trimesh

    from robotrial.benchmarks.planning import panda_path
    from robotrial.planning.task import TaskRequest

    planner = TaskPlanner(load_robot(panda_path()))
    kin = planner.kin
    start = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 1.8, 0.0])
    goal = np.array([0.8, 0.0, 0.0, -1.8, 0.0, 1.8, 0.0])
    link = next(lk for lk in planner.robot.links if lk.name == "panda_link5")
    hull = trimesh.load(link.collisions[0].geometry.filename, force="mesh").convex_hull
    m = kin.fk(start)[kin.link_index["panda_link5"]]
    x, y, z = min(hull.vertices @ m[:3, :3].T + m[:3, 3], key=lambda v: v[2])
    board = ("board", Box((0.06, 0.06, 0.02)), GeoPose((x, y, z - 0.018)))
    env = Environment()
    env.add(*board)
    first = CollisionChecker(planner.spheres, env, fine=False)
    assert first.contacts(start, fine=False) == {("panda_link5", "board")}
    names = list(planner.joint_names)
    request = TaskRequest(start, kin.link_pose(goal)[:3, 3], joint_names=names, obstacles=[board])
    res = planner.plan(request, seed=0)
    assert res.success, res.message
    assert res.checker is not None and "panda_link5" in res.checker.fine_bodies
    assert res.exact is not None and res.exact.path_valid(res.path)[0]


def test_goal_in_collision(planner) -> None:
    resp, res = answer(planner, _request(goal=(0.2, 0.0, 0.15)))
    assert res.failure == "goal_in_collision"
    assert resp.error_code == PlanTaskResponse.GOAL_IN_COLLISION
    assert "C" in resp.message


def test_no_path_within_the_time_limit(planner) -> None:
    # two walls from floor to 1.1 m leave a 10 cm slot around the base's axis and a ceiling
    # at 0.3 m keeps the arm from standing up through it: the start (hand at y < 0) and the
    # goal (hand at y > 0) are both free, and no motion joins them
    gap, length = 0.05, 0.6
    walls = [
        BoxMsg(id=name, size=Vector3(*size), pose=Pose(Point(*xyz), Quaternion()))
        for name, size, xyz in [
            ("front", (length, 0.01, 1.2), (gap + length / 2, 0, 0.5)),
            ("back", (length, 0.01, 1.2), (-gap - length / 2, 0, 0.5)),
            ("ceiling", (1.4, 1.4, 0.01), (0, 0, 0.3)),
        ]
    ]
    answer(planner, _request())  # loads the compiled kernels, as a running server has
    planner.spheres.refine()  # and every fine cover, as `robotrial warm` leaves them
    resp, res = answer(planner, _request(obstacles=walls, time_limit=2.0))
    assert res.failure == "timeout", resp.message
    assert not resp.success
    assert "no path found" in resp.message and "2 s" in resp.message
    assert resp.error_code == PlanTaskResponse.TIMED_OUT


def test_bad_requests_name_the_field(planner) -> None:
    req = _request()
    req.current_joints.position = req.current_joints.position[:3]
    refused = answer(planner, req)[0]
    assert "current_joints" in refused.message
    assert refused.error_code == PlanTaskResponse.INVALID_GOAL_CONSTRAINTS
    req = _request(start=[5.0, 0, 0, 0, 0, 0])
    assert "outside its limits" in answer(planner, req)[0].message
    bad = [BoxMsg(id="x", size=Vector3(-0.1, 0.1, 0.1), pose=Pose())]
    assert "obstacles[0].size" in answer(planner, _request(obstacles=bad))[0].message


@settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(
        st.tuples(
            st.floats(0.03, 0.15),
            st.floats(0.03, 0.15),
            st.floats(0.03, 0.15),
            st.floats(-0.3, 0.3),
            st.floats(-0.3, 0.3),
            st.floats(0.0, 0.3),
            st.floats(-3, 3),
            st.floats(-3, 3),
            st.floats(-3, 3),
        ),
        min_size=1,
        max_size=4,
    ),
    st.integers(0, 10_000),
)
def test_random_obstacles_never_yield_a_colliding_path(desk, boxes, seed) -> None:
    world = load_world("desk")
    env = Environment()
    for ob in world.static_bodies:
        env.add(ob.name, ob.geometry, ob.pose)
    obstacles = []
    for i, (sx, sy, sz, x, y, z, r, p, w) in enumerate(boxes):
        obstacles.append((f"b{i}", Box((sx, sy, sz)), GeoPose.from_xyz_rpy((x, y, z), (r, p, w))))
        env.add(*obstacles[-1])
    checker = CollisionChecker(desk.spheres, env)
    rng = np.random.default_rng(seed)
    qs = desk.kin.random(rng, 100)
    free = qs[checker.valid(qs)]
    assume(len(free) >= 2)
    res = PLANNERS["rrt_connect"]().solve(Problem(free[0], free[1][None], 1.0, seed), checker)
    if res.success:
        assert ExactChecker(checker, world, obstacles).path_valid(res.path)[0]


def test_cli_plan_prints_json_and_writes_plots(tmp_path) -> None:
    # the command as a user runs it: its process ends without the interpreter's teardown,
    # so this checks that the answer and the plot are whole when it has gone
    from robotrial.benchmarks.planning import PLAN_COMMAND

    exe = Path(sys.executable).parent / "robotrial"
    png = tmp_path / "plan.png"
    proc = subprocess.run(
        [str(exe), *PLAN_COMMAND, "--seed", "0", "--json", "--plot", str(png)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    out = json.loads(proc.stdout)
    assert proc.returncode == 0 and out["success"], proc.stderr[-500:]
    assert out["trajectory"]["joint_names"][0] == "joint1"
    assert out["trajectory"]["points"][-1]["time_from_start"]["sec"] >= 0
    assert out["plots"] == [str(png)]
    assert png.read_bytes().endswith(b"IEND\xaeB`\x82")  # the PNG's closing chunk


def test_a_fresh_cli_plan_loads_neither_scipy_linalg_nor_mujoco() -> None:
    # the desk request needs neither: numba's BLAS probe is answered without scipy, and
    # MuJoCo comes in only for a sample the spheres do not clear (none here)
    from robotrial.benchmarks.planning import PLAN_COMMAND

    code = "import sys; from robotrial.cli import main; sys.exit(main())"
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", code, *PLAN_COMMAND, "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0 and json.loads(proc.stdout)["success"], proc.stderr[-500:]
    loaded = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines()}
    assert "numba.np.arraymath" in loaded
    assert "scipy.linalg" not in loaded and "mujoco" not in loaded


def test_cli_plan_reads_a_rosbridge_request(tmp_path, capsys) -> None:
    req = tmp_path / "req.json"
    req.write_text(json.dumps(_request(goal=(1.5, 0, 0)).to_dict()))
    code = main(["plan", "--robot", "desk_arm", "--request", str(req), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and not out["success"] and out["failure"] == "unreachable"


def test_warm_plans_from_a_free_configuration(planner) -> None:
    # a server calls this at start: a plan that stopped before the tree search would
    # leave the first user's request to compile the planner
    result = planner.warm()
    assert result is not None and result.success, result and result.message
    assert len(result.trajectory.t) >= 2


def test_a_goal_whose_nearest_ik_solution_is_blocked_takes_one_reached_straight(
    example_robot_data,
) -> None:
    # The UR3 of example-robot-data asked for a point by its own base: the nearest IK
    # solution sits where no straight motion from this start enters (the search needed
    # seconds, or failed within 10 s); another solution is reached in a straight line
    ur3 = example_robot_data.models[example_robot_data.root / "ur_description/urdf/ur3_robot.urdf"]
    planner = TaskPlanner(ur3, load_world("desk"))
    start = np.array([1.34, 2.88, 0.27, 5.47, 3.97, -6.25])
    goal = planner.kin.link_pose(np.array([2.46, -2.16, -2.04, 2.2, -1.72, -2.14]))[:3, 3]
    from robotrial.planning.task import TaskRequest

    res = planner.plan(TaskRequest(start, goal, joint_names=planner.joint_names), seed=1)
    assert res.success, res.message
    assert len(res.path) == 2 and "planner_nodes" not in res.stats  # no search was needed
    reached = planner.kin.link_pose(res.path[-1])[:3, 3]
    assert np.linalg.norm(reached - goal) < 0.01
