"""The MJCF writer: MuJoCo's poses equal the reference FK, names follow the convention,
worlds and robots simulate, meshes (STL, DAE, scaled, huge) load."""

from __future__ import annotations

import importlib.metadata
import json
import os
import shutil
import subprocess
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from robotrial.geometry import Box, Cylinder, Mesh, MeshData, Pose, Sphere
from robotrial.kinematics.reference import joint_values, link_poses
from robotrial.model import library, load_robot, load_world
from robotrial.model.mjcf import (
    FREE_JOINT,
    MAX_MESH_FACES,
    PLANAR_JOINTS,
    simplify_mesh,
    to_mjcf,
)
from robotrial.model.robot import (
    Collision,
    Inertial,
    Joint,
    JointDynamics,
    JointLimit,
    Link,
    Material,
    Mimic,
    ModelError,
    RobotModel,
    Sensor,
    Visual,
)
from robotrial.model.world import Floor, Light, Obstacle, World

ROOT = Path(__file__).resolve().parents[2]


def _erd_robots_dir() -> Path:
    """The `robots` folder that the installed example-robot-data package ships."""
    for f in importlib.metadata.distribution("example-robot-data").files or []:
        if str(f).endswith(".urdf"):
            path = Path(f.locate()).resolve()
            return next(p for p in path.parents if p.name == "robots")
    raise RuntimeError("example-robot-data ships no URDF")


ERD = _erd_robots_dir()


def toy_robot() -> RobotModel:
    """A small tree with every joint kind the writer maps, odd axes and rotated inertials."""
    rng = np.random.default_rng(3)

    def inertial(mass: float) -> Inertial:
        return Inertial(
            mass,
            Pose.from_xyz_rpy(rng.normal(0, 0.05, 3), rng.normal(0, 1, 3)),
            0.02,
            0.001,
            0.0,
            0.03,
            0.002,
            0.025,
        )

    links = (
        Link(
            "base",
            inertial(3.0),
            visuals=(Visual(Box((0.2, 0.2, 0.1)), material="grey"),),
            collisions=(Collision(Box((0.2, 0.2, 0.1)), Pose((0, 0, 0.05))),),
        ),
        Link("l1", inertial(1.0), collisions=(Collision(Cylinder(0.04, 0.2), Pose((0, 0, 0.1))),)),
        Link("l2"),  # no inertial: URDF's massless link
        Link("l3", inertial(0.5), visuals=(Visual(Sphere(0.03)),)),
        Link("tcp"),
        Link("finger_a", inertial(0.05)),
        Link("finger_b", inertial(0.05)),
    )
    joints = (
        Joint(
            "j1",
            "revolute",
            "base",
            "l1",
            Pose.from_xyz_rpy((0, 0, 0.1), (0, 0, 0.5)),
            (0, 0, 1),
            JointLimit(-2.5, 2.5, 30, 2),
        ),
        Joint(
            "j2",
            "continuous",
            "l1",
            "l2",
            Pose.from_xyz_rpy((0.01, 0.1, 0.2), (0.4, -0.2, 0.1)),
            (0.3, 1.0, -0.2),
            dynamics=JointDynamics(0.5, 0.1),
        ),
        Joint(
            "j3",
            "prismatic",
            "l2",
            "l3",
            Pose.from_xyz_rpy((0, 0, 0.15), (0, 0.3, 0)),
            (0, 0, 1),
            JointLimit(-0.1, 0.2, 50, 0.5),
        ),
        Joint("tool", "fixed", "l3", "tcp", Pose.from_xyz_rpy((0, 0, 0.08), (0.1, 0.2, 0.3))),
        Joint(
            "finger_a",
            "prismatic",
            "tcp",
            "finger_a",
            Pose((0, 0.02, 0)),
            (0, 1, 0),
            JointLimit(0, 0.04, 20, 0.1),
        ),
        Joint(
            "finger_b",
            "prismatic",
            "tcp",
            "finger_b",
            Pose((0, -0.02, 0)),
            (0, -1, 0),
            JointLimit(0, 0.04, 20, 0.1),
            mimic=Mimic("finger_a", 1.0, 0.0),
        ),
    )
    sensors = (
        Sensor("cam", "camera", "l3", Pose.from_xyz_rpy((0.05, 0, 0), (0, 0.2, 0.3)), 30.0),
        Sensor("imu", "imu", "base", Pose((0, 0, 0.02))),
        Sensor("lidar", "lidar", "base", Pose((0.1, 0, 0.1))),
    )
    return RobotModel(
        "toy",
        links,
        joints,
        materials={"grey": Material("grey", (0.3, 0.3, 0.3, 1.0))},
        sensors=sensors,
        tcp="tcp",
    )


