"""Compiled collision checks of sphere bodies against environment shapes and each other,
eight configurations at a time (layer 2).

A body is a run of spheres fixed to one link (or to the object held in the hand) plus a
bounding sphere that lets far-apart pairs be skipped. A check takes a *block* of `LANES`
configurations: the forward kinematics, the bounding spheres, and every gap are computed
for all of them side by side, one configuration per SIMD lane (the loops over lanes are
the innermost ones and compile to vector instructions). The block's working arrays live
on the stack (`_stack`): the compiler then knows that nothing else writes them, which is
what lets it vectorise, and nothing is allocated while checking.

A motion is proved free stretch by stretch: a configuration whose clearance is c (the
smallest gap, over how fast the bodies may move along the motion) proves the stretch
within c of it free. The first block checks the motion's end and points spread evenly
over it, so that a blocked motion usually fails at once; what those points leave
unproved is refined, a block of points at a time, until it is proved or no longer than
the robot's resolution between two free points.

Everything a check reads is packed into two flat arrays (`Packer`), floats and integers,
with a header of offsets; a call then passes four arrays, not forty (numba's dispatcher
spends about a tenth of a microsecond on each). `model` unpacks them into named views.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np
from numba import types
from numba.core import cgutils, errors
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array

from robotrial.kinematics.chain import PRISMATIC, REVOLUTE

LANES = 8  # configurations per block: one AVX-512 register of doubles, two of AVX2
MAX_NODES = 32  # moving frames of a robot (the planning joints' links, and the root)
MAX_BODIES = 64  # sphere bodies of a robot, the held object included
BODY_SPHERES = 256  # coarse spheres of one body, at most (its copy for self pairs)
GAP_STACK = 256  # stretches waiting to be refined in one motion check
# the checks may fuse multiply-adds and assume no NaNs (the geometry has none)
_FAST = {"nnan", "nsz", "reassoc", "contract", "arcp"}
# single precision in the lanes: eight of them fill one AVX2 register (twice the lanes
# per instruction of double precision); a sphere is off by at most a few micrometres,
# so contacts count from _EPS (10 um) on
_FAR = np.float32(1e30)  # a gap larger than any scene
_EPS = np.float32(1e-5)
_F0, _F1 = np.float32(0.0), np.float32(1.0)
_TINY = np.float32(1e-12)
_ROUND_UP = np.float32(1.0 + 1e-6)
_SHAPE_BITS = 20  # env item: body << 20 | shape
_PAIR = 1 << 40  # pair item: _PAIR + pair


def _stack_codegen(shape: tuple[int, ...], dtype=types.float32):
    arrty = types.Array(dtype, len(shape), "C")
    item = dtype.bitwidth // 8

    def codegen(context, builder, sig, args):
        const = lambda v: context.get_constant(types.intp, v)  # noqa: E731
        size = int(np.prod(shape))
        data = cgutils.alloca_once(builder, context.get_value_type(dtype), size=const(size))
        strides = [item * int(np.prod(shape[i + 1 :])) for i in range(len(shape))]
        ary = context.make_array(arrty)(context, builder)
        populate_array(
            ary,
            data=data,
            shape=[const(n) for n in shape],
            strides=[const(st) for st in strides],
            itemsize=const(item),
            meminfo=None,
        )
        return ary._getvalue()

    return arrty, codegen


def _literal_sizes(*sizes) -> tuple[int, ...]:
    if not all(isinstance(n, types.IntegerLiteral) for n in sizes):
        raise errors.RequireLiteralValue("stack arrays take literal sizes")
    return tuple(n.literal_value for n in sizes)


@intrinsic
def _stack(typingctx, n0, n1):
    """An (n0, n1) float32 array on the stack of the calling function (literal sizes):
    scratch that the compiler may keep in registers and knows to alias nothing."""
    arrty, codegen = _stack_codegen(_literal_sizes(n0, n1))
    return arrty(n0, n1), codegen


@intrinsic
def _stack64(typingctx, n0, n1):
    """An (n0, n1) float64 array on the stack (see `_stack`)."""
    arrty, codegen = _stack_codegen(_literal_sizes(n0, n1), types.float64)
    return arrty(n0, n1), codegen


@intrinsic
def _stack3(typingctx, n0, n1, n2):
    """An (n0, n1, n2) float32 array on the stack (see `_stack`)."""
    arrty, codegen = _stack_codegen(_literal_sizes(n0, n1, n2))
    return arrty(n0, n1, n2), codegen


@intrinsic
def _view(typingctx, flat, n0, n1, n2):
    """The 1-D array `flat` seen as C-contiguous (n0, n1) or, with n2 > 0, (n0, n1, n2)
    (shape given as integers; n2 a literal 0 for two dimensions): no copy, no checks
    (numba's reshape calls into the runtime each time)."""
    if not isinstance(n2, types.IntegerLiteral):
        raise errors.RequireLiteralValue("_view takes a literal for its last size")
    ndim = 3 if n2.literal_value else 2
    arrty = types.Array(flat.dtype, ndim, "C")

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, args[0])
        item = context.get_constant(
            types.intp, context.get_abi_sizeof(context.get_data_type(flat.dtype))
        )
        dims = [args[1], args[2]] + ([args[3]] if ndim == 3 else [])
        strides = [item]
        for dim in reversed(dims[1:]):
            strides.insert(0, builder.mul(strides[0], dim))
        out = context.make_array(arrty)(context, builder)
        populate_array(out, data=src.data, shape=dims, strides=strides, itemsize=item, meminfo=None)
        return out._getvalue()

    return arrty(flat, n0, n1, n2), codegen


# --- the packed model --------------------------------------------------------------------


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


class Model(NamedTuple):
    """What the checks read, as views into the packed arrays. The collapsed kinematic
    tree (`Kinematics.collapsed`): parent, joint origin, type, axis, driving variable,
    mimic multiplier and offset, value when undriven. The bodies: node, bounding sphere
    (centre in the node's frame, radius), coarse and fine runs of spheres [start, end),
    sphere centres (one row per axis) and radii. Which bodies can touch obstacles, the
    self pairs (upper body first), how fast bodies move and then pairs close in per unit
    of each joint (one row per joint, padded to whole blocks of lanes), the check
    resolution and joint limits, the padding against obstacles.
    The obstacles: boxes and cylinders (inverse poses, half extents; radii and half
    lengths) and spheres (centres, radii). Where the item lists start in the work
    integers: every item, those reachable inside the joint limits, room for one list."""

    parent: np.ndarray
    origin: np.ndarray
    jtype: np.ndarray
    axis: np.ndarray
    src: np.ndarray
    mult: np.ndarray
    offset: np.ndarray
    const: np.ndarray
    node: np.ndarray
    bound_local: np.ndarray
    bound_r: np.ndarray
    start: np.ndarray
    end: np.ndarray
    fine_start: np.ndarray
    fine_end: np.ndarray
    sphere_local: np.ndarray
    radius: np.ndarray
    env_bodies: np.ndarray
    pairs: np.ndarray
    rate: np.ndarray
    resolution: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    pad: np.ndarray
    box_inv: np.ndarray
    box_half: np.ndarray
    cyl_inv: np.ndarray
    cyl_r: np.ndarray
    cyl_h: np.ndarray
    sph_c: np.ndarray
    sph_r: np.ndarray
    lists: np.ndarray


