"""Compiled collision kernels over sphere bodies and environment shapes (layer 2).

A body is a run of spheres fixed to one link (or to the object held in the hand) plus
a bounding sphere used to skip far-apart pairs. The kernels compute the link poses,
move the spheres, and stop at the first contact. Sphere centres are stored one row per
axis so that the gaps of a body's spheres to one shape are computed side by side
(SIMD).

The kernels called per configuration are compiled without numba's reference counting
(`_nrt=False`) and allocate nothing (scratch comes from `buffers`): with some thirty
arrays in play, the atomic reference counts of their arguments cost more than the
geometry did. For the same reason the clearance query is inlined into the motion
check: a call passes every array as seven machine words, and pushing them took a
third of the planner's time.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np

from robotrial.kinematics.chain import PRISMATIC, REVOLUTE, TreeArrays, fk_single

# the motion and configuration checks may fuse multiply-adds and assume no NaNs (the
# geometry has none): 9 % less time, the same answers on the benchmark problems
_FAST = {"nnan", "nsz", "reassoc", "contract", "arcp"}
_FAR = 1e30  # a gap larger than any scene
# The per-sphere loops count with unsigned integers: a signed index may be negative
# (numba then counts from the end), which turns SIMD loads into gathers.


class Shapes(NamedTuple):
    """Obstacles: boxes (inverse poses, half extents), cylinders (inverse poses, radii,
    half lengths) and spheres (centres, radii)."""

    box_inv: np.ndarray
    box_half: np.ndarray
    cyl_inv: np.ndarray
    cyl_r: np.ndarray
    cyl_h: np.ndarray
    sph_c: np.ndarray
    sph_r: np.ndarray


class Obstacles(NamedTuple):
    """The shapes and what a clearance query looks at (`item_lists`): every item, and
    those reachable inside the joint limits."""

    shapes: Shapes
    every: np.ndarray
    reachable: np.ndarray


class Bodies(NamedTuple):
    """The robot's sphere bodies in the frames of the collapsed tree: sphere centres
    (one row per axis) and radii, each body's run of spheres [start, end), its node,
    its bounding sphere (centre, radius), and which planning joints swing which (see
    `CollisionChecker._ancestry`), and each body's fine run [fine_start, fine_end): a
    tighter cover of the same link, asked only where the first run touches a shape
    (empty when the body has none or the checker does not ask it)."""

    sphere_local: np.ndarray
    radius: np.ndarray
    start: np.ndarray
    end: np.ndarray
    link: np.ndarray
    bound_local: np.ndarray
    bound_r: np.ndarray
    ancestry: np.ndarray
    fine_start: np.ndarray
    fine_end: np.ndarray


class Scratch(NamedTuple):
    """The kernels' working space (`buffers`)."""

    poses: np.ndarray
    centres: np.ndarray
    bound_c: np.ndarray
    ready: np.ndarray
    fine_ready: np.ndarray
    body_speed: np.ndarray
    pair_speed: np.ndarray
    ring: np.ndarray
    lists: np.ndarray
    gaps: np.ndarray
    pool: np.ndarray
    motion: np.ndarray


class ConfigChecks(NamedTuple):
    """What the configuration kernels take: the tree, the bodies, which bodies can
    touch obstacles, the self pairs (upper body first), the padding against obstacles
    (m), the obstacles and scratch space."""

    kin: TreeArrays
    bodies: Bodies
    env_bodies: np.ndarray
    pairs: np.ndarray
    pad: float
    env: Obstacles
    buf: Scratch


class MotionChecks(NamedTuple):
    """What the motion kernels take: the check resolution per joint, how fast bodies
    move and pairs close in per unit of each joint (`CollisionChecker._travel_bounds`),
    and the configuration kernels' arguments."""

    resolution: np.ndarray
    body_rate: np.ndarray
    pair_rate: np.ndarray
    config: ConfigChecks


def packed(checks: tuple) -> tuple:
    """`checks` (a `MotionChecks` or `ConfigChecks`) as plain nested tuples, the form
    the kernels called from Python take: numba's dispatcher types plain tuples in C and
    named ones in Python, 4 us more a call (a tenth of a short planning query). The
    kernels name them again with `motion_checks` and `config_checks`."""
    return tuple(packed(x) if isinstance(x, tuple) else x for x in checks)


@nb.njit(cache=True, inline="always")
def config_checks(t) -> ConfigChecks:
    """`ConfigChecks` from its `packed` form."""
    kin, bodies, env_bodies, pairs, pad, env, buf = t
    return ConfigChecks(
        TreeArrays(*kin),
        Bodies(*bodies),
        env_bodies,
        pairs,
        pad,
        Obstacles(Shapes(*env[0]), env[1], env[2]),
        Scratch(*buf),
    )


