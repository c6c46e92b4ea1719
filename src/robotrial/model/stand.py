"""Where a robot stands in a world: on its spawn pose, or lifted onto the floor and moved
back from the furniture when its own geometry reaches below the floor (layer 1).

A world's spawn pose puts the robot's root link there. For an arm bolted to a table top
that is right; a humanoid or a robot on a tall base has its root (a pelvis, a torso) high
above its feet, and at the spawn its legs would reach through the table and the floor.
`stand` lifts such a robot until its lowest collision geometry (all joints at zero)
rests on the floor, then moves it back (along the spawn's -x: robots face +x) until no
part of it overlaps the world's static bodies. The simulator, the planner and the page
all place the robot by this one answer.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
from robotrial.model.anatomy import has_wheels
from robotrial.model.meshes import load_mesh
from robotrial.model.robot import RobotModel
from robotrial.model.world import World

MARGIN = 0.05  # m: kept between the moved robot and any static body
BELOW = 0.01  # m: geometry this far under the floor still counts as standing on it
STEP = 0.01  # m: the step of the move back from the furniture
MOST = 3.0  # m: the farthest move back tried


def shape_points(shape: Shape) -> np.ndarray:
    """Points whose hull holds `shape`, in its own frame (a mesh's vertices)."""
    if isinstance(shape, Mesh):
        return np.asarray(load_mesh(shape).vertices, dtype=float)
    if isinstance(shape, Box):
        h = np.asarray(shape.size) / 2
    elif isinstance(shape, Cylinder):
        h = np.array([shape.radius, shape.radius, shape.length / 2])
    elif isinstance(shape, Sphere):
        h = np.full(3, shape.radius)
    else:
        return np.zeros((0, 3))
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return corners * h


def _moved(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    return points @ pose[:3, :3].T + pose[:3, 3]


def robot_parts(robot: RobotModel) -> list[np.ndarray]:
    """Each collision shape's points in the root's frame with all joints at zero."""
    frames = {robot.root: np.eye(4)}
    for j in robot.topological_joints():
        frames[j.child] = frames[j.parent] @ j.origin.matrix()
    parts = []
    for link in robot.links:
        for c in link.collisions:
            pts = shape_points(c.geometry)
            if len(pts):
                parts.append(_moved(pts, frames[link.name] @ c.origin.matrix()))
    return parts


def _overlaps(lo: np.ndarray, hi: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray]]) -> bool:
    return any(np.all(lo < b_hi + MARGIN) and np.all(hi > b_lo - MARGIN) for b_lo, b_hi in boxes)


def stand(robot: RobotModel, world: World | None, spawn: Pose | None = None) -> Pose:
    """The robot's root pose relative to `spawn` (default: the world's default spawn):
    the identity unless its geometry reaches below the floor (see the module doc). A robot
    that drives stands on its wheels where the spawn says."""
    if world is None or robot.metadata.get("drive") or has_wheels(robot):
        return Pose()
    spawn = world.spawn("default") if spawn is None else spawn
    parts = robot_parts(robot)
    if not parts:
        return Pose()
    at = spawn.matrix()
    lowest = min(float(_moved(p, at)[:, 2].min()) for p in parts)
    if lowest >= world.floor.height - BELOW:
        return Pose()
    lift = world.floor.height - lowest
    boxes = []
    for body in world.static_bodies:
        pts = _moved(shape_points(body.geometry), body.pose.matrix())
        if len(pts):
            boxes.append((pts.min(axis=0), pts.max(axis=0)))
    for back in np.arange(0.0, MOST + STEP / 2, STEP):
        offset = Pose((-float(back), 0.0, lift))
        placed = [_moved(p, at @ offset.matrix()) for p in parts]
        if not any(_overlaps(p.min(axis=0), p.max(axis=0), boxes) for p in placed):
            return offset
    return Pose((0.0, 0.0, lift))


def seen_from(world: World, offset: Pose) -> World:
    """`world` in the frame of a robot standing at `offset` from the world's origin (a
    shift, as `stand` answers): what a planner that works in the robot's frame sees."""
    if offset.is_identity():
        return world
    back = offset.inverse()
    x, y, z = back.xyz
    fl = world.floor
    return replace(
        world,
        floor=replace(fl, center=(fl.center[0] + x, fl.center[1] + y), height=fl.height + z),
        walls=tuple(replace(b, pose=back @ b.pose) for b in world.walls),
        obstacles=tuple(replace(b, pose=back @ b.pose) for b in world.obstacles),
        objects=tuple(replace(b, pose=back @ b.pose) for b in world.objects),
    )


__all__ = ["robot_parts", "seen_from", "shape_points", "stand"]
