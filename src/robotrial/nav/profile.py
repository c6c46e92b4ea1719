"""A time-optimal speed profile along a footprint plan, and the controller that tracks it
(layer 3).

A Hybrid-A* plan is a chain of poses: short drives (straight or arcs) and turns on the
spot. `plan_profile` times such a chain (a `SpeedProfile`) as fast as the base's limits
allow: every piece between two poses is a drive (`ds` m along the heading, `dtheta`
rad) or a turn on the spot; a path parameter `sigma` advances by `|ds|` on a drive and
`rho |dtheta|` on a turn (`rho` = top speed / top yaw rate, so both reach their top rate
at the same `sigma` rate). The rate is capped per piece by the top speed, the top yaw
rate over the curvature (`w = kappa v`), the speed the exact rectangle's clearance
allows (`rectangle_clearance`: `narrow_speed` at `tight_clearance`, the top speed from
`ample_clearance` up), and the yaw acceleration a change of curvature asks for
(`v^2 |dkappa/ds| <= alpha`, the curvature averaged over `curve_length`); it is zero
where a drive meets a turn on the spot or reverses. A forward pass (accelerate from the
current speed) and a backward pass (brake to a stop at the end) with the acceleration
limits (and `|kappa| a <= alpha` on arcs) give the fastest rate at every pose, and the
time of each piece follows exactly (accelerate, cruise, brake within the piece).

`minimum_time` is that time for the base's own limits with no clearance cap: the
footprint-aware yardstick of `robotrial bench nav`.

`center_poses` shifts the plan's poses sideways to where the rectangle has the most room
(a plan may hug one wall of a corridor), and `smooth_poses` lets the base turn while it
drives: it replaces stretches of a plan (a turn on the spot between two drives, or a run
of small arcs) by one cubic Hermite curve from pose to pose where the rectangle, grown
by a margin, clears every obstacle along it and the curve bends no tighter than
`max_curvature`.

`ProfileController.compute` follows the (smoothed) plan: it finds how far along the plan
the base is (position and heading), recomputes the profile from there with the
current speed (braking before any pose of the plan ahead that the scan now blocks),
takes the rate one control period ahead as the feed-forward (v, w), and corrects the
lateral and heading error (the tracking law of Kanayama et al., 1990). Before a command
is given, a short arc of it is checked with the exact rectangle; when the base is
blocked, `ok` is False (the navigator stops and recovers). A new plan replaces the one
being followed only when that one is blocked, the base has left it, the plan ends
elsewhere, or the new one is clearly sooner: replanning every second from a moving base
would otherwise start many a new plan with a turn on the spot.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numba
import numpy as np

from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.dwa import DWAResult, rollout
from robotrial.nav.hybrid import footprint_hits, wall_marks

_SPIN = 1e-6  # m: a piece shorter than this is a turn on the spot


@dataclass(frozen=True)
class ProfileConfig:
    """The base's limits (m/s, rad/s, m/s^2, rad/s^2) and what the profile and the
    tracking take from them.

    `accel_use`: the share of the accelerations the profile plans with (the rest is left
    for the tracking corrections). `curve_length` (m): the curvature is averaged over
    this length before its rate of change caps the speed. Clearance caps: below
    `tight_clearance` (m, the exact rectangle's distance to the nearest obstacle) the
    speed is at most `narrow_speed`, rising linearly to the top speed at
    `ample_clearance`. Smoothing: the rectangle keeps `smooth_margin` (m) along a curve
    that replaces part of the plan, which bends at most `max_curvature` (1/m), and spans
    at most `smooth_span` (m). Centring: poses move sideways by at most `center_shift`
    (m), the shifts averaged over `center_length` (m) and faded out over `center_taper`
    (m) before and after the ends and the turns on the spot. Tracking gains: `k_lateral`
    (1/m^2) and `k_heading` (1/m) per metre driven, `k_along` (1/s) and `k_spin` (1/s)
    on a turn on the spot.
    `period` (s): the control period. The base counts as off the plan beyond
    `off_track` (m) or `off_heading` (rad); a new plan replaces one still good to
    follow when it is sooner by more than `switch_gain` (s); scan marks within
    `wall_tolerance` (m) of the map's walls are those walls seen from a pose a little
    off."""

    max_speed: float = 1.0
    max_yaw_rate: float = 2.0
    max_accel: float = 1.0
    max_yaw_accel: float = 3.0
    accel_use: float = 0.9
    curve_length: float = 0.3
    narrow_speed: float = 0.3
    tight_clearance: float = 0.02
    ample_clearance: float = 0.10
    clearance_cap: float = 0.2
    smooth_margin: float = 0.05
    switch_gain: float = 0.5
    creep_speed: float = 0.05
    center_shift: float = 0.12
    center_length: float = 0.5
    center_taper: float = 1.0
    max_curvature: float = 3.0
    smooth_span: float = 2.5
    k_lateral: float = 9.0
    k_heading: float = 4.5
    k_along: float = 1.0
    k_spin: float = 2.0
    period: float = 0.05
    off_track: float = 0.25
    off_heading: float = 0.4
    wall_tolerance: float = 0.12

    def __post_init__(self) -> None:
        for k in ("max_speed", "max_yaw_rate", "max_accel", "max_yaw_accel", "period"):
            if not getattr(self, k) > 0:
                raise ValueError(f"profile: {k} must be positive, got {getattr(self, k)}")
        if not 0 < self.accel_use <= 1:
            raise ValueError(f"profile: accel_use must be in (0, 1], got {self.accel_use}")
        if not 0 <= self.tight_clearance < self.ample_clearance:
            raise ValueError(
                "profile: need 0 <= tight_clearance < ample_clearance, got "
                f"{self.tight_clearance}, {self.ample_clearance}"
            )
        if not 0 < self.narrow_speed <= self.max_speed:
            raise ValueError(
                f"profile: narrow_speed must be in (0, max_speed], got {self.narrow_speed}"
            )


# --- geometry of a chain of poses ------------------------------------------------------


def densify(poses: np.ndarray, step: float = 0.05, angle: float = np.radians(5.0)) -> np.ndarray:
    """The chain of poses (N, 3) with pieces no longer than `step` (m) and no larger turn
    than `angle` (rad); the yaw unwrapped (continuous), repeated poses dropped."""
    p = np.asarray(poses, dtype=float).reshape(-1, 3).copy()
    if len(p) == 0:
        raise ValueError("profile: the plan has no poses")
    p[:, 2] = np.unwrap(p[:, 2])
    out = [p[:1]]
    for a, b in itertools.pairwise(p):
        n = max(
            int(np.ceil(np.hypot(*(b[:2] - a[:2])) / step - 1e-9)),
            int(np.ceil(abs(b[2] - a[2]) / angle - 1e-9)),
        )
        if n == 0:
            continue
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + t * (b - a))
    return np.vstack(out)


def pieces(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per piece between consecutive poses (unwrapped yaw): the signed distance along
    the heading `ds` (m), the turn `dtheta` (rad) and whether it is a turn on the spot."""
    p = np.asarray(poses, dtype=float)
    d = np.diff(p, axis=0)
    mid = p[:-1, 2] + 0.5 * d[:, 2]
    along = d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid)
    spin = np.hypot(d[:, 0], d[:, 1]) < _SPIN
    ds = np.where(spin, 0.0, np.where(along < 0, -1.0, 1.0) * np.hypot(d[:, 0], d[:, 1]))
    return ds, d[:, 2], spin