@nb.njit(cache=True, inline="always")
def motion_checks(t) -> MotionChecks:
    """`MotionChecks` from its `packed` form."""
    return MotionChecks(t[0], t[1], t[2], config_checks(t[3]))


@nb.njit(cache=True, inline="always")
def _least(gaps, s0, s1) -> float:
    """The smallest of gaps[s0:s1], over four independent minima (numba's min-reductions
    do not vectorise; the gaps themselves do)."""
    m0 = m1 = m2 = m3 = _FAR
    s = s0
    while s + 4 <= s1:
        m0 = min(m0, gaps[s])
        m1 = min(m1, gaps[s + 1])
        m2 = min(m2, gaps[s + 2])
        m3 = min(m3, gaps[s + 3])
        s += 4
    while s < s1:
        m0 = min(m0, gaps[s])
        s += 1
    return min(min(m0, m1), min(m2, m3))


@nb.njit(cache=True, inline="always")
def _spheres_to_box(centres, radius, s0, s1, inv, k, half, gaps) -> float:
    """Smallest surface gap from spheres s0..s1 (world centres, one row per axis) to
    box k; negative when one overlaps it. `gaps` is scratch, one per sphere."""
    r00, r01, r02, r03 = inv[k, 0, 0], inv[k, 0, 1], inv[k, 0, 2], inv[k, 0, 3]
    r10, r11, r12, r13 = inv[k, 1, 0], inv[k, 1, 1], inv[k, 1, 2], inv[k, 1, 3]
    r20, r21, r22, r23 = inv[k, 2, 0], inv[k, 2, 1], inv[k, 2, 2], inv[k, 2, 3]
    h0, h1, h2 = half[k, 0], half[k, 1], half[k, 2]
    cx, cy, cz = centres[0], centres[1], centres[2]
    for s in range(np.uint64(s0), np.uint64(s1)):
        x, y, z = cx[s], cy[s], cz[s]
        u = max(abs(r00 * x + r01 * y + r02 * z + r03) - h0, 0.0)
        v = max(abs(r10 * x + r11 * y + r12 * z + r13) - h1, 0.0)
        w = max(abs(r20 * x + r21 * y + r22 * z + r23) - h2, 0.0)
        gaps[s] = np.sqrt(u * u + v * v + w * w) - radius[s]
    return _least(gaps, s0, s1)


@nb.njit(cache=True, inline="always")
def _spheres_to_cyl(centres, radius, s0, s1, inv, k, cyl_r, cyl_h, gaps) -> float:
    r00, r01, r02, r03 = inv[k, 0, 0], inv[k, 0, 1], inv[k, 0, 2], inv[k, 0, 3]
    r10, r11, r12, r13 = inv[k, 1, 0], inv[k, 1, 1], inv[k, 1, 2], inv[k, 1, 3]
    r20, r21, r22, r23 = inv[k, 2, 0], inv[k, 2, 1], inv[k, 2, 2], inv[k, 2, 3]
    rad, hl = cyl_r[k], cyl_h[k]
    cx, cy, cz = centres[0], centres[1], centres[2]
    for s in range(np.uint64(s0), np.uint64(s1)):
        x, y, z = cx[s], cy[s], cz[s]
        u = r00 * x + r01 * y + r02 * z + r03
        v = r10 * x + r11 * y + r12 * z + r13
        w = r20 * x + r21 * y + r22 * z + r23
        dr = max(np.sqrt(u * u + v * v) - rad, 0.0)
        dz = max(abs(w) - hl, 0.0)
        gaps[s] = np.sqrt(dr * dr + dz * dz) - radius[s]
    return _least(gaps, s0, s1)


@nb.njit(cache=True, inline="always")
def _spheres_to_point(centres, radius, s0, s1, px, py, pz, extra, gaps) -> float:
    """Smallest surface gap from spheres s0..s1 to a sphere at (px, py, pz) of radius
    `extra` (also the pairs' inner loop)."""
    cx, cy, cz = centres[0], centres[1], centres[2]
    for s in range(np.uint64(s0), np.uint64(s1)):
        dx, dy, dz = cx[s] - px, cy[s] - py, cz[s] - pz
        gaps[s] = np.sqrt(dx * dx + dy * dy + dz * dz) - radius[s] - extra
    return _least(gaps, s0, s1)


