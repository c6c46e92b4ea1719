"""The sphere model: covers shapes, agrees with MuJoCo conservatively, explains contacts."""

from __future__ import annotations

import copy
from collections import OrderedDict

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import CollisionChecker, Environment, HeldObject, RobotSpheres
from robotrial.geometry import Box, Cylinder, Pose, Sphere
from robotrial.kinematics.chain import Kinematics
from robotrial.model import load_robot, load_world


@pytest.fixture(scope="module")
def desk_arm():
    robot = load_robot("desk_arm")
    kin = Kinematics(robot)
    return robot, RobotSpheres(kin)


def _covered(points: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> bool:
    d = np.linalg.norm(points[:, None] - centres[None], axis=-1)
    return bool(np.all(np.any(d <= radii[None] + 1e-9, axis=1)))


def test_self_collision_pairs_disable_adjacent_links(desk_arm) -> None:
    _, spheres = desk_arm
    reasons = spheres.reasons
    assert reasons[("link1", "link2")] == "adjacent"
    assert reasons[("link6", "gripper_base")] == "rigid"
    # fingers are not planning joints: they are rigid with the hand
    assert reasons[("gripper_base", "finger_left_link")] == "rigid"
    names = [b.name for b in spheres.bodies]
    assert ("link2", "gripper_base") not in spheres.disabled
    assert "tcp" not in names  # a link without collision shapes has no spheres


def _desk_env(obstacles):
    world = load_world("desk")
    env = Environment()
    for ob in world.static_bodies:
        env.add(ob.name, ob.geometry, ob.pose)
    for name, shape, pose in obstacles:
        env.add(name, shape, pose)
    return world, env


def test_spheres_are_conservative_against_mujoco(desk_arm) -> None:
    """A configuration the spheres call free is free for MuJoCo's exact shapes too."""
    _, spheres = desk_arm
    obstacles = [
        ("C", Box((0.1, 0.1, 0.2)), Pose((0.2, 0.0, 0.15))),
        ("tilted", Box((0.2, 0.03, 0.1)), Pose.from_xyz_rpy((-0.1, 0.2, 0.1), (0.3, 0.5, 0.7))),
        ("pipe", Cylinder(0.03, 0.4), Pose.from_xyz_rpy((0.0, -0.25, 0.2), (1.2, 0.0, 0.4))),
        ("ball", Sphere(0.05), Pose((-0.2, -0.1, 0.25))),
    ]
    world, env = _desk_env(obstacles)
    checker = CollisionChecker(spheres, env)
    exact = ExactChecker(checker, world, obstacles)
    qs = checker.kin.random(np.random.default_rng(0), 1500)
    fast = checker.valid(qs)
    slow = np.array([exact.valid(q) for q in qs])
    assert not np.any(fast & ~slow)
    # and not hopelessly conservative
    assert fast.sum() > 0.7 * slow.sum()


def test_contacts_name_links_and_obstacles(desk_arm) -> None:
    _, spheres = desk_arm
    _, env = _desk_env([("C", Box((0.1, 0.1, 0.2)), Pose((0.2, 0.0, 0.15)))])
    checker = CollisionChecker(spheres, env)
    # leaning forward into the box
    q = np.array([0.0, 1.0, 0.6, 0.0, 0.5, 0.0])
    assert not checker.valid(q[None])[0]
    hits = checker.contacts(q)
    assert any(b == "C" for _, b in hits)
    assert checker.valid(np.zeros((1, 6)))[0]


def test_padding_and_held_object(desk_arm) -> None:
    _, spheres = desk_arm
    _, env = _desk_env([])
    kin = spheres.kin
    q = np.array([0.0, 0.9, 1.2, 0.0, 1.0, 0.0])
    tcp_z = kin.link_pose(q)[2, 3]
    checker = CollisionChecker(spheres, env)
    assert checker.valid(q[None])[0]
    # padding larger than the hand's height over the table makes the same pose collide
    assert not CollisionChecker(spheres, env, padding=tcp_z + 0.05).valid(q[None])[0]
    # a long box held in the hand reaches down into the table
    held = HeldObject(Box((0.02, 0.02, 2 * tcp_z + 0.1)), np.eye(4), "tcp")
    holding = CollisionChecker(spheres, env, held=held, held_touch_at=q)
    assert not holding.valid(q[None])[0]
    assert "finger_left_link" in holding.touch_links
    assert ("object", "table_top") in holding.contacts(q)


@settings(max_examples=25, deadline=None)
@given(
    st.floats(-0.3, 0.3),
    st.floats(-0.3, 0.3),
    st.floats(0.0, 0.4),
    st.floats(-3, 3),
    st.floats(-3, 3),
    st.floats(-3, 3),
)
def test_compiled_check_matches_numpy_contacts(x, y, z, r, p, w) -> None:
    """The compiled check and the plain numpy explanation agree, for any box pose."""
    robot = load_robot("desk_arm")
    spheres = _shared_spheres(robot)
    env = Environment()
    env.add("b", Box((0.1, 0.2, 0.05)), Pose.from_xyz_rpy((x, y, z), (r, p, w)))
    env.add("c", Cylinder(0.04, 0.3), Pose.from_xyz_rpy((-x, y, z), (p, w, r)))
    checker = CollisionChecker(spheres, env)
    qs = spheres.kin.random(np.random.default_rng(0), 60)
    fast = checker.valid(qs)
    slow = np.array([not checker.contacts(q) for q in qs])
    np.testing.assert_array_equal(fast, slow)


_SPHERES: dict[str, RobotSpheres] = {}


def _shared_spheres(robot) -> RobotSpheres:
    if robot.name not in _SPHERES:
        _SPHERES[robot.name] = RobotSpheres(Kinematics(robot))
    return _SPHERES[robot.name]


def test_a_board_the_mesh_clears_by_a_centimetre_is_not_a_contact() -> None:
    """The Panda's forearm (link 5) 8 mm above a board: its coarse spheres reach the
    board, the mesh does not (MuJoCo); the checker on the fine covers calls the
    configuration free and plans from it, with only the links touching there given their
    fine covers when asked at that configuration. 2 mm into the board it is a contact for
    both."""
    import trimesh

    from robotrial.benchmarks.planning import panda_path
    from robotrial.collision.spheres import link_spheres
    from robotrial.planning.base import Problem
    from robotrial.planning.rrt_connect import RRTConnect

    panda = load_robot(panda_path())
    kin = Kinematics(panda)
    spheres = RobotSpheres(kin, samples=500)
    coarse_only = RobotSpheres(kin, link_spheres(panda), samples=500)
    link = next(lk for lk in panda.links if lk.name == "panda_link5")
    hull = trimesh.load(link.collisions[0].geometry.filename, force="mesh").convex_hull
    q = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 1.8, 0.0])
    goal = np.array([0.8, 0.0, 0.0, -1.8, 0.0, 1.8, 0.0])
    m = kin.fk(q)[kin.link_index["panda_link5"]]
    world = hull.vertices @ m[:3, :3].T + m[:3, 3]
    low = world[np.argmin(world[:, 2])]
    for clearance, free in ((0.008, True), (-0.002, False)):
        board = (
            "board",
            Box((0.06, 0.06, 0.02)),
            Pose((low[0], low[1], low[2] - clearance - 0.01)),
        )
        env = Environment()
        env.add(*board)
        # asked at q, only the links touching there get fine covers (before the others)
        at_q = CollisionChecker(spheres, env, fine=False).finer(q)
        assert at_q is not None and bool(at_q.valid(q)[0]) == free
        if free:
            assert "panda_link5" in spheres.fine_links()
            assert len(spheres.fine_links()) < len(spheres.bodies)
        checker = CollisionChecker(spheres, env, fine=False)
        finer = checker.finer()
        assert finer is not None and finer.fine and finer.finer() is finer
        assert ExactChecker(checker, None, [board]).valid(q) == free
        # the first cover reaches the board either way
        assert not CollisionChecker(coarse_only, env).valid(q)[0]
        assert checker.contacts(q, fine=False) == {("panda_link5", "board")}
        assert bool(finer.valid(q)[0]) == free
        assert (finer.contacts(q) == set()) == free
        # once the robot's fine covers are made, a checker asks them by default
        assert CollisionChecker(spheres, env).fine
        res = RRTConnect().solve(Problem(q, goal[None], 2.0, 0), finer)
        assert res.status == ("solved" if free else "invalid_start")
        if free:
            assert ExactChecker(finer, None, [board]).path_valid(res.path)[0]
        assert CollisionChecker(coarse_only, env).finer() is None


