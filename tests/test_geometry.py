"""Pose's own rotation arithmetic against scipy's Rotation, which it no longer imports."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from robotrial.geometry import Pose, quat_from_rotation


def test_roll_pitch_yaw_matrices_and_quaternions_agree_with_scipy() -> None:
    rng = np.random.default_rng(0)
    for rpy in rng.uniform(-np.pi, np.pi, (200, 3)):
        pose = Pose.from_xyz_rpy((0.1, -0.2, 0.3), rpy)
        expected = Rotation.from_euler("xyz", rpy)
        np.testing.assert_allclose(pose.rotation(), expected.as_matrix(), atol=1e-12)
        np.testing.assert_allclose(pose.rpy, expected.as_euler("xyz"), atol=1e-9)
        m = expected.as_matrix()
        q = np.array(quat_from_rotation(m))
        np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), m, atol=1e-12)
    yaw = Pose.from_xy_yaw(1.0, 2.0, 2.5)
    np.testing.assert_allclose(
        yaw.rotation(), Rotation.from_euler("z", 2.5).as_matrix(), atol=1e-12
    )
    np.testing.assert_allclose(Pose.from_matrix(pose.matrix()).matrix(), pose.matrix(), atol=1e-12)
