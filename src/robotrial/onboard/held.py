"""The pose of an object in the hand, from the head camera's points (layer 4; plain arrays
in and out).

Two pads holding an object by friction resist little turning about the line between
them: a cup grasped with the hand pitched down turns 8-21 degrees in the hand as it is
lifted and carried. Its pose in the hand is fitted to what the camera sees of it (its
top and the sides in view, the robot's own body cut out): the object's shape and size
from the catalogue, held centred between the fingers (they close symmetrically), leaves
three unknowns, the turn about the fingers' line and the centre's offset along the
tool's other two axes. The points' distances to the object's surface are brought to
least (a robust loss, so a stray point of the fingers or the support counts little).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from robotrial.onboard.catalogue import ObjectKind

MIN_POINTS = 30  # fewer points of the object in view, and the fit is not made
MAX_TURN = np.deg2rad(45.0)  # rad the object may have turned in the hand
# m: residuals past this count less (the robust loss's scale: the head's depth noise)
FIT_SCALE = 0.005
FIT_RMS = 0.008  # m: a fit whose typical point lies farther off its surface is refused
INLIER = 0.015  # m: points this close to the fitted surface are its own
STARTS = np.deg2rad((0.0, -15.0, 15.0, -30.0, 30.0))  # turns the fit starts from
# the fit's standard deviations past which the points do not determine the turn (rad),
# then the centre (m): the apartment's cup, a third of its side and some of its top in
# view, 0.7 degrees and 0.4-0.6 mm; a 7 cm cube seen on the face a finger holds and an
# edge of another, 4.3 degrees and 1.5-2.5 mm
TURN_SPREAD = np.deg2rad(2.0)
SHIFT_SPREAD = 0.004


@dataclass(frozen=True)
class HeldFit:
    """An object's fitted pose in the tool frame: `rotation` (3x3) and `centre` (m); the
    turn about the fingers' line it found (rad, from the pose it started from), the
    points used and the fit's typical distance off the surface (m)."""

    rotation: np.ndarray
    centre: np.ndarray
    turn: float
    points: int
    rms: float


def signed_distance(kind: ObjectKind, local: np.ndarray) -> np.ndarray:
    """Signed distance (m, negative inside) of points (N, 3) in the object's own frame
    (its centre, z along its height) to the surface of an object of `kind`."""
    if kind.shape == "sphere":
        return np.linalg.norm(local, axis=1) - kind.width / 2
    if kind.shape == "cylinder":
        q = np.column_stack(
            [
                np.hypot(local[:, 0], local[:, 1]) - kind.width / 2,
                np.abs(local[:, 2]) - kind.height / 2,
            ]
        )
    else:
        q = np.abs(local) - np.asarray(kind.size, dtype=float) / 2
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    return outside + np.minimum(q.max(axis=1), 0.0)


def _turn_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def fit_held(
    points: np.ndarray,
    kind: ObjectKind,
    tcp: np.ndarray,
    rotation: np.ndarray,
    centre: np.ndarray,
) -> HeldFit | None:
    """Fit the pose in the hand of an object of `kind` to `points` (N, 3, base frame) seen
    of it, the tool at `tcp` (4x4, base frame; its y axis the fingers' line), starting
    from the pose the robot believes (`rotation`, `centre`: tool frame). The fingers keep
    the centre on their line's middle (tool y = 0); it turns about a line parallel to
    theirs. None when too few points or no pose fits them."""
    pts = np.asarray(points, dtype=float)
    if len(pts) < MIN_POINTS:
        return None
    # the points in the tool frame
    local = (pts - tcp[:3, 3]) @ tcp[:3, :3]
    reach = float(np.linalg.norm(kind.size)) / 2

    def pose(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rot = _turn_y(x[0]) @ rotation
        return rot, np.array([centre[0] + x[1], 0.0, centre[2] + x[2]])

    def residuals(x: np.ndarray) -> np.ndarray:
        rot, c = pose(x)
        return signed_distance(kind, (local - c) @ rot)

    bounds = ([-MAX_TURN, -reach, -reach], [MAX_TURN, reach, reach])
    fits = [_solve(residuals, np.array([start, 0.0, 0.0]), bounds) for start in STARTS]
    best = min(fits, key=lambda r: r.cost)
    spread = _spread(best)
    if spread is not None and spread[0] > TURN_SPREAD:
        # the faces in view do not show the turn (a box seen on the face the fingers
        # hold): the centre alone, the turn kept as believed
        best = _solve(
            lambda x: residuals(np.array([0.0, *x])), np.zeros(2), (bounds[0][1:], bounds[1][1:])
        )
        best.x = np.array([0.0, *best.x])
        spread = _spread(best)
        if spread is not None:
            spread = np.array([0.0, *spread])
    near = np.abs(best.fun) < INLIER
    if spread is None or spread[1:].max() > SHIFT_SPREAD or near.sum() < MIN_POINTS:
        return None
    rms = float(np.sqrt(np.mean(best.fun[near] ** 2)))
    if rms > FIT_RMS:
        return None
    rot, c = pose(best.x)
    return HeldFit(rot, c, float(best.x[0]), int(near.sum()), rms)


def _solve(residuals, start: np.ndarray, bounds):
    return least_squares(residuals, start, bounds=bounds, loss="soft_l1", f_scale=FIT_SCALE)


def _spread(res) -> np.ndarray | None:
    """The standard deviations of a fit's unknowns (from its Jacobian and the typical
    residual of the points on the surface); None when they are not determined."""
    near = np.abs(res.fun) < INLIER
    if near.sum() < MIN_POINTS:
        return None
    info = res.jac.T @ res.jac
    if np.linalg.cond(info) > 1e12:
        return None
    return np.sqrt(np.diag(np.linalg.inv(info)) * np.mean(res.fun[near] ** 2))


def upright_pitch(rotation: np.ndarray, hand: np.ndarray) -> float:
    """The pitch (rad, down positive) of a side grasp's hand whose held object, at
    `rotation` in the tool frame, then stands most nearly upright; `hand` is the side
    grasp's orientation at no pitch (3x3: approach along x of the heading, the tool's x
    up), so the hand at pitch p is Rz(heading) Ry(p) `hand`."""
    u = hand @ rotation @ np.array([0.0, 0.0, 1.0])
    return float(np.arctan2(-u[0], u[2]))


def lowest(kind: ObjectKind, rotation: np.ndarray) -> float:
    """How far (m) below its centre the lowest point of an object of `kind` lies, turned
    by `rotation` (3x3, its frame in one whose z is up)."""
    if kind.shape == "sphere":
        return kind.width / 2
    if kind.shape == "cylinder":
        up = abs(float(rotation[2, 2]))
        return kind.height / 2 * up + kind.width / 2 * float(np.sqrt(max(1.0 - up * up, 0.0)))
    half = np.asarray(kind.size, dtype=float) / 2
    return float(np.abs(rotation[2, :]) @ half)


def bottom(kind: ObjectKind, rotation: np.ndarray) -> np.ndarray:
    """The middle of the face an object of `kind`, turned by `rotation`, stands on once
    let go, from its centre (m): where it comes to rest over its support."""
    if kind.shape == "sphere":
        return np.array([0.0, 0.0, -kind.width / 2])
    axis = rotation[:, 2] if rotation[2, 2] >= 0 else -rotation[:, 2]
    return -axis * kind.height / 2
