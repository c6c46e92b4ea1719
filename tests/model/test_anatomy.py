"""A robot's parts found from its tree alone (model/anatomy.py): the tool link, the arm
group and the gripper of arms nobody here described, the wheels of a base; another tool
chosen; a link that cannot be the tool refused by name."""

from __future__ import annotations

import warnings
from pathlib import Path

import pybullet_data
import pytest

from robotrial.model import load_robot
from robotrial.model.anatomy import tool_choices, wheel_joints, with_tool
from robotrial.model.robot import ModelError
from robotrial.model.urdf import urdf_from_string

# file under example-robot-data's robots folder: tool, first and last arm joint, the
# gripper's first joint ("" for none)
ARMS = {
    "ur_description/urdf/ur5_robot.urdf": (
        "tool0",
        "shoulder_pan_joint",
        "wrist_3_joint",
        "",
    ),
    "panda_description/urdf/panda.urdf": (
        "panda_hand_tcp",
        "panda_joint1",
        "panda_joint7",
        "panda_finger_joint1",
    ),
    "kinova_description/robots/kinova.urdf": (
        "j2s6s200_end_effector",
        "j2s6s200_joint_1",
        "j2s6s200_joint_6",
        "",
    ),
    "z1_description/urdf/z1.urdf": ("gripperStator", "joint1", "joint6", "jointGripper"),
    "so_arm_description/urdf/so100.urdf": ("gripper", "shoulder_pan", "wrist_roll", "gripper"),
    "pr2_description/urdf/pr2.urdf": (
        "r_gripper_tool_frame",
        "torso_lift_joint",
        "r_wrist_roll_joint",
        "r_gripper_l_finger_joint",
    ),
}


def _load(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_robot(path)


@pytest.mark.parametrize("rel", sorted(ARMS))
def test_tool_arm_and_gripper_found_in_the_tree(example_robot_data, rel: str) -> None:
    model = example_robot_data.models[example_robot_data.root / rel]
    tool, first, last, finger = ARMS[rel]
    arm = model.metadata["groups"]["arm"]
    assert (model.tcp, model.end_effector, arm[0], arm[-1]) == (tool, tool, first, last)
    grip = model.metadata.get("gripper")
    assert (grip["joints"][0] if grip else "") == finger
    assert finger not in arm


def test_another_tool_makes_the_arm_the_chain_that_moves_it(example_robot_data) -> None:
    model = example_robot_data.models[
        example_robot_data.root / "ur_description/urdf/ur5_robot.urdf"
    ]
    assert tool_choices(model)[0] == "tool0"
    elbow = with_tool(model, "forearm_link")
    assert elbow.tcp == "forearm_link"
    assert elbow.metadata["groups"]["arm"] == [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
    ]
    with pytest.raises(ModelError, match="'base_link' is not moved by an arm; choose one of: "):
        with_tool(model, "base_link")
    with pytest.raises(ModelError, match="'nose' is not a link of the robot"):
        with_tool(model, "nose")


def test_a_description_that_names_its_tool_keeps_it() -> None:
    desk = load_robot("desk_arm")
    assert desk.tcp == "tcp" and desk.metadata["groups"]["arm"][0] == "joint1"
    text = Path(desk.source).read_text()
    bare = urdf_from_string(text[: text.index("<robotrial>")] + "</robot>", "bare.urdf")
    assert bare.tcp == "tcp"  # named like a tool frame, fixed to the last arm link


def test_wheels_of_a_base_nobody_described() -> None:
    husky = _load(Path(pybullet_data.getDataPath()) / "husky" / "husky.urdf")
    assert len(wheel_joints(husky)) == 4
    assert husky.tcp == ""  # no arm: no tool invented
    r2d2 = _load(Path(pybullet_data.getDataPath()) / "r2d2.urdf")
    assert "head_swivel" not in wheel_joints(r2d2)  # turns about a vertical axis