_INT_FIELDS = {
    "parent", "jtype", "src", "node", "start", "end", "fine_start", "fine_end",
    "env_bodies", "pairs", "lists",
}  # fmt: skip
_LISTS = len(Model._fields) - 1  # where `lists` is


class Packed(NamedTuple):
    """A checker as the kernels take it: the packed floats and integers (read only),
    and the work arrays (floats: speeds, stretches and each body's coarse and fine
    spheres that touched last; integers: the item lists, whose order the checks change as they
    learn which items touch)."""

    floats: np.ndarray
    ints: np.ndarray
    work: np.ndarray
    work_ints: np.ndarray


def pack(fields: dict[str, np.ndarray], every: np.ndarray, reachable: np.ndarray) -> Packed:
    """Pack the arrays named as `Model`'s fields (all but `lists`) and the item lists:
    the integers start with a header of (start, shape) per field; the floats are single
    precision, as the checks compute."""
    n_fields = len(Model._fields)
    ints: list[np.ndarray] = [np.zeros(4 * n_fields, dtype=np.int64)]
    floats: list[np.ndarray] = []
    used = {"f": 0, "i": 4 * n_fields}
    header = ints[0]
    n_every, n_reach = len(every), len(reachable)
    lists = np.cumsum([0, n_every, n_reach, n_reach, n_every], dtype=np.int64)
    for k, name in enumerate(Model._fields):
        a = lists if name == "lists" else fields[name]
        kind = "i" if name in _INT_FIELDS else "f"
        flat = np.ascontiguousarray(a, dtype=np.int64 if kind == "i" else np.float32).ravel()
        shape = [*np.shape(a), 1, 1, 1][:3]
        header[4 * k : 4 * k + 4] = [used[kind], *shape]
        (ints if kind == "i" else floats).append(flat)
        used[kind] += flat.size
    n_bodies, n_pairs = len(fields["node"]), len(fields["pairs"])
    work_ints = np.concatenate([every, reachable, np.zeros(n_reach + n_every)]).astype(np.int64)
    return Packed(
        np.concatenate(floats),
        np.concatenate(ints),
        np.zeros(3 * n_bodies + n_pairs + 2 * GAP_STACK),
        work_ints,
    )


@nb.njit(cache=True, inline="always")
def _f(floats, ints, k):
    s, n0, n1, n2 = ints[4 * k], ints[4 * k + 1], ints[4 * k + 2], ints[4 * k + 3]
    return floats[s : s + n0 * n1 * n2]


@nb.njit(cache=True, inline="always")
def _i(ints, k):
    s, n0, n1, n2 = ints[4 * k], ints[4 * k + 1], ints[4 * k + 2], ints[4 * k + 3]
    return ints[s : s + n0 * n1 * n2]


@nb.njit(cache=True, inline="always")
def _dims(ints, k):
    return ints[4 * k + 1], ints[4 * k + 2]


@nb.njit(cache=True, inline="always")
def model(floats, ints) -> Model:
    """The named views of a `pack`ed checker."""
    n = _dims(ints, 1)[0]  # nodes
    b = _dims(ints, 8)[0]  # bodies
    s = _dims(ints, 15)[1]  # spheres
    p = _dims(ints, 18)[0]  # pairs
    d, nr = _dims(ints, 19)  # joints, rates (bodies and pairs, padded)
    nb_, nc = _dims(ints, 24)[0], _dims(ints, 26)[0]
    ns = _dims(ints, 29)[0]
    return Model(
        _i(ints, 0),
        _view(_f(floats, ints, 1), n, 4, 4),
        _i(ints, 2),
        _view(_f(floats, ints, 3), n, 3, 0),
        _i(ints, 4),
        _f(floats, ints, 5),
        _f(floats, ints, 6),
        _f(floats, ints, 7),
        _i(ints, 8),
        _view(_f(floats, ints, 9), b, 3, 0),
        _f(floats, ints, 10),
        _i(ints, 11),
        _i(ints, 12),
        _i(ints, 13),
        _i(ints, 14),
        _view(_f(floats, ints, 15), 3, s, 0),
        _f(floats, ints, 16),
        _i(ints, 17),
        _view(_i(ints, 18), p, 2, 0),
        _view(_f(floats, ints, 19), d, nr, 0),
        _f(floats, ints, 20),
        _f(floats, ints, 21),
        _f(floats, ints, 22),
        _f(floats, ints, 23),
        _view(_f(floats, ints, 24), nb_, 4, 4),
        _view(_f(floats, ints, 25), nb_, 3, 0),
        _view(_f(floats, ints, 26), nc, 4, 4),
        _f(floats, ints, 27),
        _f(floats, ints, 28),
        _view(_f(floats, ints, 29), ns, 3, 0),
        _f(floats, ints, 30),
        _i(ints, _LISTS),
    )


