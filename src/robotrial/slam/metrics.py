"""Scores of a SLAM run from arrays: trajectory errors and the room measured on a map.

Layer 3 (imports only `robotrial.slam`). ATE is the RMSE of positions after the rigid
alignment that fits best (Umeyama, as `evo_ape --align`); RPE the RMSE of the
translation error of consecutive relative poses (as `evo_rpe`, delta 1 frame). The room
is measured on the map alone: the distance between opposite walls' inner faces. On real
logs, where only relations between chosen pairs of poses are known, `relation_metric`
is the relative-pose error of Kuemmerle et al. (2009) that the published tables use.
"""

from __future__ import annotations

import numpy as np

from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.scan import relative
from robotrial.slam.tiled import TiledGrid


def umeyama_2d(est: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (2x2) and translation that best map `est` (N, 2) onto `ref` (least
    squares, no scale)."""
    me, mr = est.mean(axis=0), ref.mean(axis=0)
    cov = (ref - mr).T @ (est - me) / est.shape[0]
    u, _, vt = np.linalg.svd(cov)
    s = np.eye(2)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[1, 1] = -1
    rot = u @ s @ vt
    return rot, mr - rot @ me


def ate(est: np.ndarray, ref: np.ndarray, align: bool = True) -> dict[str, float]:
    """Absolute trajectory error of positions (est, ref: (N, 3) x, y, yaw at the same
    stamps): RMSE, mean, max (m), after the best rigid alignment if `align`."""
    p = est[:, :2]
    if align and len(p) >= 2:
        rot, t = umeyama_2d(p, ref[:, :2])
        p = p @ rot.T + t
    err = np.linalg.norm(p - ref[:, :2], axis=1)
    return {
        "rmse": float(np.sqrt(np.mean(err**2))),
        "mean": float(err.mean()),
        "max": float(err.max()),
    }


def rpe(est: np.ndarray, ref: np.ndarray, delta: int = 1) -> dict[str, float]:
    """Relative pose error: RMSE and max of the translation (m) and rotation (rad) error
    of each relative motion over `delta` frames."""
    if len(est) <= delta:
        return {"rmse": 0.0, "max": 0.0, "rot_rmse": 0.0}
    t_err, r_err = [], []
    for i in range(len(est) - delta):
        de = relative(est[i], est[i + delta])
        dr = relative(ref[i], ref[i + delta])
        e = relative(dr, de)
        t_err.append(np.hypot(e[0], e[1]))
        r_err.append(abs(e[2]))
    t = np.asarray(t_err)
    return {
        "rmse": float(np.sqrt(np.mean(t**2))),
        "max": float(t.max()),
        "rot_rmse": float(np.sqrt(np.mean(np.square(r_err)))),
    }


def cell_centres(grid: LogOddsGrid | TiledGrid, mask: np.ndarray) -> np.ndarray:
    """Centres (x, y) of the grid cells where `mask` is True."""
    rows, cols = np.nonzero(mask)
    res = grid.resolution
    return np.stack(
        [grid.origin[0] + (cols + 0.5) * res, grid.origin[1] + (rows + 0.5) * res], axis=1
    )


def room_dimensions(grid: LogOddsGrid | TiledGrid) -> tuple[float, float, float]:
    """(width along the room's x, depth along its y, yaw of the room's axes in the map)
    measured on the map alone: the room's axes are the rotation that makes occupied
    cells line up best; each wall's inner face is the mean position of the occupied cells in
    the outermost dense row of cells on its side and in the rows within two cells of it
    that hold at least a quarter as many."""
    pts = cell_centres(grid, grid.ros_values() == 100)
    if len(pts) < 20:
        raise ValueError("the map has too few occupied cells to measure a room")
    pts = pts - pts.mean(axis=0)

    def sharpness(a: float) -> float:
        c, s = np.cos(a), np.sin(a)
        x = c * pts[:, 0] + s * pts[:, 1]
        y = -s * pts[:, 0] + c * pts[:, 1]
        hx = np.bincount(np.floor((x - x.min()) / 0.02).astype(int))
        hy = np.bincount(np.floor((y - y.min()) / 0.02).astype(int))
        return float(np.sum(hx.astype(float) ** 2) + np.sum(hy.astype(float) ** 2))

    angles = np.deg2rad(np.arange(-45.0, 45.0, 0.5))
    best = angles[int(np.argmax([sharpness(a) for a in angles]))]
    fine = best + np.deg2rad(np.arange(-0.5, 0.5001, 0.02))
    best = float(fine[int(np.argmax([sharpness(a) for a in fine]))])
    c, s = np.cos(best), np.sin(best)
    x = c * pts[:, 0] + s * pts[:, 1]
    y = -s * pts[:, 0] + c * pts[:, 1]
    res = grid.resolution
    return _extent(x, y, res), _extent(y, x, res), best


def _extent(u: np.ndarray, v: np.ndarray, res: float) -> float:
    """Distance between the two outermost walls across u (walls run along v)."""
    edges = np.arange(u.min() - res, u.max() + 2 * res, res)
    hist, _ = np.histogram(u, edges)
    span = max(1.0, float(v.max() - v.min()))
    # A wall is a column of cells holding at least a third of the room's length.
    dense = np.nonzero(hist * res >= span / 3)[0]
    if len(dense) < 2:
        raise ValueError("could not find two opposite walls on the map")
    faces = []
    bins = np.clip(np.digitize(u, edges) - 1, 0, len(hist) - 1)
    for k in (dense[0], dense[-1]):
        # A wall blurred over neighbouring rows (small pose errors) counts as its middle;
        # rows holding only a few cells (the ends of the walls across it) do not count.
        near = np.arange(max(0, k - 2), min(len(hist), k + 3))
        strong = near[hist[near] >= 0.25 * hist[k]]
        faces.append(float(u[np.isin(bins, strong)].mean()))
    if faces[1] - faces[0] < 1.0:
        raise ValueError("could not find two opposite walls on the map (only one side)")
    return faces[1] - faces[0]


def relation_errors(
    stamps: np.ndarray, poses: np.ndarray, relations: np.ndarray, tolerance: float = 0.01
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Errors of an estimate against relations (Kuemmerle et al. 2009): for each relation
    (t1, t2, x, y, yaw), the estimate's motion between its poses at t1 and t2, seen from
    the first, is compared with the relation: error = relation^-1 ⊕ estimated motion.
    Returns the translational error (m) and the absolute rotational error (rad) of each
    relation whose two stamps have an estimated pose within `tolerance` s, and a mask of
    the relations that did."""
    stamps = np.asarray(stamps, dtype=np.float64)
    order = np.argsort(stamps)
    s = stamps[order]

    def nearest(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        i = np.searchsorted(s, t)
        lo, hi = np.clip(i - 1, 0, len(s) - 1), np.clip(i, 0, len(s) - 1)
        pick = np.where(np.abs(s[lo] - t) <= np.abs(s[hi] - t), lo, hi)
        return order[pick], np.abs(s[pick] - t) <= tolerance

    rel = np.asarray(relations, dtype=np.float64).reshape(-1, 5)
    if len(s) == 0:
        return np.zeros(0), np.zeros(0), np.zeros(len(rel), bool)
    i1, ok1 = nearest(rel[:, 0])
    i2, ok2 = nearest(rel[:, 1])
    ok = ok1 & ok2
    trans, rot = [], []
    for a, b, r in zip(i1[ok], i2[ok], rel[ok], strict=True):
        e = relative(r[2:5], relative(poses[a], poses[b]))
        trans.append(np.hypot(e[0], e[1]))
        rot.append(abs(e[2]))
    return np.asarray(trans), np.asarray(rot), ok


def relation_metric(
    stamps: np.ndarray, poses: np.ndarray, relations: np.ndarray, tolerance: float = 0.01
) -> dict[str, float]:
    """The relative-pose error of Kuemmerle et al. as their tables give it: mean, standard
    deviation and maximum of the absolute translational error (m) and of its square
    (m^2), of the absolute rotational error (deg) and of its square (deg^2), over the
    relations the estimate covers (`used` of `relations`)."""
    t, r, ok = relation_errors(stamps, poses, relations, tolerance)
    out: dict[str, float] = {"relations": float(len(ok)), "used": float(ok.sum())}
    if len(t) == 0:
        return out
    deg = np.rad2deg(r)
    for name, v in (("trans", t), ("trans_sq", t**2), ("rot_deg", deg), ("rot_sq_deg", deg**2)):
        out[f"{name}_mean"] = float(v.mean())
        out[f"{name}_std"] = float(v.std())
        out[f"{name}_max"] = float(v.max())
    return out
