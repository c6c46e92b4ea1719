"""Which links of a robot truly touch: MuJoCo's contacts between its real collision shapes.

Layer 2. The sphere model (collision/sphere_model.py) asks this once per robot, to learn which
link pairs can ever touch; the exact checker (collision/exact.py) maps planning values
to MuJoCo's joint positions the same way.
"""

from __future__ import annotations

import numpy as np

from robotrial.geometry import Pose
from robotrial.kinematics.chain import Kinematics
from robotrial.model.mjcf import to_mjcf
from robotrial.model.world import World


def qpos_map(kin: Kinematics, m) -> tuple[np.ndarray, ...]:
    """How planning values become MuJoCo's qpos: qpos = base, then for each driven
    joint qpos[adr] = mult * q[src] + offset (mimic joints follow their master)."""
    import mujoco

    qpos0 = np.zeros(m.nq)
    adr, src, mult, off = [], [], [], []
    values = kin.full_q(np.zeros(kin.d))
    index = {n: i for i, n in enumerate(kin.joint_names)}
    for j in kin.model.joints:
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        if jid < 0 or j.type not in ("revolute", "continuous", "prismatic"):
            continue
        a = int(m.jnt_qposadr[jid])
        master, k, c = j.name, 1.0, 0.0
        if j.mimic is not None:
            master, k, c = j.mimic.joint, j.mimic.multiplier, j.mimic.offset
        if master in index:
            adr.append(a)
            src.append(index[master])
            mult.append(k)
            off.append(c)
        else:
            qpos0[a] = k * values.get(master, 0.0) + c
    return (
        qpos0,
        np.array(adr, dtype=np.int64),
        np.array(src, dtype=np.int64),
        np.array(mult),
        np.array(off),
    )


def link_contacts(
    kin: Kinematics, qs: np.ndarray, tolerance: float = 1e-6
) -> tuple[list[set[tuple[str, str]]], set[tuple[str, str]]]:
    """Which pairs of links (sorted names) have their real collision shapes penetrating
    at each configuration of `qs`, and the pairs MuJoCo's model leaves out because they
    already touch at its zero configuration (they are never reported)."""
    import mujoco

    doc = to_mjcf(
        kin.model,
        World(name="pairs"),
        spawn=Pose(),
        actuators="none",
        self_collision=True,
        visuals=False,
    )
    m = doc.compile()
    data = mujoco.MjData(m)
    qpos0, adr, src, mult, off = qpos_map(kin, m)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) or "" for i in range(m.nbody)]
    body = np.asarray(m.geom_bodyid)
    out: list[set[tuple[str, str]]] = []
    for q in np.atleast_2d(qs):
        qpos = qpos0.copy()
        qpos[adr] = mult * q[src] + off
        data.qpos[:] = qpos
        mujoco.mj_kinematics(m, data)
        mujoco.mj_collision(m, data)
        n = data.ncon
        seen: set[tuple[str, str]] = set()
        hit = data.contact.dist[:n] < -tolerance
        for g1, g2 in data.contact.geom[:n][hit]:
            a, b = names[body[g1]], names[body[g2]]
            seen.add((min(a, b), max(a, b)))
        out.append(seen)
    return out, {(min(a, b), max(a, b)) for a, b in doc.excluded}
