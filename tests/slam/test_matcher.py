"""The scan matcher recovers known offsets on a map of a small room."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.matcher import ScanMatcher, likelihood
from robotrial.slam.scan import transform_points

# A 4 x 3 m room with a 0.6 m square pillar. Its faces run through cell centres of the
# 5 cm map: a face on a cell edge would put the map's wall half a cell off, whatever the
# matcher does.
X, Y, A, B = 2.025, 1.525, 0.625, 1.225
WALLS = [((-X, -Y), (X, -Y)), ((X, -Y), (X, Y)), ((X, Y), (-X, Y)), ((-X, Y), (-X, -Y))]
PILLAR = [
    ((A, A - 0.3), (B, A - 0.3)),
    ((B, A - 0.3), (B, B - 0.3)),
    ((B, B - 0.3), (A, B - 0.3)),
    ((A, B - 0.3), (A, A - 0.3)),
]


def cast(pose: np.ndarray, n: int = 360, segments: list | None = None) -> np.ndarray:
    """End points (scanner frame) of n beams against the segments (this room's walls and
    pillar unless given): a tiny ray caster."""
    angles = np.linspace(-np.pi, np.pi, n, endpoint=False) + pose[2]
    o = pose[:2]
    best = np.full(n, np.inf)
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    for a, b in WALLS + PILLAR if segments is None else segments:
        a, b = np.asarray(a, float), np.asarray(b, float)
        e = b - a
        den = d[:, 0] * e[1] - d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((a[0] - o[0]) * e[1] - (a[1] - o[1]) * e[0]) / den
            u = ((a[0] - o[0]) * d[:, 1] - (a[1] - o[1]) * d[:, 0]) / den
        ok = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        best = np.where(ok & (t < best), t, best)
    local = angles - pose[2]
    return np.stack([best * np.cos(local), best * np.sin(local)], axis=1)


@pytest.fixture(scope="module")
def room_map() -> LogOddsGrid:
    g = LogOddsGrid(0.05)
    for pose in ([0.0, 0.0, 0.0], [-1.0, -0.5, 0.3], [0.5, -0.8, -0.2]):
        p = np.array(pose)
        ends = transform_points(p, cast(p))
        for _ in range(3):
            g.integrate(p[:2], ends, np.ones(len(ends), bool))
    return g


@pytest.mark.parametrize(
    "offset",
    [(0.10, -0.08, 0.05), (-0.15, 0.05, -0.08), (0.0, 0.2, 0.0), (0.05, 0.05, 0.15)],
)
def test_recovers_known_offsets(room_map, offset):
    true = np.array([-0.3, 0.2, 0.1])
    scan = cast(true)
    guess = true + np.array(offset)
    got = ScanMatcher(levels=3, iterations=10).match(room_map, scan, guess).pose
    assert np.hypot(*(got[:2] - true[:2])) < 0.015
    assert abs(got[2] - true[2]) < 0.01


def test_single_level_has_a_narrow_basin(room_map):
    # Guesses 25 cm off in twelve directions: the coarse levels bring every one of them
    # home, the fine level alone only some.
    true = np.array([-0.3, 0.2, 0.1])
    scan = cast(true)
    recovered = {1: 0, 3: 0}
    for a in np.linspace(0, 2 * np.pi, 12, endpoint=False):
        guess = true + np.array([0.25 * np.cos(a), 0.25 * np.sin(a), 0.0])
        for levels in recovered:
            got = ScanMatcher(levels=levels, iterations=10).match(room_map, scan, guess).pose
            recovered[levels] += bool(np.hypot(*(got[:2] - true[:2])) < 0.02)
    assert recovered[3] == 12
    assert recovered[1] <= 8


def test_likelihood_peaks_at_the_true_pose(room_map):
    true = np.array([-0.3, 0.2, 0.1])
    scan = cast(true)
    s0, l0, n0 = likelihood(room_map, scan, true)
    s1, l1, n1 = likelihood(room_map, scan, true + np.array([0.08, 0.0, 0.0]))
    assert s0 > s1 and l0 > l1 and n0 >= n1
    assert n0 > 0.9 * len(scan)
