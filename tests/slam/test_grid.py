"""Log-odds grid updates against hand-computed cases."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.slam.grid import LogOddsGrid, LogOddsModel

M = LogOddsModel(free=-0.4, occupied=0.85, clamp_min=-2.0, clamp_max=3.5)


def grid() -> LogOddsGrid:
    g = LogOddsGrid(0.1, model=M)
    g.ensure(0.0, 0.0, 1.0, 1.0, pad=0.0)
    return g


def test_beam_frees_crossed_cells_and_marks_its_end():
    g = grid()
    assert g.origin == (0.0, 0.0) and g.shape == (10, 10)
    g.integrate((0.05, 0.05), np.array([[0.55, 0.05]]), np.array([True]))
    row = g.logodds[0]
    assert row[:5] == pytest.approx([-0.4] * 5)
    assert row[5] == pytest.approx(0.85)
    assert np.all(row[6:] == 0) and np.all(g.logodds[1:] == 0)


def test_diagonal_beam_visits_one_cell_per_step():
    g = grid()
    g.integrate((0.05, 0.05), np.array([[0.35, 0.35]]), np.array([True]))
    expected = np.zeros((10, 10), np.float32)
    for k in range(3):
        expected[k, k] = -0.4
    expected[3, 3] = 0.85
    assert np.allclose(g.logodds, expected)


def test_beam_without_return_only_frees():
    g = grid()
    g.integrate((0.05, 0.05), np.array([[0.05, 0.45]]), np.array([False]))
    assert g.logodds[:5, 0] == pytest.approx([-0.4] * 5)
    assert g.logodds.max() == 0


def test_repeated_hits_clamp():
    g = grid()
    for _ in range(10):
        g.integrate((0.05, 0.05), np.array([[0.25, 0.05]]), np.array([True]))
    assert g.logodds[0, 2] == pytest.approx(3.5)
    assert g.logodds[0, 0] == pytest.approx(-2.0)
    p = g.probability()
    assert p[0, 2] == pytest.approx(1 / (1 + np.exp(-3.5)))
    assert p[5, 5] == pytest.approx(0.5)
    assert g.ros_values()[0, 2] == 100 and g.ros_values()[0, 0] == 0
    assert g.ros_values()[5, 5] == -1


def test_growing_keeps_content_in_place():
    g = grid()
    g.integrate((0.05, 0.05), np.array([[0.25, 0.05]]), np.array([True]))
    g.integrate((0.05, 0.05), np.array([[-1.05, 0.05]]), np.array([True]))
    r, c = int(np.floor((0.05 - g.origin[1]) / 0.1)), int(np.floor((0.25 - g.origin[0]) / 0.1))
    assert g.logodds[r, c] == pytest.approx(0.85)
    assert g.origin[0] <= -1.05 and g.shape[1] > 10
    assert g.origin[0] / 0.1 == pytest.approx(round(g.origin[0] / 0.1))


def test_probability_model_from_hector_factors():
    m = LogOddsModel.from_probabilities(0.4, 0.9)
    assert m.free == pytest.approx(np.log(0.4 / 0.6))
    assert m.occupied == pytest.approx(np.log(9.0))
    with pytest.raises(ValueError, match="p_free"):
        LogOddsModel.from_probabilities(0.0, 0.9)


def fan(n: int = 1800, radius: float = 3.0) -> tuple[np.ndarray, float]:
    """A full-circle scan of n beams ending on a circle around (0.02, 0.03)."""
    a = np.linspace(-np.pi, np.pi, n, endpoint=False)
    return np.stack([0.02 + radius * np.cos(a), 0.03 + radius * np.sin(a)], axis=1), a[1] - a[0]


def test_thinned_fan_marks_the_same_walls_and_frees_the_same_room():
    ends, step = fan()
    hit = np.ones(len(ends), bool)
    full, thin = LogOddsGrid(0.05, model=M), LogOddsGrid(0.05, model=M)
    full.integrate((0.02, 0.03), ends, hit)
    thin.integrate((0.02, 0.03), ends, hit, angle_step=step)
    assert full.origin == thin.origin and full.shape == thin.shape
    assert np.array_equal(full.logodds > 0, thin.logodds > 0)
    freed_full, freed_thin = full.logodds < 0, thin.logodds < 0
    assert (freed_full & freed_thin).sum() >= 0.95 * freed_full.sum()
    # Near the sensor hundreds of beams cross each cell: both clamp it.
    r, c = int((0.53 - full.origin[1]) / 0.05), int((0.02 - full.origin[0]) / 0.05)
    assert full.logodds[r, c] == pytest.approx(-2.0) and thin.logodds[r, c] == pytest.approx(-2.0)
