"""Compile a World and a RobotModel into a MuJoCo model ready for the simulator (layer 2).

The MJCF itself comes from `robotrial.model.mjcf.to_mjcf`; here we set the timestep and
the contact and ray-casting groups the simulator relies on:
- a planar base (slide x, slide y, hinge yaw) carries the robot, so its geoms skip the
  floor (the floor would only add friction) and each other; they still hit walls,
  obstacles and objects;
- the environment's collision geoms (floor, walls, obstacles, objects) go to geom group
  `RAY_GROUP`, the only group the LiDAR casts against by default (meshes of the robot's
  visuals would cost time and a spinning VLP-16 mounted on top sees little of its robot);
- a gripper holds by friction alone (`grasp_contacts`): elliptic friction cones with an
  impedance ratio of 10 (MuJoCo's advice for grasping: tangential forces as stiff as
  normal ones), the no-slip solver pass (5 iterations: without it the soft contacts let a
  held can creep 4 mm in 20 s of carrying and turn out of the grip over a minute of a
  trial), torsional friction (condim 4) where
  fingers and movable objects touch, rubber-like finger pads (friction 1.0), and stiffer
  contacts there (time constant 5 ms), and the mimic coupling of the fingers as stiff.
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
IMPRATIO = 10.0
NOSLIP_ITERATIONS = 5
GRASP_CONDIM = 4
FINGER_FRICTION = (1.0, 0.005, 0.0001)  # sliding, torsional (m), rolling (m)
GRASP_SOLREF = (0.005, 1.0)  # s, damping ratio


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
    grasp_contacts(model, robot)
    return model


def finger_links(robot: RobotModel) -> list[str]:
    """The links the gripper's finger joints (and the joints that mimic them) move."""
    fingers = set((robot.metadata.get("gripper") or {}).get("joints", []))
    return [
        j.child
        for j in robot.joints
        if j.name in fingers or (j.mimic is not None and j.mimic.joint in fingers)
    ]


def grasp_contacts(model: mujoco.MjModel, robot: RobotModel) -> None:
    """Contact settings under which fingers hold objects by friction (in place)."""
    model.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    model.opt.impratio = IMPRATIO
    model.opt.noslip_iterations = NOSLIP_ITERATIONS
    links = set(finger_links(robot))
    for g in range(model.ngeom):
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g])) or ""
        finger = body in links
        if not (finger or body.startswith("object/")):
            continue
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0:
            continue
        model.geom_condim[g] = GRASP_CONDIM
        model.geom_solref[g] = GRASP_SOLREF
        if finger:
            model.geom_friction[g] = FINGER_FRICTION
    # a finger that mimics another follows it as stiffly as the fingers touch: under a
    # 20 N squeeze the default coupling lets the pair drift 7 mm to one side
    for e in range(model.neq):
        if int(model.eq_type[e]) != int(mujoco.mjtEq.mjEQ_JOINT):
            continue
        joint = int(model.eq_obj1id[e])
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.jnt_bodyid[joint]))
        if body in links:
            model.eq_solref[e] = GRASP_SOLREF


def compile_world(
    world: World,
    robot: RobotModel,
    base: str = "planar",
    spawn: Pose | None = None,
    timestep: float = DEFAULT_TIMESTEP,
) -> mujoco.MjModel:
    """MuJoCo model of `robot` in `world` (base "planar", "free" or "fixed")."""
    from robotrial.model.mjcf import to_mjcf

    # every joint a motor (the controllers push through qfrc_applied instead), the
    # gripper's fingers position servos whose force limit is the grip force (`Gripper`)
    fingers = set((robot.metadata.get("gripper") or {}).get("joints", []))
    kinds = {j.name: "position" if j.name in fingers else "motor" for j in robot.actuated_joints}
    doc = to_mjcf(robot, world, base=base, spawn=spawn, actuators=kinds)
    return prepare(doc.compile(), robot, timestep)