@numba.njit(cache=True)
def _rect_clearance(xs, ys, ths, blocked, dist, ox, oy, res, a, b, cap):
    """Per pose: how far (m, up to `cap`) the rectangle of half sides a x b can grow (as a
    box) before it touches a blocked cell square; negative: it already overlaps."""
    rows, cols = blocked.shape
    h = 0.5 * res
    reach = np.hypot(a, b) + cap + res
    n = int(np.ceil(reach / res))
    out = np.full(xs.shape[0], cap)
    for i in range(xs.shape[0]):
        x, y = xs[i], ys[i]
        c0 = int(np.floor((x - ox) / res))
        r0 = int(np.floor((y - oy) / res))
        if 0 <= r0 < rows and 0 <= c0 < cols and dist[r0, c0] > reach:
            continue
        c, s = np.cos(ths[i]), np.sin(ths[i])
        ac, as_ = abs(c), abs(s)
        best = cap
        for r in range(r0 - n, r0 + n + 1):
            for cc in range(c0 - n, c0 + n + 1):
                outside = r < 0 or r >= rows or cc < 0 or cc >= cols
                if not outside and not blocked[r, cc]:
                    continue
                px = ox + (cc + 0.5) * res - x
                py = oy + (r + 0.5) * res - y
                m = (abs(px) - h - a * ac - b * as_) / (ac + as_)
                m = max(m, (abs(py) - h - a * as_ - b * ac) / (ac + as_))
                m = max(m, abs(px * c + py * s) - a - h * (ac + as_))
                m = max(m, abs(-px * s + py * c) - b - h * (ac + as_))
                if m < best:
                    best = m
        out[i] = best
    return out


