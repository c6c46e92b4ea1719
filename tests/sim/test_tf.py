"""The TF tree: every frame connects to the base, and TF agrees with MuJoCo's poses."""

from __future__ import annotations

import mujoco
import numpy as np

from robotrial.geometry import Pose
from robotrial.sim.tf import chain_to_root


def test_every_frame_connects_to_the_root(boxroom):
    sim = boxroom.make_sim()
    transforms = sim.tf.static + sim.tf.dynamic(sim.joint_values())
    children = [t.child for t in transforms]
    assert len(children) == len(set(children)), "a frame with two parents"
    for frame in sim.tf.frames:
        chain_to_root(transforms, frame, sim.robot.root)


def test_tf_agrees_with_mujoco(boxroom):
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(0.7, -0.4, 1.1))
    sim.set_joint_targets({"j1": 0.8, "j2": -0.5})
    sim.advance(1.0)
    w = sim.world
    for site in ("lidar", "imu"):
        sid = mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_SITE, site)
        pose = sim.frame_pose(sim.tf.sensor_frames[site])
        assert np.allclose(pose[:3, 3], w.data.site_xpos[sid], atol=1e-6)
        assert np.allclose(pose[:3, :3], w.data.site_xmat[sid].reshape(3, 3), atol=1e-6)
    hand = sim.frame_pose("hand")
    assert np.allclose(hand, w.body_pose("hand"), atol=1e-6)
