"""A standing robot's pose from the raw scans of SLAM nodes (slam.keyframes)."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.slam.keyframes import Keyframes

# a 5 x 4 m room with a 0.6 x 0.4 m pillar, as wall segments
SEGMENTS = [
    ((0.0, 0.0), (5.0, 0.0)),
    ((5.0, 0.0), (5.0, 4.0)),
    ((5.0, 4.0), (0.0, 4.0)),
    ((0.0, 4.0), (0.0, 0.0)),
    ((2.0, 1.0), (2.6, 1.0)),
    ((2.6, 1.0), (2.6, 1.4)),
    ((2.6, 1.4), (2.0, 1.4)),
    ((2.0, 1.4), (2.0, 1.0)),
]


def _scan(pose: np.ndarray, n: int = 720) -> np.ndarray:
    """Exact end points (base frame) of a 360-degree scan from `pose` in the room."""
    a = np.linspace(-np.pi, np.pi, n, endpoint=False)
    d = np.column_stack([np.cos(a + pose[2]), np.sin(a + pose[2])])
    t = np.full(n, np.inf)
    for p, q in SEGMENTS:
        p, e = np.array(p), np.array(q) - np.array(p)
        den = d[:, 0] * e[1] - d[:, 1] * e[0]
        w = p - pose[:2]
        with np.errstate(divide="ignore", invalid="ignore"):
            k = (w[0] * e[1] - w[1] * e[0]) / den
            u = (w[0] * d[:, 1] - w[1] * d[:, 0]) / den
        ok = (k > 0) & (u >= 0) & (u <= 1)
        t[ok] = np.minimum(t[ok], k[ok])
    return np.column_stack([t * np.cos(a), t * np.sin(a)])


def test_a_work_site_pose_is_found_on_the_nodes_scans_from_a_guess_cm_off():
    """Four nodes' scans in the room; a robot standing elsewhere, its guess 3.6 cm and
    0.6 degrees off: matched to the nodes' lines it comes out within a millimetre."""
    nodes = [
        np.array(p) for p in ((1.0, 1.0, 0.0), (4.0, 1.0, 1.5), (4.0, 3.0, 3.0), (1.0, 3.0, -1.6))
    ]
    keyframes = Keyframes(nodes, [_scan(q) for q in nodes], np.array([2.5, 2.0]), 4.0)
    truth = np.array([3.3, 2.1, 0.4])
    guess = truth + np.array([0.03, -0.02, 0.01])
    pose, used = keyframes.match(_scan(truth), guess)
    assert used > 600
    assert np.hypot(*(pose[:2] - truth[:2])) < 1e-3
    assert abs(pose[2] - truth[2]) < 5e-4


def test_no_nodes_nearby_is_refused_by_name():
    with pytest.raises(ValueError, match=r"keyframes: 0 points within 1\.0 m"):
        Keyframes([np.array([9.0, 9.0, 0.0])], [np.zeros((0, 2))], np.zeros(2), 1.0)