def test_a_post_the_first_link_sweeps_into_is_a_wall_no_goal_past_it_is_reached(desk_arm) -> None:
    """A post where the first link (moved by joint 1 alone; here one sphere on a 15 cm
    lever) passes at joint 1 = 1.5 rad: the checker names the joint range it blocks,
    and configurations on the far side of it are past the wall, those on the near side
    are not."""
    from robotrial.model.robot import CollisionSphere

    kin = desk_arm[1].kin
    lever = [CollisionSphere("link1", (0.15, 0.0, 0.05), 0.03)]
    spheres = RobotSpheres(kin, lever, samples=100, fine=lever)
    q = np.clip(np.zeros(kin.d), kin.lower, kin.upper)
    q[0] = 1.5
    m = kin.fk(q)[kin.link_index["link1"]]
    post = m[:3, :3] @ np.array([0.15, 0.0, 0.05]) + m[:3, 3]
    env = Environment()
    env.add("post", Box((0.03, 0.03, 0.03)), Pose(tuple(map(float, post))))
    checker = CollisionChecker(spheres, env)
    (wall,) = checker.walls()
    assert wall.joint == 0 and wall.obstacle == "post" and wall.body == "link1"
    assert 1.0 < wall.low < 1.5 < wall.high < 2.0
    near, past = q.copy(), q.copy()
    near[0], past[0] = 0.0, 2.5
    assert list(checker.beyond_walls(near, np.stack([near, past]))) == [False, True]
    assert CollisionChecker(spheres, Environment()).walls() == []


