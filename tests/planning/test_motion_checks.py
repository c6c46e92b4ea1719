"""Motion checks that skip samples where clearance proves a stretch free never pass a
motion that dense sampling finds in contact (with obstacles, padding, a held object),
and still reject every blocked one they are asked about."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from robotrial.benchmarks.planning import panda_path
from robotrial.collision import kernels
from robotrial.collision.sphere_model import CollisionChecker, Environment, HeldObject, RobotSpheres
from robotrial.geometry import Box, Cylinder, Pose
from robotrial.kinematics.chain import Kinematics, fk_single
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


@nb.njit
def _speeds(q, dq, packed_config):
    """The motion checks' speeds at `q` along `dq`: per body, per pair (its second body
    seen from its first), and the sphere centres."""
    kin, bodies, _, pairs, _, _, buf = kernels.config_checks(packed_config)
    parent, origin, jtype, axis, src, mult, offset, const = kin
    poses, centres, bound_c, ready, motion = (
        buf.poses,
        buf.centres,
        buf.bound_c,
        buf.ready,
        buf.motion,
    )
    fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, poses)
    kernels._bounds(poses, bodies.link, bodies.bound_local, bound_c, ready, buf.fine_ready)
    for b in range(bodies.link.shape[0]):
        kernels._place(
            b, poses, bodies.link, bodies.sphere_local, bodies.start, bodies.end, centres, ready
        )
    for j in range(dq.shape[0]):
        motion[6, j] = dq[j]
    kernels._twists(kin, poses, motion)
    body = np.empty(bodies.link.shape[0])
    for b in range(body.shape[0]):
        body[b] = kernels._body_speed(b, poses, bodies.link, bound_c, bodies.bound_r, motion)
    pair = np.empty(pairs.shape[0])
    for p in range(pair.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        pair[p] = kernels._pair_speed(a, b, poses, bodies.link, bound_c, bodies.bound_r, motion)
    return body, pair, centres.copy()


@pytest.mark.parametrize("robot", ["desk_arm", "panda"])
def test_speeds_at_a_configuration_bound_the_spheres_motion(robot: str) -> None:
    """Inside a stretch the motion check trusts each body's speed at the configuration
    it looks at, grown by its bound on acceleration. Measured by finite differences
    along random motions: no sphere moves faster, no pair of spheres closes in faster,
    and no speed changes faster than that."""
    spheres = RobotSpheres(Kinematics(load_robot(panda_path() if robot == "panda" else robot)))
    args = kernels.MotionChecks(*CollisionChecker(spheres, Environment()).kernel_args())
    body_rate, config = args.body_rate, kernels.ConfigChecks(*args.config)
    bodies, pairs = kernels.Bodies(*config.bodies), config.pairs
    starts, ends = bodies.start, bodies.end
    rng = np.random.default_rng(11)
    h = 1e-4
    for _ in range(200):
        q = spheres.kin.random(rng, 1)[0]
        dq = rng.normal(size=q.shape) * rng.uniform(0.05, 1.0)
        body, pair, c0 = _speeds(q, dq, args.config)
        cp = _speeds(q + h * dq, dq, args.config)[2]
        cm = _speeds(q - h * dq, dq, args.config)[2]
        velocity = (cp - cm) / (2 * h)
        accel = np.linalg.norm((cp - 2 * c0 + cm) / h**2, axis=0)
        swing = bodies[7] @ np.abs(dq)
        growth = body_rate @ (np.abs(dq) * (np.abs(dq) + 2 * swing))
        for b in range(len(body)):
            s = slice(starts[b], ends[b])
            assert np.linalg.norm(velocity[:, s], axis=0).max() <= body[b] * 1.001 + 1e-9
            assert accel[s].max() <= growth[b] * 1.01 + 1e-6
        for p, (i, j) in enumerate(pairs):
            gaps = c0[:, starts[i] : ends[i], None] - c0[:, None, starts[j] : ends[j]]
            rel = velocity[:, starts[i] : ends[i], None] - velocity[:, None, starts[j] : ends[j]]
            closing = -np.sum(gaps * rel, axis=0) / np.linalg.norm(gaps, axis=0)
            assert closing.max() <= pair[p] * 1.001 + 1e-9
