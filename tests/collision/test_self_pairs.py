"""The self-collision matrix (collision/self_pairs.py), found as MoveIt's Setup Assistant
finds it, on an arm nobody here wrote: the UR5 of example-robot-data is free at the
upright pose its users were refused at, lets its forearm pass a wrist a centimetre
away, and stays conservative against MuJoCo."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import CollisionChecker, RobotSpheres
from robotrial.kinematics.chain import Kinematics
from robotrial.model.urdf import urdf_from_string

UPRIGHT = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
# the forearm passes wrist 2 with 1.4 cm between their shapes (MuJoCo's distance)
FOREARM_BY_WRIST = np.array([-3.324, -2.265, 1.884, 0.089, 0.08, -3.315])
# the forearm cuts into wrist 2
FOREARM_IN_WRIST = np.array([0.139, -0.34, -0.919, 2.114, -0.413, 0.772])


@pytest.fixture(scope="module")
def ur5(example_robot_data) -> RobotSpheres:
    model = example_robot_data.models[
        example_robot_data.root / "ur_description/urdf/ur5_robot.urdf"
    ]
    return RobotSpheres(Kinematics(model), samples=1000)


def test_ur5_pairs_left_out_and_why(ur5: RobotSpheres) -> None:
    reasons = ur5.reasons
    assert reasons[("base_link", "shoulder_link")] == "adjacent"
    assert reasons[("wrist_3_link", "ee_link")] == "rigid"
    # the spheres of the base and the upper arm touch wherever the arm is: the model
    # could never tell them apart, so (as the Setup Assistant's "always") it does not try
    assert reasons[("base_link", "upper_arm_link")] == "always"
    assert ("base_link", "forearm_link") not in reasons  # the forearm can hit the base


def test_ur5_upright_is_free_and_the_checks_stay_conservative(ur5: RobotSpheres) -> None:
    checker = CollisionChecker(ur5)
    assert checker.valid(UPRIGHT[None])[0], checker.contacts(UPRIGHT)
    exact = ExactChecker(checker)
    qs = ur5.kin.random(np.random.default_rng(1), 300)
    fast = checker.valid(qs)
    slow = np.array([exact.valid(q) for q in qs])
    assert not np.any(fast & ~slow)
    assert fast.sum() > 0.3 * len(qs)


def _coarse_spheres_touch(spheres: RobotSpheres, q: np.ndarray, a: str, b: str) -> bool:
    poses = spheres.kin.fk(q)
    world = []
    for body in (next(x for x in spheres.bodies if x.name == name) for name in (a, b)):
        m = poses[spheres.kin.link_index[body.link]]
        world.append((body.centres @ m[:3, :3].T + m[:3, 3], body.radii))
    (ca, ra), (cb, rb) = world
    return bool(np.any(np.linalg.norm(ca[:, None] - cb[None], axis=-1) <= ra[:, None] + rb[None]))


def test_ur5_forearm_near_its_wrist_is_free_and_in_it_is_not(ur5: RobotSpheres) -> None:
    """The forearm and wrist 2 pass 1-2 cm apart over a share of the UR5's free space,
    where their coarse spheres already touch: the fine covers decide there, once a
    request starting there has made them (those two links' only)."""
    pair = ("forearm_link", "wrist_2_link")
    assert pair in ur5.close
    assert _coarse_spheres_touch(ur5, FOREARM_BY_WRIST, *pair)
    CollisionChecker(ur5).finer(FOREARM_BY_WRIST)
    assert set(pair) <= ur5.fine_links()
    checker = CollisionChecker(ur5)  # a plain checker asks the close pairs' fine covers
    exact = ExactChecker(checker)
    assert exact.valid(FOREARM_BY_WRIST)
    assert checker.valid(FOREARM_BY_WRIST[None])[0], checker.contacts(FOREARM_BY_WRIST)
    assert not checker.contacts(FOREARM_BY_WRIST)
    assert exact.contacts(FOREARM_IN_WRIST) == [pair]
    assert not checker.valid(FOREARM_IN_WRIST[None])[0]
    assert checker.contacts(FOREARM_IN_WRIST) == {pair}
    # a motion from one to the other is refused, one that stays near the wrist is not
    assert not checker.motion_valid(FOREARM_BY_WRIST, FOREARM_IN_WRIST)
    assert checker.motion_valid(FOREARM_BY_WRIST, FOREARM_BY_WRIST + 0.01)


def test_links_without_shapes_are_looked_through_for_adjacency() -> None:
    """A link between two joints that holds no shape (a wrist's virtual link) leaves its
    neighbours adjacent, as the Setup Assistant counts them."""
    box = '<collision><geometry><box size="0.05 0.05 0.2"/></geometry></collision>'
    joint = (
        '<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/>'
        '<origin xyz="0 0 0.2"/><axis xyz="{a}"/>'
        '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'
    )
    text = (
        '<robot name="wrist"><link name="base">' + box + '</link><link name="virtual"/>'
        '<link name="hand">'
        + box
        + "</link>"
        + joint.format(n="pitch", p="base", c="virtual", a="0 1 0")
        + joint.format(n="roll", p="virtual", c="hand", a="0 0 1")
        + "</robot>"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the virtual link's repaired mass
        model = urdf_from_string(text, "wrist.urdf")
    spheres = RobotSpheres(Kinematics(model), samples=200)
    assert spheres.reasons[("base", "hand")] == "adjacent"