@nb.njit(cache=True, inline="always")
def _point_gap2(k, shapes, x, y, z) -> float:
    """Squared distance from point (x, y, z) to environment shape k (0 inside)."""
    box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r = shapes
    n_box, n_cyl = box_inv.shape[0], cyl_inv.shape[0]
    if k < n_box:
        inv, half = box_inv, box_half
        u = max(
            abs(inv[k, 0, 0] * x + inv[k, 0, 1] * y + inv[k, 0, 2] * z + inv[k, 0, 3]) - half[k, 0],
            0.0,
        )
        v = max(
            abs(inv[k, 1, 0] * x + inv[k, 1, 1] * y + inv[k, 1, 2] * z + inv[k, 1, 3]) - half[k, 1],
            0.0,
        )
        w = max(
            abs(inv[k, 2, 0] * x + inv[k, 2, 1] * y + inv[k, 2, 2] * z + inv[k, 2, 3]) - half[k, 2],
            0.0,
        )
        return u * u + v * v + w * w
    if k < n_box + n_cyl:
        c, inv = k - n_box, cyl_inv
        u = inv[c, 0, 0] * x + inv[c, 0, 1] * y + inv[c, 0, 2] * z + inv[c, 0, 3]
        v = inv[c, 1, 0] * x + inv[c, 1, 1] * y + inv[c, 1, 2] * z + inv[c, 1, 3]
        w = inv[c, 2, 0] * x + inv[c, 2, 1] * y + inv[c, 2, 2] * z + inv[c, 2, 3]
        dr = max(np.sqrt(u * u + v * v) - cyl_r[c], 0.0)
        dz = max(abs(w) - cyl_h[c], 0.0)
        return dr * dr + dz * dz
    c = k - n_box - n_cyl
    dx, dy, dz = x - sph_c[c, 0], y - sph_c[c, 1], z - sph_c[c, 2]
    g = max(np.sqrt(dx * dx + dy * dy + dz * dz) - sph_r[c], 0.0)
    return g * g


@nb.njit(cache=True, inline="always")
def _shape_gaps(k, shapes, centres, radius, s0, s1, gaps) -> float:
    """Surface gaps from spheres s0..s1 to environment shape k (boxes, then cylinders,
    then spheres) into `gaps`; returns the smallest."""
    box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r = shapes
    n_box, n_cyl = box_inv.shape[0], cyl_inv.shape[0]
    if k < n_box:
        return _spheres_to_box(centres, radius, s0, s1, box_inv, k, box_half, gaps)
    if k < n_box + n_cyl:
        return _spheres_to_cyl(centres, radius, s0, s1, cyl_inv, k - n_box, cyl_r, cyl_h, gaps)
    c = k - n_box - n_cyl
    return _spheres_to_point(
        centres, radius, s0, s1, sph_c[c, 0], sph_c[c, 1], sph_c[c, 2], sph_r[c], gaps
    )


@nb.njit(cache=True, inline="always")
def _place(b, poses, body_link, sphere_local, body_start, body_end, centres, ready) -> None:
    """Move body b's spheres to the world frame, once per configuration (on demand: most
    bodies are far from everything and never need their spheres)."""
    if ready[b]:
        return
    ready[b] = True
    li = body_link[b]
    r00, r01, r02, t0 = poses[li, 0, 0], poses[li, 0, 1], poses[li, 0, 2], poses[li, 0, 3]
    r10, r11, r12, t1 = poses[li, 1, 0], poses[li, 1, 1], poses[li, 1, 2], poses[li, 1, 3]
    r20, r21, r22, t2 = poses[li, 2, 0], poses[li, 2, 1], poses[li, 2, 2], poses[li, 2, 3]
    for s in range(np.uint64(body_start[b]), np.uint64(body_end[b])):
        x, y, z = sphere_local[0, s], sphere_local[1, s], sphere_local[2, s]
        centres[0, s] = r00 * x + r01 * y + r02 * z + t0
        centres[1, s] = r10 * x + r11 * y + r12 * z + t1
        centres[2, s] = r20 * x + r21 * y + r22 * z + t2


@nb.njit(cache=True, inline="always")
def _bounds(poses, body_link, bound_local, bound_c, ready, fine_ready) -> None:
    """Place every body's bounding sphere in the world (x, y and z rows); no body has
    its spheres placed yet, coarse or fine (`_place` does that on demand)."""
    for b in range(body_link.shape[0]):
        li = body_link[b]
        x, y, z = bound_local[b, 0], bound_local[b, 1], bound_local[b, 2]
        for i in range(3):
            bound_c[i, b] = (
                poses[li, i, 0] * x + poses[li, i, 1] * y + poses[li, i, 2] * z + poses[li, i, 3]
            )
        ready[b] = False
        fine_ready[b] = False


