"""The floor area a mobile robot covers, read from its simulation (layer 2).

The navigation costmaps (and the home verdict) take the robot as a rectangle about its
base frame; this is where that rectangle comes from: the collision geometry of every
robot body (or of the base's links only), in the base frame, at the simulation's current
joint values.
"""

from __future__ import annotations

from collections.abc import Collection

import mujoco
import numpy as np

from robotrial.sim.simulation import Simulation


def is_env_body(m: mujoco.MjModel, body: int) -> bool:
    """Whether a body belongs to the world's movable objects, not to the robot."""
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(body)) or ""
    return name.startswith("object/")


def base_extent(sim: Simulation, links: Collection[str] | None = None) -> tuple[float, float]:
    """Length (x) and width (y) of the box around the robot's collision geoms in its base
    frame, symmetric about the base origin (as the navigation planners assume). With
    `links`, only the geoms of those links count (a base without the arm it carries)."""
    m, d = sim.world.model, sim.world.data
    base = sim.world.body_pose(sim.world.base_body)
    inv = np.linalg.inv(base)
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    bodies = None
    if links is not None:
        bodies = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in links}
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == 0 or m.geom_contype[g] == 0 or is_env_body(m, m.geom_bodyid[g]):
            continue
        if bodies is not None and m.geom_bodyid[g] not in bodies:
            continue
        rot = d.geom_xmat[g].reshape(3, 3)
        c, half = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        pts = d.geom_xpos[g] + (c + corners * half) @ rot.T
        local = (pts - base[:3, 3]) @ inv[:3, :3].T
        lo = np.minimum(lo, local[:, :2].min(axis=0))
        hi = np.maximum(hi, local[:, :2].max(axis=0))
    if not np.all(np.isfinite(lo)):
        raise ValueError(
            f"robot {sim.robot.name!r} has no collision geometry to take a footprint from"
        )
    half = np.maximum(np.abs(lo), np.abs(hi))
    return 2 * float(half[0]), 2 * float(half[1])