def rectangle_clearance(
    costmap: Costmap, poses: np.ndarray, blocked: np.ndarray | None = None, cap: float = 0.2
) -> np.ndarray:
    """The exact rectangle's clearance (m) at each pose (N, 3): how far it could grow on
    every side before it touches a blocked cell (default: lethal; cells outside the map
    count as blocked), at most `cap`; negative where it overlaps one."""
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    fp = costmap.footprint
    return _rect_clearance(
        p[:, 0].copy(),
        p[:, 1].copy(),
        p[:, 2].copy(),
        costmap.lethal if blocked is None else blocked,
        costmap.distance,
        costmap.origin[0],
        costmap.origin[1],
        costmap.resolution,
        0.5 * fp.length,
        0.5 * fp.width,
        float(cap),
    )


# --- the speed profile -----------------------------------------------------------------


@numba.njit(cache=True)
def _passes(dsig, acc, cap, u0, u_end):
    """Forward (from `u0`) and backward (to `u_end`) passes of the rate along the path."""
    n = cap.shape[0]
    u = cap.copy()
    u[0] = min(u0, cap[0])
    for i in range(n - 1):
        u[i + 1] = min(u[i + 1], np.sqrt(u[i] * u[i] + 2.0 * acc[i] * dsig[i]))
    u[n - 1] = min(u[n - 1], u_end)
    for i in range(n - 2, -1, -1):
        u[i] = min(u[i], np.sqrt(u[i + 1] * u[i + 1] + 2.0 * acc[i] * dsig[i]))
    return u


@dataclass
class SpeedProfile:
    """The fastest rate along a chain of poses within the limits (see the module
    docstring): per pose `sigma` (the path parameter) and `rate` (d sigma / dt); per
    piece `ds`, `dtheta`, `spin`, `dsig` and the time `dt` (s)."""

    poses: np.ndarray
    sigma: np.ndarray
    rate: np.ndarray
    ds: np.ndarray
    dtheta: np.ndarray
    spin: np.ndarray
    dsig: np.ndarray
    dt: np.ndarray
    acc: np.ndarray
    cap: np.ndarray

    @property
    def duration(self) -> float:
        """Seconds from the first pose to a stop on the last."""
        return float(self.dt.sum())

    def rate_at(self, i: int, x: float) -> float:
        """The rate `x` (path parameter) into piece `i`: accelerating from its start,
        braking to its end, at most its cap."""
        a = self.acc[i]
        ua, ub = self.rate[i], self.rate[i + 1]
        x = min(max(x, 0.0), self.dsig[i])
        return float(
            min(
                self.cap[i],
                np.sqrt(ua * ua + 2 * a * x),
                np.sqrt(ub * ub + 2 * a * (self.dsig[i] - x)),
            )
        )

    def command(self, i: int, rate: float) -> tuple[float, float]:
        """(v, w) at `rate` on piece `i`."""
        if self.dsig[i] <= 0:
            return 0.0, 0.0
        k = rate / self.dsig[i]
        return float(k * self.ds[i]), float(k * self.dtheta[i])