def test_a_box_by_a_link_one_joint_moves_finds_its_wall_without_making_a_cover(
    desk_arm,
) -> None:
    """The fine cover of a link one planning joint moves (the desk arm's first) is made
    with the robot: a request whose box comes near that link finds the wall there
    without making a cover (0.1-0.3 s a link, past a later plan's time). Its sweeps,
    placed with the robot too, find the walls that sweeps placed on demand find."""
    spheres = desk_arm[1]
    kin = spheres.kin
    assert "link1" in spheres.fine_links()
    made = spheres.fine_links()
    q = np.clip(np.zeros(kin.d), kin.lower, kin.upper)
    q[0] = 1.5
    fine = spheres.fine_body("link1")
    m = kin.fk(q)[kin.link_index["link1"]]
    post = m[:3, :3] @ fine.centres[np.argmax(fine.radii)] + m[:3, 3]
    env = Environment()
    env.add("post", Box((0.03, 0.03, 0.03)), Pose(tuple(map(float, post))))
    walls = CollisionChecker(spheres, env).walls()
    assert any(w.joint == 0 and w.obstacle == "post" and w.low < 1.5 < w.high for w in walls)
    assert spheres.fine_links() == made
    on_demand = copy.copy(spheres)
    on_demand._memo, on_demand._shapes = {}, OrderedDict()
    assert CollisionChecker(on_demand, env).walls() == walls


def test_a_wall_only_the_spheres_bulge_makes_is_told_from_one_the_link_makes(desk_arm) -> None:
    """A board over the first link's top (its cross cylinder, 3 cm round at 7 cm) at
    every turn of joint 1. A little above it, only the fine spheres' bulge reaches in:
    the wall it makes is not sure (the link passes without touching). Pushed 3 mm into
    the link, the wall is sure."""
    spheres = desk_arm[1]
    kin = spheres.kin
    link = next(b for b in spheres.bodies if b.name == "link1")
    top = 0.10  # the cross cylinder's top, in link 1's frame
    reach = float(np.max(link.fine_centres[:, 2] + link.fine_radii)) - top
    assert reach > 0.002
    q = np.clip(np.zeros(kin.d), kin.lower, kin.upper)
    m = kin.fk(q)[kin.link_index["link1"]]

    def walls(gap: float) -> list:
        centre = m[:3, :3] @ np.array([0.0, 0.0, top + gap + 0.005]) + m[:3, 3]
        env = Environment()
        env.add("board", Box((0.1, 0.1, 0.01)), Pose(tuple(map(float, centre))))
        return [w for w in CollisionChecker(spheres, env).walls() if w.body == "link1"]

    above = walls(reach / 3)  # the fine spheres reach 2/3 of their bulge into the board
    assert above and not any(w.sure for w in above)
    assert all(reach <= w.bulge + 1e-9 for w in above)
    into = walls(-0.003)
    assert into and all(w.sure for w in into)


