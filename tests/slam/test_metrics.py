"""ATE and RPE agree with evo on the same trajectories."""

from __future__ import annotations

import numpy as np
import pytest
from evo.core import metrics
from evo.core.trajectory import PoseTrajectory3D
from scipy.spatial.transform import Rotation

from robotrial.slam.metrics import ate, rpe


def to_evo(poses: np.ndarray) -> PoseTrajectory3D:
    xyz = np.column_stack([poses[:, :2], np.zeros(len(poses))])
    q = Rotation.from_euler("z", poses[:, 2:3]).as_quat()[:, [3, 0, 1, 2]]
    return PoseTrajectory3D(xyz, q, np.arange(len(poses), dtype=float))


@pytest.fixture
def pair():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 2 * np.pi, 200)
    ref = np.column_stack([2 * np.cos(t), np.sin(2 * t), t + np.pi / 2])
    c, s = np.cos(0.2), np.sin(0.2)
    est = ref.copy()
    est[:, 0] = c * ref[:, 0] - s * ref[:, 1] + 0.5
    est[:, 1] = s * ref[:, 0] + c * ref[:, 1] - 0.3
    est[:, 2] = ref[:, 2] + 0.2
    est[:, :2] += rng.normal(0, 0.02, (200, 2))
    est[:, 2] += rng.normal(0, 0.01, 200)
    return est, ref


def test_ate_matches_evo_ape_with_alignment(pair):
    est, ref = pair
    e, r = to_evo(est), to_evo(ref)
    e.align(r, correct_scale=False)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((r, e))
    assert ate(est, ref)["rmse"] == pytest.approx(
        ape.get_statistic(metrics.StatisticsType.rmse), rel=1e-6
    )


def test_rpe_matches_evo_rpe(pair):
    est, ref = pair
    m = metrics.RPE(metrics.PoseRelation.translation_part, delta=1, delta_unit=metrics.Unit.frames)
    m.process_data((to_evo(ref), to_evo(est)))
    assert rpe(est, ref)["rmse"] == pytest.approx(
        m.get_statistic(metrics.StatisticsType.rmse), rel=1e-6
    )


def test_room_dimensions_of_a_drawn_room():
    """Walls one cell thick: the room measures between the rows of wall cells."""
    from robotrial.slam.grid import LogOddsGrid
    from robotrial.slam.metrics import room_dimensions

    g = LogOddsGrid(0.05)
    g.ensure(-1.0, -1.0, 5.0, 4.0, pad=0.0)

    def mark(x: float, y: float) -> None:
        g.logodds[int((y - g.origin[1]) // 0.05), int((x - g.origin[0]) // 0.05)] = 3.0

    for x in np.arange(0.025, 4.0, 0.05):
        mark(x, 0.025)
        mark(x, 2.975)
    for y in np.arange(0.025, 3.0, 0.05):
        mark(0.025, y)
        mark(3.975, y)
    width, depth, yaw = room_dimensions(g)
    assert width == pytest.approx(3.95, abs=0.005)
    assert depth == pytest.approx(2.95, abs=0.005)
    assert yaw == pytest.approx(0.0, abs=1e-6)

    half = LogOddsGrid(0.05)
    half.ensure(-1.0, -1.0, 5.0, 4.0, pad=0.0)
    half.logodds[:] = g.logodds
    half.logodds[:, 45:] = 0.0  # the east wall never seen
    with pytest.raises(ValueError, match="opposite walls"):
        room_dimensions(half)
