"""Known planning problems: the g2rViewer desk task and harder scenes for any arm.

Layer 3. A problem is a robot, obstacles, and start and goal configurations (found by
IK from end-effector targets, deterministically). Benchmarks and tests share them.
Scenes scale with the arm: positions are fractions of its reach R (the farthest the end
effector gets from the shoulder) and its shoulder height.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import CollisionChecker, Environment, RobotSpheres
from robotrial.geometry import Box, Cylinder, Pose, Shape
from robotrial.kinematics.chain import Kinematics
from robotrial.kinematics.ik import solve_ik
from robotrial.model.robot import RobotModel
from robotrial.model.world import World

Obstacles = list[tuple[str, Shape, Pose]]

DOWN = np.diag([1.0, -1.0, -1.0])  # tool z pointing down
FORWARD = Rotation.from_euler("y", np.pi / 2).as_matrix()  # tool z pointing along +x

# the desk task of the g2rViewer paper: obstacle C, start and goal near the table top
DESK_OBSTACLE = ("C", Box((0.1, 0.1, 0.2)), Pose((0.2, 0.0, 0.15)))
DESK_START_XYZ = (0.15, -0.15, 0.02)
DESK_GOAL_XYZ = (0.18, 0.2, 0.02)


@dataclass
class PlanningProblem:
    """A robot among obstacles with a start and a goal configuration."""

    name: str
    description: str
    robot: RobotModel
    kin: Kinematics
    spheres: RobotSpheres
    obstacles: Obstacles
    start: np.ndarray
    goal: np.ndarray
    world: World | None = None
    env: Environment = field(default_factory=Environment)

    def checker(self, padding: float = 0.0) -> CollisionChecker:
        return CollisionChecker(self.spheres, self.env, padding)

    def exact(self, checker: CollisionChecker | None = None) -> ExactChecker:
        return ExactChecker(checker or self.checker(), self.world, self.obstacles)


def reach(kin: Kinematics, samples: int = 2000, seed: int = 0) -> tuple[float, np.ndarray]:
    """The arm's reach (m) from its shoulder, and the shoulder position (the frame of the
    second planning joint), over random configurations."""
    rng = np.random.default_rng(seed)
    poses = kin.fk(kin.random(rng, samples))
    second = int(np.nonzero(kin.src == 1)[0][0])
    shoulder = poses[0, second, :3, 3]
    return float(np.max(np.linalg.norm(poses[:, kin.tip, :3, 3] - shoulder, axis=1))), shoulder


def _target(xyz, rot: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rot
    t[:3, 3] = xyz
    return t


def _configuration(
    kin: Kinematics, checker: CollisionChecker, target: np.ndarray, seed: int, what: str
) -> np.ndarray:
    """A collision-free IK solution for `target` (pose, else position only), nearest the
    middle of the joint ranges turned toward the target (the arm facing it, not
    reaching over its back)."""
    rng = np.random.default_rng(seed)
    facing = 0.5 * (kin.lower + kin.upper)
    facing[0] = np.clip(np.arctan2(target[1, 3], target[0, 3]), kin.lower[0], kin.upper[0])
    for tgt in (target, target[:3, 3]):
        ik = solve_ik(kin, tgt, facing, rng=rng, restarts=256, accept=checker.valid)
        if ik.success:
            return ik.q
    raise ValueError(f"problem {what}: no collision-free IK solution for {target[:3, 3]}")


def _build(
    name: str,
    description: str,
    robot: RobotModel,
    obstacles: Obstacles,
    start: np.ndarray,
    goal: np.ndarray,
    world: World | None = None,
    spheres: RobotSpheres | None = None,
    floor: bool = True,
    seed: int = 0,
) -> PlanningProblem:
    kin = spheres.kin if spheres is not None else Kinematics(robot)
    spheres = spheres or RobotSpheres(kin)
    env = Environment()
    if world is not None:
        for ob in world.static_bodies:
            env.add(ob.name, ob.geometry, ob.pose)
    elif floor:
        obstacles = [("floor", Box((4.0, 4.0, 0.1)), Pose((0.0, 0.0, -0.05))), *obstacles]
    for n, s, p in obstacles:
        env.add(n, s, p)
    checker = CollisionChecker(spheres, env)
    qs = _configuration(kin, checker, start, seed, f"{name} start")
    qg = _configuration(kin, checker, goal, seed + 1, f"{name} goal")
    return PlanningProblem(name, description, robot, kin, spheres, obstacles, qs, qg, world, env)


def desk_task(
    robot: RobotModel, world: World, spheres: RobotSpheres | None = None
) -> PlanningProblem:
    """The g2rViewer experiment: from near (0.15, -0.15, 0.02) to near (0.18, 0.2, 0.02)
    around obstacle C (0.1 x 0.1 x 0.2 m at (0.2, 0, 0.15)), gripper pointing down."""
    return _build(
        "desk",
        "g2rViewer desk task: around obstacle C, from one side of it to the other",
        robot,
        [DESK_OBSTACLE],
        _target(DESK_START_XYZ, DOWN),
        _target(DESK_GOAL_XYZ, DOWN),
        world=world,
        spheres=spheres,
    )


def _box(name: str, size, xyz) -> tuple[str, Shape, Pose]:
    return (name, Box(tuple(float(v) for v in size)), Pose(tuple(float(v) for v in xyz)))  # type: ignore[arg-type]


def obstacle_scene(r: float, h: float) -> tuple[Obstacles, np.ndarray, np.ndarray]:
    """A wall-like box between start and goal (the platform paper's obstacle avoidance)."""
    obs = [_box("wall", (0.3 * r, 0.15 * r, h + 0.6 * r), (0.6 * r, 0, (h + 0.6 * r) / 2))]
    return (
        obs,
        _target((0.6 * r, -0.45 * r, h * 0.6), DOWN),
        _target((0.6 * r, 0.45 * r, h * 0.6), DOWN),
    )


def shelf_scene(r: float, h: float) -> tuple[Obstacles, np.ndarray, np.ndarray]:
    """A shelf in front; the goal is inside its middle compartment, reached horizontally."""
    x0, x1, w, t = 0.5 * r, 0.95 * r, 0.45 * r, 0.03 * r
    levels = (h - 0.25 * r, h + 0.15 * r, h + 0.55 * r)
    top = levels[-1] + t
    obs = [
        _box(f"board{i}", (x1 - x0, 2 * w, t), ((x0 + x1) / 2, 0, z)) for i, z in enumerate(levels)
    ]
    obs += [
        _box("side_left", (x1 - x0, t, top), ((x0 + x1) / 2, w, top / 2)),
        _box("side_right", (x1 - x0, t, top), ((x0 + x1) / 2, -w, top / 2)),
        _box("back", (t, 2 * w, top), (x1, 0, top / 2)),
    ]
    goal_z = (levels[0] + levels[1]) / 2
    return (
        obs,
        _target((0.3 * r, -0.6 * r, h + 0.3 * r), DOWN),
        _target((0.72 * r, 0, goal_z), FORWARD),
    )


def cage_scene(r: float, h: float) -> tuple[Obstacles, np.ndarray, np.ndarray]:
    """The arm inside a cage of pillars, a roof and rails; the goal is outside, through a
    window between a rail and the roof."""
    a, t = 0.5 * r, 0.05 * r
    roof, rail = h + 0.55 * r, h + 0.05 * r
    obs: Obstacles = [
        (f"pillar{i}", Cylinder(t, roof), Pose((sx * a, sy * a, roof / 2)))
        for i, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1)))
    ]
    obs.append(_box("roof", (2 * a + 2 * t, 2 * a + 2 * t, t), (0, 0, roof + t / 2)))
    obs += [
        _box("rail_front", (t, 2 * a, t), (a, 0, rail)),
        _box("rail_back", (t, 2 * a, t), (-a, 0, rail)),
        _box("rail_left", (2 * a, t, t), (0, a, rail)),
        _box("rail_right", (2 * a, t, t), (0, -a, rail)),
    ]
    return (
        obs,
        _target((0.25 * r, -0.25 * r, h * 0.5), DOWN),
        _target((0.8 * r, 0.15 * r, (rail + roof) / 2), FORWARD),
    )