@nb.njit(cache=True, inline="always")
def _pair_gap(a, b, reach, radius, body_start, body_end, bound_r, centres, bound_c, gaps) -> float:
    """Smallest surface gap between the placed spheres of bodies a and b, over the
    spheres of a that come within `reach` of b's bounding sphere (the others are
    farther than that from all of b)."""
    bx, by, bz, brad = bound_c[0, b], bound_c[1, b], bound_c[2, b], bound_r[b]
    m = _FAR
    s0, s1 = body_start[b], body_end[b]
    for i in range(body_start[a], body_end[a]):
        x, y, z = centres[0, i], centres[1, i], centres[2, i]
        lim = radius[i] + brad + reach
        if (x - bx) ** 2 + (y - by) ** 2 + (z - bz) ** 2 > lim * lim:
            continue
        m = min(m, _spheres_to_point(centres, radius, s0, s1, x, y, z, radius[i], gaps))
    return m


@nb.njit(cache=True, inline="always")
def _twists(kin, poses, motion) -> None:
    """Each node's angular (rows 0-2) and origin's linear (rows 3-5) velocity per unit
    of the motion (row 6: the change of each planning joint) at the configuration
    whose link poses `poses` holds."""
    parent, jtype, axis, src, mult = kin.parent, kin.jtype, kin.axis, kin.src, kin.mult
    for i in range(6):
        motion[i, 0] = 0.0
    for k in range(1, parent.shape[0]):
        p = parent[k]
        wx, wy, wz = motion[0, p], motion[1, p], motion[2, p]
        dx = poses[k, 0, 3] - poses[p, 0, 3]
        dy = poses[k, 1, 3] - poses[p, 1, 3]
        dz = poses[k, 2, 3] - poses[p, 2, 3]
        vx = motion[3, p] + wy * dz - wz * dy
        vy = motion[4, p] + wz * dx - wx * dz
        vz = motion[5, p] + wx * dy - wy * dx
        rate = mult[k] * motion[6, src[k]] if src[k] >= 0 else 0.0
        ax, ay, az = axis[k, 0], axis[k, 1], axis[k, 2]
        ux = rate * (poses[k, 0, 0] * ax + poses[k, 0, 1] * ay + poses[k, 0, 2] * az)
        uy = rate * (poses[k, 1, 0] * ax + poses[k, 1, 1] * ay + poses[k, 1, 2] * az)
        uz = rate * (poses[k, 2, 0] * ax + poses[k, 2, 1] * ay + poses[k, 2, 2] * az)
        if jtype[k] == REVOLUTE:
            wx, wy, wz = wx + ux, wy + uy, wz + uz
        elif jtype[k] == PRISMATIC:
            vx, vy, vz = vx + ux, vy + uy, vz + uz
        motion[0, k], motion[1, k], motion[2, k] = wx, wy, wz
        motion[3, k], motion[4, k], motion[5, k] = vx, vy, vz


@nb.njit(cache=True, inline="always")
def _body_speed(b, poses, body_link, bound_c, bound_r, motion) -> float:
    """How fast (per unit of the motion) body b's spheres move at this configuration:
    at most its bounding sphere's centre speed plus its radius times the spin."""
    li = body_link[b]
    dx = bound_c[0, b] - poses[li, 0, 3]
    dy = bound_c[1, b] - poses[li, 1, 3]
    dz = bound_c[2, b] - poses[li, 2, 3]
    wx, wy, wz = motion[0, li], motion[1, li], motion[2, li]
    vx = motion[3, li] + wy * dz - wz * dy
    vy = motion[4, li] + wz * dx - wx * dz
    vz = motion[5, li] + wx * dy - wy * dx
    return np.sqrt(vx * vx + vy * vy + vz * vz) + np.sqrt(wx * wx + wy * wy + wz * wz) * bound_r[b]


@nb.njit(cache=True, inline="always")
def _pair_speed(a, b, poses, body_link, bound_c, bound_r, motion) -> float:
    """How fast (per unit of the motion) body b's spheres approach body a's at this
    configuration: b's velocity in the frame that moves with a's link (turning about
    a's spheres does not change their distance to anything)."""
    la, lb = body_link[a], body_link[b]
    x, y, z = bound_c[0, b], bound_c[1, b], bound_c[2, b]
    ax, ay, az = x - poses[la, 0, 3], y - poses[la, 1, 3], z - poses[la, 2, 3]
    bx, by, bz = x - poses[lb, 0, 3], y - poses[lb, 1, 3], z - poses[lb, 2, 3]
    wax, way, waz = motion[0, la], motion[1, la], motion[2, la]
    wbx, wby, wbz = motion[0, lb], motion[1, lb], motion[2, lb]
    vx = motion[3, lb] + wby * bz - wbz * by - motion[3, la] - (way * az - waz * ay)
    vy = motion[4, lb] + wbz * bx - wbx * bz - motion[4, la] - (waz * ax - wax * az)
    vz = motion[5, lb] + wbx * by - wby * bx - motion[5, la] - (wax * ay - way * ax)
    wx, wy, wz = wbx - wax, wby - way, wbz - waz
    return np.sqrt(vx * vx + vy * vy + vz * vz) + np.sqrt(wx * wx + wy * wy + wz * wz) * bound_r[b]