def plan_profile(
    poses: np.ndarray,
    config: ProfileConfig,
    clearance: np.ndarray | None = None,
    start_rate: float = 0.0,
    accel_use: float | None = None,
    stop_at: int | None = None,
    curvature_rate: bool = True,
) -> SpeedProfile:
    """The time-optimal profile along `poses` (N, 3, unwrapped yaw, as from `densify`),
    starting at `start_rate` and stopping on the last pose (or at pose `stop_at`).
    `clearance` (N,) m caps the speed per pose (None: no cap). `accel_use` overrides the
    configuration's share of the accelerations (1.0: the base's full limits). Without
    `curvature_rate` the yaw acceleration that changes of curvature ask for is left out
    (each piece taken as its own arc)."""
    c = config
    p = np.asarray(poses, dtype=float)
    n = len(p)
    share = c.accel_use if accel_use is None else accel_use
    acc, yaw_acc = share * c.max_accel, share * c.max_yaw_accel
    rho = c.max_speed / c.max_yaw_rate
    if n < 2:
        z = np.zeros(0)
        return SpeedProfile(p, np.zeros(n), np.zeros(n), z, z, z.astype(bool), z, z, z, z)
    ds, dth, spin = pieces(p)
    dsig = np.where(spin, rho * np.abs(dth), np.abs(ds))
    kappa = np.where(spin, 0.0, dth / np.maximum(np.abs(ds), _SPIN))
    # piece caps on the rate
    piece_cap = np.where(
        spin,
        rho * c.max_yaw_rate,
        np.minimum(c.max_speed, c.max_yaw_rate / np.maximum(np.abs(kappa), 1e-9)),
    )
    piece_acc = np.where(
        spin, rho * yaw_acc, np.minimum(acc, yaw_acc / np.maximum(np.abs(kappa), 1e-9))
    )
    node_cap = np.full(n, np.inf)
    node_cap[:-1] = piece_cap
    node_cap[1:] = np.minimum(node_cap[1:], piece_cap)
    # a drive meeting a turn on the spot, or reversing, stops there
    drive_sign = np.where(spin, 0.0, np.sign(ds))
    change = drive_sign[1:] != drive_sign[:-1]
    node_cap[1:-1][change] = 0.0
    # the yaw acceleration a change of curvature needs: v^2 |dkappa/ds| <= alpha
    s = np.concatenate([[0.0], np.cumsum(np.abs(ds))])
    if s[-1] > 0 and curvature_rate:
        mids = 0.5 * (s[:-1] + s[1:])
        half = 0.5 * c.curve_length
        cum = np.concatenate([[0.0], np.cumsum(kappa * np.abs(ds))])  # heading turned
        lo = np.interp(np.clip(mids - half, 0, s[-1]), s, cum)
        hi = np.interp(np.clip(mids + half, 0, s[-1]), s, cum)
        span = np.maximum(np.clip(mids + half, 0, s[-1]) - np.clip(mids - half, 0, s[-1]), 1e-3)
        kbar = (hi - lo) / span
        dk = np.abs(np.diff(kbar)) / np.maximum(0.5 * (np.abs(ds[1:]) + np.abs(ds[:-1])), 1e-3)
        drive_pair = ~spin[1:] & ~spin[:-1]
        v_k = np.sqrt(yaw_acc / np.maximum(dk, 1e-9))
        node_cap[1:-1] = np.where(drive_pair, np.minimum(node_cap[1:-1], v_k), node_cap[1:-1])
    if clearance is not None:
        frac = np.clip(
            (np.asarray(clearance) - c.tight_clearance) / (c.ample_clearance - c.tight_clearance),
            0.0,
            1.0,
        )
        v_clear = c.narrow_speed + (c.max_speed - c.narrow_speed) * frac
        # only drives are capped: a turn on the spot does not move the centre
        moving = np.zeros(n, dtype=bool)
        moving[:-1] |= ~spin
        moving[1:] |= ~spin
        node_cap = np.where(moving, np.minimum(node_cap, v_clear), node_cap)
    end = n - 1 if stop_at is None else int(np.clip(stop_at, 0, n - 1))
    node_cap[end:] = 0.0
    rate = _passes(dsig, piece_acc, node_cap, float(max(start_rate, 0.0)), 0.0)
    dt = _piece_times(rate[:-1], rate[1:], piece_acc, dsig, piece_cap)
    dt[end:] = 0.0
    sigma = np.concatenate([[0.0], np.cumsum(dsig)])
    return SpeedProfile(p, sigma, rate, ds, dth, spin, dsig, dt, piece_acc, piece_cap)


def _piece_times(
    ua: np.ndarray, ub: np.ndarray, acc: np.ndarray, dsig: np.ndarray, cap: np.ndarray
) -> np.ndarray:
    """Time (s) of each piece from rate `ua` to `ub`: accelerate, cruise at the piece's
    cap (or peak below it), brake."""
    acc = np.maximum(acc, 1e-9)
    peak = np.minimum(cap, np.sqrt(np.maximum(0.5 * (ua**2 + ub**2) + acc * dsig, 0.0)))
    peak = np.maximum(peak, np.maximum(ua, ub))
    d1 = (peak**2 - ua**2) / (2 * acc)
    d2 = (peak**2 - ub**2) / (2 * acc)
    cruise = np.maximum(dsig - d1 - d2, 0.0)
    t = (
        (peak - ua) / acc
        + (peak - ub) / acc
        + np.where(peak > 0, cruise / np.maximum(peak, 1e-9), 0)
    )
    return np.where(dsig > 0, t, 0.0)


def minimum_time(
    poses: np.ndarray,
    limits: ProfileConfig,
    goal_yaw: float | None = None,
    costmap: Costmap | None = None,
    margin: float = 0.03,
) -> float:
    """The least time (s) in which a base with these limits (used in full) follows the
    chain of poses (N, 3) from rest to rest, turns on the spot included, then turns on
    the spot to `goal_yaw` (rad) if given. With a `costmap`, the chain is first smoothed
    (`smooth_poses`, the rectangle keeping `margin` m): the base turns while it drives
    where the rectangle clears a curve."""
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    if costmap is not None:
        p = smooth_poses(costmap, p, replace(limits, smooth_margin=margin))
    else:
        p = densify(p)
    if goal_yaw is not None:
        last = p[-1].copy()
        last[2] = last[2] + (goal_yaw - last[2] + np.pi) % (2 * np.pi) - np.pi
        p = densify(np.vstack([p, last]))
    return plan_profile(p, limits, accel_use=1.0).duration


# --- turning while driving: smoothing a plan -------------------------------------------


