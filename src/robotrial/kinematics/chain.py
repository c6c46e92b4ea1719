"""Compiled forward kinematics and Jacobians over any RobotModel tree, batched (layer 2).

A `Kinematics` flattens a RobotModel into arrays (parent index, joint origin, joint
type, axis, which planning variable drives the joint) once; numba kernels then compute
the world pose of every link for many configurations at a time. The planning variables
are a subset of the actuated joints (an arm group); the other joints are held at fixed
values, and mimic joints follow their master.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numba as nb
import numpy as np

from robotrial.model.robot import RobotModel

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2


class TreeArrays(NamedTuple):
    """A kinematic tree as the compiled kernels take it, one row per link: parent
    index, joint origin (4x4), joint type, axis, driving planning variable (-1 for
    none), mimic multiplier and offset, and the value of joints no variable drives."""

    parent: np.ndarray
    origin: np.ndarray
    jtype: np.ndarray
    axis: np.ndarray
    src: np.ndarray
    mult: np.ndarray
    offset: np.ndarray
    const: np.ndarray


_PIO2_HI, _PIO2_LO = 1.5707963267948966, 6.123233995736766e-17  # pi/2 = hi + lo
# Taylor coefficients of (sin r - r) / r^3 and (cos r - 1) / r^2 in powers of r^2
_S = (-1 / 6, 1 / 120, -1 / 5040, 1 / 362880, -1 / 39916800, 1 / 6227020800, -1 / 1307674368000)
_C = (
    -1 / 2,
    1 / 24,
    -1 / 720,
    1 / 40320,
    -1 / 3628800,
    1 / 479001600,
    -1 / 87178291200,
    1 / 20922789888000,
)


@nb.njit(cache=True, inline="always")
def sincos(v: float) -> tuple[float, float]:
    """(sin v, cos v) in one pass: v is reduced to [-pi/4, pi/4], where the series above
    reach double precision (error 2e-15 for joint angles, 1e-12 at |v| = 1e4). The two
    libm calls it replaces cost two thirds of a forward kinematics pass."""
    k = np.floor(v * (1.0 / _PIO2_HI) + 0.5)
    r = (v - k * _PIO2_HI) - k * _PIO2_LO
    x = r * r
    x2 = x * x
    x4 = x2 * x2
    ps = (_S[0] + _S[1] * x) + x2 * (_S[2] + _S[3] * x) + x4 * (_S[4] + _S[5] * x + x2 * _S[6])
    pc = (
        (_C[0] + _C[1] * x)
        + x2 * (_C[2] + _C[3] * x)
        + x4 * ((_C[4] + _C[5] * x) + x2 * (_C[6] + _C[7] * x))
    )
    sr, cr = r + r * x * ps, 1.0 + x * pc
    quadrant = int(k) & 3
    odd = quadrant & 1 == 1  # selects, not branches: the quadrant is unpredictable
    a, b = (cr, sr) if odd else (sr, cr)
    return (1 - (quadrant & 2)) * a, (1 - ((quadrant + 1) & 2)) * b


@nb.njit(cache=True, inline="always")
def _rc(out, pk, i, origin, k, j) -> float:
    """Row i of link pk's rotation times column j of link k's joint origin."""
    return (
        out[pk, i, 0] * origin[k, 0, j]
        + out[pk, i, 1] * origin[k, 1, j]
        + out[pk, i, 2] * origin[k, 2, j]
    )


@nb.njit(cache=True, inline="always")
def fk_single(q, parent, origin, jtype, axis, src, mult, offset, const, out) -> None:
    """World poses of all links for one configuration `q` into `out` (L, 4, 4).

    Written on 3x3 rotations and translations in scalars, without array views (each
    view costs an atomic reference count): the collision checks call it millions of
    times.
    """
    n_links = parent.shape[0]
    for i in range(4):
        for j in range(4):
            out[0, i, j] = origin[0, i, j]
    for k in range(1, n_links):
        pk = parent[k]
        # a = parent rotation @ joint origin (3x4)
        a00 = _rc(out, pk, 0, origin, k, 0)
        a01 = _rc(out, pk, 0, origin, k, 1)
        a02 = _rc(out, pk, 0, origin, k, 2)
        a10 = _rc(out, pk, 1, origin, k, 0)
        a11 = _rc(out, pk, 1, origin, k, 1)
        a12 = _rc(out, pk, 1, origin, k, 2)
        a20 = _rc(out, pk, 2, origin, k, 0)
        a21 = _rc(out, pk, 2, origin, k, 1)
        a22 = _rc(out, pk, 2, origin, k, 2)
        t0 = _rc(out, pk, 0, origin, k, 3) + out[pk, 0, 3]
        t1 = _rc(out, pk, 1, origin, k, 3) + out[pk, 1, 3]
        t2 = _rc(out, pk, 2, origin, k, 3) + out[pk, 2, 3]
        jt = jtype[k]
        if jt == REVOLUTE:
            s_ = src[k]
            v = mult[k] * q[s_] + offset[k] if s_ >= 0 else const[k]
            x, y, z = axis[k, 0], axis[k, 1], axis[k, 2]
            s, c = sincos(v)
            if x == 0.0 and y == 0.0:  # about z, as most joint frames are set up
                s *= z
                out[k, 0, 0], out[k, 0, 1], out[k, 0, 2] = a00 * c + a01 * s, a01 * c - a00 * s, a02
                out[k, 1, 0], out[k, 1, 1], out[k, 1, 2] = a10 * c + a11 * s, a11 * c - a10 * s, a12
                out[k, 2, 0], out[k, 2, 1], out[k, 2, 2] = a20 * c + a21 * s, a21 * c - a20 * s, a22
            else:
                t = 1.0 - c
                r00, r01, r02 = t * x * x + c, t * x * y - s * z, t * x * z + s * y
                r10, r11, r12 = t * x * y + s * z, t * y * y + c, t * y * z - s * x
                r20, r21, r22 = t * x * z - s * y, t * y * z + s * x, t * z * z + c
                out[k, 0, 0] = a00 * r00 + a01 * r10 + a02 * r20
                out[k, 0, 1] = a00 * r01 + a01 * r11 + a02 * r21
                out[k, 0, 2] = a00 * r02 + a01 * r12 + a02 * r22
                out[k, 1, 0] = a10 * r00 + a11 * r10 + a12 * r20
                out[k, 1, 1] = a10 * r01 + a11 * r11 + a12 * r21
                out[k, 1, 2] = a10 * r02 + a11 * r12 + a12 * r22
                out[k, 2, 0] = a20 * r00 + a21 * r10 + a22 * r20
                out[k, 2, 1] = a20 * r01 + a21 * r11 + a22 * r21
                out[k, 2, 2] = a20 * r02 + a21 * r12 + a22 * r22
        else:
            if jt == PRISMATIC:
                s_ = src[k]
                v = mult[k] * q[s_] + offset[k] if s_ >= 0 else const[k]
                x, y, z = axis[k, 0], axis[k, 1], axis[k, 2]
                t0 += v * (a00 * x + a01 * y + a02 * z)
                t1 += v * (a10 * x + a11 * y + a12 * z)
                t2 += v * (a20 * x + a21 * y + a22 * z)
            out[k, 0, 0], out[k, 0, 1], out[k, 0, 2] = a00, a01, a02
            out[k, 1, 0], out[k, 1, 1], out[k, 1, 2] = a10, a11, a12
            out[k, 2, 0], out[k, 2, 1], out[k, 2, 2] = a20, a21, a22
        out[k, 0, 3], out[k, 1, 3], out[k, 2, 3] = t0, t1, t2
        out[k, 3, 0], out[k, 3, 1], out[k, 3, 2], out[k, 3, 3] = 0.0, 0.0, 0.0, 1.0


@nb.njit(cache=True, parallel=False)
def fk_batch(qs, parent, origin, jtype, axis, src, mult, offset, const) -> np.ndarray:
    """World poses (N, L, 4, 4) of all links for configurations `qs` (N, d)."""
    n = qs.shape[0]
    out = np.empty((n, parent.shape[0], 4, 4))
    for b in range(n):
        fk_single(qs[b], parent, origin, jtype, axis, src, mult, offset, const, out[b])
    return out


@nb.njit(cache=True)
def jacobian_from_poses(poses, tip, point, ancestors, jtype, axis, src, mult, d) -> np.ndarray:
    """Geometric Jacobian (6, d) of world point `point` on link `tip`: linear rows first.

    `ancestors[tip, k]` is True when link k's joint moves link `tip`.
    """
    jac = np.empty((6, d))
    jacobian_into(poses, tip, point, ancestors, jtype, axis, src, mult, jac)
    return jac


@nb.njit(cache=True)
def jacobian_into(poses, tip, point, ancestors, jtype, axis, src, mult, jac) -> None:
    """`jacobian_from_poses` written into `jac` (6, d), allocating nothing: the inner
    loop of IK calls it every iteration."""
    jac[:] = 0.0
    for k in range(poses.shape[0]):
        s = src[k]
        if s < 0 or jtype[k] == FIXED or not ancestors[tip, k]:
            continue
        w0 = poses[k, 0, 0] * axis[k, 0] + poses[k, 0, 1] * axis[k, 1] + poses[k, 0, 2] * axis[k, 2]
        w1 = poses[k, 1, 0] * axis[k, 0] + poses[k, 1, 1] * axis[k, 1] + poses[k, 1, 2] * axis[k, 2]
        w2 = poses[k, 2, 0] * axis[k, 0] + poses[k, 2, 1] * axis[k, 1] + poses[k, 2, 2] * axis[k, 2]
        if jtype[k] == REVOLUTE:
            r0 = point[0] - poses[k, 0, 3]
            r1 = point[1] - poses[k, 1, 3]
            r2 = point[2] - poses[k, 2, 3]
            jac[0, s] += mult[k] * (w1 * r2 - w2 * r1)
            jac[1, s] += mult[k] * (w2 * r0 - w0 * r2)
            jac[2, s] += mult[k] * (w0 * r1 - w1 * r0)
            jac[3, s] += mult[k] * w0
            jac[4, s] += mult[k] * w1
            jac[5, s] += mult[k] * w2
        else:
            jac[0, s] += mult[k] * w0
            jac[1, s] += mult[k] * w1
            jac[2, s] += mult[k] * w2


def default_planning_joints(model: RobotModel, tip: str = "") -> list[str]:
    """The arm's planning joints: the `arm` group when the model names one, else the
    actuated joints on the chain from the root to the end effector."""
    groups = model.metadata.get("groups", {}) if model.metadata else {}
    if isinstance(groups, Mapping) and groups.get("arm"):
        return [str(n) for n in groups["arm"]]
    chain = model.chain(tip or model.end_effector)
    return [j.name for j in chain if j.actuated]


class Kinematics:
    """Arrays and compiled kernels for the forward kinematics of one robot.

    `joints` are the planning variables (default: `default_planning_joints`); every other
    actuated joint is held at its value in `fixed` (a name -> value mapping; default 0
    clipped into the joint's limits). Link order: the root first, then tree order.
    """

    def __init__(
        self,
        model: RobotModel,
        joints: Sequence[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        tip: str = "",
    ) -> None:
        self.model = model
        self.tip_name = tip or model.end_effector
        names = list(joints) if joints is not None else default_planning_joints(model, tip)
        actuated = {j.name: j for j in model.actuated_joints}
        for n in names:
            if n not in actuated:
                raise ValueError(
                    f"robot {model.name!r}: {n!r} is not an actuated joint; "
                    f"actuated joints are {sorted(actuated)}"
                )
        self.joint_names: list[str] = names
        self.d = len(names)
        all_lo, all_hi = model.joint_limits()
        limits = dict(zip(model.joint_names, zip(all_lo, all_hi, strict=True), strict=True))
        self.lower = np.array([limits[n][0] for n in names])
        self.upper = np.array([limits[n][1] for n in names])
        fixed_values = {
            n: float(np.clip(0.0, *limits[n])) for n in model.joint_names if n not in names
        }
        for n, v in (fixed or {}).items():
            if n in fixed_values:
                fixed_values[n] = float(v)
        self.fixed_values = fixed_values
        index = {n: i for i, n in enumerate(names)}

        joints_in_order = model.topological_joints()
        self.link_names: list[str] = [model.root] + [j.child for j in joints_in_order]
        self.link_index = {n: i for i, n in enumerate(self.link_names)}
        n_links = len(self.link_names)
        self.parent = np.full(n_links, -1, dtype=np.int64)
        self.origin = np.tile(np.eye(4), (n_links, 1, 1))
        self.jtype = np.zeros(n_links, dtype=np.int64)
        self.axis = np.zeros((n_links, 3))
        self.src = np.full(n_links, -1, dtype=np.int64)
        self.mult = np.ones(n_links)
        self.offset = np.zeros(n_links)
        self.const = np.zeros(n_links)
        self.joint_of_link: list[str] = [""] * n_links
        for j in joints_in_order:
            k = self.link_index[j.child]
            self.joint_of_link[k] = j.name
            self.parent[k] = self.link_index[j.parent]
            self.origin[k] = j.origin.matrix()
            if j.type in ("revolute", "continuous"):
                self.jtype[k] = REVOLUTE
            elif j.type == "prismatic":
                self.jtype[k] = PRISMATIC
            else:
                continue  # fixed, floating and planar joints sit at their origin
            ax = np.asarray(j.axis, dtype=float)
            self.axis[k] = ax / np.linalg.norm(ax) if np.linalg.norm(ax) > 0 else ax
            master, mult, off = j.name, 1.0, 0.0
            if j.mimic is not None:
                master, mult, off = j.mimic.joint, j.mimic.multiplier, j.mimic.offset
            self.mult[k], self.offset[k] = mult, off
            if master in index:
                self.src[k] = index[master]
            else:
                self.const[k] = mult * fixed_values.get(master, 0.0) + off
        self.ancestors = np.zeros((n_links, n_links), dtype=np.bool_)
        for k in range(n_links):
            a = k
            while a >= 0:
                self.ancestors[k, a] = True
                a = self.parent[a]
        # links that some planning variable moves
        self.moving = np.array(
            [bool(np.any((self.src >= 0) & self.ancestors[k])) for k in range(n_links)]
        )
        self.tip = self.link_index[self.tip_name]
        self._tip_chain: tuple[TreeArrays, np.ndarray, int] | None = None

    def _args(self) -> TreeArrays:
        return TreeArrays(
            self.parent,
            self.origin,
            self.jtype,
            self.axis,
            self.src,
            self.mult,
            self.offset,
            self.const,
        )

    def collapsed(self) -> tuple[TreeArrays, np.ndarray, np.ndarray]:
        """The same tree with only the links a planning variable moves (and the root):
        every other link rides rigidly on its nearest such ancestor. Returns the kernel
        arguments of the smaller tree, the node of each link in it, and each link's
        constant pose in its node's frame (L, 4, 4). The collision checks compute the
        few moving frames and place the rest through these constants."""
        n_links = len(self.link_names)
        node = np.zeros(n_links, dtype=np.int64)
        rel = np.tile(np.eye(4), (n_links, 1, 1))
        keep = [0]
        for k in range(1, n_links):
            if self.jtype[k] != FIXED and self.src[k] >= 0:
                node[k] = len(keep)
                keep.append(k)
                continue
            p = self.parent[k]
            node[k] = node[p]
            rel[k] = (
                rel[p] @ self.origin[k] @ _joint_motion(self.jtype[k], self.axis[k], self.const[k])
            )
        idx = np.array(keep)
        origin = np.array([rel[self.parent[k]] @ self.origin[k] for k in keep[1:]])
        args = TreeArrays(
            np.concatenate([[-1], node[self.parent[idx[1:]]]]).astype(np.int64),
            np.concatenate([self.origin[:1], origin.reshape(-1, 4, 4)]),
            self.jtype[idx].copy(),
            self.axis[idx].copy(),
            self.src[idx].copy(),
            self.mult[idx].copy(),
            self.offset[idx].copy(),
            self.const[idx].copy(),
        )
        return args, node, rel

    def tip_chain(self) -> tuple[TreeArrays, np.ndarray, int]:
        """The frames IK needs: the root, the moving frames that carry the end effector
        (`collapsed`), and the end effector as a fixed frame on the last of them. Returns
        the kernel arguments of that chain, its `ancestors` matrix and the end effector's
        index in it (the last). Made once: on an arm with fingers a forward kinematics
        pass over it skips the links IK never reads."""
        if self._tip_chain is None:
            args, node, rel = self.collapsed()
            keep = []
            k = int(node[self.tip])
            while k >= 0:
                keep.append(k)
                k = int(args.parent[k])
            keep.reverse()
            at = {k: i for i, k in enumerate(keep)}
            n = len(keep) + 1
            parent = np.array([-1] + [at[int(args.parent[k])] for k in keep[1:]] + [n - 2])
            chain = TreeArrays(
                parent.astype(np.int64),
                np.concatenate([args.origin[keep], rel[self.tip][None]]),
                np.append(args.jtype[keep], FIXED).astype(np.int64),
                np.concatenate([args.axis[keep], np.zeros((1, 3))]),
                np.append(args.src[keep], -1).astype(np.int64),
                np.append(args.mult[keep], 1.0),
                np.append(args.offset[keep], 0.0),
                np.append(args.const[keep], 0.0),
            )
            ancestors = np.tril(np.ones((n, n), dtype=np.bool_))  # a chain: every earlier frame
            self._tip_chain = (chain, ancestors, n - 1)
        return self._tip_chain

    def check_q(self, q: np.ndarray) -> np.ndarray:
        a = np.ascontiguousarray(np.asarray(q, dtype=float))
        if a.shape[-1] != self.d:
            raise ValueError(
                f"robot {self.model.name!r}: expected {self.d} joint values "
                f"{self.joint_names}, got shape {a.shape}"
            )
        return a

    def fk(self, q: np.ndarray) -> np.ndarray:
        """World poses of every link: (L, 4, 4) for one `q` (d,), (N, L, 4, 4) for (N, d)."""
        a = self.check_q(q)
        if a.ndim == 1:
            return fk_batch(a[None], *self._args())[0]
        return fk_batch(a.reshape(-1, self.d), *self._args())

    def link_pose(self, q: np.ndarray, link: str = "") -> np.ndarray:
        """World pose(s) of one link (the end effector by default)."""
        return self.fk(q)[..., self.link_index[link or self.tip_name], :, :]

    def jacobian(self, q: np.ndarray, link: str = "") -> np.ndarray:
        """Geometric Jacobian (6, d) of a link's origin at `q`: rows vx, vy, vz, wx, wy, wz."""
        a = self.check_q(q)
        poses = self.fk(a)
        k = self.link_index[link or self.tip_name]
        return jacobian_from_poses(
            poses,
            k,
            poses[k, :3, 3].copy(),
            self.ancestors,
            self.jtype,
            self.axis,
            self.src,
            self.mult,
            self.d,
        )

    def full_q(self, q: np.ndarray) -> dict[str, float]:
        """Values of every actuated joint, by name, for planning variables `q`."""
        out = dict(self.fixed_values)
        out.update({n: float(v) for n, v in zip(self.joint_names, q, strict=True)})
        return out

    def random(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """`n` configurations drawn uniformly inside the joint limits."""
        return rng.uniform(self.lower, self.upper, size=(n, self.d))


def _joint_motion(jtype: int, axis: np.ndarray, value: float) -> np.ndarray:
    """The 4x4 motion of a joint of type `jtype` about/along unit `axis` by `value`."""
    m = np.eye(4)
    if jtype == REVOLUTE:
        x, y, z = axis
        c, s = np.cos(value), np.sin(value)
        k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        m[:3, :3] = np.eye(3) + s * k + (1.0 - c) * (k @ k)
    elif jtype == PRISMATIC:
        m[:3, 3] = value * np.asarray(axis)
    return m


def fk(model: RobotModel, q: Sequence[float] | Mapping[str, float]) -> dict[str, np.ndarray]:
    """World 4x4 pose of every link for actuated joint values `q` (compiled path)."""
    values = q if isinstance(q, Mapping) else dict(zip(model.joint_names, q, strict=True))
    kin = Kinematics(model, joints=model.joint_names)
    poses = kin.fk(np.array([float(values.get(n, 0.0)) for n in model.joint_names]))
    return dict(zip(kin.link_names, poses, strict=True))