@nb.njit(cache=True, inline="always")
def _time_to_cover(gap, v, s, g) -> float:
    """How long (in units of the motion) it surely takes to cover `gap`: at the fixed
    bound `v`, or starting at speed `s` and speeding up by at most `g` per unit
    (s c + g c^2 / 2 = gap); whichever is longer."""
    return max(gap / v, 2.0 * gap / (s + np.sqrt(s * s + 2.0 * g * gap)))


_SHAPE_BITS = 20  # env item: body << 20 | shape
_PAIR = 1 << 40  # pair item: _PAIR + pair


def item_lists(never: np.ndarray, n_pairs: int) -> tuple[np.ndarray, np.ndarray]:
    """What a clearance query looks at, as item numbers: env body e against shape k is
    e << 20 | k, pair p is 2^40 + p. Returns all items (for configurations anywhere)
    and the items without the body-shape pairs `never` marks as out of reach inside
    the joint limits (for motions)."""
    e, k = np.indices(never.shape).reshape(2, -1)
    env = (e << _SHAPE_BITS) | k
    pairs = _PAIR + np.arange(n_pairs, dtype=np.int64)
    every = np.concatenate([env, pairs]).astype(np.int64)
    reachable = np.concatenate([env[~never.ravel()], pairs]).astype(np.int64)
    return every, reachable


def buffers(kin: TreeArrays, bodies: Bodies, n_items: int, n_pairs: int, queue: int) -> Scratch:
    """Scratch space for the kernels: link poses, sphere centres (x, y and z rows),
    body bounds (rows), which bodies have their spheres placed (coarse, fine), the speeds of bodies
    (the bound over a motion, how fast it may change, the speed at the configuration
    at hand) and of pairs (the bound, its change), a ring of `queue` stretches for
    `segment_clearance` (where they start and end, where their item list is), one gap
    per sphere, a pool for the item lists, and the links' velocities (rows 0-5) along
    the motion (row 6). The kernels allocate nothing: they are compiled without
    reference counting, which would cost more than the geometry."""
    n_bodies, n_nodes, d = bodies.link.shape[0], kin.parent.shape[0], bodies.ancestry.shape[0]
    n_spheres = bodies.radius.shape[0]
    return Scratch(
        np.empty((n_nodes, 4, 4)),
        np.empty((3, n_spheres)),
        np.empty((3, n_bodies)),
        np.zeros(n_bodies, dtype=np.bool_),
        np.zeros(n_bodies, dtype=np.bool_),
        np.zeros((3, n_bodies)),
        np.zeros((2, max(n_pairs, 1))),
        np.empty((queue, 2)),
        np.empty((queue, 2), dtype=np.int64),
        np.empty(n_spheres),
        np.empty(min(queue * max(n_items, 1), 1 << 16), dtype=np.int64),
        np.empty((7, max(n_nodes, d))),
    )


@nb.njit(cache=True, _nrt=False)
def config_valid(q, checks) -> bool:
    """True when configuration `q` is free of self and environment contacts (`checks`:
    a `ConfigChecks`)."""
    kin, bodies, env_bodies, pairs, pad, env, buf = checks
    return (
        _listed_clearance(
            q,
            0.0,
            buf.body_speed,
            buf.pair_speed,
            kin,
            bodies,
            env_bodies,
            pairs,
            pad,
            env,
            buf,
            env.every,
        )
        >= 0.0
    )


@nb.njit(cache=True, nogil=True)
def valid_batch(qs, packed_checks) -> np.ndarray:
    """Which configurations of `qs` (N, d) are free (`packed_checks`: a `ConfigChecks`,
    `packed`)."""
    checks = config_checks(packed_checks)
    out = np.empty(qs.shape[0], dtype=np.bool_)
    for i in range(qs.shape[0]):
        out[i] = config_valid(qs[i], checks)
    return out


