"""Motion checks that skip samples where clearance proves a stretch free never pass a
motion that dense sampling finds in contact (with obstacles, padding, a held object),
and still reject every blocked one they are asked about."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.benchmarks.planning import panda_path
from robotrial.collision.sphere_model import CollisionChecker, Environment, HeldObject, RobotSpheres
from robotrial.geometry import Box, Cylinder, Pose
from robotrial.kinematics.chain import Kinematics
from robotrial.model import load_robot


@pytest.fixture(scope="module")
def spheres() -> RobotSpheres:
    return RobotSpheres(Kinematics(load_robot("desk_arm")))


def _dense_valid(checker: CollisionChecker, a: np.ndarray, b: np.ndarray) -> bool:
    """Every point of a -> b at a tenth of the checker's resolution is free."""
    n = int(np.ceil(np.max(np.abs(b - a) / checker.resolution) * 10)) + 1
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    return bool(np.all(checker.valid(a + t * (b - a))))


def _random_env(rng: np.random.Generator) -> Environment:
    env = Environment()
    env.add("table", Box((1.0, 1.0, 0.05)), Pose((0.0, 0.0, -0.03)))
    for i in range(3):
        xyz = (*rng.uniform(-0.35, 0.35, 2), rng.uniform(0.0, 0.35))
        rpy = tuple(rng.uniform(-3, 3, 3))
        env.add(f"box{i}", Box(tuple(rng.uniform(0.03, 0.15, 3))), Pose.from_xyz_rpy(xyz, rpy))
    env.add("post", Cylinder(0.03, 0.4), Pose((-0.2, 0.25, 0.2)))
    return env


@pytest.mark.parametrize("case", ["plain", "padding", "held"])
def test_motion_checks_agree_with_dense_sampling(spheres: RobotSpheres, case: str) -> None:
    rng = np.random.default_rng(7)
    kin = spheres.kin
    accepted = rejected = 0
    for _ in range(4):
        env = _random_env(rng)
        held = (
            HeldObject(Box((0.03, 0.03, 0.12)), Pose((0.0, 0.0, 0.06)).matrix(), "tcp")
            if case == "held"
            else None
        )
        checker = CollisionChecker(
            spheres, env, padding=0.01 if case == "padding" else 0.0, held=held
        )
        qs = kin.random(rng, 400)
        free = qs[checker.valid(qs)]
        a, b = free[:60], free[60:120]
        # short motions too: the ones a planner's tree extends by
        b = np.vstack([b[:30], a[30:] + 0.3 * (b[30:] - a[30:])])
        fast = checker.motions_valid(a, b)
        for i in range(len(a)):
            dense = _dense_valid(checker, a[i], b[i])
            if fast[i]:
                assert dense, f"motion {a[i]} -> {b[i]} passed but dense sampling hits"
                accepted += 1
            else:
                rejected += 1
    assert accepted > 10 and rejected > 10  # both answers were exercised


def test_pairs_marked_never_touching_stay_apart(spheres: RobotSpheres) -> None:
    """A body that one or two joints move and that cannot reach a shape is left out of
    clearances; over random configurations its spheres indeed never touch that shape."""
    env = Environment()
    env.add("table", Box((1.0, 1.0, 0.05)), Pose((0.0, 0.0, -0.03)))
    env.add("post", Cylinder(0.03, 0.4), Pose((-0.2, 0.25, 0.2)))
    checker = CollisionChecker(spheres, env)
    never = checker.never_touching
    assert never.any(), "the first link turning above the table should be marked"
    kin = spheres.kin
    qs = kin.random(np.random.default_rng(3), 3000)
    poses = kin.fk(qs)
    kinds = ["box", "cylinder"]  # the kernels' order: boxes, then cylinders
    for e, k in zip(*np.nonzero(never), strict=True):
        body = checker.bodies[checker.env_bodies[e]]
        m = poses[:, kin.link_index[body.link]]
        pts = np.einsum("nij,sj->nsi", m[:, :3, :3], body.centres) + m[:, None, :3, 3]
        local = pts - env.poses[k][:3, 3]
        if kinds[k] == "box":
            gap = np.linalg.norm(np.maximum(np.abs(local) - env.dims[k], 0.0), axis=-1)
        else:
            radial = np.maximum(np.linalg.norm(local[..., :2], axis=-1) - env.dims[k][0], 0.0)
            gap = np.hypot(radial, np.maximum(np.abs(local[..., 2]) - env.dims[k][1], 0.0))
        assert np.all(gap > body.radii), f"{body.name} touches {env.names[k]}"


@pytest.mark.parametrize("robot", ["desk_arm", "panda"])
def test_travel_bounds_hold_the_spheres_motion(robot: str) -> None:
    """A motion check trusts that over a straight motion dq no sphere of a body moves
    farther than body_rate . |dq| and no two spheres of a pair close in by more than
    pair_rate . |dq|. Measured along random motions, sampled finely: they do not."""
    spheres = RobotSpheres(Kinematics(load_robot(panda_path() if robot == "panda" else robot)))
    checker = CollisionChecker(spheres, Environment())
    kin, bodies = spheres.kin, checker.bodies
    body_rate, pair_rate = checker._travel
    rng = np.random.default_rng(11)
    t = np.linspace(0.0, 1.0, 201)[:, None]
    for _ in range(40):
        a = kin.random(rng, 1)[0]
        dq = rng.normal(size=a.shape) * rng.uniform(0.05, 1.0)
        b = np.clip(a + dq, kin.lower, kin.upper)
        poses = kin.fk(a + t * (b - a))
        world = [
            np.einsum("nij,sj->nsi", poses[:, kin.link_index[x.link], :3, :3], x.centres)
            + poses[:, kin.link_index[x.link], None, :3, 3]
            for x in bodies
        ]
        # per unit of the motion, between neighbouring samples
        travel = body_rate @ np.abs(b - a) / (len(t) - 1)
        for i, w in enumerate(world):
            moved = np.linalg.norm(np.diff(w, axis=0), axis=-1).max()
            assert moved <= travel[i] * 1.001 + 1e-12, bodies[i].name
        closing = pair_rate @ np.abs(b - a) / (len(t) - 1)
        for p, (i, j) in enumerate(checker.pairs):
            dist = np.linalg.norm(world[i][:, :, None] - world[j][:, None], axis=-1)
            assert (-np.diff(dist, axis=0)).max() <= closing[p] * 1.001 + 1e-12