def under_table_scene(r: float, h: float) -> tuple[Obstacles, np.ndarray, np.ndarray]:
    """A low table in front; the goal is under it, the start above it."""
    top_z, t = h + 0.25 * r, 0.03 * r
    x0, x1, w = 0.4 * r, 1.0 * r, 0.5 * r
    obs = [_box("table_top", (x1 - x0, 2 * w, t), ((x0 + x1) / 2, 0, top_z))]
    obs += [
        _box(f"leg{i}", (t, t, top_z), (x, y, top_z / 2))
        for i, (x, y) in enumerate(((x0, w), (x0, -w), (x1, w), (x1, -w)))
    ]
    return (
        obs,
        _target((0.65 * r, 0, top_z + 0.35 * r), DOWN),
        _target((0.55 * r, 0, 0.55 * top_z), FORWARD),
    )


SCENES: dict[str, Callable[[float, float], tuple[Obstacles, np.ndarray, np.ndarray]]] = {
    "obstacle": obstacle_scene,
    "shelf": shelf_scene,
    "cage": cage_scene,
    "under_table": under_table_scene,
}


def scene_problem(
    robot: RobotModel, scene: str, spheres: RobotSpheres | None = None, seed: int = 0
) -> PlanningProblem:
    """One of SCENES built around `robot` standing on the floor at the origin."""
    kin = spheres.kin if spheres is not None else Kinematics(robot)
    r, shoulder = reach(kin)
    obstacles, start, goal = SCENES[scene](r, float(shoulder[2]))
    doc = (SCENES[scene].__doc__ or "").strip().splitlines()[0]
    return _build(scene, doc, robot, obstacles, start, goal, spheres=spheres, seed=seed)