def test_what_a_robot_keeps_per_obstacle_follows_each_scene(desk_arm) -> None:
    """A robot keeps what its sweeps found per obstacle (so that a request's checker
    measures only its new boxes): a post moved to the other side of joint 1 gets its own
    wall, and each scene's checker answers as one of a robot that kept nothing."""
    from robotrial.model.robot import CollisionSphere

    kin = desk_arm[1].kin
    lever = [CollisionSphere("link1", (0.15, 0.0, 0.05), 0.03)]
    spheres = RobotSpheres(kin, lever, samples=100, fine=lever)
    q = np.clip(np.zeros(kin.d), kin.lower, kin.upper)

    def scene(angle: float) -> Environment:
        q[0] = angle
        m = kin.fk(q)[kin.link_index["link1"]]
        post = m[:3, :3] @ np.array([0.15, 0.0, 0.05]) + m[:3, 3]
        env = Environment()
        env.add("post", Box((0.03, 0.03, 0.03)), Pose(tuple(map(float, post))))
        env.add("far", Box((0.1, 0.1, 0.1)), Pose((0.0, 0.0, 0.6)))
        return env

    walls = []
    for angle in (1.5, -1.5, 1.5):
        env = scene(angle)
        kept = CollisionChecker(spheres, env)
        fresh = CollisionChecker(RobotSpheres(kin, lever, samples=100, fine=lever), env)
        assert kept.walls() == fresh.walls()
        assert np.array_equal(kept.never_touching, fresh.never_touching)
        (wall,) = kept.walls()
        walls.append(wall)
    assert walls[0] == walls[2] and walls[1].high < -1.0 < 1.0 < walls[0].low


def test_a_link_two_joints_move_into_a_fixed_link_whatever_the_first_does_is_a_wall(
    desk_arm,
) -> None:
    """A sphere on link 2 (moved by joints 1 and 2) swings into a large sphere on the
    fixed base when joint 2 tips it past about 1.1 rad either way, whatever joint 1's
    yaw: both ends of joint 2's range are walls of the base, and a configuration there
    is past them."""
    from robotrial.model.robot import CollisionSphere

    kin = desk_arm[1].kin
    shapes = [
        CollisionSphere("base_link", (0.0, 0.0, -0.05), 0.28),
        CollisionSphere("link1", (0.0, 0.0, 0.03), 0.01),  # so that link2 is not adjacent
        CollisionSphere("link2", (0.0, 0.0, 0.16), 0.02),
    ]
    spheres = RobotSpheres(kin, shapes, samples=300, fine=shapes)
    # the desk arm's meshes never meet there (the matrix leaves the pair out); these
    # spheres stand for links that do
    spheres.disabled.discard(("base_link", "link2"))
    checker = CollisionChecker(spheres)
    low, high = sorted(checker.walls(), key=lambda w: w.low)
    for wall in (low, high):
        assert (wall.joint, wall.body, wall.obstacle) == (1, "link2", "base_link")
    assert low.low == kin.lower[1] and -1.5 < low.high < -0.9
    assert 0.9 < high.low < 1.5 and high.high == kin.upper[1]
    q = np.clip(np.zeros(kin.d), kin.lower, kin.upper)
    past = q.copy()
    past[1] = 1.88
    assert list(checker.beyond_walls(q, np.stack([q, past]))) == [False, True]


def test_check_answers_do_not_depend_on_what_earlier_checks_learnt(desk_arm) -> None:
    """A checker learns which items, and which spheres of a body, touched last, and
    starts there: the same motions asked after others (in the reverse order, on a fresh
    checker) get the same answers, and so do configurations."""
    _, spheres = desk_arm
    _, env = _desk_env([("post", Cylinder(0.04, 0.4), Pose.from_xyz_rpy((0.2, 0.0, 0.2)))])
    env.add("block", Box((0.1, 0.1, 0.1)), Pose.from_xyz_rpy((0.0, 0.2, 0.1), (0.3, 0.0, 0.5)))
    rng = np.random.default_rng(3)
    kin = spheres.kin
    a, b = kin.random(rng, 150), kin.random(rng, 150)
    first = CollisionChecker(spheres, env, fine=True)
    a = a[first.valid(a)]
    b = b[: len(a)]
    once = first.motions_valid(a, b)
    learnt = CollisionChecker(spheres, env, fine=True)
    learnt.motions_valid(a[::-1], b[::-1])
    assert 0 < once.sum() < len(once)  # both kinds of answer are asked
    np.testing.assert_array_equal(learnt.motions_valid(a, b), once)
    np.testing.assert_array_equal(learnt.valid(b), first.valid(b))