def hermite(a: np.ndarray, b: np.ndarray, step: float = 0.04) -> tuple[np.ndarray, float]:
    """Poses (M, 3) about `step` m apart along the cubic Hermite curve from pose `a` to
    pose `b` (the tangents along their headings, as long as the chord), and the curve's
    largest curvature (1/m)."""
    chord = float(np.hypot(*(b[:2] - a[:2])))
    ma = chord * np.array([np.cos(a[2]), np.sin(a[2])])
    mb = chord * np.array([np.cos(b[2]), np.sin(b[2])])
    n = max(4, int(np.ceil(1.3 * chord / step)))
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    t2, t3 = t * t, t * t * t
    pos = (
        (2 * t3 - 3 * t2 + 1) * a[:2]
        + (t3 - 2 * t2 + t) * ma
        + (-2 * t3 + 3 * t2) * b[:2]
        + (t3 - t2) * mb
    )
    d1 = (6 * t2 - 6 * t) * a[:2] + (3 * t2 - 4 * t + 1) * ma
    d1 += (-6 * t2 + 6 * t) * b[:2] + (3 * t2 - 2 * t) * mb
    d2 = (12 * t - 6) * a[:2] + (6 * t - 4) * ma + (-12 * t + 6) * b[:2] + (6 * t - 2) * mb
    speed = np.hypot(d1[:, 0], d1[:, 1])
    kappa = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.maximum(speed, 1e-9) ** 3
    yaw = np.unwrap(np.arctan2(d1[:, 1], d1[:, 0]))
    yaw += a[2] - yaw[0]
    return np.column_stack([pos, yaw]), float(np.abs(kappa).max())


def smooth_poses(
    costmap: Costmap,
    poses: np.ndarray,
    config: ProfileConfig = ProfileConfig(),
    blocked: np.ndarray | None = None,
) -> np.ndarray:
    """The plan (N, 3) with stretches replaced by Hermite curves where the rectangle,
    grown by `smooth_margin`, clears `blocked` (default: lethal) all along one and it bends
    no tighter than `max_curvature`: the base turns while it drives instead of stopping
    to turn. Returns the chain (M, 3, unwrapped yaw) about 5 cm apart."""
    c = config
    p = np.asarray(poses, dtype=float).reshape(-1, 3).copy()
    p[:, 2] = np.unwrap(p[:, 2])
    # anchors: the plan's own poses, without repeats
    keep = np.concatenate([[True], np.abs(np.diff(p, axis=0)).max(axis=1) > 1e-9])
    p = p[keep]
    n = len(p)
    if n < 3:
        return densify(p)
    blk = costmap.lethal if blocked is None else blocked
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p[:, :2], axis=0).T))])
    out = [p[:1]]
    i = 0
    while i < n - 1:
        done = False
        # the farthest anchors first: the longest curve bends least
        ends = np.flatnonzero((s > s[i] + 0.1) & (s <= s[i] + c.smooth_span))
        tried = 0
        for j in ends[::-1]:
            if j <= i + 1 or tried >= 6:
                break
            if j < n - 1 and np.hypot(*(p[j + 1, :2] - p[j, :2])) < _SPIN:
                continue  # do not end a curve in the middle of a turn on the spot
            a, b = p[i], p[j]
            chord = b[:2] - a[:2]
            # both headings must point along the chord: a forward curve
            ha = np.array([np.cos(a[2]), np.sin(a[2])])
            hb = np.array([np.cos(b[2]), np.sin(b[2])])
            if chord @ ha <= 0.2 * np.hypot(*chord) or chord @ hb <= 0.2 * np.hypot(*chord):
                continue
            tried += 1
            curve, kmax = hermite(a, b)
            if kmax > c.max_curvature:
                continue
            if footprint_hits(costmap, curve, c.smooth_margin, blk).any():
                continue
            turn = b[2] - curve[-1, 2]
            curve[:, 2] += np.linspace(0.0, turn, len(curve))  # the unwrap of b's yaw
            out.append(curve[1:])
            i = int(j)
            done = True
            break
        if not done:
            out.append(densify(p[i : i + 2])[1:])
            i += 1
    return np.vstack(out)


