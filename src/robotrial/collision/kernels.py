"""Compiled collision kernels over sphere bodies and environment shapes (layer 2).

A body is a run of spheres fixed to one link (or to the object held in the hand) plus
a bounding sphere used to skip far-apart pairs. The kernels compute the link poses,
move the spheres, and stop at the first contact.

The kernels called per configuration are compiled without numba's reference counting
(`_nrt=False`) and allocate nothing (scratch comes from `buffers`): with some thirty
arrays in play, the atomic reference counts of their arguments cost more than the
geometry did.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from robotrial.kinematics.chain import fk_single


@nb.njit(cache=True, inline="always")
def _box_gap2(x, y, z, inv, k, half) -> float:
    """Squared distance from point (x, y, z) to box k (0 inside); indices, not views,
    keep the inner loop free of array-view bookkeeping."""
    d2 = 0.0
    for i in range(3):
        u = inv[k, i, 0] * x + inv[k, i, 1] * y + inv[k, i, 2] * z + inv[k, i, 3]
        e = abs(u) - half[k, i]
        if e > 0.0:
            d2 += e * e
    return d2


@nb.njit(cache=True, inline="always")
def _cyl_gap2(x, y, z, inv, k, radius, half_length) -> float:
    u = inv[k, 0, 0] * x + inv[k, 0, 1] * y + inv[k, 0, 2] * z + inv[k, 0, 3]
    v = inv[k, 1, 0] * x + inv[k, 1, 1] * y + inv[k, 1, 2] * z + inv[k, 1, 3]
    w = inv[k, 2, 0] * x + inv[k, 2, 1] * y + inv[k, 2, 2] * z + inv[k, 2, 3]
    dr = max(np.sqrt(u * u + v * v) - radius[k], 0.0)
    dz = max(abs(w) - half_length[k], 0.0)
    return dr * dr + dz * dz


@nb.njit(cache=True, inline="always")
def _place(b, poses, sphere_link, sphere_local, body_start, body_end, centres, ready) -> None:
    """Move body b's spheres to the world frame, once per configuration (on demand: most
    bodies are far from everything and never need their spheres)."""
    if ready[b]:
        return
    ready[b] = True
    for s in range(body_start[b], body_end[b]):
        li = sphere_link[s]
        x, y, z = sphere_local[s, 0], sphere_local[s, 1], sphere_local[s, 2]
        for i in range(3):
            centres[s, i] = (
                poses[li, i, 0] * x + poses[li, i, 1] * y + poses[li, i, 2] * z + poses[li, i, 3]
            )


@nb.njit(cache=True, inline="always")
def _bounds(poses, body_link, bound_local, bound_c, ready) -> None:
    """Place every body's bounding sphere in the world; no body has its spheres placed
    yet (`_place` does that on demand)."""
    for b in range(body_link.shape[0]):
        li = body_link[b]
        x, y, z = bound_local[b, 0], bound_local[b, 1], bound_local[b, 2]
        for i in range(3):
            bound_c[b, i] = (
                poses[li, i, 0] * x + poses[li, i, 1] * y + poses[li, i, 2] * z + poses[li, i, 3]
            )
        ready[b] = False


@nb.njit(cache=True, inline="always")
def _body_hits_env(
    b,
    sphere_link,
    sphere_local,
    radius,
    body_start,
    body_end,
    bound_r,
    pad,
    box_inv,
    box_half,
    cyl_inv,
    cyl_r,
    cyl_h,
    sph_c,
    sph_r,
    poses,
    centres,
    bound_c,
    ready,
):
    """Does body `b` touch any environment shape (boxes, cylinders, spheres)? Its
    bounding sphere first: most bodies are far from every shape. Arrays come one by one:
    unpacking tuples in a helper costs reference counting on every call."""
    n_box, n_cyl = box_inv.shape[0], cyl_inv.shape[0]
    bx, by, bz = bound_c[b, 0], bound_c[b, 1], bound_c[b, 2]
    br = bound_r[b] + pad
    for k in range(n_box + n_cyl + sph_c.shape[0]):
        g2 = _shape_gap2(
            bx, by, bz, k, n_box, n_cyl, box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r
        )
        if g2 > br * br:
            continue
        _place(b, poses, sphere_link, sphere_local, body_start, body_end, centres, ready)
        for s in range(body_start[b], body_end[b]):
            r = radius[s] + pad
            g2 = _shape_gap2(
                centres[s, 0],
                centres[s, 1],
                centres[s, 2],
                k,
                n_box,
                n_cyl,
                box_inv,
                box_half,
                cyl_inv,
                cyl_r,
                cyl_h,
                sph_c,
                sph_r,
            )
            if g2 <= r * r:
                return True
    return False


@nb.njit(cache=True, inline="always")
def _bodies_touch(
    a,
    b,
    sphere_link,
    sphere_local,
    radius,
    body_start,
    body_end,
    bound_r,
    poses,
    centres,
    bound_c,
    ready,
) -> bool:
    dx = bound_c[a, 0] - bound_c[b, 0]
    dy = bound_c[a, 1] - bound_c[b, 1]
    dz = bound_c[a, 2] - bound_c[b, 2]
    lim = bound_r[a] + bound_r[b]
    if dx * dx + dy * dy + dz * dz > lim * lim:
        return False
    _place(a, poses, sphere_link, sphere_local, body_start, body_end, centres, ready)
    _place(b, poses, sphere_link, sphere_local, body_start, body_end, centres, ready)
    bx, by, bz, brad = bound_c[b, 0], bound_c[b, 1], bound_c[b, 2], bound_r[b]
    for i in range(body_start[a], body_end[a]):
        # skip spheres of a that miss b's bounding sphere
        dx = centres[i, 0] - bx
        dy = centres[i, 1] - by
        dz = centres[i, 2] - bz
        lim = radius[i] + brad
        if dx * dx + dy * dy + dz * dz > lim * lim:
            continue
        for j in range(body_start[b], body_end[b]):
            dx = centres[i, 0] - centres[j, 0]
            dy = centres[i, 1] - centres[j, 1]
            dz = centres[i, 2] - centres[j, 2]
            lim = radius[i] + radius[j]
            if dx * dx + dy * dy + dz * dz <= lim * lim:
                return True
    return False


def buffers(kin, bodies, n_pairs: int, queue: int) -> tuple:
    """Scratch space for the kernels: link poses, sphere centres, body bounds, which
    bodies have their spheres placed, body and pair speeds of a motion, and a queue of
    `queue` intervals for `segment_clearance`. The kernels allocate nothing: they are
    compiled without reference counting, which would cost more than the geometry."""
    n_bodies = bodies[5].shape[0]
    return (
        np.empty((kin[0].shape[0], 4, 4)),
        np.empty((bodies[0].shape[0], 3)),
        np.empty((n_bodies, 3)),
        np.zeros(n_bodies, dtype=np.bool_),
        np.empty(n_bodies),
        np.empty(max(n_pairs, 1)),
        np.empty((queue, 2), dtype=np.int64),
        np.empty((queue, 2)),
    )


@nb.njit(cache=True, _nrt=False)
def config_valid(q, kin, bodies, env_bodies, pairs, pad, env, buf) -> bool:
    """True when configuration `q` is free of self and environment contacts. `buf` is
    scratch space from `buffers`."""
    parent, origin, jtype, axis, src, mult, offset, const = kin
    sphere_link, sphere_local, radius, body_start, body_end, body_link, bound_local, bound_r = (
        bodies
    )
    box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r = env[:7]
    poses, centres, bound_c, ready = buf[0], buf[1], buf[2], buf[3]
    fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, poses)
    _bounds(poses, body_link, bound_local, bound_c, ready)
    for e in range(env_bodies.shape[0]):
        b = env_bodies[e]
        if _body_hits_env(
            b,
            sphere_link,
            sphere_local,
            radius,
            body_start,
            body_end,
            bound_r,
            pad,
            box_inv,
            box_half,
            cyl_inv,
            cyl_r,
            cyl_h,
            sph_c,
            sph_r,
            poses,
            centres,
            bound_c,
            ready,
        ):
            return False
    for p in range(pairs.shape[0]):
        if _bodies_touch(
            pairs[p, 0],
            pairs[p, 1],
            sphere_link,
            sphere_local,
            radius,
            body_start,
            body_end,
            bound_r,
            poses,
            centres,
            bound_c,
            ready,
        ):
            return False
    return True


@nb.njit(cache=True)
def valid_batch(qs, kin, bodies, env_bodies, pairs, pad, env, buf) -> np.ndarray:
    out = np.empty(qs.shape[0], dtype=np.bool_)
    for i in range(qs.shape[0]):
        out[i] = config_valid(qs[i], kin, bodies, env_bodies, pairs, pad, env, buf)
    return out


@nb.njit(cache=True, _nrt=False)
def config_clearance(
    q, cap, body_speed, pair_speed, kin, bodies, env_bodies, pairs, pad, env, buf
) -> float:
    """How long (in units of the motion's parameter, at most `cap`) the configuration
    `q` surely stays free while bodies move no faster than `body_speed` (m per unit,
    one per body) and pairs approach no faster than `pair_speed` (one per pair): the
    smallest gap over speed. -1 when `q` is in contact. Bounding spheres that cannot
    make it within `cap` are not opened."""
    parent, origin, jtype, axis, src, mult, offset, const = kin
    sphere_link, sphere_local, radius, body_start, body_end, body_link, bound_local, bound_r = (
        bodies
    )
    box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r, never = env
    poses, centres, bound_c, ready = buf[0], buf[1], buf[2], buf[3]
    fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, poses)
    _bounds(poses, body_link, bound_local, bound_c, ready)
    best = cap
    n_box, n_cyl = box_inv.shape[0], cyl_inv.shape[0]
    for e in range(env_bodies.shape[0]):
        b = env_bodies[e]
        v = body_speed[b]
        bx, by, bz = bound_c[b, 0], bound_c[b, 1], bound_c[b, 2]
        br = bound_r[b] + pad
        for k in range(n_box + n_cyl + sph_c.shape[0]):
            if never[e, k]:
                continue
            reach = br + best * v
            g2 = _shape_gap2(
                bx, by, bz, k, n_box, n_cyl, box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r
            )
            if g2 > reach * reach:
                continue
            _place(b, poses, sphere_link, sphere_local, body_start, body_end, centres, ready)
            for s in range(body_start[b], body_end[b]):
                r = radius[s] + pad
                reach = r + best * v
                g2 = _shape_gap2(
                    centres[s, 0],
                    centres[s, 1],
                    centres[s, 2],
                    k,
                    n_box,
                    n_cyl,
                    box_inv,
                    box_half,
                    cyl_inv,
                    cyl_r,
                    cyl_h,
                    sph_c,
                    sph_r,
                )
                if g2 > reach * reach:
                    continue
                if g2 <= r * r:
                    return -1.0
                best = (np.sqrt(g2) - r) / v
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        v = pair_speed[p]
        dx = bound_c[a, 0] - bound_c[b, 0]
        dy = bound_c[a, 1] - bound_c[b, 1]
        dz = bound_c[a, 2] - bound_c[b, 2]
        reach = bound_r[a] + bound_r[b] + best * v
        if dx * dx + dy * dy + dz * dz > reach * reach:
            continue
        _place(a, poses, sphere_link, sphere_local, body_start, body_end, centres, ready)
        _place(b, poses, sphere_link, sphere_local, body_start, body_end, centres, ready)
        bx, by, bz, brad = bound_c[b, 0], bound_c[b, 1], bound_c[b, 2], bound_r[b]
        for i in range(body_start[a], body_end[a]):
            # a sphere of a that cannot reach b's bounding sphere in time skips b's spheres
            dx = centres[i, 0] - bx
            dy = centres[i, 1] - by
            dz = centres[i, 2] - bz
            reach = radius[i] + brad + best * v
            if dx * dx + dy * dy + dz * dz > reach * reach:
                continue
            for j in range(body_start[b], body_end[b]):
                dx = centres[i, 0] - centres[j, 0]
                dy = centres[i, 1] - centres[j, 1]
                dz = centres[i, 2] - centres[j, 2]
                r = radius[i] + radius[j]
                reach = r + best * v
                g2 = dx * dx + dy * dy + dz * dz
                if g2 > reach * reach:
                    continue
                if g2 <= r * r:
                    return -1.0
                best = (np.sqrt(g2) - r) / v
    return best


@nb.njit(cache=True, inline="always")
def _shape_gap2(
    x, y, z, k, n_box, n_cyl, box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r
) -> float:
    """Squared distance from a point to environment shape k (boxes, then cylinders,
    then spheres; 0 inside)."""
    if k < n_box:
        return _box_gap2(x, y, z, box_inv, k, box_half)
    if k < n_box + n_cyl:
        return _cyl_gap2(x, y, z, cyl_inv, k - n_box, cyl_r, cyl_h)
    c = k - n_box - n_cyl
    dx, dy, dz = x - sph_c[c, 0], y - sph_c[c, 1], z - sph_c[c, 2]
    g = max(np.sqrt(dx * dx + dy * dy + dz * dz) - sph_r[c], 0.0)
    return g * g


@nb.njit(cache=True, _nrt=False)
def segment_clearance(
    a, b, c_a, resolution, body_rate, pair_rate, kin, bodies, env_bodies, pairs, pad, env, buf, q
) -> float:
    """Is the straight motion a -> b free? -1 when not, else the clearance at `b` in units
    of this motion (at most 1). `b` is checked, `a` is assumed free; `c_a` is its
    clearance for this motion when known (from the previous step of a straight walk),
    negative to compute it when needed.

    Sub-intervals are split coarse to fine (midpoint first, so a blocked motion fails
    after few checks) until each is either no longer than `resolution` per joint or
    proved free by the clearance at its ends: a body moves at most body_rate[b] . |dq|
    metres over a motion dq (pair_rate likewise for two bodies closing in), so an
    interval that the end clearances cover cannot hold a contact. `buf` and `q` are
    scratch space."""
    d = a.shape[0]
    span = 0.0
    for j in range(d):
        span = max(span, abs(b[j] - a[j]) / resolution[j])
    n = max(int(np.ceil(span)), 1)
    body_speed, pair_speed, iv, cl = buf[4], buf[5], buf[6], buf[7]
    args = (kin, bodies, env_bodies, pairs, pad, env, buf)
    body_speed[:] = 0.0
    pair_speed[:] = 0.0
    for j in range(d):
        dq = abs(b[j] - a[j])
        for i in range(body_rate.shape[0]):
            body_speed[i] += body_rate[i, j] * dq
        for i in range(pair_rate.shape[0]):
            pair_speed[i] += pair_rate[i, j] * dq
    c_b = config_clearance(b, 1.0, body_speed, pair_speed, *args)
    if c_b < 0.0 or n == 1 or c_b >= 1.0:
        return c_b
    # a queue of intervals between samples i0 < i1 of the n-step grid with the clearance
    # at each end, breadth first; an interval of one step needs nothing more
    if 2 * n + 2 > iv.shape[0]:  # longer than any motion inside the joint limits
        return _grid_walk(a, b, n, c_b, body_speed, pair_speed, args, q)
    iv[0, 0], iv[0, 1], cl[0, 0], cl[0, 1] = 0, n, c_a, c_b
    head, tail = 0, 1
    while head < tail:
        i0, i1, c0, c1 = iv[head, 0], iv[head, 1], cl[head, 0], cl[head, 1]
        head += 1
        if i1 - i0 <= 1:
            continue
        if c0 < 0.0 and i1 < n:
            # a's clearance, left unknown until an interval shorter than the motion
            # needs it: a blocked motion often fails at its midpoint first
            c0 = max(config_clearance(a, i1 / n, body_speed, pair_speed, *args), 0.0)
        if c0 + c1 >= (i1 - i0) / n:
            continue
        im = (i0 + i1) // 2
        t = im / n
        for j in range(d):
            q[j] = a[j] + t * (b[j] - a[j])
        c = config_clearance(q, 0.5 * (i1 - i0) / n, body_speed, pair_speed, *args)
        if c < 0.0:
            return -1.0
        iv[tail, 0], iv[tail, 1], cl[tail, 0], cl[tail, 1] = i0, im, c0, c
        iv[tail + 1, 0], iv[tail + 1, 1], cl[tail + 1, 0], cl[tail + 1, 1] = im, i1, c, c1
        tail += 2
    return c_b


@nb.njit(cache=True, _nrt=False)
def _grid_walk(a, b, n, c_b, body_speed, pair_speed, args, q) -> float:
    """`segment_clearance` without its queue: every sample of the n-step grid in turn."""
    for i in range(1, n):
        t = i / n
        for j in range(a.shape[0]):
            q[j] = a[j] + t * (b[j] - a[j])
        if config_clearance(q, 0.0, body_speed, pair_speed, *args) < 0.0:
            return -1.0
    return c_b


@nb.njit(cache=True)
def motions_valid(
    a, b, resolution, body_rate, pair_rate, kin, bodies, env_bodies, pairs, pad, env, buf
) -> np.ndarray:
    """For each row i: is the straight joint-space motion a[i] -> b[i] free? Ends excluded
    for `a` (assumed valid), included for `b`."""
    q = np.empty(a.shape[1])
    out = np.empty(a.shape[0], dtype=np.bool_)
    for m in range(a.shape[0]):
        out[m] = 0.0 <= segment_clearance(
            a[m],
            b[m],
            -1.0,
            resolution,
            body_rate,
            pair_rate,
            kin,
            bodies,
            env_bodies,
            pairs,
            pad,
            env,
            buf,
            q,
        )
    return out