def rates(body_rate: np.ndarray, pair_rate: np.ndarray) -> np.ndarray:
    """The `rate` field from the bodies' (bodies, d) and the pairs' (pairs, d) rates: one
    row per joint, bodies then pairs, zeros up to a whole number of lane blocks."""
    both = np.vstack([body_rate, pair_rate]).T
    n = -(-both.shape[1] // LANES) * LANES
    out = np.zeros((both.shape[0], max(n, LANES)))
    out[:, : both.shape[1]] = both
    return out


def item_lists(never: np.ndarray, n_pairs: int) -> tuple[np.ndarray, np.ndarray]:
    """What a check looks at, as item numbers: env body e against shape k is
    e << 20 | k, pair p is 2^40 + p. Returns all items (for configurations anywhere)
    and the items without the body-shape pairs `never` marks as out of reach inside
    the joint limits (for motions)."""
    e, k = np.indices(never.shape).reshape(2, -1)
    env = (e << _SHAPE_BITS) | k
    pairs = _PAIR + np.arange(n_pairs, dtype=np.int64)
    every = np.concatenate([env, pairs]).astype(np.int64)
    reachable = np.concatenate([env[~never.ravel()], pairs]).astype(np.int64)
    return every, reachable


# --- one block of configurations -----------------------------------------------------------


_PIO2_HI = np.float32(1.5707963705062866)  # pi/2 = hi + lo in single precision
_PIO2_LO = np.float32(np.pi / 2 - 1.5707963705062866)
_TWO_OVER_PI, _HALF = np.float32(2 / np.pi), np.float32(0.5)
# Taylor coefficients of (sin r - r) / r^3 and (cos r - 1) / r^2 in powers of r^2, as far
# as single precision needs on [-pi/4, pi/4]
_S1, _S2, _S3, _S4 = (np.float32(c) for c in (-1 / 6, 1 / 120, -1 / 5040, 1 / 362880))
_C1, _C2, _C3, _C4, _C5 = (
    np.float32(c) for c in (-1 / 2, 1 / 24, -1 / 720, 1 / 40320, -1 / 3628800)
)


@nb.njit(cache=True, inline="always")
def _sincos(v):
    """(sin v, cos v) of a single-precision angle in one pass, branch-free (it runs in
    SIMD lanes): v reduced to [-pi/4, pi/4], then short series (error below 1e-7)."""
    k = np.floor(v * _TWO_OVER_PI + _HALF)
    r = (v - k * _PIO2_HI) - k * _PIO2_LO
    x = r * r
    sr = r + r * x * (_S1 + x * (_S2 + x * (_S3 + x * _S4)))
    cr = _F1 + x * (_C1 + x * (_C2 + x * (_C3 + x * (_C4 + x * _C5))))
    quadrant = np.int32(k) & 3
    odd = quadrant & 1 == 1  # selects, not branches: the quadrant varies by lane
    a, b = (cr, sr) if odd else (sr, cr)
    return np.float32(1 - (quadrant & 2)) * a, np.float32(1 - ((quadrant + 1) & 2)) * b


@nb.njit(cache=True, inline="always")
def _fk(m, qb, poses, parent_pose, k0, k1) -> None:
    """The poses of nodes k0..k1-1 (their parents' are known) for each lane's
    configuration qb[:, lane] into poses[node] (rows: the rotation's nine entries by
    rows, then the translation; columns: lanes). Node 0 is the root."""
    origin = m.origin
    if k0 == 0:
        for i in range(3):
            for j in range(3):
                for lane in range(LANES):
                    poses[0, 3 * i + j, lane] = origin[0, i, j]
            for lane in range(LANES):
                poses[0, 9 + i, lane] = origin[0, i, 3]
    for k in range(max(k0, 1), k1):
        pk = max(m.parent[k], 0)  # known >= 0: no wraparound test on each load
        for i in range(12):  # a copy: reads and writes of one array would not vectorise
            for lane in range(LANES):
                parent_pose[i, lane] = poses[pk, i, lane]
        o00, o01, o02, o03 = origin[k, 0, 0], origin[k, 0, 1], origin[k, 0, 2], origin[k, 0, 3]
        o10, o11, o12, o13 = origin[k, 1, 0], origin[k, 1, 1], origin[k, 1, 2], origin[k, 1, 3]
        o20, o21, o22, o23 = origin[k, 2, 0], origin[k, 2, 1], origin[k, 2, 2], origin[k, 2, 3]
        jt, s_ = m.jtype[k], m.src[k]
        driven = s_ >= 0
        row = max(s_, 0)
        mult, off, const = m.mult[k], m.offset[k], m.const[k]
        x, y, z = m.axis[k, 0], m.axis[k, 1], m.axis[k, 2]
        about_z = jt == REVOLUTE and x == 0.0 and y == 0.0
        rev = _F1 if jt == REVOLUTE else _F0
        pri = _F1 if jt == PRISMATIC else _F0
        if about_z:  # the common case: a turn about the joint frame's z
            for lane in range(LANES):
                a00, a01, a02, a10, a11, a12, a20, a21, a22, t0, t1, t2 = _compose(
                    parent_pose, lane, o00, o01, o02, o03, o10, o11, o12, o13, o20, o21, o22, o23
                )
                s, c = _sincos(mult * qb[row, lane] + off if driven else const)
                s *= z
                poses[k, 0, lane] = a00 * c + a01 * s
                poses[k, 1, lane] = a01 * c - a00 * s
                poses[k, 2, lane] = a02
                poses[k, 3, lane] = a10 * c + a11 * s
                poses[k, 4, lane] = a11 * c - a10 * s
                poses[k, 5, lane] = a12
                poses[k, 6, lane] = a20 * c + a21 * s
                poses[k, 7, lane] = a21 * c - a20 * s
                poses[k, 8, lane] = a22
                poses[k, 9, lane] = t0
                poses[k, 10, lane] = t1
                poses[k, 11, lane] = t2
        else:  # any axis; a prismatic or fixed joint turns by nothing
            for lane in range(LANES):
                a00, a01, a02, a10, a11, a12, a20, a21, a22, t0, t1, t2 = _compose(
                    parent_pose, lane, o00, o01, o02, o03, o10, o11, o12, o13, o20, o21, o22, o23
                )
                v = mult * qb[row, lane] + off if driven else const
                s, c = _sincos(v)
                s *= rev
                c = rev * c + (_F1 - rev)
                t = _F1 - c
                r00, r01, r02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
                r10, r11, r12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
                r20, r21, r22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
                slide = pri * v
                poses[k, 0, lane] = a00 * r00 + a01 * r10 + a02 * r20
                poses[k, 1, lane] = a00 * r01 + a01 * r11 + a02 * r21
                poses[k, 2, lane] = a00 * r02 + a01 * r12 + a02 * r22
                poses[k, 3, lane] = a10 * r00 + a11 * r10 + a12 * r20
                poses[k, 4, lane] = a10 * r01 + a11 * r11 + a12 * r21
                poses[k, 5, lane] = a10 * r02 + a11 * r12 + a12 * r22
                poses[k, 6, lane] = a20 * r00 + a21 * r10 + a22 * r20
                poses[k, 7, lane] = a20 * r01 + a21 * r11 + a22 * r21
                poses[k, 8, lane] = a20 * r02 + a21 * r12 + a22 * r22
                poses[k, 9, lane] = t0 + slide * (a00 * x + a01 * y + a02 * z)
                poses[k, 10, lane] = t1 + slide * (a10 * x + a11 * y + a12 * z)
                poses[k, 11, lane] = t2 + slide * (a20 * x + a21 * y + a22 * z)


@nb.njit(cache=True, inline="always")
def _compose(p, lane, o00, o01, o02, o03, o10, o11, o12, o13, o20, o21, o22, o23):
    """The parent's pose (lane `lane` of p) times a joint's origin: its rotation by rows,
    then its translation."""
    p00, p01, p02 = p[0, lane], p[1, lane], p[2, lane]
    p10, p11, p12 = p[3, lane], p[4, lane], p[5, lane]
    p20, p21, p22 = p[6, lane], p[7, lane], p[8, lane]
    return (
        p00 * o00 + p01 * o10 + p02 * o20,
        p00 * o01 + p01 * o11 + p02 * o21,
        p00 * o02 + p01 * o12 + p02 * o22,
        p10 * o00 + p11 * o10 + p12 * o20,
        p10 * o01 + p11 * o11 + p12 * o21,
        p10 * o02 + p11 * o12 + p12 * o22,
        p20 * o00 + p21 * o10 + p22 * o20,
        p20 * o01 + p21 * o11 + p22 * o21,
        p20 * o02 + p21 * o12 + p22 * o22,
        p00 * o03 + p01 * o13 + p02 * o23 + p[9, lane],
        p10 * o03 + p11 * o13 + p12 * o23 + p[10, lane],
        p20 * o03 + p21 * o13 + p22 * o23 + p[11, lane],
    )


@nb.njit(cache=True, inline="always")
def _node_pose(poses, nd, pose) -> None:
    """Copy node nd's pose (12 rows of lanes) into `pose`."""
    nd = max(nd, 0)
    for i in range(12):
        for lane in range(LANES):
            pose[i, lane] = poses[nd, i, lane]


@nb.njit(cache=True, inline="always")
def _place(pose, lx, ly, lz, lane) -> tuple[float, float, float]:
    """A point given in a node's frame, in the world, for one lane."""
    return (
        pose[0, lane] * lx + pose[1, lane] * ly + pose[2, lane] * lz + pose[9, lane],
        pose[3, lane] * lx + pose[4, lane] * ly + pose[5, lane] * lz + pose[10, lane],
        pose[6, lane] * lx + pose[7, lane] * ly + pose[8, lane] * lz + pose[11, lane],
    )


@nb.njit(cache=True, inline="always")
def _take(gap, d2, r, reach) -> None:
    """gap = min(gap, sqrt(d2) - r) per lane (d2: a squared distance from a sphere's
    centre), skipped when no lane's sphere comes within reach[0, lane] of the other
    thing: most spheres of a body near an obstacle are not, and the square roots are
    the checks' costliest instructions."""
    near = False
    for lane in range(LANES):
        lim = r + reach[0, lane]
        near |= d2[0, lane] <= lim * lim
    if near:
        for lane in range(LANES):
            gap[0, lane] = min(gap[0, lane], np.sqrt(d2[0, lane]) - r)


@nb.njit(cache=True, inline="always")
def _inverse(m, k):
    """Box or cylinder k's inverse pose, its three rows of four."""
    nbox = m.box_inv.shape[0]
    cyl = k >= nbox
    c = k - nbox if cyl else k
    inv = m.cyl_inv if cyl else m.box_inv
    return (
        inv[c, 0, 0], inv[c, 0, 1], inv[c, 0, 2], inv[c, 0, 3],
        inv[c, 1, 0], inv[c, 1, 1], inv[c, 1, 2], inv[c, 1, 3],
        inv[c, 2, 0], inv[c, 2, 1], inv[c, 2, 2], inv[c, 2, 3],
    )  # fmt: skip


@nb.njit(cache=True, inline="always")
def _to_shape(m, k, pose) -> None:
    """Turn `pose` (a body's, 12 rows of lanes) into the body's pose in the frame of
    environment shape k (a sphere's frame: its centre, unturned). Done once per body and
    shape, it spares each of the body's spheres a second transform."""
    nbox, ncyl = m.box_inv.shape[0], m.cyl_inv.shape[0]
    if k >= nbox + ncyl:
        c = k - nbox - ncyl
        for i in range(3):
            ci = m.sph_c[c, i]
            for lane in range(LANES):
                pose[9 + i, lane] -= ci
        return
    i00, i01, i02, i03, i10, i11, i12, i13, i20, i21, i22, i23 = _inverse(m, k)
    for col in range(4):  # the rotation's columns, then the translation
        r0, r1, r2 = (9, 10, 11) if col == 3 else (col, 3 + col, 6 + col)
        t0, t1, t2 = (i03, i13, i23) if col == 3 else (_F0, _F0, _F0)
        for lane in range(LANES):
            x, y, z = pose[r0, lane], pose[r1, lane], pose[r2, lane]
            pose[r0, lane] = i00 * x + i01 * y + i02 * z + t0
            pose[r1, lane] = i10 * x + i11 * y + i12 * z + t1
            pose[r2, lane] = i20 * x + i21 * y + i22 * z + t2


@nb.njit(cache=True, inline="always")
def _sphere_d2(m, k, pose, s, d2) -> None:
    """d2[0, lane] = the squared distance from sphere s's centre to environment shape k
    (0 inside), with `pose` the body's pose in the shape's frame (`_to_shape`): boxes,
    then cylinders, then spheres."""
    nbox, ncyl = m.box_inv.shape[0], m.cyl_inv.shape[0]
    lx, ly, lz = m.sphere_local[0, s], m.sphere_local[1, s], m.sphere_local[2, s]
    if k < nbox:
        h0, h1, h2 = m.box_half[k, 0], m.box_half[k, 1], m.box_half[k, 2]
        for lane in range(LANES):
            x, y, z = _place(pose, lx, ly, lz, lane)
            u = max(abs(x) - h0, _F0)
            v = max(abs(y) - h1, _F0)
            w = max(abs(z) - h2, _F0)
            d2[0, lane] = u * u + v * v + w * w
    elif k < nbox + ncyl:
        rad, hl = m.cyl_r[k - nbox], m.cyl_h[k - nbox]
        for lane in range(LANES):
            x, y, z = _place(pose, lx, ly, lz, lane)
            dr = max(np.sqrt(x * x + y * y) - rad, _F0)
            dz = max(abs(z) - hl, _F0)
            d2[0, lane] = dr * dr + dz * dz
    else:
        rad = m.sph_r[k - nbox - ncyl]
        for lane in range(LANES):
            x, y, z = _place(pose, lx, ly, lz, lane)
            g = max(np.sqrt(x * x + y * y + z * z) - rad, _F0)
            d2[0, lane] = g * g


@nb.njit(cache=True, inline="always")
def _env_gap(m, k, b, pose, reach, pad, stop, d2, gap, fine, memo) -> bool:
    """gap[0, lane] = the smallest surface gap, less the padding, from body b's spheres
    (placed by `pose`, which this turns into the shape's frame) to environment shape k:
    negative where they touch, more than reach[0, lane] when that is all it comes to.
    True when some lane touches.

    Where a coarse sphere touches, the body's fine run decides (the narrow phase): both
    covers hold the link, so the larger of their gaps is still no more than the link's
    own, and it is the clearance a motion check builds on. With `stop` the coarse run
    starts from its sphere that touched last (memo[n_bodies + b]), the fine run is
    asked at the first coarse sphere that touches, from its own sphere that touched
    last (memo[b]), and the first lane where both touch ends the search; the gaps of
    a search that goes on are the same, as a minimum takes any order."""
    for lane in range(LANES):
        gap[0, lane] = _FAR
    _to_shape(m, k, pose)
    f0, f1 = max(m.fine_start[b], 0), m.fine_end[b]
    n_fine = f1 - f0
    first = min(int(memo[b]), n_fine - 1) if stop else 0
    touch = refined = False
    s0, s1 = max(m.start[b], 0), m.end[b]
    n_coarse, at = s1 - s0, m.node.shape[0] + b
    lead = min(int(memo[at]), n_coarse - 1) if stop else 0
    for i in range(n_coarse + 1):  # the coarse run; after it, its fine run if not asked
        if i < n_coarse:
            s = s0 + lead + i
            s = s - n_coarse if s >= s1 else s
            _sphere_d2(m, k, pose, s, d2)
            r = m.radius[s]
            _take(gap, d2, r, reach)
            for lane in range(LANES):
                touch |= d2[0, lane] <= (r + pad) * (r + pad)
            if not (stop and touch) or refined:
                continue
            memo[at] = s - s0
            if n_fine == 0:  # the coarse run decides: a lane touches
                for lane in range(LANES):
                    gap[0, lane] -= pad
                return True
        if not touch or refined or n_fine == 0:
            continue
        refined = True
        for lane in range(LANES):
            fine[0, lane] = _FAR
        for j in range(n_fine):
            f = f0 + first + j
            f = f - n_fine if f >= f1 else f
            _sphere_d2(m, k, pose, f, d2)
            r = m.radius[f]
            _take(fine, d2, r, reach)
            if stop:
                hit = False
                for lane in range(LANES):
                    hit |= max(gap[0, lane], fine[0, lane]) <= pad
                if hit:
                    memo[b] = f - f0
                    for lane in range(LANES):
                        gap[0, lane] = max(gap[0, lane], fine[0, lane]) - pad
                    return True
    if refined:
        for lane in range(LANES):
            gap[0, lane] = max(gap[0, lane], fine[0, lane])
    hit = False
    for lane in range(LANES):
        gap[0, lane] -= pad
        hit |= gap[0, lane] <= _F0
    return hit


@nb.njit(cache=True, inline="always")
def _bound_gaps2(m, k, bounds, b, out) -> None:
    """out[0, lane] = the squared distance from body b's bounding-sphere centre to
    environment shape k (0 inside)."""
    nbox, ncyl = m.box_inv.shape[0], m.cyl_inv.shape[0]
    if k < nbox + ncyl:
        cyl = k >= nbox
        c = k - nbox if cyl else k
        i00, i01, i02, i03, i10, i11, i12, i13, i20, i21, i22, i23 = _inverse(m, k)
        if not cyl:
            h0, h1, h2 = m.box_half[c, 0], m.box_half[c, 1], m.box_half[c, 2]
            for lane in range(LANES):
                x, y, z = bounds[b, 0, lane], bounds[b, 1, lane], bounds[b, 2, lane]
                u = max(abs(i00 * x + i01 * y + i02 * z + i03) - h0, _F0)
                v = max(abs(i10 * x + i11 * y + i12 * z + i13) - h1, _F0)
                w = max(abs(i20 * x + i21 * y + i22 * z + i23) - h2, _F0)
                out[0, lane] = u * u + v * v + w * w
        else:
            rad, hl = m.cyl_r[c], m.cyl_h[c]
            for lane in range(LANES):
                x, y, z = bounds[b, 0, lane], bounds[b, 1, lane], bounds[b, 2, lane]
                u = i00 * x + i01 * y + i02 * z + i03
                v = i10 * x + i11 * y + i12 * z + i13
                w = i20 * x + i21 * y + i22 * z + i23
                dr = max(np.sqrt(u * u + v * v) - rad, _F0)
                dz = max(abs(w) - hl, _F0)
                out[0, lane] = dr * dr + dz * dz
    else:
        c = k - nbox - ncyl
        px, py, pz, rad = m.sph_c[c, 0], m.sph_c[c, 1], m.sph_c[c, 2], m.sph_r[c]
        for lane in range(LANES):
            dx = bounds[b, 0, lane] - px
            dy = bounds[b, 1, lane] - py
            dz = bounds[b, 2, lane] - pz
            g = max(np.sqrt(dx * dx + dy * dy + dz * dz) - rad, _F0)
            out[0, lane] = g * g


@nb.njit(cache=True, inline="always")
def _pair_gaps2(bounds, a, b, out) -> None:
    """out[0, lane] = the squared distance between the bounding-sphere centres of bodies
    a and b."""
    for lane in range(LANES):
        dx = bounds[a, 0, lane] - bounds[b, 0, lane]
        dy = bounds[a, 1, lane] - bounds[b, 1, lane]
        dz = bounds[a, 2, lane] - bounds[b, 2, lane]
        out[0, lane] = dx * dx + dy * dy + dz * dz


@nb.njit(cache=True, inline="always")
def _near_bound(bounds, b, x, y, z, r, reach, lane) -> bool:
    """Does a point (x, y, z) come within r + reach[0, lane] of body b's bounding-sphere
    centre in this lane?"""
    dx, dy, dz = x - bounds[b, 0, lane], y - bounds[b, 1, lane], z - bounds[b, 2, lane]
    lim = r + reach[0, lane]
    return dx * dx + dy * dy + dz * dz <= lim * lim


@nb.njit(cache=True, inline="always")
def _run(m, b, fine) -> tuple[int, int]:
    """Body b's spheres [start, end): its fine run when `fine` and it has one that fits
    the checks' room, else its coarse run."""
    s0, s1 = max(m.fine_start[b], 0), m.fine_end[b]
    if fine and 0 < s1 - s0 <= BODY_SPHERES:
        return s0, s1
    return max(m.start[b], 0), m.end[b]


@nb.njit(cache=True, inline="always")
def _pair_gaps(m, poses, a, b, reach, bounds, pose, centres, point, listed, d2, gap, fine) -> None:
    """gap[0, lane] = the smallest surface gap between the spheres of bodies a and b
    (coarse, or with `fine` the fine runs of those that have one), or more than
    reach[0, lane] when that is all it comes to. Only spheres that come within reach of
    the other body's bounding sphere in some lane are compared."""
    for lane in range(LANES):
        gap[0, lane] = _FAR
    _node_pose(poses, m.node[b], pose)
    n_b = 0
    b0, b1 = _run(m, b, fine)
    for s in range(b0, b1):
        lx, ly, lz, r = (
            m.sphere_local[0, s],
            m.sphere_local[1, s],
            m.sphere_local[2, s],
            m.radius[s],
        )
        near = False
        for lane in range(LANES):
            x, y, z = _place(pose, lx, ly, lz, lane)
            centres[n_b, 0, lane], centres[n_b, 1, lane], centres[n_b, 2, lane] = x, y, z
            near |= _near_bound(bounds, a, x, y, z, r + m.bound_r[a], reach, lane)
        if near:
            listed[0, n_b] = s
            n_b += 1
    if n_b == 0:
        return
    _node_pose(poses, m.node[a], pose)
    a0, a1 = _run(m, a, fine)
    for s in range(a0, a1):
        lx, ly, lz, ra = (
            m.sphere_local[0, s],
            m.sphere_local[1, s],
            m.sphere_local[2, s],
            m.radius[s],
        )
        near = False
        for lane in range(LANES):
            x, y, z = _place(pose, lx, ly, lz, lane)
            point[0, lane], point[1, lane], point[2, lane] = x, y, z
            near |= _near_bound(bounds, b, x, y, z, ra + m.bound_r[b], reach, lane)
        if not near:
            continue
        for t in range(n_b):
            for lane in range(LANES):
                dx = point[0, lane] - centres[t, 0, lane]
                dy = point[1, lane] - centres[t, 1, lane]
                dz = point[2, lane] - centres[t, 2, lane]
                d2[0, lane] = dx * dx + dy * dy + dz * dz
            _take(gap, d2, ra + m.radius[max(int(listed[0, t]), 0)], reach)


@nb.njit(cache=True, inline="always")
def _bound(m, qb, poses, scratch, bounds, ready, b, placed) -> int:
    """Place body b's bounding sphere (and the nodes up to its own) unless done already;
    returns how many nodes are placed. A block that finds a contact early spares the
    rest of the tree and of the bodies."""
    if ready[0, b] != _F0:
        return placed
    ready[0, b] = _F1
    nd = max(m.node[b], 0)
    if nd >= placed:
        _fk(m, qb, poses, scratch, placed, nd + 1)
        placed = nd + 1
    x, y, z = m.bound_local[b, 0], m.bound_local[b, 1], m.bound_local[b, 2]
    for i in range(3):
        for lane in range(LANES):
            bounds[b, i, lane] = (
                poses[nd, 3 * i, lane] * x
                + poses[nd, 3 * i + 1, lane] * y
                + poses[nd, 3 * i + 2, lane] * z
                + poses[nd, 9 + i, lane]
            )
    return placed


@nb.njit(cache=True, _nrt=False, nogil=True, fastmath=_FAST)
def _block(
    floats, ints, work, work_ints, qs, caps, out, i0, i1, keep_at, keep_reach, stop, twice, again
):
    """Check the block of configurations qs[:, lane] (one per lane) against the items
    work_ints[i0:i1] and write each lane's clearance to out[0, lane]: the smallest gap
    over how fast its body (pair) moves along the motion (the speeds in `work`, m per
    unit of the motion), at most caps[0, lane]; negative for a lane in contact.

    An item is opened (its spheres compared) where its bounding spheres come within a
    lane's cap; the self pairs so found are opened after all the obstacles. With `stop`,
    the check stops at the first contact and returns the position of the item in
    contact, else -1. With keep_at >= 0, the items within keep_reach of some lane (over
    their speed) are also written to work_ints[keep_at:] (the items a motion's later
    checks need: see `motion_free`), and their count is returned too; then, with `twice`
    and no contact found, the same configurations are checked a second time against the
    items kept, with caps again[0, lane] (the clearances a motion's proof needs): the
    poses and bounding spheres already placed serve both, and out holds the second's."""
    m = model(floats, ints)
    n_bodies = m.node.shape[0]
    memo = work[n_bodies + m.pairs.shape[0] + 2 * GAP_STACK :]  # fine spheres that touched
    qb = _stack(MAX_NODES, LANES)
    poses = _stack3(MAX_NODES, 12, LANES)
    bounds = _stack3(MAX_BODIES, 3, LANES)
    pose = _stack(12, LANES)
    scratch = _stack(12, LANES)
    best = _stack(1, LANES)
    gap = _stack(1, LANES)
    fine = _stack(1, LANES)
    coarse = _stack(1, LANES)
    gap2 = _stack(1, LANES)
    reach = _stack(1, LANES)
    centres = _stack3(BODY_SPHERES, 3, LANES)
    point = _stack(3, LANES)
    listed = _stack(1, BODY_SPHERES)
    ready = _stack(1, MAX_BODIES)
    for j in range(m.lower.shape[0]):  # the joints' rows only
        for lane in range(LANES):
            qb[j, lane] = qs[j, lane]
    for lane in range(LANES):
        best[0, lane] = caps[0, lane]
    for b in range(n_bodies):
        ready[0, b] = _F0
    placed = 0  # the nodes whose poses are known: 0..placed-1 (computed as needed)
    pad = m.pad[0] + _EPS
    reach_kept = np.float32(keep_reach)
    deferred = m.lists[3]  # room for the self pairs to open after the obstacles
    kept = 0
    for second in range(2):
        if second:  # the same configurations again, the items kept, the caps asked
            if not twice or keep_at < 0:
                break
            i0, i1 = keep_at, keep_at + kept
            for lane in range(LANES):
                best[0, lane] = again[0, lane]
        n_pairs = 0
        for it in range(i0, i1):
            item = work_ints[it]
            env = item < _PAIR
            if env:
                a = b = max(m.env_bodies[item >> _SHAPE_BITS], 0)
                k = item & ((1 << _SHAPE_BITS) - 1)
            else:
                p = item - _PAIR
                a, b = max(m.pairs[p, 0], 0), max(m.pairs[p, 1], 0)
            for body in (a, b):  # one call site: each inlined copy costs compile time
                placed = _bound(m, qb, poses, scratch, bounds, ready, body, placed)
            if env:
                v = np.float32(work[b])
                r = m.bound_r[b] + pad
                _bound_gaps2(m, k, bounds, b, gap2)
            else:
                v = np.float32(work[n_bodies + p])
                r = m.bound_r[a] + m.bound_r[b] + _EPS
                _pair_gaps2(bounds, a, b, gap2)
            near = False
            for lane in range(LANES):
                lim = r + max(best[0, lane], _F0) * v
                near |= gap2[0, lane] <= lim * lim
            if keep_at >= 0 and not second:
                keep = False
                lim = r + reach_kept * v
                for lane in range(LANES):
                    keep |= gap2[0, lane] <= lim * lim
                if keep:
                    work_ints[keep_at + kept] = item
                    kept += 1
            if not near:
                continue
            if item >= _PAIR:  # self pairs cost more: after the obstacles
                work_ints[deferred + n_pairs] = it
                n_pairs += 1
                continue
            for lane in range(LANES):
                reach[0, lane] = max(best[0, lane], _F0) * v + pad
            _node_pose(poses, m.node[b], pose)
            hit = _env_gap(m, k, b, pose, reach, pad, stop, gap2, gap, fine, memo)
            if hit and stop:
                return it, kept
            for lane in range(LANES):
                best[0, lane] = min(best[0, lane], gap[0, lane] / max(v, _TINY))
        for o in range(n_pairs):
            it = work_ints[deferred + o]
            p = work_ints[it] - _PAIR
            a, b = max(m.pairs[p, 0], 0), max(m.pairs[p, 1], 0)
            v = np.float32(work[n_bodies + p])
            for lane in range(LANES):
                reach[0, lane] = max(best[0, lane], _F0) * v + _EPS
            # where the coarse spheres touch, the fine runs decide (both covers hold the
            # links, so the larger gap is still no more than theirs); one call site
            refined = m.fine_end[a] > m.fine_start[a] or m.fine_end[b] > m.fine_start[b]
            for level in range(2):
                if level == 1:
                    touch = False
                    for lane in range(LANES):
                        touch |= gap[0, lane] <= _EPS
                        coarse[0, lane] = gap[0, lane]
                    if not (touch and refined):
                        break
                _pair_gaps(
                    m,
                    poses,
                    a,
                    b,
                    reach,
                    bounds,
                    pose,
                    centres,
                    point,
                    listed,
                    gap2,
                    gap,
                    level == 1,
                )
                if level == 1:
                    for lane in range(LANES):
                        gap[0, lane] = max(gap[0, lane], coarse[0, lane])
            hit = False
            for lane in range(LANES):
                g = gap[0, lane] - _EPS
                hit |= g <= _F0
                best[0, lane] = min(best[0, lane], g / max(v, _TINY))
            if hit and stop:
                return it, kept
        for lane in range(LANES):
            out[0, lane] = best[0, lane]
    return -1, kept


# --- configurations and motions --------------------------------------------------------------


@nb.njit(cache=True, _nrt=False, nogil=True)
def config_free(floats, ints, work, work_ints, q) -> bool:
    """True when configuration `q` is free of self and environment contacts."""
    qs = _stack(MAX_NODES, LANES)
    caps = _stack(1, LANES)
    out = _stack(1, LANES)
    for j in range(q.shape[0]):
        for lane in range(LANES):
            qs[j, lane] = q[j]
    for lane in range(LANES):
        caps[0, lane] = 0.0
    lists = _i(ints, _LISTS)  # every item, then the reachable ones, then the pool
    it, _ = _block(
        floats, ints, work, work_ints, qs, caps, out, lists[0], lists[1], -1, 0.0, True, False, caps
    )
    return it < 0


@nb.njit(cache=True, _nrt=False, nogil=True)
def configs_free(floats, ints, work, work_ints, qs, n) -> bool:
    """True when the first n rows of `qs` (n <= LANES) are all free of contacts: one
    block for them all (a query's start and goals), where `config_free` takes one each."""
    block = _stack(MAX_NODES, LANES)
    caps = _stack(1, LANES)
    out = _stack(1, LANES)
    for lane in range(LANES):
        row = lane if lane < n else 0
        for j in range(qs.shape[1]):
            block[j, lane] = qs[row, j]
        caps[0, lane] = 0.0
    lists = _i(ints, _LISTS)
    it, _ = _block(
        floats, ints, work, work_ints, block, caps, out, lists[0], lists[1], -1, 0.0, True,
        False, caps,
    )  # fmt: skip
    return it < 0


@nb.njit(cache=True, _nrt=False, nogil=True)
def valid_batch(qs, out, floats, ints, work, work_ints) -> None:
    """out[i]: is configuration qs[i] free? (`qs` (N, d))"""
    n, d = qs.shape
    block = _stack(MAX_NODES, LANES)
    caps = _stack(1, LANES)
    clear = _stack(1, LANES)
    lists = _i(ints, _LISTS)
    for lane in range(LANES):
        caps[0, lane] = 0.0
    for i in range(0, n, LANES):
        for lane in range(LANES):
            row = min(i + lane, n - 1)
            for j in range(d):
                block[j, lane] = qs[row, j]
        _block(
            floats, ints, work, work_ints, block, caps, clear, lists[0], lists[1], -1, 0.0, False,
            False, caps,
        )  # fmt: skip
        for lane in range(min(LANES, n - i)):
            out[i + lane] = clear[0, lane] >= 0.0


@nb.njit(cache=True, inline="always")
def _to_front(items, first, i) -> None:
    """Move items[i] to items[first], the others keeping their order: the item that
    touched last is the likeliest to touch next, and a check stops at its first contact.
    The order changes no answer."""
    item = items[i]
    while i > first:
        items[i] = items[i - 1]
        i -= 1
    items[first] = item


@nb.njit(cache=True, inline="always")
def _blocked(work_ints, r0, r1, it) -> bool:
    """False, after bringing the item in contact (at position `it` of a motion's pool)
    to the front of the reachable list: the next motion looks at it first."""
    item = work_ints[it]
    for i in range(r0, r1):
        if work_ints[i] == item:
            _to_front(work_ints, r0, i)
            break
    return False


@nb.njit(cache=True, inline="always")
def _push(work, at, top, lo, hi, floor) -> int:
    """Push the stretch [lo, hi] left unproved between two free points, unless it is no
    longer than `floor`; returns the stack's new size, or -1 when it is full."""
    if hi - lo <= floor:
        return top
    if top == GAP_STACK:
        return -1
    work[at + 2 * top], work[at + 2 * top + 1] = lo, hi
    return top + 1


@nb.njit(cache=True, inline="always")
def _fill(qs, a, b, lane, t) -> None:
    """Lane `lane` of the block: the point t along a -> b."""
    for j in range(a.shape[0]):
        qs[j, lane] = a[j] + t * (b[j] - a[j])


@nb.njit(cache=True, _nrt=False, nogil=True)
def _sweep(floats, ints, work, work_ints, a, b, x0, x1, floor, i0, i1) -> int:
    """Check the points of [x0, x1] no farther than `floor` apart, a block at a time (the
    fallback when too many stretches wait); the position of an item in contact, or -1."""
    qs = _stack(MAX_NODES, LANES)
    caps = _stack(1, LANES)
    out = _stack(1, LANES)
    n = int(np.ceil((x1 - x0) / floor))
    for lane in range(LANES):
        caps[0, lane] = 0.0
    for i in range(1, n, LANES):
        for lane in range(LANES):
            _fill(qs, a, b, lane, x0 + (x1 - x0) * min(i + lane, n) / n)
        it, _ = _block(
            floats, ints, work, work_ints, qs, caps, out, i0, i1, -1, 0.0, True, False, caps
        )
        if it >= 0:
            return it
    return -1


@nb.njit(cache=True, _nrt=False, nogil=True)
def motion_free(floats, ints, work, work_ints, a, b) -> bool:
    """Is the straight joint-space motion a -> b free? `a` is assumed free, `b` is checked.

    A body moves at most rate[:, b] . |b - a| metres over the motion (likewise for two
    bodies of a pair closing in), so a point whose clearance is c (in units of the motion)
    proves the stretch within c of it free. The first block checks b and seven points
    spread evenly before it, plainly: a blocked motion usually fails there. It also
    lists the items that come within reach of the motion at all; the later blocks look
    at those alone, the next one for the clearances of the same points. Each stretch
    left unproved between two free points is then refined by points spread over it
    (several small stretches share a block), until it is proved or the points around it
    are no farther apart than half the robot's resolution (per joint)."""
    m = model(floats, ints)
    d = a.shape[0]
    n_bodies, n_pairs = m.node.shape[0], m.pairs.shape[0]
    span = 0.0
    for j in range(d):
        span = max(span, abs(b[j] - a[j]) / m.resolution[j])
    # what is left unproved between two free points is at most half a resolution step
    # (the dense validation's step): a full step let a finger graze a box in between
    floor = 0.5 / max(np.ceil(span), 1.0)
    # each body's and pair's speed, a block of them at a time: the rates' rows are
    # joints, so the lanes take eight bodies (pairs) at once; rounded up a little, as
    # single precision could round a sum down
    speed = _stack(1, LANES)
    n_rates = n_bodies + n_pairs
    for i in range(0, n_rates, LANES):
        for lane in range(LANES):
            speed[0, lane] = _F0
        for j in range(d):
            dq = np.float32(abs(b[j] - a[j]))
            for lane in range(LANES):
                speed[0, lane] += m.rate[j, i + lane] * dq
        for lane in range(min(LANES, n_rates - i)):
            work[i + lane] = speed[0, lane] * _ROUND_UP
    qs = _stack(MAX_NODES, LANES)
    caps = _stack(1, LANES)
    again = _stack(1, LANES)
    out = _stack(1, LANES)
    plan = _stack64(4, LANES)  # per stretch in a block: lo, hi, its first lane, its lanes
    lists = m.lists
    r0, r1, pool = lists[1], lists[2], lists[2]
    # a plain check of b and seven points spread before it first (no clearances: a
    # blocked motion fails here, at the least cost); it lists the items in reach too,
    # and unless those points are no farther apart than the floor, it then checks them
    # again against those items for what they prove around them (their poses kept)
    for lane in range(LANES):
        _fill(qs, a, b, lane, (lane + 1.0) / LANES)
        caps[0, lane] = 0.0
        again[0, lane] = (1.0 if lane == 0 else 0.5) / LANES
    twice = floor < 1.0 / LANES
    it, kept = _block(
        floats, ints, work, work_ints, qs, caps, out, r0, r1, pool, 1.0 / LANES, True, twice, again
    )
    if 0 <= it < pool:
        _to_front(work_ints, r0, it)
        return False
    if it >= 0:
        return _blocked(work_ints, r0, r1, it)
    if not twice:
        return True
    at = n_bodies + n_pairs
    top = 0
    edge = 0.0  # where the proof of the last free point ends
    for lane in range(LANES):
        x, c = (lane + 1.0) / LANES, out[0, lane]
        pushed = _push(work, at, top, edge, x - c, floor)
        if pushed < 0:  # no room: check that stretch point by point now
            it = _sweep(floats, ints, work, work_ints, a, b, edge, x - c, floor, pool, pool + kept)
            if it >= 0:
                break
        top = max(top, pushed)
        edge = x + c
    while top > 0 and it < 0:
        # as many stretches as fill a block, each given lanes for its length
        used = n_plans = 0
        while top > 0 and used < LANES:
            top -= 1
            lo, hi = work[at + 2 * top], work[at + 2 * top + 1]
            # enough points that the pieces between them are within the floor
            lanes = min(LANES - used, max(int(np.ceil((hi - lo) / floor)) - 1, 1))
            plan[0, n_plans], plan[1, n_plans] = lo, hi
            plan[2, n_plans], plan[3, n_plans] = used, lanes
            h = (hi - lo) / (lanes + 1)
            for k in range(lanes):
                _fill(qs, a, b, used + k, lo + (k + 1) * h)
                caps[0, used + k] = 0.5 * h
            used += lanes
            n_plans += 1
        for lane in range(used, LANES):  # the rest repeat the last point
            for j in range(d):
                qs[j, lane] = qs[j, used - 1]
            caps[0, lane] = 0.0
        it, _ = _block(
            floats, ints, work, work_ints, qs, caps, out, pool, pool + kept, -1, 0.0, True,
            False, caps,
        )  # fmt: skip
        if it >= 0:
            break
        for g in range(n_plans):
            lo, hi = plan[0, g], plan[1, g]
            first, lanes = int(plan[2, g]), int(plan[3, g])
            h = (hi - lo) / (lanes + 1)
            edge = lo
            for k in range(lanes + 1):
                # the stretch before lane k's point, and after the last one
                x, c = (lo + (k + 1) * h, out[0, first + k]) if k < lanes else (hi, _F0)
                pushed = _push(work, at, top, edge, x - c, floor)
                if pushed < 0:
                    it = _sweep(
                        floats, ints, work, work_ints, a, b, edge, x - c, floor, pool, pool + kept
                    )
                    if it >= 0:
                        break
                top = max(top, pushed)
                edge = x + c
            if it >= 0:
                break
    if it < 0:
        return True
    return _blocked(work_ints, r0, r1, it)


@nb.njit(cache=True, _nrt=False, nogil=True)
def motions_valid(a, b, out, floats, ints, work, work_ints) -> None:
    """out[i]: is the straight joint-space motion a[i] -> b[i] free? Ends excluded for
    `a` (assumed valid), included for `b`."""
    for i in range(a.shape[0]):
        out[i] = motion_free(floats, ints, work, work_ints, a[i], b[i])
