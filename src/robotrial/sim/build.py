"""Compile a World and a RobotModel into a MuJoCo model ready for the simulator (layer 2).

The MJCF itself comes from `robotrial.model.mjcf.to_mjcf`; here we set the timestep and
the contact and ray-casting groups the simulator relies on:
- a planar base (slide x, slide y, hinge yaw) carries the robot, so its geoms skip the
  floor (the floor would only add friction) and each other; they still hit walls,
  obstacles and objects;
- the environment's collision geoms (floor, walls, obstacles, objects) go to geom group
  `RAY_GROUP`, the only group the LiDAR casts against by default (meshes of the robot's
  visuals would cost time and a spinning VLP-16 mounted on top sees little of its robot).
"""

from __future__ import annotations

import mujoco
import numpy as np

from robotrial.geometry import Pose
from robotrial.model.robot import RobotModel
from robotrial.model.world import World

FLOOR_BIT, ROBOT_BIT, ENV_BIT = 1, 2, 4
RAY_GROUP = 5
DEFAULT_TIMESTEP = 0.002


def robot_geoms(model: mujoco.MjModel, robot: RobotModel) -> np.ndarray:
    """Ids of the geoms that belong to the robot's links."""
    links = {lk.name for lk in robot.links}
    out = []
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g]))
        if name in links:
            out.append(g)
    return np.array(out, dtype=int)


def prepare(
    model: mujoco.MjModel, robot: RobotModel, timestep: float = DEFAULT_TIMESTEP
) -> mujoco.MjModel:
    """Set the timestep, integrator, contact bits and ray group on a compiled model (in
    place)."""
    if not timestep > 0:
        raise ValueError(f"sim: timestep must be positive, got {timestep}")
    model.opt.timestep = timestep
    # The controllers apply explicit forces; semi-implicit Euler (with implicit joint
    # damping) is stable for them and costs a third of implicitfast per step.
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    mine = set(robot_geoms(model, robot).tolist())
    planar = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "base_yaw") >= 0
    for g in range(model.ngeom):
        collides = model.geom_contype[g] != 0 or model.geom_conaffinity[g] != 0
        if not collides:
            continue
        if g in mine:
            if planar:
                model.geom_contype[g] = ROBOT_BIT
                model.geom_conaffinity[g] = ENV_BIT
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        if planar:
            if name == "floor":
                model.geom_contype[g] = FLOOR_BIT
                model.geom_conaffinity[g] = ENV_BIT
            else:
                model.geom_contype[g] = ENV_BIT
                model.geom_conaffinity[g] = FLOOR_BIT | ROBOT_BIT | ENV_BIT
        model.geom_group[g] = RAY_GROUP
    return model


def compile_world(
    world: World,
    robot: RobotModel,
    base: str = "planar",
    spawn: Pose | None = None,
    timestep: float = DEFAULT_TIMESTEP,
) -> mujoco.MjModel:
    """MuJoCo model of `robot` in `world` (base "planar", "free" or "fixed")."""
    from robotrial.model.mjcf import to_mjcf

    doc = to_mjcf(robot, world, base=base, spawn=spawn)
    return prepare(doc.compile(), robot, timestep)
