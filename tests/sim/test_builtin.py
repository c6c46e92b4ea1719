"""The built-in mobile manipulator in the trial rooms: scan and depth against the room."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from robotrial.geometry import Pose
from robotrial.sim.simulation import SimOptions, Simulation, StreamSettings
from robotrial.sim.tf import chain_to_root

ROOM_A = (0.0, 0.0, 7.78, 7.62)  # the free interior: x0, y0, x1, y1


def room_distance(origin, angles):
    x0, y0, x1, y1 = ROOM_A
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (x1 - origin[0]) / c, (x0 - origin[0]) / c)
        ty = np.where(s > 0, (y1 - origin[1]) / s, (y0 - origin[1]) / s)
    return np.minimum(np.abs(tx), np.abs(ty))


@pytest.fixture(scope="module")
def mm_sim():
    opts = SimOptions(
        cameras=True,
        streams={
            "velodyne": StreamSettings(noise=0.0),
            "depth_camera": StreamSettings(noise=0.0),
            "hand_camera": StreamSettings(enabled=False),
        },
    )
    sim = Simulation.create(
        "room_a", "mobile_manipulator", spawn=Pose.from_xy_yaw(3.0, 3.5, 0.0), options=opts
    )
    sim.start()
    yield sim
    sim.close()


def test_scan_in_room_a_matches_the_walls(mm_sim):
    scan = mm_sim.latest["scan"].data
    pose = mm_sim.frame_pose(scan.frame)
    yaw = np.arctan2(pose[1, 0], pose[0, 0])
    angles = scan.angle_min + np.arange(len(scan.ranges)) * scan.angle_increment
    want = room_distance(pose[:2, 3], angles + yaw)
    seen = np.isfinite(scan.ranges)
    assert seen.mean() > 0.99
    assert np.max(np.abs(scan.ranges[seen] - want[seen])) < 0.01


def test_depth_camera_sees_the_wall_ahead(mm_sim):
    img = mm_sim.latest["depth_camera"].data
    assert img.encoding == "32FC1" and img.pixels.shape == (480, 640)
    cam = mm_sim.frame_pose(img.frame)  # optical frame: z forward
    axis = cam[:3, 2]
    assert axis[0] > 0.9
    want = (ROOM_A[2] - cam[0, 3]) / axis[0]
    # the arm stands in the middle of the view; the wall fills the row at the sides
    side = img.pixels[239:241, 40:80]
    assert np.allclose(side, want, atol=0.01)
    rgb = mm_sim.latest["front_camera"].data
    assert rgb.encoding == "rgb8" and rgb.pixels.shape == (480, 640, 3)
    assert rgb.pixels.std() > 5  # a scene, not a blank frame


def test_sensor_frames_match_the_mjcf_sites(mm_sim):
    w = mm_sim.world
    transforms = mm_sim.tf.static + mm_sim.tf.dynamic(mm_sim.joint_values())
    for s in mm_sim.robot.sensors:
        frame = mm_sim.tf.sensor_frames[s.name]
        chain_to_root(transforms, frame, mm_sim.robot.root)
        sid = mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_SITE, s.name)
        pose = mm_sim.frame_pose(frame)
        assert np.allclose(pose[:3, 3], w.data.site_xpos[sid], atol=1e-6), s.name


def test_scan_in_room_b_sees_the_cylinder():
    opts = SimOptions(cameras=False, streams={"velodyne": StreamSettings(noise=0.0)})
    sim = Simulation.create(
        "room_b", "mobile_manipulator", spawn=Pose.from_xy_yaw(1.5, 3.81, 0.0), options=opts
    )
    sim.start()
    scan = sim.latest["scan"].data
    pose = sim.frame_pose(scan.frame)
    ahead = round((0.0 - scan.angle_min) / scan.angle_increment)
    want = 3.89 - pose[0, 3] - 0.5
    assert scan.ranges[ahead] == pytest.approx(want, abs=0.01)


def test_lidar_sees_mesh_obstacles_where_they_stand(tmp_path):
    import trimesh

    from robotrial.model.world import world_from_dict

    trimesh.creation.box(extents=(0.6, 0.6, 1.0)).export(tmp_path / "crate.stl")
    world = world_from_dict(
        {
            "name": "mesh_room",
            "floor": {"size": [20, 20]},
            "obstacles": [
                {
                    "name": "crate",
                    "shape": "mesh",
                    "file": "crate.stl",
                    "pose": {"xyz": [3.0, 0.5, 0.5], "rpy": [0, 0, 0.3]},
                }
            ],
        },
        base=tmp_path,
    )
    opts = SimOptions(cameras=False, streams={"velodyne": StreamSettings(noise=0.0)})
    sim = Simulation.create(
        world, "mobile_manipulator", spawn=Pose.from_xy_yaw(0.0, 0.5, 0.0), options=opts
    )
    sim.start()
    scan = sim.latest["scan"].data
    lidar = sim.frame_pose(scan.frame)
    ahead = round((0.0 - scan.angle_min) / scan.angle_increment)
    # the crate's face towards the robot, rotated by 0.3 rad, seen along the x axis
    c, s = np.cos(0.3), np.sin(0.3)
    # ray from (lx, 0.5) along +x hits the crate boundary |R^T (p - centre)| <= 0.3
    t = np.linspace(0, 5, 50001)
    px, py = lidar[0, 3] + t - 3.0, np.zeros_like(t) + lidar[1, 3] - 0.5
    inside = (np.abs(c * px + s * py) <= 0.3) & (np.abs(-s * px + c * py) <= 0.3)
    want = t[np.argmax(inside)]
    assert scan.ranges[ahead] == pytest.approx(want, abs=0.01)
    sim.close()


def test_the_torso_lift_raises_the_arm_and_holds_it_there():
    from robotrial.sim.controllers import JointReference

    opts = SimOptions(cameras=False, streams={"velodyne": StreamSettings(enabled=False)})
    sim = Simulation.create(
        "room_a", "mobile_manipulator", spawn=Pose.from_xy_yaw(3.0, 3.5, 0.0), options=opts
    )
    sim.start()
    before = sim.frame_pose("arm_link6")[:3, 3]
    arm = {n: v for n, v in sim.joint_values().items() if n.startswith("arm_joint")}
    # the skills' command: the lift alone, at most 0.1 m/s, from rest to rest
    sim.follow(JointReference(["arm_lift_joint"], [0.0, 4.0], [[0.0], [0.3]], [[0.0], [0.0]]))
    sim.advance(5.0)
    after = sim.frame_pose("arm_link6")[:3, 3]
    assert sim.joint_values()["arm_lift_joint"] == pytest.approx(0.3, abs=0.003)
    assert after - before == pytest.approx([0.0, 0.0, 0.3], abs=0.005)
    held = {n: v for n, v in sim.joint_values().items() if n.startswith("arm_joint")}
    assert held == pytest.approx(arm, abs=0.01)  # the arm kept its pose on the way up
    sim.close()
