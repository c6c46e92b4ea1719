"""The self-collision matrix (collision/self_pairs.py), found as MoveIt's Setup Assistant
finds it, on an arm nobody here wrote: the UR5 of example-robot-data is free at the
upright pose its users were refused at, and stays conservative against MuJoCo."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import CollisionChecker, RobotSpheres
from robotrial.kinematics.chain import Kinematics
from robotrial.model.urdf import urdf_from_string

UPRIGHT = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])


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