def center_poses(
    costmap: Costmap,
    poses: np.ndarray,
    config: ProfileConfig = ProfileConfig(),
    blocked: np.ndarray | None = None,
) -> np.ndarray:
    """The plan's poses (N, 3) shifted sideways, by at most `center_shift` m, to where the
    rectangle has the most room (a plan that hugs one wall of a corridor is slower than
    one down its middle); the shifts are averaged over `center_length` m and vanish at
    both ends and at turns on the spot. `smooth_poses` then draws its curves through
    them, and checks them."""
    c = config
    p = np.asarray(poses, dtype=float).reshape(-1, 3).copy()
    n = len(p)
    if n < 5 or c.center_shift <= 0:
        return p
    blk = costmap.lethal if blocked is None else blocked
    ds, _, spin = pieces(p)
    moving = np.zeros(n, dtype=bool)
    moving[1:-1] = ~spin[:-1] & ~spin[1:]
    offsets = np.linspace(-c.center_shift, c.center_shift, 9)
    normal = np.column_stack([-np.sin(p[:, 2]), np.cos(p[:, 2])])
    clear = np.stack(
        [
            rectangle_clearance(
                costmap, np.column_stack([p[:, :2] + o * normal, p[:, 2]]), blk, c.clearance_cap
            )
            for o in offsets
        ]
    )
    base = clear[len(offsets) // 2]
    best = offsets[np.argmax(clear, axis=0)]
    best = np.where(clear.max(axis=0) > base + 0.01, best, 0.0)
    best[~moving] = 0.0
    step = max(float(np.median(np.abs(ds[~spin]))) if (~spin).any() else 0.0, 1e-3)
    k = max(1, round(0.5 * c.center_length / step))
    shift = np.convolve(np.pad(best, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), "valid")
    # the base must come to the plan's own turning points and ends on the plan: the
    # shifts fade out over `center_taper` m of travel before and after them
    fixed = np.flatnonzero(~moving)
    along = np.concatenate([[0.0], np.cumsum(np.abs(ds))])
    gap = np.abs(along[:, None] - along[fixed][None, :]).min(axis=1)
    shift *= np.clip(gap / c.center_taper, 0.0, 1.0)
    p[:, :2] += shift[:, None] * normal
    return p


# --- the controller --------------------------------------------------------------------


class ProfileController:
    """Follows footprint plans at the fastest speed their clearance allows (see the
    module docstring); the navigator's controller interface plus `set_path`."""

    def __init__(self, footprint: Footprint, config: ProfileConfig = ProfileConfig()) -> None:
        self.footprint = footprint
        self.config = config
        self.poses: np.ndarray | None = None  # the chain being followed (M, 3)
        self.clearance: np.ndarray | None = None
        self.profile: SpeedProfile | None = None
        self.progress = 0  # index of the piece the base is on
        self.adopted = 0
        self._blocked = False  # the plan's command was blocked: take up the next plan

    # --- the plan ----------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the plan being followed (a new goal)."""
        self.poses = None
        self.clearance = None
        self.profile = None
        self.progress = 0
        self._blocked = False

    def set_path(
        self,
        poses: np.ndarray,
        costmap: Costmap,
        pose: tuple[float, ...],
        velocity: tuple[float, float] = (0.0, 0.0),
    ) -> bool:
        """A new plan (N, 3 poses, or N, 2 points: the heading along them) from the
        navigator on its global costmap, the base at `pose` moving at `velocity` (v, w).
        It replaces the plan being followed if that one is blocked, left behind or ends
        elsewhere, or if it is sooner by more than `switch_gain` s. Returns whether it
        was taken up."""
        c = self.config
        plan = _as_poses(poses, pose)
        blocked = costmap.lethal & ~wall_marks(costmap, c.wall_tolerance)
        keep = (
            self.poses is not None
            and not self._blocked
            and self._still_good(plan, costmap, blocked, pose)
        )
        plan = center_poses(costmap, plan, c, blocked)
        chain = smooth_poses(costmap, plan, c, blocked)
        clearance = rectangle_clearance(costmap, chain, blocked, c.clearance_cap)
        if keep:
            assert self.poses is not None and self.clearance is not None
            v0 = abs(float(velocity[0]))
            i = self._locate(np.asarray(pose, dtype=float))[0]
            left = plan_profile(self.poses[i:], c, self.clearance[i:], start_rate=v0).duration
            new = _time_from(chain, clearance, c, v0)
            if new > left - c.switch_gain:
                return False
        self.poses = chain
        self.clearance = clearance
        self.progress = 0
        self.adopted += 1
        self._blocked = False
        return True

    def _still_good(
        self, plan: np.ndarray, costmap: Costmap, blocked: np.ndarray, pose: tuple[float, ...]
    ) -> bool:
        assert self.poses is not None
        if np.hypot(*(plan[-1, :2] - self.poses[-1, :2])) > 0.05:
            return False
        i, _, err, yaw_err = self._locate(np.asarray(pose, dtype=float))
        if err > self.config.off_track or abs(yaw_err) > self.config.off_heading:
            return False
        return not footprint_hits(costmap, self.poses[i:], 0.0, blocked).any()

    def _locate(self, pose: np.ndarray) -> tuple[int, float, float, float]:
        """The piece the base is on (near the last one), how far along it (0..1), the
        base's distance from the plan (m) and its heading error (rad)."""
        p = self.poses
        assert p is not None
        n = len(p)
        lo, hi = max(0, self.progress - 3), min(n, self.progress + 60)
        seg = p[lo:hi]
        dyaw = _wrap(seg[:, 2] - pose[2])
        d2 = (seg[:, 0] - pose[0]) ** 2 + (seg[:, 1] - pose[1]) ** 2 + (0.25 * dyaw) ** 2
        k = lo + int(np.argmin(d2))
        best = None
        for i in (k - 1, k):
            if i < 0 or i >= n - 1:
                continue
            a, b = p[i], p[i + 1]
            d = b[:2] - a[:2]
            ln2 = float(d @ d)
            if ln2 < _SPIN**2:
                span = b[2] - a[2]
                t = float(np.clip(_wrap(pose[2] - a[2]) / span, 0.0, 1.0)) if span else 1.0
            else:
                t = float(np.clip((pose[:2] - a[:2]) @ d / ln2, 0.0, 1.0))
            ref = a + t * (b - a)
            r = np.hypot(*(pose[:2] - ref[:2])) + 0.25 * abs(_wrap(pose[2] - ref[2]))
            if best is None or r < best[0]:
                best = (r, i, t, ref)
        if best is None:
            i = min(k, n - 2) if n > 1 else 0
            ref = p[min(k, n - 1)]
            best = (0.0, i, 1.0, ref)
        _, i, t, ref = best
        return i, t, float(np.hypot(*(pose[:2] - ref[:2]))), float(_wrap(ref[2] - pose[2]))

    # --- the control step --------------------------------------------------------------

    def compute(
        self,
        pose: tuple[float, float, float],
        velocity: tuple[float, float],
        path: np.ndarray,
        costmap: Costmap,
        goal_distance: float | None = None,
        goal_yaw: float | None = None,
    ) -> DWAResult:
        """The command (v, w) on the plan set by `set_path` (`path` is taken instead when
        none was set); `ok` False when the base cannot move without touching something.
        `goal_distance` and `goal_yaw` are accepted for the navigator's interface."""
        c = self.config
        pose_a = np.asarray(pose, dtype=float)
        if self.poses is None:
            if path is None or len(path) == 0:
                raise ValueError("profile: no plan to follow")
            plan = _as_poses(path, pose)
            self.poses = densify(plan)
            self.clearance = rectangle_clearance(costmap, self.poses, cap=c.clearance_cap)
        p = self.poses
        assert self.clearance is not None
        v0, w0 = float(velocity[0]), float(velocity[1])
        blocked = costmap.lethal & ~wall_marks(costmap, c.wall_tolerance)
        i, t, _, _ = self._locate(pose_a)
        self.progress = i
        rest = p[i:]
        # poses ahead within the stopping distance (plus a margin) that the scan now blocks
        stop_at = None
        reach = v0 * v0 / (2 * c.accel_use * c.max_accel) + 0.6
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(rest[:, :2], axis=0).T))])
        near = np.flatnonzero(along <= reach)
        # only where the whole rectangle lies inside the (local) costmap
        border = int(np.ceil(self.footprint.circumscribed_radius / costmap.resolution)) + 1
        rc = costmap.world_to_cell(rest[near, :2])
        rows, cols = costmap.shape
        window = (
            (rc[:, 0] >= border)
            & (rc[:, 0] < rows - border)
            & (rc[:, 1] >= border)
            & (rc[:, 1] < cols - border)
        )
        check = near[window]
        if len(check):
            hit = footprint_hits(costmap, rest[check], 0.0, blocked)
            if hit.any():
                stop_at = int(check[int(np.argmax(hit))])
        # the rate now: the base's speed along this piece
        spin = pieces(p[i : i + 2])[2]
        rho = c.max_speed / c.max_yaw_rate
        rate0 = rho * abs(w0) if spin[0] else abs(v0)
        prof = plan_profile(
            rest,
            c,
            self.clearance[i:],
            start_rate=rate0,
            stop_at=None if stop_at is None else max(stop_at - 1, 0),
        )
        self.profile = prof
        if len(prof.dsig) == 0 or prof.sigma[-1] <= 0:
            return DWAResult(0.0, 0.0, True, np.zeros((0, 3)), 1)
        # the rate one period ahead of where the base is on this piece
        sig = t * prof.dsig[0]
        acc0 = c.accel_use * (c.max_accel if not spin[0] else rho * c.max_yaw_accel)
        ahead = sig + rate0 * c.period + 0.5 * acc0 * c.period**2
        last = len(prof.dsig) - 1
        j = int(np.clip(np.searchsorted(prof.sigma, ahead, side="right") - 1, 0, last))
        x = ahead - prof.sigma[j]
        if j < last and prof.dsig[j] - x < 2e-3 and prof.rate[j + 1] == 0.0:
            # at the very end of a piece that stops (a drive before a turn on the spot):
            # start the next one
            j, x = j + 1, 0.5 * acc0 * c.period**2
        rate = prof.rate_at(j, x)
        v_ff, w_ff = prof.command(j, rate)
        # tracking: the reference pose where the base is on its piece
        ref = p[i] + t * (p[i + 1] - p[i]) if i + 1 < len(p) else p[i]
        dx, dy = ref[0] - pose_a[0], ref[1] - pose_a[1]
        cs, sn = np.cos(pose_a[2]), np.sin(pose_a[2])
        ex, ey = cs * dx + sn * dy, -sn * dx + cs * dy
        eth = float(_wrap(ref[2] - pose_a[2]))
        if abs(v_ff) > 1e-6:
            sgn = 1.0 if v_ff > 0 else -1.0
            v = v_ff * np.cos(eth) + c.k_along * ex
            w = w_ff + abs(v_ff) * (sgn * c.k_lateral * ey + c.k_heading * np.sin(eth))
        else:
            v = c.k_along * ex if stop_at is None or stop_at > 1 else 0.0
            v = float(np.clip(v, -0.05, 0.05))
            w = w_ff + c.k_spin * eth
        dv, dw = c.max_accel * c.period, c.max_yaw_accel * c.period
        v = float(np.clip(np.clip(v, v0 - dv, v0 + dv), -c.max_speed, c.max_speed))
        w = float(np.clip(np.clip(w, w0 - dw, w0 + dw), -c.max_yaw_rate, c.max_yaw_rate))
        # the command's next moments must leave the rectangle clear
        slower = max(0.0, v0 - dv) if v0 > 0 else min(0.0, v0 + dv)
        # slowing down keeps the arc's curvature: the same turn rate at a lower speed
        # would turn the base off the plan (into a doorway's jamb) while it brakes
        bend = w * slower / v if v * slower > 1e-9 else w
        candidates = [(v, w), (slower, float(np.clip(bend, w0 - dw, w0 + dw)))]
        candidates.append((candidates[-1][0], float(np.clip(0.0, w0 - dw, w0 + dw))))
        if abs(v) < 0.1 and stop_at is None:
            # where a turn on the spot is blocked (the base stopped a little off the
            # plan's turning point), turning while creeping forwards or backwards may not be
            turn = w if abs(w) > 0.05 else 0.3 * float(np.sign(w_ff + eth) or 1.0)
            turn = float(np.clip(turn, w0 - dw, w0 + dw))
            candidates += [(c.creep_speed, turn), (-c.creep_speed, turn)]
        here_clear = not footprint_hits(costmap, pose_a[None], 0.0, blocked).any()
        for k, (cv, cw) in enumerate(candidates):
            if cv == 0.0 and cw == 0.0:
                continue
            steps = max(2, int(np.ceil((abs(cv) / c.max_accel + 0.2) / 0.05)))
            traj = rollout(tuple(pose_a), np.array([cv]), np.array([cw]), steps, 0.05)[0]
            hits = footprint_hits(costmap, traj, 0.0, blocked)
            if not hits.any() or (not here_clear and not hits[-1]):
                if k >= 3:
                    # a turn on the spot of the plan would touch (the base stopped off
                    # the plan's turning point): the navigator's next plan, from where
                    # the base is, replaces it
                    self._blocked = True
                return DWAResult(cv, cw, True, traj, len(candidates))
        self._blocked = True
        # nothing moving is clear: stop (the navigator recovers if this lasts)
        return DWAResult(0.0, 0.0, False, np.zeros((0, 3)), len(candidates))