def _set_q(model: mujoco.MjModel, data: mujoco.MjData, robot: RobotModel, q: np.ndarray) -> None:
    for name, value in joint_values(robot, q).items():
        if robot.joint(name).type != "fixed":  # a mimic tag on a fixed joint: no motion
            data.qpos[model.joint(name).qposadr[0]] = value


def assert_fk_equal(
    robot: RobotModel,
    samples: int = 5,
    base: str = "fixed",
    spawn: Pose | None = None,
    seed: int = 0,
) -> None:
    """MuJoCo's body poses after mj_kinematics equal link_poses for random joint values."""
    spawn = spawn or Pose()
    doc = to_mjcf(robot, base=base, spawn=spawn, actuators="none", visuals=False)
    model = doc.compile()
    data = mujoco.MjData(model)
    lo, hi = robot.joint_limits()
    rng = np.random.default_rng(seed)
    for _ in range(samples):
        q = rng.uniform(lo, hi)
        mujoco.mj_resetData(model, data)
        _set_q(model, data, robot, q)
        mujoco.mj_kinematics(model, data)
        expected = link_poses(robot, q, base=None if robot.root == "world" else spawn.matrix())
        for link, pose in expected.items():
            if link == "world":
                continue
            body = model.body(link)
            np.testing.assert_allclose(data.xpos[body.id], pose[:3, 3], atol=1e-9, err_msg=link)
            np.testing.assert_allclose(
                data.xmat[body.id].reshape(3, 3), pose[:3, :3], atol=1e-9, err_msg=link
            )


# --- kinematics ---------------------------------------------------------------------------


@pytest.mark.parametrize("base", ["fixed", "free", "planar"])
def test_fk_of_a_hand_built_tree_matches_the_reference(base: str) -> None:
    spawn = Pose.from_xyz_rpy((1.0, -2.0, 0.3), (0.0, 0.0, 2.5))
    assert_fk_equal(toy_robot(), samples=20, base=base, spawn=spawn)


@pytest.mark.parametrize("name", library.robot_names())
def test_fk_of_builtin_robots_matches_the_reference(name: str) -> None:
    assert_fk_equal(load_robot(name), samples=10)


@pytest.mark.parametrize(
    "urdf",
    [
        "panda_description/urdf/panda.urdf",
        "ur_description/urdf/ur5_robot.urdf",
        "tiago_description/robots/tiago.urdf",
        "baxter_description/urdf/baxter.urdf",
        "allegro_hand_description/urdf/allegro_right_hand.urdf",
    ],
)
def test_fk_of_corpus_robots_matches_the_reference(urdf: str) -> None:
    assert_fk_equal(load_robot(ERD / urdf), samples=5)


@st.composite
def random_trees(draw) -> RobotModel:
    """Robots of 2 to 8 links with random parents, joint kinds, origins and axes."""
    n = draw(st.integers(2, 8))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    links = [Link(f"link{i}", Inertial(1.0, ixx=0.01, iyy=0.01, izz=0.01)) for i in range(n)]
    joints = []
    for i in range(1, n):
        kind = str(rng.choice(["revolute", "continuous", "prismatic", "fixed"]))
        lo = float(rng.uniform(-3, 0))
        joints.append(
            Joint(
                f"joint{i}",
                kind,  # type: ignore[arg-type]
                f"link{int(rng.integers(0, i))}",
                f"link{i}",
                Pose.from_xyz_rpy(rng.normal(0, 0.3, 3), rng.uniform(-np.pi, np.pi, 3)),
                tuple(rng.normal(0, 1, 3) + 1e-3),
                JointLimit(lo, lo + float(rng.uniform(0.1, 3)), 10, 1),
            )
        )
    return RobotModel("random", tuple(links), tuple(joints))


