"""The arm's collision scene from depth frames (onboard/voxels.py): the robot cut out of
what it sees, voxels marked and seen through, table tops as slabs, boxes for the planner;
and the planner's checker for such scenes (collision/voxels.py) agreeing with the general
one."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.collision.sphere_model import CollisionChecker, Environment
from robotrial.collision.voxels import VoxelChecker
from robotrial.geometry import Box, Pose
from robotrial.kinematics.reference import link_poses
from robotrial.model import load_robot
from robotrial.onboard.camera import RgbdFrame
from robotrial.onboard.catalogue import Catalogue
from robotrial.onboard.perception import ObjectDetector
from robotrial.onboard.voxels import RobotBody, VoxelMap, merge_runs
from robotrial.planning.task import TaskPlanner

# a camera 1 m up looking along the base's +x (optical z), image 80 x 60
LOOK = np.eye(4)
LOOK[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
LOOK[:3, 3] = (0.0, 0.0, 1.0)
K = (60.0, 60.0, 39.5, 29.5)


def wall_at(distance: float) -> RgbdFrame:
    return RgbdFrame(np.full((60, 80), distance, dtype=np.float32), None, K, LOOK, 0.0)


@pytest.mark.parametrize("seed", range(20))
def test_merged_boxes_cover_exactly_the_voxels(seed: int) -> None:
    rng = np.random.default_rng(seed)
    keys = np.argwhere(rng.random((7, 6, 5)) < 0.6) + rng.integers(-20, 20, 3)
    cover = {}
    for lo, hi in merge_runs(keys):
        for k in np.ndindex(*(hi - lo + 1)):
            key = tuple(int(v) for v in lo + np.array(k))
            cover[key] = cover.get(key, 0) + 1
    assert cover == {tuple(int(v) for v in k): 1 for k in keys}
    assert len(merge_runs(keys)) < len(keys)


def test_a_wall_seen_then_seen_through_is_forgotten() -> None:
    vm = VoxelMap()
    near = wall_at(1.0)
    vm.integrate(near, near.points()[0], np.zeros(3))
    assert len(vm) > 0 and np.allclose(vm.centres()[:, 0], 1.01, atol=0.011)
    far = wall_at(2.0)
    vm.integrate(far, far.points()[0], np.zeros(3))
    assert np.all(vm.centres()[:, 0] > 1.9)  # the first wall is gone, the second is there
    # on the map: the base turned and moved, the voxels stay where they were in the world
    boxes = vm.boxes(np.array([1.0, 0.0, np.pi / 2]), np.zeros(3), 5.0)
    assert boxes and all(b.size[0] > 0 for _, b, _ in boxes)
    centres = np.array([p.xyz for _, _, p in boxes])
    assert np.allclose(centres[:, 1], -1.0, atol=0.02)  # 1 m ahead of the old pose: to the right


def test_a_table_top_becomes_a_slab_at_the_fitted_height() -> None:
    rng = np.random.default_rng(0)
    xy = rng.uniform([0.6, -0.4], [1.4, 0.4], (6000, 2))
    pts = np.column_stack([xy, 0.753 + rng.normal(0, 0.002, len(xy))])
    frame = RgbdFrame(np.full((60, 80), np.nan, dtype=np.float32), None, K, LOOK, 0.0)
    surfaces = ObjectDetector(Catalogue([])).surfaces(pts)
    vm = VoxelMap()
    vm.integrate(frame, pts, np.zeros(3), surfaces)
    assert len(vm) == 0  # no voxels: the top is a slab
    boxes = vm.boxes(np.zeros(3), np.array([1.0, 0.0, 0.75]), 1.0)
    tops = [p.xyz[2] + b.size[2] / 2 for _, b, p in boxes]
    assert 0 < len(boxes) < 12 and np.allclose(tops, 0.753, atol=0.004)


def test_the_robot_cuts_its_own_body_out_of_what_it_sees() -> None:
    robot = load_robot("mobile_manipulator")
    stow = robot.metadata["poses"]["stow"]
    body = RobotBody(robot)
    poses = link_poses(robot, stow)
    on_arm = poses["arm_link4"][:3, 3]
    on_base = poses["base_link"][:3, 3] + np.array([0.0, 0.0, 0.1])
    away = np.array([1.2, 0.0, 0.8])
    mask = body.mask(np.array([on_arm, on_base, away]), stow)
    assert mask.tolist() == [True, True, False]
    held = [(Box((0.1, 0.1, 0.1)), Pose((1.2, 0.0, 0.8)).matrix())]
    assert body.mask(away[None], stow, held)[0]


def test_the_voxel_checker_agrees_with_the_general_one() -> None:
    planner = TaskPlanner(load_robot("mobile_manipulator"), validate=False)
    rng = np.random.default_rng(1)
    env = Environment()
    for i in range(150):
        size = tuple(float(v) for v in rng.uniform(0.02, 0.08, 3))
        env.add(
            f"v/{i}",
            Box(size),
            Pose(tuple(float(v) for v in rng.uniform([0.3, -0.8, 0.2], [1.3, 0.8, 1.2]))),
        )
    general = CollisionChecker(planner.spheres, env)
    voxel = VoxelChecker(planner.spheres, env)
    assert np.array_equal(general.never_touching, voxel.never_touching)
    assert general.never_touching.any()
    qs = planner.kin.random(rng, 3000)
    assert np.array_equal(general.valid(qs), voxel.valid(qs))
    a, b = qs[:200], qs[200:400]
    ok = general.valid(a)
    assert np.array_equal(general.motions_valid(a[ok], b[ok]), voxel.motions_valid(a[ok], b[ok]))
