"""Path post-processing: drop needless waypoints, shortcut, and round the corners.

Layer 3. Every change is checked with the planner's checker, so a valid path stays
valid: shortcuts replace a stretch by a straight segment only when that segment is free.
With the sphere checker the whole of it runs compiled (`shortcut_and_round`), calling
the motion kernel directly; the NumPy functions serve any other checker.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from robotrial.collision.kernels import motion_free
from robotrial.planning.base import Checker, CompiledChecker


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


# --- the same, compiled over the sphere checker's kernels -------------------------------

BATCH = 16  # shortcut pairs drawn at once, as `shortcut` draws them


@nb.njit(cache=True, inline="always")
def arc_lengths(path):
    """(n,) joint-space length of the path (n, d) up to each waypoint, from 0."""
    n, d = path.shape
    cum = np.zeros(n)
    for i in range(n - 1):
        s2 = 0.0
        for j in range(d):
            s2 += (path[i + 1, j] - path[i, j]) ** 2
        cum[i + 1] = cum[i] + np.sqrt(s2)
    return cum


@nb.njit(cache=True, nogil=True)
def _reduce(path, floats, ints, work, work_ints):
    """`reduce_vertices`, compiled: from each kept waypoint, the farthest later one
    reachable in a straight line (tried from the far end down: the first free one is it)."""
    n = path.shape[0]
    if n <= 2:
        return path.copy()
    keep = np.empty(n, dtype=np.int64)
    keep[0] = 0
    m = 1
    i = 0
    while i < n - 1:
        j = i + 1
        for k in range(n - 1, i, -1):
            if motion_free(floats, ints, work, work_ints, path[i], path[k]):
                j = k
                break
        keep[m] = j
        m += 1
        i = j
    out = np.empty((m, path.shape[1]))
    for r in range(m):
        out[r] = path[keep[r]]
    return out


@nb.njit(cache=True, inline="always")
def _point(path, cum, s, out):
    """Write the point at arc length `s` into `out`; return its segment's index (`_at`)."""
    n = path.shape[0]
    k = min(max(np.searchsorted(cum, s, side="right") - 1, 0), n - 2)
    seg = cum[k + 1] - cum[k]
    t = (s - cum[k]) / seg if seg > 0 else 0.0
    for j in range(path.shape[1]):
        out[j] = path[k, j] + t * (path[k + 1, j] - path[k, j])
    return k


@nb.njit(cache=True, inline="always")
def _shortcut(path, draws, floats, ints, work, work_ints):
    """`shortcut`, compiled, with its uniform draws given: (batches, BATCH, 2) in [0, 1).
    The pairs of a batch are tried in order of gain, so the first free one is the best."""
    d = path.shape[1]
    path = _reduce(path, floats, ints, work, work_ints)
    a = np.empty((BATCH, d))
    b = np.empty((BATCH, d))
    ka = np.empty(BATCH, dtype=np.int64)
    kb = np.empty(BATCH, dtype=np.int64)
    gain = np.empty(BATCH)
    for batch in range(draws.shape[0]):
        n = path.shape[0]
        if n <= 2:
            break
        cum = arc_lengths(path)
        if cum[-1] <= 0:
            break
        for p in range(BATCH):
            s0, s1 = draws[batch, p, 0] * cum[-1], draws[batch, p, 1] * cum[-1]
            if s1 < s0:
                s0, s1 = s1, s0
            ka[p] = _point(path, cum, s0, a[p])
            kb[p] = _point(path, cum, s1, b[p])
            chord = 0.0
            for j in range(d):
                chord += (b[p, j] - a[p, j]) ** 2
            gain[p] = 0.0 if ka[p] == kb[p] else (s1 - s0) - np.sqrt(chord)
        for p in np.argsort(-gain, kind="mergesort"):
            if gain[p] <= 1e-6:
                break
            if motion_free(floats, ints, work, work_ints, a[p], b[p]):
                head, tail = ka[p] + 1, n - kb[p] - 1
                new = np.empty((head + 2 + tail, d))
                new[:head] = path[:head]
                new[head] = a[p]
                new[head + 1] = b[p]
                new[head + 2 :] = path[kb[p] + 1 :]
                path = new
                break
    return _reduce(path, floats, ints, work, work_ints)


@nb.njit(cache=True, inline="always")
def _round(path, fraction, floats, ints, work, work_ints):
    """`round_corners`, compiled."""
    n, d = path.shape
    if n <= 2:
        return path.copy()
    out = np.empty((2 * n, d))
    out[0] = path[0]
    m = 1
    a = np.empty(d)
    b = np.empty(d)
    for i in range(1, n - 1):
        for j in range(d):
            c = path[i, j]
            a[j] = c + fraction * (out[m - 1, j] - c)
            b[j] = c + fraction * (path[i + 1, j] - c)
        if motion_free(floats, ints, work, work_ints, a, b):
            out[m] = a
            out[m + 1] = b
            m += 2
        else:
            out[m] = path[i]
            m += 1
    out[m] = path[n - 1]
    return out[: m + 1].copy()


@nb.njit(cache=True, nogil=True)
def _post(path, draws, fraction, floats, ints, work, work_ints):
    """Shortcut, then round: one compiled function, one load from numba's cache."""
    short = _shortcut(path, draws, floats, ints, work, work_ints)
    return short, _round(short, fraction, floats, ints, work, work_ints)


def shortcut_and_round(
    path: np.ndarray,
    checker: CompiledChecker,
    rng: np.random.Generator,
    attempts: int = 60,
    fraction: float = 0.25,
) -> tuple[np.ndarray, np.ndarray]:
    """`shortcut` then `round_corners` in one compiled call over a checker's kernels:
    the same paths from the same random draws. Returns (shortcut path, rounded path)."""
    draws = rng.random((-(-attempts // BATCH), BATCH, 2))
    path = np.ascontiguousarray(path, dtype=float)
    return _post(path, draws, float(fraction), *checker.kernel_args())
