"""Reach maps: batched position IK from nearby seeds, and the bank-seeded question
"does the hand get there, free of collision" (planning/reach.py)."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.collision.sphere_model import CollisionChecker, Environment
from robotrial.geometry import Box, Pose
from robotrial.kinematics.chain import Kinematics
from robotrial.kinematics.ik import solve_positions
from robotrial.model import load_robot
from robotrial.planning.reach import ReachBank, reached
from robotrial.planning.task import robot_spheres


@pytest.fixture(scope="module")
def arm():
    kin = Kinematics(load_robot("manipulator_h"))
    spheres = robot_spheres(kin)
    bank = ReachBank(kin, CollisionChecker(spheres, Environment()), samples=20_000)
    return kin, spheres, bank


def test_batched_ik_puts_the_hand_on_reachable_points_and_not_on_far_ones(arm) -> None:
    kin, _, _ = arm
    rng = np.random.default_rng(1)
    qs = kin.random(rng, 60)
    targets = kin.fk(qs)[:, kin.tip, :3, 3]
    seeds = qs[:, None, :] + rng.normal(0.0, 0.15, (60, 2, kin.d))
    sol, ok = solve_positions(kin, targets, seeds, tol_pos=0.005)
    assert ok.any(axis=1).mean() > 0.9
    hands = kin.fk(sol[ok])[:, kin.tip, :3, 3]
    assert np.max(np.linalg.norm(hands - np.repeat(targets, 2, axis=0)[ok.ravel()], axis=1)) < 0.005
    far = targets + np.array([2.0, 0.0, 0.0])
    assert not solve_positions(kin, far, seeds)[1].any()
    with pytest.raises(ValueError, match="seeds must be"):
        solve_positions(kin, targets, seeds[:, :, :3])


def test_a_box_over_the_points_keeps_the_hand_out(arm) -> None:
    _, spheres, bank = arm
    xs = np.linspace(0.25, 0.45, 9)
    points = np.column_stack([xs, np.zeros_like(xs), np.full_like(xs, 0.25)])
    free = CollisionChecker(spheres, Environment())
    assert reached(bank, free, points).all()
    env = Environment()
    env.add("crate", Box((0.4, 0.3, 0.3)), Pose((0.35, 0.0, 0.2)))
    assert not reached(bank, CollisionChecker(spheres, env), points).any()
    # beyond the arm's length: no bank configuration is near, so no IK is tried
    assert not reached(bank, free, np.array([[1.5, 0.0, 0.3]])).any()
