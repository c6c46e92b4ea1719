"""Path post-processing: drop needless waypoints, shortcut, and round the corners.

Layer 3. Every change is checked with the planner's checker, so a valid path stays
valid: shortcuts replace a stretch by a straight segment only when that segment is free.
"""

from __future__ import annotations

import numpy as np

from robotrial.planning.base import Checker


def reduce_vertices(path: np.ndarray, checker: Checker) -> np.ndarray:
    """From each kept waypoint, jump to the farthest later waypoint reachable in a straight
    line (one batched motion check per kept waypoint)."""
    path = np.asarray(path, dtype=float)
    if len(path) <= 2:
        return path
    out = [path[0]]
    i = 0
    while i < len(path) - 1:
        later = path[i + 1 :]
        ok = checker.motions_valid(np.repeat(path[i][None], len(later), 0), later)
        j = i + 1 + int(np.nonzero(ok)[0].max()) if np.any(ok) else i + 1
        out.append(path[j])
        i = j
    return np.array(out)


def _at(path: np.ndarray, cum: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points at arc lengths `s` (n,) and the indices of the segments they lie on."""
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(path) - 2)
    seg = cum[k + 1] - cum[k]
    t = np.where(seg > 0, (s - cum[k]) / np.where(seg > 0, seg, 1.0), 0.0)
    return path[k] + t[:, None] * (path[k + 1] - path[k]), k


def shortcut(
    path: np.ndarray, checker: Checker, rng: np.random.Generator, attempts: int = 60
) -> np.ndarray:
    """Random shortcuts between points anywhere on the path (not only waypoints), tried
    in batches of 16; each accepted one replaces the stretch between its ends."""
    path = reduce_vertices(path, checker)
    done = 0
    while done < attempts and len(path) > 2:
        seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        if cum[-1] <= 0:
            break
        s = np.sort(rng.uniform(0, cum[-1], size=(16, 2)), axis=1)
        a, ka = _at(path, cum, s[:, 0])
        b, kb = _at(path, cum, s[:, 1])
        done += 16
        # only pairs on different segments can shorten the path
        gain = (s[:, 1] - s[:, 0]) - np.linalg.norm(b - a, axis=1)
        gain[ka == kb] = 0.0
        try_ = np.nonzero(gain > 1e-6)[0]
        if len(try_) == 0:
            continue
        ok = checker.motions_valid(a[try_], b[try_])
        if not np.any(ok):
            continue
        best = try_[ok][int(np.argmax(gain[try_][ok]))]
        path = np.vstack([path[: ka[best] + 1], a[best], b[best], path[kb[best] + 1 :]])
    return reduce_vertices(path, checker)


def densify(path: np.ndarray, step: float) -> np.ndarray:
    """Insert waypoints so that no segment is longer than `step` (joint-space L2)."""
    path = np.asarray(path, dtype=float)
    if len(path) < 2:
        return path.copy()
    d = np.diff(path, axis=0)
    n = np.maximum(np.ceil(np.linalg.norm(d, axis=1) / step).astype(int), 1)
    seg = np.repeat(np.arange(len(d)), n)  # the segment of each new point
    frac = (np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n) + 1) / np.repeat(n, n)
    return np.vstack([path[:1], path[seg] + frac[:, None] * d[seg]])


def round_corners(path: np.ndarray, checker: Checker, fraction: float = 0.25) -> np.ndarray:
    """Cut each corner by a chord between points `fraction` of the way along its two
    segments (when the chord is free), so the timed spline turns gently."""
    path = np.asarray(path, dtype=float)
    if len(path) <= 2:
        return path
    out = [path[0]]
    for i in range(1, len(path) - 1):
        p, c, n = out[-1], path[i], path[i + 1]
        a = c + fraction * (p - c)
        b = c + fraction * (n - c)
        if checker.motions_valid(a[None], b[None])[0]:
            out.extend([a, b])
        else:
            out.append(c)
    out.append(path[-1])
    return np.array(out)