@settings(max_examples=25, deadline=None)
@given(random_trees())
def test_fk_of_random_trees_matches_the_reference(robot: RobotModel) -> None:
    assert_fk_equal(robot, samples=3, spawn=Pose.from_xyz_rpy((0.1, 0.2, 0.3), (0.3, 0.2, 0.1)))


def test_planar_base_joints_are_the_world_pose_of_the_base() -> None:
    robot = toy_robot()
    spawn = Pose.from_xy_yaw(1.5, -0.5, 0.8, z=0.1)
    model = to_mjcf(robot, base="planar", spawn=spawn).compile()
    data = mujoco.MjData(model)
    qx, qy, qyaw = (model.joint(n).qposadr[0] for n in PLANAR_JOINTS)
    np.testing.assert_allclose(data.qpos[[qx, qy, qyaw]], [1.5, -0.5, 0.8])
    data.qpos[[qx, qy, qyaw]] = [3.0, 4.0, -1.0]
    mujoco.mj_kinematics(model, data)
    expected = Pose.from_xy_yaw(3.0, 4.0, -1.0, z=0.1).matrix()
    np.testing.assert_allclose(data.xpos[model.body("base").id], expected[:3, 3], atol=1e-12)
    np.testing.assert_allclose(
        data.xmat[model.body("base").id].reshape(3, 3), expected[:3, :3], atol=1e-12
    )


def test_free_base_starts_at_the_spawn_pose() -> None:
    spawn = Pose.from_xyz_rpy((0.5, 0.2, 1.0), (0.1, 0.2, 0.3))
    model = to_mjcf(toy_robot(), base="free", spawn=spawn).compile()
    data = mujoco.MjData(model)
    assert model.joint(FREE_JOINT).type == mujoco.mjtJoint.mjJNT_FREE
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.xpos[model.body("base").id], spawn.xyz, atol=1e-12)


# --- names ----------------------------------------------------------------------------------


def test_names_follow_the_shared_convention() -> None:
    robot = toy_robot()
    model = to_mjcf(robot, actuators="position").compile()
    bodies = {model.body(i).name for i in range(model.nbody)}
    assert {lk.name for lk in robot.links} <= bodies
    joints = {model.joint(i).name for i in range(model.njnt)}
    assert joints == {"j1", "j2", "j3", "finger_a", "finger_b"}
    actuators = [model.actuator(i).name for i in range(model.nu)]
    assert actuators == ["j1", "j2", "j3", "finger_a"]  # the mimic joint is not driven
    assert model.site("tcp").bodyid[0] == model.body("tcp").id
    for s in ("cam", "imu", "lidar"):
        assert model.site(s).bodyid[0] == model.body(robot.sensor(s).link).id
    assert model.ncam == 1 and model.camera("cam").bodyid[0] == model.body("l3").id
    assert model.sensor("imu/gyro").type == mujoco.mjtSensor.mjSENS_GYRO
    assert model.neq == 1 and model.eq_type[0] == mujoco.mjtEq.mjEQ_JOINT


def test_camera_looks_along_the_sensor_x_axis() -> None:
    robot = toy_robot()
    model = to_mjcf(robot).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    sensor = robot.sensor("cam")
    frame = link_poses(robot, np.zeros(4))["l3"] @ sensor.origin.matrix()
    cam = data.cam_xmat[model.camera("cam").id].reshape(3, 3)
    np.testing.assert_allclose(-cam[:, 2], frame[:3, 0], atol=1e-12)  # forward
    np.testing.assert_allclose(cam[:, 1], frame[:3, 2], atol=1e-12)  # up
    np.testing.assert_allclose(data.cam_xpos[model.camera("cam").id], frame[:3, 3], atol=1e-12)


def test_mimic_joint_follows_its_leader_in_simulation() -> None:
    model = to_mjcf(toy_robot(), actuators="position").compile()
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("finger_a").id] = 0.03
    mujoco.mj_step(model, data, 1000)
    a = data.qpos[model.joint("finger_a").qposadr[0]]
    b = data.qpos[model.joint("finger_b").qposadr[0]]
    assert a == pytest.approx(0.03, abs=5e-3)
    assert b == pytest.approx(a, abs=1e-3)