@nb.njit(cache=True, _nrt=False, inline="always")
def config_clearance(
    q, cap, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf
) -> float:
    """How long (in units of the motion's parameter, at most `cap`) the configuration
    `q` surely stays free while bodies move no faster than `body_speed[0]` (m per unit,
    one per body) and pairs approach no faster than `pair_speed[0]` (one per pair): the
    smallest gap over speed. -1 when `q` is in contact. For configurations inside the
    joint limits (it skips what `never` rules out there)."""
    return _listed_clearance(
        q, cap, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf, env.reachable
    )


@nb.njit(cache=True, _nrt=False, fastmath=_FAST)
def _listed_clearance(
    q, cap, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf, items
) -> float:
    """The clearance over all of `items`. Not inlined: the motion check inlines only its
    centre query, and each inlined copy of the query costs compile time (a cold start
    compiled for 74 s with four copies, 35 s with two)."""
    c, i = _clearance(
        q,
        cap,
        -1.0,
        body_speed,
        pair_speed,
        kin,
        bodies,
        env_bodies,
        pairs,
        pad,
        env,
        buf,
        items,
        0,
        items.shape[0],
        buf.pool,
        0,
        False,
    )
    if c < 0.0:
        _to_front(items, i)
    return c


@nb.njit(cache=True, inline="always")
def _to_front(items, i) -> None:
    """Move items[i] to the front, the others keeping their order: the item that
    touched last is the likeliest to touch next, and a query stops at its first
    contact. The order changes no answer (a clearance is the smallest gap of all)."""
    item = items[i]
    while i > 0:
        items[i] = items[i - 1]
        i -= 1
    items[0] = item


@nb.njit(cache=True, _nrt=False, inline="always")
def _clearance(
    q,
    cap,
    keep,
    body_speed,
    pair_speed,
    kin,
    bodies,
    env_bodies,
    pairs,
    pad,
    env,
    buf,
    items,
    i0,
    i1,
    out,
    o0,
    local,
) -> tuple[float, int]:
    """`config_clearance` over items[i0:i1] only. The items whose bounding spheres are
    within `keep` times their speed are written to out[o0:] (for the intervals around
    `q`: see `segment_clearance`; none when `keep` is negative); returns the clearance
    and the end of that list, or -1 and the index of the item in contact. Bounding
    spheres that cannot make it within `cap` are not opened.

    With `local`, the speeds are also bounded by those at `q` (from the links'
    velocities along the motion in buf.motion[6]) plus how much they may grow within the
    stretch (body_speed[1], pair_speed[1]): near the middle of a stretch a body
    usually moves much slower than its bound over all configurations."""
    parent, origin, jtype, axis, src, mult, offset, const = kin
    sphere_local, radius, bound_local, bound_r = (
        bodies.sphere_local,
        bodies.radius,
        bodies.bound_local,
        bodies.bound_r,
    )
    body_start, body_end, body_link = bodies.start, bodies.end, bodies.link
    poses, centres, bound_c, ready = buf.poses, buf.centres, buf.bound_c, buf.ready
    gaps, motion = buf.gaps, buf.motion
    fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, poses)
    _bounds(poses, body_link, bound_local, bound_c, ready, buf.fine_ready)
    best = cap
    moving = cap > 0.0
    record = keep >= 0.0
    if local:  # the links' velocities along the motion at `q`, the bodies' speeds
        _twists(kin, poses, motion)
        for e in range(env_bodies.shape[0]):
            b = env_bodies[e]
            body_speed[2, b] = _body_speed(b, poses, body_link, bound_c, bound_r, motion)
    s = g = 0.0  # the speed of the item at hand here and its growth
    o = o0
    for it in range(i0, i1):
        item = items[it]
        if item < _PAIR:
            e = item >> _SHAPE_BITS
            k = item & ((1 << _SHAPE_BITS) - 1)
            b = env_bodies[e]
            v = body_speed[0, b] if moving else 0.0
            r = bound_r[b] + pad
            g2 = _point_gap2(k, env.shapes, bound_c[0, b], bound_c[1, b], bound_c[2, b])
            near = v  # the fastest the body may come nearer on average within `best`
            if local:  # at its speed here and how fast that may grow
                s, g = body_speed[2, b], body_speed[1, b]
                near = min(v, s + 0.5 * g * best)
            if record:  # without a branch on the distance: it is unpredictable
                out[o] = item
                o += g2 <= (r + keep * (min(v, s + 0.5 * g * keep) if local else v)) ** 2
            if g2 > (r + best * near) ** 2:
                continue
            _place(b, poses, body_link, sphere_local, body_start, body_end, centres, ready)
            gap = (
                _shape_gaps(k, env.shapes, centres, radius, body_start[b], body_end[b], gaps) - pad
            )
            # where the first run touches, the body's fine run decides (the narrow phase):
            # both runs hold the link, so the larger gap is still no more than its own
            f0, f1 = bodies.fine_start[b], bodies.fine_end[b]
            if gap <= 0.0 and f1 > f0:
                _place(
                    b, poses, body_link, sphere_local, bodies.fine_start, bodies.fine_end,
                    centres, buf.fine_ready,
                )  # fmt: skip
                gap = max(gap, _shape_gaps(k, env.shapes, centres, radius, f0, f1, gaps) - pad)
        else:
            p = item - _PAIR
            a, b = pairs[p, 0], pairs[p, 1]
            v = pair_speed[0, p] if moving else 0.0
            dx = bound_c[0, a] - bound_c[0, b]
            dy = bound_c[1, a] - bound_c[1, b]
            dz = bound_c[2, a] - bound_c[2, b]
            g2 = dx * dx + dy * dy + dz * dz
            r = bound_r[a] + bound_r[b]
            if record:  # without a branch on the distance: it is unpredictable
                out[o] = item
                o += g2 <= (r + keep * v) ** 2
            if g2 > (r + best * v) ** 2:
                continue
            if local:
                s = _pair_speed(a, b, poses, body_link, bound_c, bound_r, motion)
                g = pair_speed[1, p]
                if g2 > (r + best * (s + 0.5 * g * best)) ** 2:
                    continue
            _place(a, poses, body_link, sphere_local, body_start, body_end, centres, ready)
            _place(b, poses, body_link, sphere_local, body_start, body_end, centres, ready)
            reach = best * (min(v, s + 0.5 * g * best) if local else v)
            gap = _pair_gap(
                a, b, reach, radius, body_start, body_end, bound_r, centres, bound_c, gaps
            )
        if gap <= 0.0:
            return -1.0, it
        if gap < best * v:
            best = min(best, _time_to_cover(gap, v, s, g)) if local else gap / v
    return best, o


