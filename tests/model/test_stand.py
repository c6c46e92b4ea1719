"""Where a robot stands (model/stand.py): a robot whose legs reach below the desk's floor
stands on the floor, back from the table, alike in the simulator's MJCF and the
planner's world; an arm on the table top stays where the spawn says."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from robotrial.model import load_robot, load_world
from robotrial.model.mjcf import to_mjcf
from robotrial.model.stand import seen_from, stand
from robotrial.model.urdf import urdf_from_string

# a pelvis with a 1 m leg under it and an arm of two links above: a humanoid's build
TALL = """<robot name="tall">
  <link name="pelvis"><collision><geometry><box size="0.2 0.3 0.1"/></geometry></collision></link>
  <link name="leg"><collision><origin xyz="0 0 -0.5"/>
    <geometry><box size="0.15 0.2 1.0"/></geometry></collision></link>
  <joint name="hip" type="fixed"><parent link="pelvis"/><child link="leg"/></joint>
  <link name="upper"><collision><origin xyz="0.15 0 0"/>
    <geometry><box size="0.3 0.05 0.05"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="pelvis"/><child link="upper"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <link name="hand"><collision><origin xyz="0.1 0 0"/>
    <geometry><box size="0.2 0.05 0.05"/></geometry></collision></link>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="hand"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
</robot>"""


@pytest.fixture(scope="module")
def desk():
    return load_world("desk")


@pytest.fixture(scope="module")
def tall():
    return urdf_from_string(TALL)


def test_a_robot_with_legs_stands_on_the_floor_back_from_the_table(tall, desk) -> None:
    pose = stand(tall, desk)
    # the leg's foot (1 m under the pelvis) rests on the floor, 0.75 m under the top
    assert pose.xyz[2] == pytest.approx(1.0 - 0.75)
    # the leg (0.15 m deep) clears the table's near edge (x -0.35), and not by far
    assert -0.35 - 0.075 - 0.08 < pose.xyz[0] < -0.35 - 0.075


def test_an_arm_on_the_table_stays_at_the_spawn(desk) -> None:
    assert stand(load_robot("desk_arm"), desk).is_identity()


def test_simulator_and_planner_place_it_alike(tall, desk) -> None:
    pose = stand(tall, desk)
    mjcf = to_mjcf(tall, desk, actuators="none")
    model = mjcf.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pelvis = data.body("pelvis").xpos
    assert np.allclose(pelvis, pose.xyz, atol=1e-9)
    # the planner works in the pelvis's frame (TaskPlanner's world is this): the table
    # top is below it, in front
    seen = seen_from(desk, pose)
    top = seen.body("table_top").pose.xyz
    assert top == pytest.approx((0.15 - pose.xyz[0], 0.0, -0.02 - pose.xyz[2]))
    assert seen.floor.height == pytest.approx(-0.75 - pose.xyz[2])