def test_joint_limits_damping_friction_and_armature_are_written() -> None:
    model = to_mjcf(toy_robot(), armature=0.02).compile()
    j1, j2, j3 = model.joint("j1"), model.joint("j2"), model.joint("j3")
    assert j1.limited[0] and list(j1.range) == [-2.5, 2.5]
    assert not j2.limited[0]  # continuous
    assert j3.limited[0] and list(j3.range) == pytest.approx([-0.1, 0.2])
    assert model.dof_damping[j2.dofadr[0]] == 0.5
    assert model.dof_frictionloss[j2.dofadr[0]] == 0.1
    assert model.dof_armature[j1.dofadr[0]] == 0.02
    world = to_mjcf(toy_robot(), small_world(), armature=0.02).compile()
    cube = world.joint("object/cube").dofadr[0]
    assert not world.dof_armature[cube : cube + 6].any()  # objects keep their own inertia
    assert list(model.actuator("j1").ctrlrange) == [-30, 30]  # motor: +- effort


@pytest.mark.parametrize("name", ["desk_arm", "manipulator_h"])
def test_position_servos_hold_an_arm_against_gravity(name: str) -> None:
    robot = load_robot(name)
    model = to_mjcf(robot, actuators="position").compile()
    data = mujoco.MjData(model)
    lo, hi = robot.joint_limits()
    target = lo + (hi - lo) * 0.4
    for name, value in zip(robot.joint_names, target, strict=True):
        data.ctrl[model.actuator(name).id] = value
    mujoco.mj_step(model, data, 1500)
    for name, value in zip(robot.joint_names, target, strict=True):
        assert data.qpos[model.joint(name).qposadr[0]] == pytest.approx(value, abs=0.05), name


# --- inertia ----------------------------------------------------------------------------


def test_inertial_frame_and_tensor_are_kept() -> None:
    robot = toy_robot()
    model = to_mjcf(robot).compile()
    for link in ("base", "l1", "l3"):
        inertial = robot.link(link).inertial
        body = model.body(link)
        assert body.mass[0] == pytest.approx(inertial.mass)
        np.testing.assert_allclose(body.ipos, inertial.origin.xyz, atol=1e-12)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, body.iquat)
        rot = rot.reshape(3, 3)
        got = rot @ np.diag(body.inertia) @ rot.T
        r = inertial.origin.rotation()
        want = r @ inertial.tensor() @ r.T
        np.testing.assert_allclose(got, want, atol=1e-9)


def test_massless_links_and_bad_inertias_are_made_acceptable_with_a_note() -> None:
    robot = toy_robot()
    bad = Inertial(1.0, Pose(), 0.01, 0.0, 0.0, 0.01, 0.0, 0.05)  # 0.01 + 0.01 < 0.05
    links = tuple(lk if lk.name != "l3" else Link("l3", bad) for lk in robot.links)
    doc = to_mjcf(robot.with_changes(links=links))
    assert any("l3" in n and "triangle" in n for n in doc.notes)
    model = doc.compile()
    assert model.body("l2").mass[0] > 0
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 500)
    assert np.all(np.isfinite(data.qpos))


# --- world --------------------------------------------------------------------------------


def small_world() -> World:
    return World(
        name="room",
        floor=Floor(size=(6.0, 4.0)),
        walls=(Obstacle("north", Box((6.0, 0.1, 1.0)), Pose((0, 2.0, 0.5)), kind="wall"),),
        obstacles=(Obstacle("pillar", Cylinder(0.2, 1.0), Pose((1.5, 1.0, 0.5))),),
        objects=(Obstacle("cube", Box((0.1, 0.1, 0.1)), Pose((-1.0, 0.0, 0.5)), mass=0.2),),
        lights=(Light("sun"),),
        spawns={"default": Pose.from_xy_yaw(0.5, -1.0, 0.3)},
    )


def test_world_mesh_obstacles_are_static_geoms(tmp_path) -> None:
    stl = tmp_path / "crate.stl"
    trimesh.creation.box((0.4, 0.4, 0.4)).export(stl)
    world = World(name="m", obstacles=(Obstacle("crate", Mesh(str(stl)), Pose((1, 0, 0.2))),))
    doc = to_mjcf(world=world)
    model = doc.compile()
    geom = model.geom("obstacle/crate")
    assert geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.bodyid[0] == 0
    assert list(doc.assets) == [f"{model.mesh(0).name}.stl"]


