"""A small robot in a box room, written by hand for the simulator's tests.

The RobotModel and the MJCF follow the naming of docs (docs/robots.md): bodies named as
links, a planar base (base_x, base_y, base_yaw), a site per sensor, `object/NAME` bodies.
Room interior: x in [-3.89, 3.89], y in [-3.81, 3.81] (7.78 x 7.62 m, room A's size).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from robotrial.geometry import Box, Pose
from robotrial.model.robot import (
    Collision,
    Inertial,
    Joint,
    JointLimit,
    Link,
    RobotModel,
    Sensor,
)
from robotrial.sim.build import prepare
from robotrial.sim.scene import SimWorld
from robotrial.sim.simulation import SimOptions, Simulation

HALF_X, HALF_Y = 3.89, 3.81
LIDAR_HEIGHT = 0.7  # floor to lidar


def _link(name: str, mass: float = 0.0, size=(0.1, 0.1, 0.1)) -> Link:
    if mass <= 0:
        return Link(name)
    return Link(
        name,
        inertial=Inertial(mass, ixx=mass * 0.01, iyy=mass * 0.01, izz=mass * 0.01),
        collisions=(Collision(Box(size)),),
    )


def robot_model(lidar_params: dict | None = None) -> RobotModel:
    params = {
        "rings": 16,
        "vertical_min": np.deg2rad(-15),
        "vertical_max": np.deg2rad(15),
        "horizontal_resolution": np.deg2rad(0.4),
        "range_min": 0.3,
        "range_max": 100.0,
        "noise": 0.0,
    }
    params.update(lidar_params or {})
    rev = JointLimit(-3.0, 3.0, 200.0, 2.0)
    return RobotModel(
        name="boxbot",
        links=(
            _link("base_footprint"),
            _link("base_link", 40.0, (0.8, 0.5, 0.2)),
            _link("wheel_left", 1.0),
            _link("wheel_right", 1.0),
            _link("lidar_link"),
            _link("link1", 2.0),
            _link("link2", 1.5),
            _link("hand"),
        ),
        joints=(
            Joint("base_joint", "fixed", "base_footprint", "base_link", Pose((0, 0, 0.2))),
            Joint(
                "wheel_left_joint",
                "continuous",
                "base_link",
                "wheel_left",
                Pose((0, 0.3, 0)),
                (0, 1, 0),
            ),
            Joint(
                "wheel_right_joint",
                "continuous",
                "base_link",
                "wheel_right",
                Pose((0, -0.3, 0)),
                (0, 1, 0),
            ),
            Joint(
                "lidar_joint",
                "fixed",
                "base_link",
                "lidar_link",
                Pose((0.2, 0, LIDAR_HEIGHT - 0.2)),
            ),
            Joint("j1", "revolute", "base_link", "link1", Pose((-0.1, 0, 0.1)), (0, 0, 1), rev),
            Joint("j2", "revolute", "link1", "link2", Pose((0, 0, 0.3)), (0, 1, 0), rev),
            Joint("hand_joint", "fixed", "link2", "hand", Pose((0.3, 0, 0))),
        ),
        sensors=(
            Sensor("lidar", "lidar", "lidar_link", Pose(), 10.0, params),
            Sensor("imu", "imu", "base_link", Pose((0, 0, 0.05)), 100.0, {}),
        ),
        tcp="hand",
        metadata={
            "drive": {"max_speed": 1.0, "max_accel": 1.0, "max_yaw_rate": 2.0, "wheel_radius": 0.1},
            "groups": {"base": ["wheel_left_joint", "wheel_right_joint"]},
            "gripper": {"joints": [], "link": "hand"},
        },
    )


MJCF = f"""
<mujoco model="boxroom">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="0.002"/>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="5 5 0.1" rgba=".8 .8 .8 1"/>
    <geom name="wall/north" type="box" pos="0 {HALF_Y + 0.05} 1" size="4.1 0.05 1"/>
    <geom name="wall/south" type="box" pos="0 {-HALF_Y - 0.05} 1" size="4.1 0.05 1"/>
    <geom name="wall/east" type="box" pos="{HALF_X + 0.05} 0 1" size="0.05 4.1 1"/>
    <geom name="wall/west" type="box" pos="{-HALF_X - 0.05} 0 1" size="0.05 4.1 1"/>
    <body name="base_footprint">
      <joint name="base_x" type="slide" axis="1 0 0"/>
      <joint name="base_y" type="slide" axis="0 1 0"/>
      <joint name="base_yaw" type="hinge" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="0.1" diaginertia="0.001 0.001 0.001"/>
      <body name="base_link" pos="0 0 0.2">
        <geom type="box" size="0.4 0.25 0.1" mass="40"/>
        <site name="imu" pos="0 0 0.05"/>
        <body name="wheel_left" pos="0 0.3 0">
          <joint name="wheel_left_joint" type="hinge" axis="0 1 0"/>
          <geom type="cylinder" size="0.1 0.03" euler="1.5708 0 0" mass="1"/>
        </body>
        <body name="wheel_right" pos="0 -0.3 0">
          <joint name="wheel_right_joint" type="hinge" axis="0 1 0"/>
          <geom type="cylinder" size="0.1 0.03" euler="1.5708 0 0" mass="1"/>
        </body>
        <body name="lidar_link" pos="0.2 0 {LIDAR_HEIGHT - 0.2}">
          <site name="lidar"/>
          <geom type="cylinder" size="0.05 0.04" mass="0.5"/>
        </body>
        <body name="link1" pos="-0.1 0 0.1">
          <joint name="j1" type="hinge" axis="0 0 1" range="-3 3" damping="0.5"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04" mass="2"/>
          <body name="link2" pos="0 0 0.3">
            <joint name="j2" type="hinge" axis="0 1 0" range="-3 3" damping="0.5"/>
            <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1.5"/>
            <body name="hand" pos="0.3 0 0">
              <site name="tcp"/>
            </body>
          </body>
        </body>
      </body>
    </body>
    <body name="object/cube" pos="2 1 0.05">
      <freejoint name="object/cube"/>
      <geom type="box" size="0.05 0.05 0.05" mass="0.2"/>
    </body>
  </worldbody>
</mujoco>
"""


def make_sim(
    seed: int = 0, spawn: Pose | None = None, options: SimOptions | None = None, **lidar
) -> Simulation:
    robot = robot_model(lidar)
    model = prepare(mujoco.MjModel.from_xml_string(MJCF), robot)
    world = SimWorld(model, seed=seed, base_body="base_footprint")
    world.spawn(spawn or Pose())
    return Simulation(world, robot, options or SimOptions(cameras=False))


class BoxRoom:
    """What the tests need of the box room: its size and a simulation factory."""

    half_x = HALF_X
    half_y = HALF_Y
    robot_model = staticmethod(robot_model)
    make_sim = staticmethod(make_sim)
    mjcf = MJCF


@pytest.fixture(scope="session")
def boxroom() -> type[BoxRoom]:
    return BoxRoom
