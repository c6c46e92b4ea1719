"""MotionBenchMaker's problem files: a MoveIt scene and request in MBM's format become a
Panda problem that our planner solves and MuJoCo validates; the real set from PyPI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robotrial.benchmarks import mbm
from robotrial.benchmarks.planning import panda_path
from robotrial.geometry import Box, Cylinder
from robotrial.model import load_robot

JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
START = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
GOAL = [1.2, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785]

SCENE = """\
robot_state:
  joint_state:
    position: [0, 0, 0, 0, 0, 0, 0, 0, 0]
    name: [panda_joint1, panda_joint2, panda_joint3, panda_joint4, panda_joint5,
           panda_joint6, panda_joint7, panda_finger_joint1, panda_finger_joint2]
world:
  collision_objects:
    - id: table
      primitive_poses:
        - position: [0.5, 0.0, -0.3]
          orientation: [0, 0, 0, 1]
      primitives:
        - type: box
          dimensions: [0.6, 1.2, 0.04]
    - id: post
      primitive_poses:
        - position: [0.45, 0.35, 0.25]
          orientation: [0, 0, 0.3826834, 0.9238795]
      primitives:
        - type: cylinder
          dimensions: [0.5, 0.05]
"""


def request(start=START, goal=GOAL) -> str:
    constraints = "\n".join(
        f"      - joint_name: {name}\n        position: {value}"
        for name, value in zip(JOINTS, goal, strict=True)
    )
    names = ", ".join([*JOINTS, "panda_finger_joint1", "panda_finger_joint2"])
    return f"""\
start_state:
  joint_state:
    position: {[*start, 0.065, 0.065]}
    name: [{names}]
goal_constraints:
  - joint_constraints:
{constraints}
group_name: panda_arm
"""


@pytest.fixture(scope="module")
def panda():
    return load_robot(panda_path())


def write_scene(folder: Path, req: str) -> Path:
    scene = folder / "box_panda"
    scene.mkdir(parents=True)
    (scene / "scene0001.yaml").write_text(SCENE)
    (scene / "request0001.yaml").write_text(req)
    return folder


def test_a_scene_and_request_become_a_problem_we_solve(tmp_path, panda) -> None:
    obstacles = mbm.read_scene(write_scene(tmp_path, request()) / "box_panda" / "scene0001.yaml")
    (_, table, table_pose), (_, post, post_pose) = obstacles
    assert table == Box((0.6, 1.2, 0.04)) and table_pose.xyz == (0.5, 0.0, -0.3)
    assert post == Cylinder(radius=0.05, length=0.5)  # MoveIt gives height, radius
    assert post_pose.yaw == pytest.approx(np.pi / 4, abs=1e-6)

    (prob,) = mbm.problems(tmp_path, "box", 1, panda)
    np.testing.assert_allclose(prob.start, START)
    np.testing.assert_allclose(prob.goal, GOAL)
    result = mbm.run_scene([prob], time_limit=5.0, ompl=True)
    assert result["ours"]["solved"] == 1 and result["ompl"]["solved"] == 1
    assert result["alternating"]["solved"] == 1  # OMPL's algorithm on our checks
    assert result["ours_colliding"] == 0 and result["ompl_colliding"] == 0
    assert result["rows"][0]["valid_ends_mujoco"]


def test_a_request_without_a_goal_for_a_joint_names_the_file(tmp_path, panda) -> None:
    folder = write_scene(tmp_path, request().replace("joint_name: panda_joint7", "joint_name: x"))
    with pytest.raises(mbm.MbmError, match=r"request0001\.yaml.*panda_joint7"):
        mbm.problems(folder, "box", 1, panda)


def test_an_unknown_primitive_names_the_object(tmp_path) -> None:
    (tmp_path / "s.yaml").write_text(SCENE.replace("type: cylinder", "type: cone"))
    with pytest.raises(mbm.MbmError, match=r"post.*'cone'"):
        mbm.read_scene(tmp_path / "s.yaml")


@pytest.fixture(scope="module")
def published() -> Path:
    """The real set's folder, which `make test` downloads from PyPI into the cache before
    the tests run (the tests stay off the network)."""
    folder = mbm.cache_dir() / "problems"
    if not (folder / "box_panda").is_dir():
        pytest.fail(f"MotionBenchMaker's problems are not in {folder}: `make test` fetches them")
    return folder


def test_the_published_set(panda, published) -> None:
    """The first cage problem of the real set is solved without a colliding path, timed
    back to back and cold."""
    probs = mbm.problems(published, "cage", 1, panda)
    result = mbm.run_scene(probs, time_limit=5.0, ompl=False)
    assert result["ours"]["solved"] == 1 and result["ours_colliding"] == 0
    assert result["ours_cold_cpu"]["solved"] == 1


def test_a_finger_grazing_a_box_between_check_points_is_refused(panda, published) -> None:
    """table_pick's third problem: a motion whose right finger passes through the box
    over 2 % of its length, between two points a resolution step apart that are both
    free. The motion check refuses it, as dense sampling of the same spheres does (MuJoCo's
    hulls of the finger meshes graze it or not depending on how the meshes were read)."""
    prob = mbm.problems(published, "table_pick", 3, panda)[2]
    checker = prob.checker()
    a = np.array(
        [0.0619586, -0.09859873, -0.07450758, -1.76485943, -0.83649102, 2.05172185, 0.46612469]
    )
    b = np.array(
        [-0.31905377, 0.05693607, -0.58054562, -1.18823641, -0.6514377, 2.34821334, 0.74174626]
    )
    t = np.linspace(0.0, 1.0, 1001)[:, None]
    assert checker.valid(a[None])[0] and checker.valid(b[None])[0]
    assert not checker.valid(a + t * (b - a)).all()
    assert not checker.motion_valid(a, b)


def test_a_tree_boxed_in_a_shelf_gets_out_in_a_quarter_of_the_iterations(panda, published) -> None:
    """bookshelf_tall's second problem: the trees stay at a few nodes for thousands of
    iterations, nearly every sample refused by a node's domain or its extension running
    into a board. Drawing refused samples near the tree and adapting each node's step
    frees it in a quarter of the iterations or fewer (seeds 0-6: 2,865 against 12,902);
    the paths stay free under MuJoCo."""
    from robotrial.planning.base import Problem
    from robotrial.planning.rrt_connect import RRTConnect

    prob = mbm.problems(published, "bookshelf_tall", 2, panda)[1]
    checker = prob.checker()
    exact = prob.exact(checker)
    iterations = {}
    for unstick in (True, False):
        planner = RRTConnect(unstick=unstick)
        runs = [
            planner.solve(Problem(prob.start, prob.goal[None], 10.0, s), checker) for s in range(7)
        ]
        assert all(r.success for r in runs)
        assert all(exact.path_valid(r.path)[0] for r in runs)
        iterations[unstick] = np.median([r.stats["iterations"] for r in runs])
    assert iterations[True] <= 0.25 * iterations[False], iterations