def test_world_names_and_an_object_falls_to_the_floor() -> None:
    model = to_mjcf(world=small_world()).compile()
    for geom in ("floor", "wall/north", "obstacle/pillar", "object/cube"):
        model.geom(geom)
    assert model.joint("object/cube").type == mujoco.mjtJoint.mjJNT_FREE
    assert model.body("object/cube").mass[0] == pytest.approx(0.2)
    assert model.nlight == 1
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1000)
    assert data.xpos[model.body("object/cube").id][2] == pytest.approx(0.05, abs=2e-3)


def test_robot_in_a_world_stands_at_the_default_spawn() -> None:
    model = to_mjcf(toy_robot(), small_world(), base="planar").compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.xpos[model.body("base").id][:2], [0.5, -1.0], atol=1e-12)


@pytest.mark.parametrize("world_name", library.world_names())
def test_mobile_manipulator_drives_in_every_builtin_world(world_name: str) -> None:
    robot = load_robot("mobile_manipulator")
    groups = robot.metadata["groups"]
    kinds = {j: "velocity" for j in groups["base"]}
    kinds |= {j: "position" for j in groups["arm"] + groups["gripper"]}
    kinds |= {"base_x": "velocity", "base_y": "velocity", "base_yaw": "velocity"}
    world = load_world(world_name)
    model = to_mjcf(robot, world, base="planar", actuators=kinds).compile()
    data = mujoco.MjData(model)
    start = world.spawns.get("default", Pose())
    assert data.qpos[model.joint("base_x").qposadr[0]] == pytest.approx(start.xyz[0])
    assert model.nu == len(kinds)
    for wheel in groups["base"]:  # let the wheels roll
        data.ctrl[model.actuator(wheel).id] = 0.3 / robot.metadata["drive"]["wheel_radius"]
    data.ctrl[model.actuator("base_x").id] = 0.3
    mujoco.mj_step(model, data, 500)
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0
    moved = data.qpos[model.joint("base_x").qposadr[0]] - start.xyz[0]
    assert 0.1 < moved < 0.4


def test_robot_collides_with_the_world_but_not_with_itself_by_default() -> None:
    robot = toy_robot()
    world = World(
        name="drop",
        objects=(Obstacle("cube", Box((0.05, 0.05, 0.05)), Pose((0, 0, 0.5)), mass=0.1),),
    )
    model = to_mjcf(robot, world, actuators="position").compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 600)
    # the cube lands on the base's collision box (top at z = 0.1), not on the floor
    assert data.xpos[model.body("object/cube").id][2] > 0.1
    robot_bodies = {model.body(lk.name).id for lk in robot.links}
    for c in data.contact[: data.ncon]:
        pair = {model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]}
        assert not pair <= robot_bodies


def test_self_collision_excludes_pairs_touching_at_rest() -> None:
    robot = toy_robot()
    ball = Collision(Sphere(0.3))  # reaches down into l1, two links above it
    links = tuple(
        lk if lk.name != "l3" else Link("l3", lk.inertial, collisions=(ball,)) for lk in robot.links
    )
    robot = robot.with_changes(links=links)
    doc = to_mjcf(robot, self_collision=True)
    model = doc.compile()
    assert '<exclude body1="l1" body2="l3" />' in doc.xml
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0


# --- meshes ---------------------------------------------------------------------------------


def _world_vertices(model: mujoco.MjModel, data: mujoco.MjData, geom: str) -> np.ndarray:
    g = model.geom(geom)
    mesh = model.mesh(g.dataid[0])
    adr, n = mesh.vertadr[0], mesh.vertnum[0]
    local = model.mesh_vert[adr : adr + n]
    return local @ data.geom_xmat[g.id].reshape(3, 3).T + data.geom_xpos[g.id]