def _time_from(chain: np.ndarray, clearance: np.ndarray, config: ProfileConfig, v0: float) -> float:
    """The profile's time along `chain` for a base now driving at `v0` m/s: if the chain
    starts with a turn on the spot, the base first stops."""
    spin = pieces(chain[:2])[2]
    if len(spin) and spin[0]:
        stop = v0 / (config.accel_use * config.max_accel)
        return stop + plan_profile(chain, config, clearance).duration
    return plan_profile(chain, config, clearance, start_rate=v0).duration


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _as_poses(path: np.ndarray, pose: tuple[float, ...]) -> np.ndarray:
    """A plan as poses: (N, 3) as given, or (N, 2) points with the heading along each
    stretch and a turn on the spot at each corner (from the base's own yaw first)."""
    p = np.asarray(path, dtype=float)
    if p.ndim != 2 or p.shape[1] not in (2, 3) or len(p) == 0:
        raise ValueError(f"profile: a plan is (N, 2) points or (N, 3) poses, got {p.shape}")
    if p.shape[1] == 3:
        return p
    keep = np.concatenate([[True], np.hypot(*np.diff(p, axis=0).T) > 1e-9])
    p = p[keep]
    out = [[p[0, 0], p[0, 1], float(pose[2])]]
    for a, b in itertools.pairwise(p):
        yaw = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
        out.append([a[0], a[1], yaw])
        out.append([b[0], b[1], yaw])
    return np.array(out)
