"""The particle filter's tiled maps: each particle's map is what a grid of its own would
hold, children share their parents' tiles, and matching all particles at once recovers
their offsets (GMapping's proposal and weights); one tiled map (Hector's and the pose
graph's) holds what a grid would, costs only the tiles scans reach, and is matched on as
a grid is."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.matcher import ScanMatcher, likelihood
from robotrial.slam.scan import Beams, transform_points
from robotrial.slam.tiled import TILE, TiledGrid, TiledMaps

from .test_matcher import cast


def fan_scan(pose: np.ndarray, n: int = 720) -> Beams:
    """A scan of the test room from `pose` (base frame, scan order, every beam a hit)."""
    return Beams((0.0, 0.0), cast(pose, n), np.ones(n, bool), 2 * np.pi / n)


POSES = np.array([[0.0, 0.0, 0.0], [-1.0, -0.5, 0.3], [0.5, -0.8, -0.2]])


def test_each_map_holds_what_a_grid_of_its_own_would():
    maps = TiledMaps(len(POSES), 0.05)
    scan = fan_scan(POSES[0])
    maps.write(POSES, scan)
    for k, pose in enumerate(POSES):
        one = LogOddsGrid(0.05)
        one.integrate(pose[:2], transform_points(pose, scan.ends), scan.hit, scan.angle_step)
        got = maps.dense(k)
        # The same cells, in frames a whole number of cells apart; a beam's end is
        # transformed in another order here, so one in fifty cells on a cell boundary
        # may take its neighbour's free step.
        dr = round((one.origin[1] - got.origin[1]) / 0.05)
        dc = round((one.origin[0] - got.origin[0]) / 0.05)
        h, w = one.shape
        a = got.logodds[dr : dr + h, dc : dc + w]
        seen = (a != 0) | (one.logodds != 0)
        assert np.isclose(a, one.logodds)[seen].mean() > 0.97
        assert np.array_equal(a > 0, one.logodds > 0)
        assert abs(np.count_nonzero(got.logodds) - np.count_nonzero(one.logodds)) < 10


def test_children_share_their_parents_tiles_until_they_write():
    maps = TiledMaps(4, 0.05)
    maps.write(np.zeros((4, 3)), fan_scan(np.zeros(3)))
    own = maps.tiles_held
    maps.resample(np.array([0, 0, 0, 0]))
    # The other three maps' tiles are free again; the four children hold one set.
    assert maps.tiles_held == own // 4
    before = maps.dense(0).logodds.copy()
    moved = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.3, 0.1, 0.2]])
    maps.write(moved, fan_scan(moved[3]))
    # Child 3's write did not reach child 0's copy of the shared tiles (0 wrote too).
    assert not np.array_equal(maps.dense(0).logodds, maps.dense(3).logodds)
    assert np.array_equal(maps.dense(0).logodds, maps.dense(1).logodds)
    assert maps.tiles_held < 4 * own // 4 + 4 * (maps.index.shape[1] * maps.index.shape[2])
    assert maps.nbytes >= maps.tiles_held * TILE * TILE * 4
    assert not np.array_equal(before, maps.dense(0).logodds)


def test_all_particles_matched_at_once_recover_their_offsets():
    true = np.array([-0.3, 0.2, 0.1])
    offsets = np.array([(0.10, -0.08, 0.05), (-0.15, 0.05, -0.08), (0.05, 0.05, 0.12)])
    maps = TiledMaps(3, 0.05)
    for pose in POSES:
        for _ in range(3):
            maps.write(np.repeat(pose[None, :], 3, axis=0), fan_scan(pose, 360))
    scan = cast(true, 720)
    coarse, origin = maps.coarse(0, (-3.0, -3.0, 3.0, 3.0), 3)
    poses, loglik = maps.match(coarse, origin, scan, scan, true + offsets, (1.0, 1.0, 1.0), 10)
    assert np.all(np.hypot(*(poses[:, :2] - true[:2]).T) < 0.015)
    assert np.all(np.abs(poses[:, 2] - true[2]) < 0.01)
    # The weights are the likelihood of each matched pose on its own map.
    for k, (pose, ll) in enumerate(zip(poses, loglik, strict=True)):
        assert ll == pytest.approx(likelihood(maps.dense(k), scan, pose)[1])
    # With the scan: it is written into each map at its matched pose.
    maps.match(coarse, origin, scan, scan, true + offsets, (1.0, 1.0, 1.0), 10,
               scan=fan_scan(true))  # fmt: skip
    for k in range(3):
        g = maps.dense(k)
        ends = transform_points(poses[k], scan)
        r = np.floor((ends[:, 1] - g.origin[1]) / 0.05).astype(int)
        c = np.floor((ends[:, 0] - g.origin[0]) / 0.05).astype(int)
        assert np.mean(g.logodds[r, c] > 0) > 0.95


def test_one_tiled_map_holds_a_grids_cells_and_costs_only_the_tiles_scans_reach():
    grid, tiled = LogOddsGrid(0.05), TiledGrid(0.05)
    for pose in POSES:
        ends = transform_points(pose, cast(pose))
        for g in (grid, tiled):
            g.integrate(pose[:2], ends, np.ones(len(ends), bool))
    dr = round((grid.origin[1] - tiled.origin[1]) / 0.05)
    dc = round((grid.origin[0] - tiled.origin[0]) / 0.05)
    h, w = grid.shape
    got = tiled.ros_values()[dr : dr + h, dc : dc + w]
    # Cells on a cell boundary may differ (one in five hundred), hardly any wall.
    assert (got == grid.ros_values()).mean() > 0.995
    assert np.count_nonzero((got == 100) != (grid.ros_values() == 100)) <= 3
    # The same room seen again 300 m away: the map's box spans 300 m (36 million
    # cells), its memory the two rooms' tiles.
    far = np.array([300.0, 0.0, 0.0])
    ends = transform_points(far, cast(np.zeros(3)))
    tiled.integrate(far[:2], ends, np.ones(len(ends), bool))
    assert tiled.extent()[2] - tiled.extent()[0] > 300
    assert tiled.nbytes < 3 * 4 * grid.logodds.size


def test_the_matcher_recovers_known_offsets_on_a_tiled_map():
    tiled = TiledGrid(0.05)
    for pose in POSES:
        ends = transform_points(pose, cast(pose))
        for _ in range(3):
            tiled.integrate(pose[:2], ends, np.ones(len(ends), bool))
    true = np.array([-0.3, 0.2, 0.1])
    scan = cast(true)
    matcher = ScanMatcher(levels=3, iterations=10)
    for offset in [(0.10, -0.08, 0.05), (-0.15, 0.05, -0.08), (0.0, 0.2, 0.0)]:
        got = matcher.match(tiled, scan, true + np.array(offset)).pose
        assert np.hypot(*(got[:2] - true[:2])) < 0.015
        assert abs(got[2] - true[2]) < 0.01


def test_along_a_corridor_the_match_keeps_the_odometry_prediction_not_the_draw():
    # Two walls 2 m apart along x: the scan fixes y and yaw, the motion prior alone says
    # where along the corridor the robot is, and that is its mean, the prediction.
    a = np.linspace(-np.pi, np.pi, 720, endpoint=False)
    hit = np.abs(np.sin(a)) > 0.2
    r = np.where(hit, 1.0 / np.maximum(np.abs(np.sin(a)), 0.2), 5.0)
    ends = np.c_[r * np.cos(a), r * np.sin(a)]
    maps = TiledMaps(1, 0.05)
    for x in np.arange(-3.0, 3.01, 0.5):
        maps.write(np.array([[x, 0.0, 0.0]]), Beams((0.0, 0.0), ends, hit, a[1] - a[0]))
    pts = ends[hit & (np.abs(ends[:, 0]) < 3.0)]
    predicted = np.array([[0.0, 0.0, 0.0]])
    draw = np.array([[0.3, 0.06, 0.04]])
    coarse, origin = maps.coarse(0, (-6.0, -3.0, 6.0, 3.0), 3)
    got, _ = maps.match(coarse, origin, pts, pts, draw, (0.2, 0.2, 0.2), 10, prior_means=predicted)
    assert abs(got[0, 0]) < 0.03  # the prediction's x, not the draw's 0.3
    assert abs(got[0, 1]) < 0.02 and abs(got[0, 2]) < 0.01  # the walls fix y and yaw
    # Centred on the draw, the prior holds the draw's x: its noise stays in the estimate.
    held, _ = maps.match(coarse, origin, pts, pts, draw, (0.2, 0.2, 0.2), 10)
    assert abs(held[0, 0] - 0.3) < 0.03