@pytest.mark.parametrize("scale", [(1.0, 1.0, 1.0), (2.0, 0.5, 1.5), (-1.0, 1.0, 1.0)])
def test_scaled_and_mirrored_meshes_keep_their_shape(scale) -> None:
    box = trimesh.creation.box((0.1, 0.2, 0.3))
    box.apply_translation((0.3, 0.0, 0.1))
    mesh = Mesh("part.stl", scale, MeshData(box.vertices, box.faces))
    robot = RobotModel("m", (Link("base", visuals=(Visual(mesh, Pose((0, 0, 1))),)),))
    model = to_mjcf(robot).compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    got = _world_vertices(model, data, "base/visual/0")
    want = box.vertices * np.asarray(scale) + (0, 0, 1)
    np.testing.assert_allclose(got.min(axis=0), want.min(axis=0), atol=1e-6)
    np.testing.assert_allclose(got.max(axis=0), want.max(axis=0), atol=1e-6)
    # the triangles still face outwards: positive signed volume
    m = model.mesh(0)
    faces = model.mesh_face[m.faceadr[0] : m.faceadr[0] + m.facenum[0]]
    tri = model.mesh_vert[m.vertadr[0] : m.vertadr[0] + m.vertnum[0]][faces]
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert volume == pytest.approx(0.006 * abs(np.prod(scale)), rel=1e-6)


def test_dae_meshes_load_through_pycollada() -> None:
    dae = ERD / "ur_description/meshes/ur5/visual/forearm.dae"
    robot = RobotModel(
        "d",
        (
            Link(
                "base", Inertial(1.0, ixx=0.1, iyy=0.1, izz=0.1), visuals=(Visual(Mesh(str(dae))),)
            ),
        ),
    )
    doc = to_mjcf(robot)
    assert not doc.notes, doc.notes
    model = doc.compile()
    assert model.nmesh == 1 and model.mesh_vertnum[0] > 3
    # the forearm is about 0.5 m long: metres, not the file's own units
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    extent = np.ptp(_world_vertices(model, data, "base/visual/0"), axis=0)
    assert 0.3 < extent.max() < 0.7


def test_huge_meshes_are_simplified_below_mujocos_limit() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=7, radius=0.2)  # 327,680 triangles
    assert len(sphere.faces) > MAX_MESH_FACES
    data = MeshData(sphere.vertices, sphere.faces)
    robot = RobotModel("big", (Link("base", visuals=(Visual(Mesh("ball.stl", data=data)),)),))
    doc = to_mjcf(robot)
    assert any("simplified" in n for n in doc.notes)
    model = doc.compile()
    assert model.mesh_facenum[0] <= MAX_MESH_FACES
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    radii = np.linalg.norm(_world_vertices(model, data, "base/visual/0"), axis=1)
    assert radii.min() > 0.199 and radii.max() < 0.2001


def test_a_lower_triangle_budget_makes_lighter_documents() -> None:
    robot = load_robot(ERD / "panda_description/urdf/panda.urdf")
    full = to_mjcf(robot)
    light = to_mjcf(robot, max_mesh_faces=2000)
    assert sum(map(len, light.assets.values())) < sum(map(len, full.assets.values())) / 2
    model = light.compile()
    assert model.mesh_facenum.max() <= 2000
    assert any("simplified" in n for n in light.notes)
    with pytest.raises(ModelError, match="max_mesh_faces"):
        to_mjcf(robot, max_mesh_faces=10**6)


def test_simplified_mesh_stays_within_a_grid_cell_of_the_original() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
    simple = simplify_mesh(MeshData(sphere.vertices, sphere.faces), max_faces=2000)
    assert 500 < len(simple.faces) <= 2000
    radii = np.linalg.norm(simple.vertices, axis=1)
    assert radii.min() > 0.95 and radii.max() <= 1.0 + 1e-12


def test_unreadable_visual_mesh_is_left_out_but_a_collision_mesh_is_an_error(tmp_path) -> None:
    broken = tmp_path / "broken.stl"
    broken.write_text("not a mesh")
    visual = RobotModel("v", (Link("base", visuals=(Visual(Mesh(str(broken))),)),))
    doc = to_mjcf(visual)
    assert any("broken.stl" in n for n in doc.notes)
    doc.compile()
    collision = RobotModel("c", (Link("base", collisions=(Collision(Mesh(str(broken))),)),))
    with pytest.raises(ModelError, match=r"base/collision/0.*broken\.stl"):
        to_mjcf(collision)


