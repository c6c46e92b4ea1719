"""Forward kinematics against the reference and MuJoCo, Jacobians, and IK success."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from robotrial.benchmarks.planning import panda_path
from robotrial.geometry import Box, Pose
from robotrial.kinematics.chain import Kinematics, fk, fk_batch, jacobian_from_poses, sincos
from robotrial.kinematics.ik import solve_ik
from robotrial.kinematics.reference import link_poses
from robotrial.model import load_robot
from robotrial.model.mjcf import to_mjcf
from robotrial.model.robot import Collision, Joint, JointLimit, Link, Mimic, RobotModel

ROBOTS = ["desk_arm", "manipulator_h", "panda"]


def _robot(name: str) -> RobotModel:
    return load_robot(panda_path() if name == "panda" else name)


def tilted_arm() -> RobotModel:
    """A 6-DOF arm with tilted joint frames, offsets, a prismatic finger and a mimic."""
    rng = np.random.default_rng(3)
    links = [Link("base", collisions=(Collision(Box((0.1, 0.1, 0.04))),))]
    joints = []
    prev = "base"
    for i, ax in enumerate([(0, 0, 1), (0, 1, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0, 0, 1)]):
        links.append(
            Link(f"l{i + 1}", collisions=(Collision(Box((0.04, 0.04, 0.1)), Pose((0, 0, 0.05))),))
        )
        joints.append(
            Joint(
                f"j{i + 1}",
                "revolute",
                prev,
                f"l{i + 1}",
                Pose.from_xyz_rpy((0.01 * i, 0.02, 0.1), rng.uniform(-0.4, 0.4, 3)),
                ax,
                JointLimit(-2.5, 2.5, 1, 2),
            )
        )
        prev = f"l{i + 1}"
    links += [Link("fa"), Link("fb"), Link("tcp")]
    joints += [
        Joint(
            "fa", "prismatic", prev, "fa", Pose((0, 0, 0.05)), (0, 1, 0), JointLimit(0, 0.02, 1, 1)
        ),
        Joint(
            "fb",
            "prismatic",
            prev,
            "fb",
            Pose((0, 0, 0.05)),
            (0, -1, 0),
            JointLimit(0, 0.02, 1, 1),
            mimic=Mimic("fa", 2.0, 0.001),
        ),
        Joint("tcpj", "fixed", prev, "tcp", Pose((0, 0, 0.08))),
    ]
    return RobotModel("tilted", tuple(links), tuple(joints), tcp="tcp")


@pytest.mark.parametrize("name", [*ROBOTS, "tilted"])
def test_fk_matches_reference(name: str) -> None:
    robot = tilted_arm() if name == "tilted" else _robot(name)
    kin = Kinematics(robot, joints=robot.joint_names)
    rng = np.random.default_rng(0)
    qs = kin.random(rng, 20)
    batch = kin.fk(qs)
    for q, poses in zip(qs, batch, strict=True):
        ref = link_poses(robot, q)
        for i, link in enumerate(kin.link_names):
            np.testing.assert_allclose(poses[i], ref[link], atol=1e-12)
    single = fk(robot, qs[0])
    np.testing.assert_allclose(single[kin.tip_name], batch[0, kin.tip], atol=1e-12)


def test_sincos_matches_libm_over_joint_ranges() -> None:
    rng = np.random.default_rng(2)
    quarter = np.arange(-16, 17) * np.pi / 4  # where the reduction changes quadrant
    angles = np.concatenate([rng.uniform(-4 * np.pi, 4 * np.pi, 2000), quarter, quarter + 1e-9])
    got = np.array([sincos(float(v)) for v in angles])
    np.testing.assert_allclose(got[:, 0], np.sin(angles), rtol=0, atol=4e-15)
    np.testing.assert_allclose(got[:, 1], np.cos(angles), rtol=0, atol=4e-15)


@pytest.mark.parametrize("name", ROBOTS)
def test_fk_matches_mujoco(name: str) -> None:
    robot = _robot(name)
    kin = Kinematics(robot, joints=robot.joint_names)
    model = to_mjcf(robot, actuators="none").compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(1)
    for q in kin.random(rng, 10):
        values = dict(zip(robot.joint_names, q, strict=True))
        for j in robot.joints:
            if j.mimic is not None:
                values[j.name] = j.mimic.multiplier * values[j.mimic.joint] + j.mimic.offset
        for jname, v in values.items():
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, jname)
            data.qpos[model.jnt_qposadr[jid]] = v
        mujoco.mj_kinematics(model, data)
        poses = kin.fk(q)
        for i, link in enumerate(kin.link_names):
            bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link)
            if bid < 0:
                continue
            np.testing.assert_allclose(poses[i, :3, 3], data.xpos[bid], atol=1e-6)
            np.testing.assert_allclose(poses[i, :3, :3], data.xmat[bid].reshape(3, 3), atol=1e-6)


@pytest.mark.parametrize("name", [*ROBOTS, "tilted"])
def test_tip_chain_places_the_end_effector_as_the_whole_tree(name: str) -> None:
    """IK's chain (the moving frames to the end effector, the end effector fixed on the
    last) puts the end effector where the full tree does, with the same Jacobian."""
    robot = tilted_arm() if name == "tilted" else _robot(name)
    kin = Kinematics(robot)
    chain, ancestors, tip = kin.tip_chain()
    assert len(chain.parent) <= len(kin.link_names)
    for q in kin.random(np.random.default_rng(1), 10):
        poses = fk_batch(q[None], *chain)[0]
        np.testing.assert_allclose(poses[tip], kin.link_pose(q), atol=1e-12)
        jac = jacobian_from_poses(
            poses, tip, poses[tip, :3, 3].copy(), ancestors, *chain[2:6], kin.d
        )
        np.testing.assert_allclose(jac, kin.jacobian(q), atol=1e-12)


@pytest.mark.parametrize("name", ["desk_arm", "tilted"])
def test_jacobian_matches_finite_differences(name: str) -> None:
    robot = tilted_arm() if name == "tilted" else _robot(name)
    kin = Kinematics(robot, joints=robot.joint_names)
    rng = np.random.default_rng(2)
    q = kin.random(rng, 1)[0]
    jac = kin.jacobian(q)
    eps = 1e-6
    for i in range(kin.d):
        dq = np.zeros(kin.d)
        dq[i] = eps
        plus, minus = kin.link_pose(q + dq), kin.link_pose(q - dq)
        np.testing.assert_allclose(jac[:3, i], (plus[:3, 3] - minus[:3, 3]) / (2 * eps), atol=1e-7)
        # angular part: R' R^T is the skew matrix of the angular velocity
        dr = (plus[:3, :3] - minus[:3, :3]) / (2 * eps) @ kin.link_pose(q)[:3, :3].T
        np.testing.assert_allclose(jac[3:, i], [dr[2, 1], dr[0, 2], dr[1, 0]], atol=1e-6)


def test_planning_joints_default_to_the_arm_group() -> None:
    robot = _robot("desk_arm")
    kin = Kinematics(robot)
    assert kin.joint_names == robot.metadata["groups"]["arm"]
    assert "finger_left" not in kin.joint_names
    with pytest.raises(ValueError, match="not an actuated joint"):
        Kinematics(robot, joints=["joint1", "tcp_joint"])


@pytest.mark.parametrize("name", ["desk_arm", "panda"])
def test_ik_reaches_random_reachable_targets(name: str) -> None:
    """>= 99 % of full-pose targets (poses of random configurations) are solved."""
    kin = Kinematics(_robot(name))
    rng = np.random.default_rng(4)
    targets = kin.fk(kin.random(rng, 150))[:, kin.tip]
    solved = 0
    for target in targets:
        res = solve_ik(kin, target, np.zeros(kin.d), rng=rng, wanted=1)
        if res.success:
            solved += 1
            pose = kin.link_pose(res.q)
            assert np.linalg.norm(pose[:3, 3] - target[:3, 3]) < 1e-3
            assert np.all(res.q >= kin.lower) and np.all(res.q <= kin.upper)
    assert solved / len(targets) >= 0.99


def test_ik_position_only_and_nearest_solution() -> None:
    kin = Kinematics(_robot("desk_arm"))
    rng = np.random.default_rng(5)
    current = np.array([0.3, 0.5, 0.8, 0.1, 0.6, -0.2])
    target = kin.link_pose(current + 0.05)
    res = solve_ik(kin, target, current, rng=rng)
    assert res.success
    # the nearest solution is the one next to the current joints, not another branch
    assert np.max(np.abs(res.q - (current + 0.05))) < 0.05
    res = solve_ik(kin, np.array([0.2, 0.1, 0.1]), current, rng=rng)
    assert res.success and res.orientation_error == 0.0
    np.testing.assert_allclose(kin.link_pose(res.q)[:3, 3], [0.2, 0.1, 0.1], atol=1e-3)


def test_ik_reports_how_far_an_unreachable_target_is() -> None:
    kin = Kinematics(_robot("desk_arm"))
    res = solve_ik(
        kin, np.array([2.0, 0.0, 0.1]), np.zeros(kin.d), rng=np.random.default_rng(0), restarts=16
    )
    assert not res.success
    assert 1.4 < res.position_error < 1.7