@nb.njit(cache=True, _nrt=False, fastmath=_FAST)
def segment_clearance(a, b, c_a, checks, q) -> float:
    """Is the straight motion a -> b free? -1 when not, else the clearance at `b` in units
    of this motion (at most 1). `b` is checked, `a` is assumed free; `c_a` is its
    clearance for this motion when known (from the previous step of a straight walk),
    negative to compute it when needed.

    A body moves at most body_rate[b] . |dq| metres over a motion dq (pair_rate likewise
    for two bodies closing in), so a configuration whose clearance is c proves the
    stretch within c of it free. The stretches not yet proved free are checked at their
    centres, coarse to fine (a blocked motion fails after few checks), until each is
    proved free or no longer than `resolution` per joint between two free ends.

    The check at the centre of a stretch of half length w also lists the items
    (body-shape and body-body pairs) within w of their speed: the checks inside the
    stretch ask for at most their distance to its border, so nothing else can answer
    them, and they look at that list alone. `checks` is a `MotionChecks`; `q` is
    scratch space."""
    resolution, body_rate, pair_rate, config = checks
    kin, bodies, env_bodies, pairs, pad, env, buf = config
    d = a.shape[0]
    span = 0.0
    for j in range(d):
        span = max(span, abs(b[j] - a[j]) / resolution[j])
    n = max(int(np.ceil(span)), 1)
    body_speed, pair_speed, ring, lists = buf.body_speed, buf.pair_speed, buf.ring, buf.lists
    pool, motion = buf.pool, buf.motion
    body_speed[:] = 0.0
    pair_speed[:] = 0.0
    for j in range(d):
        dq = abs(b[j] - a[j])
        for i in range(body_rate.shape[0]):
            body_speed[0, i] += body_rate[i, j] * dq
        for i in range(pair_rate.shape[0]):
            pair_speed[0, i] += pair_rate[i, j] * dq
    c_b = config_clearance(
        b, 1.0, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf
    )
    if c_b < 0.0 or n == 1 or c_b >= 1.0:
        return c_b
    floor = 1.0 / n  # a stretch this short between two free ends needs nothing more
    cap = ring.shape[0]
    if n + 2 > cap:  # longer than any motion inside the joint limits
        return _grid_walk(
            a, b, n, c_b, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf, q
        )
    # a ring of the stretches (x0, x1) left to prove, breadth first, each with its item
    # list pool[l0:l1]; x0 < 0 marks a stretch from `a` whose clearance is not known
    # yet (a blocked motion often fails at its centre first). They are disjoint and
    # longer than `floor`, so fewer than n are ever waiting.
    reachable = env.reachable
    n_items = reachable.shape[0]
    for i in range(n_items):
        pool[i] = reachable[i]
    used = n_items
    x_end = 1.0 - c_b
    if c_a >= x_end:
        return c_b
    _growth(a, b, body_rate, pair_rate, bodies.ancestry, body_speed, pair_speed, motion)
    ring[0, 0], ring[0, 1] = c_a if c_a >= 0.0 else -1.0, x_end
    lists[0, 0], lists[0, 1] = 0, n_items
    head, tail = 0, 1
    while head < tail:
        slot = head % cap
        x0, x1 = ring[slot, 0], ring[slot, 1]
        l0, l1 = lists[slot, 0], lists[slot, 1]
        head += 1
        unknown = x0 < 0.0
        if unknown and x1 < x_end:
            x0 = max(
                config_clearance(
                    a, x1, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf
                ),
                0.0,
            )
            unknown = False
            if x1 - x0 <= floor:
                continue
        x0 = max(x0, 0.0)
        m = 0.5 * (x0 + x1)
        w = 0.5 * (x1 - x0)
        for j in range(d):
            q[j] = a[j] + m * (b[j] - a[j])
        room = used + l1 - l0 <= pool.shape[0]  # else the parts keep this list
        c, end = _clearance(
            q,
            w,
            w if room else -1.0,
            body_speed,
            pair_speed,
            kin,
            bodies,
            env_bodies,
            pairs,
            pad,
            env,
            buf,
            pool,
            l0,
            l1,
            pool,
            used,
            True,
        )
        if c < 0.0:
            for i in range(n_items):
                if reachable[i] == pool[end]:
                    _to_front(reachable, i)
                    break
            return -1.0
        if room:
            l0, l1, used = used, end, end
        if c >= w:
            continue
        if m - c - x0 > floor:
            slot = tail % cap
            ring[slot, 0], ring[slot, 1] = -1.0 if unknown else x0, m - c
            lists[slot, 0], lists[slot, 1] = l0, l1
            tail += 1
        if x1 - m - c > floor:
            slot = tail % cap
            ring[slot, 0], ring[slot, 1] = m + c, x1
            lists[slot, 0], lists[slot, 1] = l0, l1
            tail += 1
    return c_b