def test_saved_folder_loads_from_disk(tmp_path) -> None:
    robot = load_robot(ERD / "panda_description/urdf/panda.urdf")
    doc = to_mjcf(robot, small_world())
    path = doc.save(tmp_path / "panda")
    assert path.suffix == ".xml" and len(list(path.parent.glob("*.stl"))) == len(doc.assets)
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.nbody == doc.compile().nbody


def _world_rooted(kind: str) -> RobotModel:
    """A URDF-style robot hanging from a `world` link by a fixed or floating joint."""
    arm = toy_robot()
    links = (Link("world"), *arm.links)
    joints = (Joint("mount", kind, "world", "base", Pose((0.2, 0, 0.5))), *arm.joints)
    return arm.with_changes(links=links, joints=joints)


@pytest.mark.parametrize(
    ("kind", "base"), [("fixed", "fixed"), ("fixed", "free"), ("floating", "fixed")]
)
def test_a_urdf_world_link_is_mujocos_world_body(kind: str, base: str) -> None:
    robot = _world_rooted(kind)
    model = to_mjcf(robot, base=base).compile()
    assert model.body("world").id == 0
    assert model.body("base").parentid[0] == 0
    assert_fk_equal(robot, samples=3, base=base)
    free = mujoco.mjtJoint.mjJNT_FREE
    has_free = any(model.jnt_type[i] == free for i in range(model.njnt))
    assert has_free == (kind == "floating" or base == "free")


# --- bad input ----------------------------------------------------------------------------


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ModelError, match="robot, a world"):
        to_mjcf()
    with pytest.raises(ModelError, match="base"):
        to_mjcf(toy_robot(), base="flying")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="nope"):
        to_mjcf(toy_robot(), actuators={"nope": "motor"})
    with pytest.raises(ModelError, match="actuators"):
        to_mjcf(toy_robot(), actuators="magic")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="base_x"):
        to_mjcf(toy_robot(), actuators={"base_x": "velocity"})  # only with a planar base
    robot = toy_robot()
    clash = robot.with_changes(sensors=(Sensor("tcp", "imu", "base"),))
    with pytest.raises(ModelError, match="'tcp'"):
        to_mjcf(clash)


# --- the browser's MuJoCo (3.3.8, WebAssembly) ------------------------------------------------

NODE_CHECK = ROOT / "tests/model/mjcf_check.mjs"


def _mujoco_js() -> Path | None:
    for candidate in (
        os.environ.get("ROBOTRIAL_MUJOCO_JS", ""),
        str(ROOT / "web/node_modules/mujoco-js"),
    ):
        if candidate and (Path(candidate) / "package.json").is_file():
            return Path(candidate)
    return None


def test_documents_load_and_step_in_mujoco_js(tmp_path) -> None:
    if _mujoco_js() is None or shutil.which("node") is None:
        pytest.fail(
            "node and npm's mujoco-js are needed (web/node_modules, from `make setup`, or "
            "ROBOTRIAL_MUJOCO_JS)"
        )
    docs = {
        "toy": to_mjcf(toy_robot(), small_world(), base="planar", actuators="position"),
        "self": to_mjcf(toy_robot(), self_collision=True, actuators="velocity"),
        "panda": to_mjcf(load_robot(ERD / "panda_description/urdf/panda.urdf")),
        # as the web page asks for it (app/catalog.py): the arm on its riser
        "mobile_manipulator": to_mjcf(load_robot("mobile_manipulator"), actuators="position"),
    }
    paths = [str(doc.save(tmp_path / name)) for name, doc in docs.items()]
    out = subprocess.run(
        ["node", str(NODE_CHECK), *paths],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "MUJOCO_JS": str(_mujoco_js())},
    )
    assert out.returncode == 0, out.stderr + out.stdout
    reports = [json.loads(line) for line in out.stdout.splitlines()]
    assert len(reports) == len(docs)
    for doc, report in zip(docs.values(), reports, strict=True):
        model = doc.compile()
        assert report["version"].startswith("3.")
        assert report["nbody"] == model.nbody and report["nu"] == model.nu
        assert report["finite"], report
