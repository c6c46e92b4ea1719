"""Plain forward kinematics, one configuration at a time: the readable reference.

Layer 2: imports `robotrial.geometry` and `robotrial.model`. The compiled, batched
kinematics are tested against this; so is the MJCF writer (MuJoCo's poses equal these).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from robotrial.model.robot import Joint, RobotModel


def joint_motion(joint: Joint, value: float) -> np.ndarray:
    """The 4x4 transform a one-DOF joint adds at `value` (rad or m) about/along its axis."""
    m = np.eye(4)
    axis = np.asarray(joint.axis, dtype=float)
    n = np.linalg.norm(axis)
    axis = axis / n if n > 0 else axis
    if joint.type in ("revolute", "continuous"):
        m[:3, :3] = Rotation.from_rotvec(axis * value).as_matrix()
    elif joint.type == "prismatic":
        m[:3, 3] = axis * value
    return m


def joint_values(model: RobotModel, q: Sequence[float] | Mapping[str, float]) -> dict[str, float]:
    """Values of every one-DOF joint, mimic joints included, from the actuated `q`."""
    if isinstance(q, Mapping):
        values = {name: float(q.get(name, 0.0)) for name in model.joint_names}
    else:
        names = model.joint_names
        if len(q) != len(names):
            raise ValueError(f"robot {model.name!r} has {len(names)} joints {names}, got {len(q)}")
        values = {n: float(v) for n, v in zip(names, q, strict=True)}
    for j in model.joints:
        if j.mimic is not None:
            values[j.name] = j.mimic.multiplier * values.get(j.mimic.joint, 0.0) + j.mimic.offset
    return values


def link_poses(
    model: RobotModel,
    q: Sequence[float] | Mapping[str, float],
    base: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """World (or `base`-relative) 4x4 pose of every link for joint values `q`.

    Floating and planar joints are taken at their origin (their state is the base pose).
    """
    values = joint_values(model, q)
    poses = {model.root: np.eye(4) if base is None else np.asarray(base, dtype=float)}
    for j in model.topological_joints():
        m = poses[j.parent] @ j.origin.matrix()
        if j.name in values:
            m = m @ joint_motion(j, values[j.name])
        poses[j.child] = m
    return poses
