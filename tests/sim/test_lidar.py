"""The simulated VLP-16 and its 2D scan against analytic geometry of a box room."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.geometry import Pose
from robotrial.sim.lidar import LidarPattern, ScanConfig, laserscan_from_points
from robotrial.sim.simulation import SimOptions, StreamSettings


def box_distance(
    origin: np.ndarray, angles: np.ndarray, HALF_X: float, HALF_Y: float
) -> np.ndarray:
    """Horizontal distance from `origin` (x, y) to the room's walls along world `angles`."""
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (HALF_X - origin[0]) / c, (-HALF_X - origin[0]) / c)
        ty = np.where(s > 0, (HALF_Y - origin[1]) / s, (-HALF_Y - origin[1]) / s)
    return np.minimum(np.abs(tx), np.abs(ty))


def test_pattern_is_a_vlp16():
    p = LidarPattern(horizontal_resolution=np.deg2rad(0.2))
    d = p.directions()
    assert d.shape == (16 * 1800, 3)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    el = np.rad2deg(np.arcsin(d[:, 2]))
    assert el.min() == pytest.approx(-15) and el.max() == pytest.approx(15)
    assert np.allclose(np.diff(np.rad2deg(p.elevations)), 2.0)


def test_points_lie_on_walls_and_floor(boxroom):
    HALF_X, HALF_Y = boxroom.half_x, boxroom.half_y
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(0.5, -0.3, 0.4))
    sim.start()
    cloud = sim.latest["lidar"].data
    world = sim.frame_pose("lidar")
    pts = cloud.points.astype(float) @ world[:3, :3].T + world[:3, 3]
    on_x = np.abs(np.abs(pts[:, 0]) - HALF_X) < 1e-4
    on_y = np.abs(np.abs(pts[:, 1]) - HALF_Y) < 1e-4
    on_floor = np.abs(pts[:, 2]) < 1e-4
    assert 13000 < len(pts) <= 16 * 900  # beams over the 2 m walls see nothing
    assert np.all(on_x | on_y | on_floor)
    assert on_floor.sum() > 1000 and (on_x | on_y).sum() > 1000


def test_scan_matches_analytic_wall_distances(boxroom):
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(0.5, -0.3, 0.4))
    sim.start()
    scan = sim.latest["scan"].data
    pose = sim.frame_pose("lidar")
    yaw = np.arctan2(pose[1, 0], pose[0, 0])
    angles = scan.angle_min + np.arange(len(scan.ranges)) * scan.angle_increment
    want = box_distance(pose[:2, 3], angles + yaw, boxroom.half_x, boxroom.half_y)
    assert scan.frame == "lidar"
    assert np.all(np.isfinite(scan.ranges))
    assert np.max(np.abs(scan.ranges - want)) < 0.01


def _wall_errors(boxroom, noise: float) -> np.ndarray:
    """Scan range minus the true distance to the walls, one sweep with range noise."""
    opts = SimOptions(cameras=False, streams={"lidar": StreamSettings(noise=noise)})
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(-1.0, 1.0, -0.2), options=opts)
    sim.start()
    scan = sim.latest["scan"].data
    pose = sim.frame_pose("lidar")
    yaw = np.arctan2(pose[1, 0], pose[0, 0])
    angles = scan.angle_min + np.arange(len(scan.ranges)) * scan.angle_increment
    return scan.ranges - box_distance(pose[:2, 3], angles + yaw, boxroom.half_x, boxroom.half_y)


def test_scan_noise_is_the_configured_noise(boxroom):
    err = _wall_errors(boxroom, 0.02)
    # the median of the rings on a wall is less noisy than one ring, never noisier
    assert 0.003 < np.std(err) < 0.02
    assert np.max(np.abs(err)) < 0.01 + 5 * 0.02


def test_scan_reads_flat_walls_without_bias(boxroom):
    # The minimum of several noisy rings would read about 1.3 cm short with 1 cm noise.
    err = _wall_errors(boxroom, 0.01)
    assert np.isfinite(err).all()
    assert abs(err.mean()) < 3 * err.std() / np.sqrt(len(err))


def test_point_cloud_and_beams_flatten_alike_with_noise(boxroom):
    opts = SimOptions(cameras=False, streams={"lidar": StreamSettings(noise=0.01)})
    sim = boxroom.make_sim(spawn=Pose.from_xy_yaw(0.5, -0.3, 0.4), options=opts)
    sim.start()
    scan = sim.latest["scan"].data
    cloud = sim.latest["lidar"].data
    cfg = ScanConfig(
        min_height=scan_band_bottom(sim),
        angle_increment=scan.angle_increment,
        range_min=scan.range_min,
        range_max=scan.range_max,
        surface_tolerance=0.05,
    )
    again = laserscan_from_points(cloud.points, cfg)
    assert np.allclose(again.ranges, scan.ranges, atol=1e-5)


def scan_band_bottom(sim) -> float:
    """The scan's lower height limit in the LiDAR frame (10 cm above the floor)."""
    return 0.1 - float(sim.frame_pose("lidar")[2, 3])


def test_laserscan_keeps_height_band_and_nearest_per_angle():
    pts = np.array(
        [
            [2.0, 0.0, 0.0],  # angle 0, in band
            [1.5, 0.0, 0.1],  # angle 0, nearer, in band
            [1.0, 0.0, 2.0],  # angle 0, above the band
            [0.0, 3.0, -0.1],  # angle +90 deg
            [0.1, 0.0, 0.0],  # nearer than range_min
        ]
    )
    cfg = ScanConfig(
        min_height=-0.2, max_height=0.5, angle_increment=np.deg2rad(1.0), range_min=0.2
    )
    scan = laserscan_from_points(pts, cfg)
    assert len(scan.ranges) == 360
    i0 = round((0 - scan.angle_min) / scan.angle_increment)
    i90 = round((np.pi / 2 - scan.angle_min) / scan.angle_increment)
    assert scan.ranges[i0] == pytest.approx(1.5)
    assert scan.ranges[i90] == pytest.approx(3.0)
    assert np.isfinite(scan.ranges).sum() == 2


def test_bad_lidar_settings_are_refused():
    with pytest.raises(ValueError, match="horizontal_resolution"):
        LidarPattern(horizontal_resolution=-0.1)
    with pytest.raises(ValueError, match="range_min"):
        LidarPattern(range_min=5.0, range_max=1.0)
    with pytest.raises(ValueError, match="max_height"):
        ScanConfig(min_height=1.0, max_height=0.0)
