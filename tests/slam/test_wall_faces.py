"""Where the map puts a wall: a box room scanned with noisy ranges from a loop of true
poses, its faces on the map's cell boundaries (as in the built-in worlds, whose walls
and spawns have round coordinates) or a third of a cell off them. The scan matchers
must read each face where it is (docs/slam.md, "The grid")."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.slam.grid import LogOddsGrid, LogOddsModel
from robotrial.slam.matcher import ScanMatcher, likelihood
from robotrial.slam.scan import transform_points

from .test_matcher import cast

NOISE = 0.0043  # m, the simulated 2D scan's range noise (docs/benchmarks/slam.md)
BEAMS = 1800


def scan_room(res: float, offset: float, model: LogOddsModel | None = None):
    """The map of a 4 x 3 m room whose faces lie `offset` cells past the map's cell
    boundaries, written from 40 noisy scans at their true poses; and, for every fourth
    scan, its pose and each wall's points (scanner frame) with the axis of the wall's
    normal and its outward sign."""
    x0, x1 = -2.0 + offset * res, 2.0 + offset * res
    y0, y1 = -1.5 + offset * res, 1.5 + offset * res
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    segments = [(corners[k], corners[(k + 1) % 4]) for k in range(4)]
    # (axis of the normal, face, outward sign) of the south, east, north and west walls
    faces = [(1, y0, -1), (0, x1, 1), (1, y1, 1), (0, x0, -1)]
    rng = np.random.default_rng(0)
    grid = LogOddsGrid(res, model=model)
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    poses = np.stack([1.2 * np.cos(t), 0.8 * np.sin(t), t + np.pi / 2], axis=1)
    readings = []
    for k, pose in enumerate(poses):
        local = cast(pose, BEAMS, segments)
        r = np.hypot(local[:, 0], local[:, 1])
        local *= ((r + rng.normal(0, NOISE, BEAMS)) / r)[:, None]
        ends = transform_points(pose, local)
        grid.integrate(pose[:2], ends, np.ones(BEAMS, bool), 2 * np.pi / BEAMS)
        if k % 4:
            continue
        walls = []
        for axis, face, sign in faces:
            along = ends[:, 1 - axis]
            lo, hi = (x0, x1) if axis == 1 else (y0, y1)
            on = (np.abs(ends[:, axis] - face) < 0.05) & (along > lo + 0.2) & (along < hi - 0.2)
            walls.append((local[on], axis, sign))
        readings.append((pose, walls))
    return grid, readings


def matcher_reading(grid: LogOddsGrid, pose: np.ndarray, pts: np.ndarray, axis: int) -> float:
    """Where Hector's matcher puts one wall's points: matched from the true pose, free to
    move only along the wall's normal; the shift of the pose (m, along `axis`)."""
    sigma = [1e-4, 1e-4, 1e-5]
    sigma[axis] = 1.0
    out = ScanMatcher(levels=1, iterations=10).match(grid, pts, pose, prior_sigma=tuple(sigma))
    return float(out.pose[axis] - pose[axis])


def field_reading(grid: LogOddsGrid, pose: np.ndarray, pts: np.ndarray, axis: int) -> float:
    """Where GMapping's likelihood field puts one wall's points: the middle of the
    shifts of the pose along the wall's normal that score best."""
    shifts = np.linspace(-grid.resolution, grid.resolution, 81)
    scores = []
    for s in shifts:
        q = pose.copy()
        q[axis] += s
        scores.append(likelihood(grid, pts, q)[1])
    scores = np.asarray(scores)
    return float(shifts[scores >= scores.max() - 1e-9].mean())


def face_errors(res: float, offset: float, model: LogOddsModel | None = None):
    """Mean outward error (m) of the faces as the matcher and as the likelihood field
    read them, over the walls and the scans."""
    grid, readings = scan_room(res, offset, model)
    hector, field = [], []
    for pose, walls in readings:
        for pts, axis, sign in walls:
            hector.append(sign * matcher_reading(grid, pose, pts, axis))
            field.append(sign * field_reading(grid, pose, pts, axis))
    return float(np.mean(hector)), float(np.mean(field))


@pytest.mark.parametrize("res", [0.025, 0.05])
@pytest.mark.parametrize("offset", [0.0, 1 / 3], ids=["on-boundaries", "third-of-a-cell-off"])
def test_matchers_read_each_wall_face_where_it_is(res, offset):
    hector, field = face_errors(res, offset)
    assert abs(hector) < 0.004, f"Hector's matcher reads the faces {hector * 100:+.2f} cm out"
    assert abs(field) < 0.004, f"the likelihood field reads the faces {field * 100:+.2f} cm out"


def test_without_the_margin_faces_on_cell_boundaries_read_outward():
    # Beams freeing every cell up to their end points clear the cell in front of a face
    # that lies on a cell boundary, and the map's wall moves out by up to half a cell.
    hector, field = face_errors(0.05, 0.0, LogOddsModel(hit_margin=0.0))
    assert hector > 0.008 and field > 0.015