@nb.njit(cache=True, inline="always")
def _growth(a, b, body_rate, pair_rate, ancestry, body_speed, pair_speed, motion) -> None:
    """The motion a -> b into motion[6], and into body_speed[1] and pair_speed[1] how
    fast the speeds of bodies and pairs may change along it (per unit of the motion),
    from their lever arms about each joint: sum over joints j of arm_j |dq_j| (|dq_j| +
    2 sum over the joints i that swing j's axis of |dq_i|)."""
    d = a.shape[0]
    for j in range(d):
        motion[6, j] = b[j] - a[j]
    body_speed[1, :] = 0.0
    for i in range(pair_rate.shape[0]):
        pair_speed[1, i] = pair_rate[i, d]  # inf: pairs whose speed here is no bound
    for j in range(d):
        dq = abs(motion[6, j])
        swing = 0.0
        for i in range(d):
            swing += ancestry[j, i] * abs(motion[6, i])
        grow = dq * (dq + 2.0 * swing)
        for i in range(body_rate.shape[0]):
            body_speed[1, i] += body_rate[i, j] * grow
        for i in range(pair_rate.shape[0]):
            pair_speed[1, i] += pair_rate[i, j] * grow


@nb.njit(cache=True, _nrt=False)
def _grid_walk(
    a, b, n, c_b, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf, q
) -> float:
    """`segment_clearance` without its queue: every sample of the n-step grid in turn."""
    for i in range(1, n):
        t = i / n
        for j in range(a.shape[0]):
            q[j] = a[j] + t * (b[j] - a[j])
        if (
            config_clearance(
                q, 0.0, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf
            )
            < 0.0
        ):
            return -1.0
    return c_b


@nb.njit(cache=True, nogil=True)
def motions_valid(a, b, packed_checks) -> np.ndarray:
    """For each row i: is the straight joint-space motion a[i] -> b[i] free? Ends excluded
    for `a` (assumed valid), included for `b`. `packed_checks`: a `MotionChecks`,
    `packed`."""
    checks = motion_checks(packed_checks)
    q = np.empty(a.shape[1])
    out = np.empty(a.shape[0], dtype=np.bool_)
    for m in range(a.shape[0]):
        out[m] = 0.0 <= segment_clearance(a[m], b[m], -1.0, checks, q)
    return out
