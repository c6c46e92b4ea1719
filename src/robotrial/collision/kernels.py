"""Compiled collision kernels over sphere bodies and environment shapes (layer 2).

A body is a run of spheres fixed to one link (or to the object held in the hand) plus
a bounding sphere used to skip far-apart pairs. The kernels compute the link poses,
move the spheres, and stop at the first contact.
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


@nb.njit(cache=True)
def world_spheres(poses, sphere_link, sphere_local, out) -> None:
    """Sphere centres in the world frame from the link poses."""
    for s in range(sphere_link.shape[0]):
        li = sphere_link[s]
        x, y, z = sphere_local[s, 0], sphere_local[s, 1], sphere_local[s, 2]
        for i in range(3):
            out[s, i] = (
                poses[li, i, 0] * x + poses[li, i, 1] * y + poses[li, i, 2] * z + poses[li, i, 3]
            )


@nb.njit(cache=True, inline="always")
def _body_hits_env(b, centres, radius, body_start, body_end, bound_c, bound_r, pad, env):
    """Does body `b` touch any environment shape? `env` holds boxes, cylinders, spheres."""
    box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r = env
    bx, by, bz = bound_c[b, 0], bound_c[b, 1], bound_c[b, 2]
    br = bound_r[b] + pad
    for k in range(box_inv.shape[0]):
        if _box_gap2(bx, by, bz, box_inv, k, box_half) > br * br:
            continue
        for s in range(body_start[b], body_end[b]):
            r = radius[s] + pad
            if (
                _box_gap2(centres[s, 0], centres[s, 1], centres[s, 2], box_inv, k, box_half)
                <= r * r
            ):
                return True
    for k in range(cyl_inv.shape[0]):
        if _cyl_gap2(bx, by, bz, cyl_inv, k, cyl_r, cyl_h) > br * br:
            continue
        for s in range(body_start[b], body_end[b]):
            r = radius[s] + pad
            if (
                _cyl_gap2(centres[s, 0], centres[s, 1], centres[s, 2], cyl_inv, k, cyl_r, cyl_h)
                <= r * r
            ):
                return True
    for k in range(sph_c.shape[0]):
        dx = bx - sph_c[k, 0]
        dy = by - sph_c[k, 1]
        dz = bz - sph_c[k, 2]
        lim = br + sph_r[k]
        if dx * dx + dy * dy + dz * dz > lim * lim:
            continue
        for s in range(body_start[b], body_end[b]):
            dx = centres[s, 0] - sph_c[k, 0]
            dy = centres[s, 1] - sph_c[k, 1]
            dz = centres[s, 2] - sph_c[k, 2]
            lim = radius[s] + pad + sph_r[k]
            if dx * dx + dy * dy + dz * dz <= lim * lim:
                return True
    return False


@nb.njit(cache=True, inline="always")
def _bodies_touch(a, b, centres, radius, body_start, body_end, bound_c, bound_r) -> bool:
    dx = bound_c[a, 0] - bound_c[b, 0]
    dy = bound_c[a, 1] - bound_c[b, 1]
    dz = bound_c[a, 2] - bound_c[b, 2]
    lim = bound_r[a] + bound_r[b]
    if dx * dx + dy * dy + dz * dz > lim * lim:
        return False
    for i in range(body_start[a], body_end[a]):
        for j in range(body_start[b], body_end[b]):
            dx = centres[i, 0] - centres[j, 0]
            dy = centres[i, 1] - centres[j, 1]
            dz = centres[i, 2] - centres[j, 2]
            lim = radius[i] + radius[j]
            if dx * dx + dy * dy + dz * dz <= lim * lim:
                return True
    return False


@nb.njit(cache=True, inline="always")
def config_valid(q, kin, bodies, env_bodies, pairs, pad, env, poses, centres, bound_c) -> bool:
    """True when configuration `q` is free of self and environment contacts."""
    parent, origin, jtype, axis, src, mult, offset, const = kin
    sphere_link, sphere_local, radius, body_start, body_end, body_link, bound_local, bound_r = (
        bodies
    )
    fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, poses)
    world_spheres(poses, sphere_link, sphere_local, centres)
    world_spheres(poses, body_link, bound_local, bound_c)
    for e in range(env_bodies.shape[0]):
        if _body_hits_env(
            env_bodies[e], centres, radius, body_start, body_end, bound_c, bound_r, pad, env
        ):
            return False
    for p in range(pairs.shape[0]):
        if _bodies_touch(
            pairs[p, 0], pairs[p, 1], centres, radius, body_start, body_end, bound_c, bound_r
        ):
            return False
    return True


@nb.njit(cache=True)
def valid_batch(qs, kin, bodies, env_bodies, pairs, pad, env) -> np.ndarray:
    n_links = kin[0].shape[0]
    poses = np.empty((n_links, 4, 4))
    centres = np.empty((bodies[0].shape[0], 3))
    bound_c = np.empty((bodies[5].shape[0], 3))
    out = np.empty(qs.shape[0], dtype=np.bool_)
    for i in range(qs.shape[0]):
        out[i] = config_valid(
            qs[i], kin, bodies, env_bodies, pairs, pad, env, poses, centres, bound_c
        )
    return out


@nb.njit(cache=True)
def _bisection_order(n: int) -> np.ndarray:
    """Indices 1..n-1 coarse to fine (the midpoint first, then the quarter points, ...),
    so that a blocked motion fails after few checks."""
    order = np.empty(max(n - 1, 0), dtype=np.int64)
    seen = np.zeros(n + 1, dtype=np.bool_)
    seen[0] = True
    seen[n] = True
    k = 0
    parts = 2
    while parts <= 2 * n:
        for odd in range(1, parts, 2):
            i = int(np.floor(odd * n / parts + 0.5))
            if 0 < i < n and not seen[i]:
                seen[i] = True
                order[k] = i
                k += 1
        parts *= 2
    for i in range(1, n):
        if not seen[i]:
            order[k] = i
            k += 1
    return order


@nb.njit(cache=True)
def motions_valid(a, b, resolution, kin, bodies, env_bodies, pairs, pad, env) -> np.ndarray:
    """For each row i: is the straight joint-space motion a[i] -> b[i] free? Ends excluded
    for `a` (assumed valid), included for `b`."""
    n_links = kin[0].shape[0]
    poses = np.empty((n_links, 4, 4))
    centres = np.empty((bodies[0].shape[0], 3))
    bound_c = np.empty((bodies[5].shape[0], 3))
    d = a.shape[1]
    out = np.empty(a.shape[0], dtype=np.bool_)
    q = np.empty(d)
    for m in range(a.shape[0]):
        span = 0.0
        for j in range(d):
            span = max(span, abs(b[m, j] - a[m, j]) / resolution[j])
        n = max(int(np.ceil(span)), 1)
        ok = config_valid(b[m], kin, bodies, env_bodies, pairs, pad, env, poses, centres, bound_c)
        if ok and n > 1:
            order = _bisection_order(n)
            for i in order:
                t = i / n
                for j in range(d):
                    q[j] = a[m, j] + t * (b[m, j] - a[m, j])
                if not config_valid(
                    q, kin, bodies, env_bodies, pairs, pad, env, poses, centres, bound_c
                ):
                    ok = False
                    break
        out[m] = ok
    return out
