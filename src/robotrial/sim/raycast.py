"""Ray casting against a MuJoCo scene in compiled code (layer 2).

`RayScene` copies some geoms of a model (the environment) into flat arrays and casts
many rays against them at once: primitives (plane, sphere, capsule, ellipsoid,
cylinder, box) with the same geometry as MuJoCo's mj_ray, in numba, split over threads;
meshes with mj_multiRay. The LiDAR (sim/lidar.py) is its user.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numba
import numpy as np

PRIMITIVE_GROUP, MESH_GROUP = 0, 1
_PLANE, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX = (
    int(mujoco.mjtGeom.mjGEOM_PLANE),
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
)
_PRIMITIVES = {_PLANE, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX}


class RayScene:
    """Some geoms of a model (the environment) copied into a small MuJoCo model of their
    own, to cast rays against. An object the gripper holds (its collisions switched off)
    is left out, as a robot's self filter would leave it out of its scans.

    Casting against a copy that holds only the walls, obstacles and objects (not the
    robot's visual and collision geoms) is several times faster. Geoms of moving bodies
    ride on mocap bodies that `sync` puts where the simulation has them. Primitive geoms
    (plane, sphere, capsule, ellipsoid, cylinder, box) go to group `PRIMITIVE_GROUP`, which
    `cast_primitives` intersects in compiled code; the rest (meshes) to `MESH_GROUP`, left
    to mj_multiRay.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> None:
        spec = mujoco.MjSpec()
        self.source = model
        self.bodies: list[int] = []
        self._probe: list[int] = []
        mocap: dict[int, Any] = {}
        for g in np.asarray(geoms, dtype=int):
            b = int(model.geom_bodyid[g])
            moving = b != 0 and model.body_weldid[b] != 0
            if moving and b not in mocap:
                mocap[b] = spec.worldbody.add_body(mocap=True)
                self.bodies.append(b)
                self._probe.append(int(g))
            parent = mocap[b] if moving else spec.worldbody
            gtype = mujoco.mjtGeom(int(model.geom_type[g]))
            if moving:
                pos, quat = model.geom_pos[g].copy(), model.geom_quat[g].copy()
            else:
                pos = data.geom_xpos[g].copy()
                quat = np.zeros(4)
                mujoco.mju_mat2Quat(quat, data.geom_xmat[g])
            kw: dict[str, Any] = {
                "type": gtype,
                "size": model.geom_size[g].copy(),
                "pos": pos,
                "quat": quat,
            }
            if gtype == mujoco.mjtGeom.mjGEOM_MESH:
                mid = int(model.geom_dataid[g])
                va, vn = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
                fa, fn = model.mesh_faceadr[mid], model.mesh_facenum[mid]
                name = f"mesh{mid}"
                if spec.mesh(name) is None:
                    spec.add_mesh(
                        name=name,
                        uservert=model.mesh_vert[va : va + vn].reshape(-1).tolist(),
                        userface=model.mesh_face[fa : fa + fn].reshape(-1).tolist(),
                    )
                kw["meshname"] = name
            kw["group"] = PRIMITIVE_GROUP if int(gtype) in _PRIMITIVES else MESH_GROUP
            parent.add_geom(**kw)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        groups = self.model.geom_group
        self.primitives = np.nonzero(groups == PRIMITIVE_GROUP)[0]
        self.has_meshes = bool(np.any(groups == MESH_GROUP))
        self.mesh_groups = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
        self.mesh_groups[MESH_GROUP] = 1
        self._type = self.model.geom_type[self.primitives].astype(np.int32)
        self._size = np.ascontiguousarray(self.model.geom_size[self.primitives])
        self.sync(data)

    def cast_primitives(
        self,
        pnt: np.ndarray,
        rot: np.ndarray,
        directions: np.ndarray,
        dist: np.ndarray,
        geom: np.ndarray,
        columns: int = 0,
    ) -> None:
        """Nearest hit among the primitive geoms of rays from `pnt` along `rot @ d` for each
        sensor-frame direction d: distance into `dist` and geom id into `geom` (-1: none),
        as mj_multiRay would give. `columns` > 0 says the directions are rings of that many
        azimuths each, evenly around a full turn from -pi (a LidarPattern's layout); then
        each geom is tested only by the beams whose azimuths can reach it."""
        idx = self.primitives
        _cast_primitives(
            pnt,
            rot,
            directions,
            self._type,
            np.ascontiguousarray(self.data.geom_xpos[idx]),
            np.ascontiguousarray(self.data.geom_xmat[idx]),
            self._size,
            idx.astype(np.int32),
            dist,
            geom,
            columns,
        )

    def sync(self, data: mujoco.MjData) -> None:
        """Move the copies of moving geoms to their bodies' current poses."""
        if not self.bodies:
            mujoco.mj_kinematics(self.model, self.data)
            return
        m = self.source
        for i, (b, g) in enumerate(zip(self.bodies, self._probe, strict=True)):
            held = m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
            self.data.mocap_pos[i] = _AWAY if held else data.xpos[b]
            self.data.mocap_quat[i] = data.xquat[b]
        mujoco.mj_kinematics(self.model, self.data)


_MINVAL = 1e-15
_AWAY = np.array([0.0, 0.0, -1e4])  # where a held object's copy waits, out of every beam


@numba.njit(cache=True, inline="always")
def _quad_roots(a, b, c):
    """Roots x0 <= x1 of a*x^2 + 2*b*x + c = 0 (a > 0); (-1, -1) without a real pair."""
    det = b * b - a * c
    if det < _MINVAL:
        return -1.0, -1.0
    det = np.sqrt(det)
    return (-b - det) / a, (-b + det) / a


@numba.njit(cache=True, inline="always")
def _first(x0, x1):
    if x0 >= 0:
        return x0
    if x1 >= 0:
        return x1
    return -1.0


@numba.njit(cache=True, inline="always")
def _closer(best, t):
    if t >= 0 and (best < 0 or t < best):
        return t
    return best


@numba.njit(cache=True)
def _ray_primitive(kind, s0, s1, s2, px, py, pz, vx, vy, vz):
    """Distance along (vx, vy, vz) from (px, py, pz), both in the geom's frame, to the
    surface of a primitive geom with MuJoCo's sizes; -1 if it misses."""
    if kind == _PLANE:
        if vz > -_MINVAL:
            return -1.0
        t = -pz / vz
        if t < 0:
            return -1.0
        if (s0 <= 0 or abs(px + t * vx) <= s0) and (s1 <= 0 or abs(py + t * vy) <= s1):
            return t
        return -1.0
    if kind == _BOX:
        return _ray_box(s0, s1, s2, px, py, pz, vx, vy, vz)
    a = vx * vx + vy * vy + vz * vz
    b = vx * px + vy * py + vz * pz
    cc = px * px + py * py + pz * pz
    if kind == _SPHERE:
        x0, x1 = _quad_roots(a, b, cc - s0 * s0)
        return _first(x0, x1)
    if kind == _ELLIPSOID:
        i0, i1, i2 = 1.0 / (s0 * s0), 1.0 / (s1 * s1), 1.0 / (s2 * s2)
        x0, x1 = _quad_roots(
            i0 * vx * vx + i1 * vy * vy + i2 * vz * vz,
            i0 * vx * px + i1 * vy * py + i2 * vz * pz,
            i0 * px * px + i1 * py * py + i2 * pz * pz - 1.0,
        )
        return _first(x0, x1)
    # bounding sphere first: most rays miss most cylinders and capsules
    if kind == _CYLINDER:
        r2 = s0 * s0 + s1 * s1
    else:
        r2 = (s0 + s1) * (s0 + s1)
    x0, x1 = _quad_roots(a, b, cc - r2)
    if _first(x0, x1) < 0:
        return -1.0
    best = -1.0
    # round side of a cylinder or capsule, between the flat ends
    x0, x1 = _quad_roots(vx * vx + vy * vy, vx * px + vy * py, px * px + py * py - s0 * s0)
    t = _first(x0, x1)
    if t >= 0 and abs(pz + t * vz) <= s1:
        best = t
    if kind == _CYLINDER:
        if abs(vz) > _MINVAL:
            for side in (-1.0, 1.0):
                t = (side * s1 - pz) / vz
                if t >= 0:
                    qx, qy = px + t * vx, py + t * vy
                    if qx * qx + qy * qy <= s0 * s0:
                        best = _closer(best, t)
        return best
    for side in (-1.0, 1.0):  # capsule: the hemispheres beyond each end
        dz = pz - side * s1
        x0, x1 = _quad_roots(a, vx * px + vy * py + vz * dz, px * px + py * py + dz * dz - s0 * s0)
        for t in (x0, x1):
            if t >= 0 and side * (pz + t * vz) >= s1:
                best = _closer(best, t)
    return best


@numba.njit(cache=True)
def _ray_box(s0, s1, s2, px, py, pz, vx, vy, vz):
    """Distance to a box (half sizes s) centred at the origin, from inside or outside;
    -1 if the ray misses (slab test)."""
    near, far = -np.inf, np.inf
    for p, v, h in ((px, vx, s0), (py, vy, s1), (pz, vz, s2)):
        if abs(v) > _MINVAL:
            t1 = (-h - p) / v
            t2 = (h - p) / v
            if t1 > t2:
                t1, t2 = t2, t1
            if t1 > near:
                near = t1
            if t2 < far:
                far = t2
        elif abs(p) > h:
            return -1.0
    if near > far or far < 0:
        return -1.0
    return near if near >= 0 else far


@numba.njit(cache=True)
def _cast_primitives(pnt, rot, directions, kinds, pos, mat, size, ids, dist, geom, columns):
    """Nearest primitive hit per ray (see RayScene.cast_primitives). Geom by geom, nearest
    first, skipping rays that already hit something closer than the geom's bounding
    sphere, and (with `columns`) beams outside the geom's azimuth span."""
    ng = kinds.shape[0]
    nr = directions.shape[0]
    lp = np.empty((ng, 3))
    m = np.empty((ng, 3, 3))  # geom frame <- sensor frame
    reach = np.empty(ng)  # nearest the geom can be: centre distance - bounding radius
    for g in range(ng):
        for i in range(3):
            acc = 0.0
            for k in range(3):
                acc += mat[g, 3 * k + i] * (pnt[k] - pos[g, k])
            lp[g, i] = acc
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += mat[g, 3 * k + i] * rot[k, j]
                m[g, i, j] = acc
        s0, s1, s2 = size[g, 0], size[g, 1], size[g, 2]
        if kinds[g] == _PLANE:
            radius = np.inf
        elif kinds[g] == _SPHERE:
            radius = s0
        elif kinds[g] == _CAPSULE:
            radius = s0 + s1
        elif kinds[g] == _CYLINDER:
            radius = np.sqrt(s0 * s0 + s1 * s1)
        else:
            radius = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        reach[g] = np.sqrt(lp[g, 0] ** 2 + lp[g, 1] ** 2 + lp[g, 2] ** 2) - radius
    for r in range(nr):
        dist[r] = -1.0
        geom[r] = -1
    for g in np.argsort(reach):
        kind = kinds[g]
        s0, s1, s2 = size[g, 0], size[g, 1], size[g, 2]
        px, py, pz = lp[g, 0], lp[g, 1], lp[g, 2]
        m00, m01, m02 = m[g, 0, 0], m[g, 0, 1], m[g, 0, 2]
        m10, m11, m12 = m[g, 1, 0], m[g, 1, 1], m[g, 1, 2]
        m20, m21, m22 = m[g, 2, 0], m[g, 2, 1], m[g, 2, 2]
        lower = reach[g]
        gid = ids[g]
        c_lo, c_hi, rings = 0, nr - 1, 1
        if columns > 0:
            rings = nr // columns
            c_lo, c_hi = _azimuth_columns(kind, s0, s1, s2, lp[g], m[g], columns)
        for ring in range(rings):
            for c in range(c_lo, c_hi + 1):
                r = ring * columns + c % columns if columns > 0 else c
                best = dist[r]
                if best >= 0 and best < lower:
                    continue
                dx, dy, dz = directions[r, 0], directions[r, 1], directions[r, 2]
                vx = m00 * dx + m01 * dy + m02 * dz
                vy = m10 * dx + m11 * dy + m12 * dz
                vz = m20 * dx + m21 * dy + m22 * dz
                if kind == _BOX:
                    t = _ray_box(s0, s1, s2, px, py, pz, vx, vy, vz)
                else:
                    t = _ray_primitive(kind, s0, s1, s2, px, py, pz, vx, vy, vz)
                if t >= 0 and (best < 0 or t < best):
                    dist[r] = t
                    geom[r] = gid


@numba.njit(cache=True)
def _azimuth_columns(kind, s0, s1, s2, lp, m, columns):
    """First and last column (may run past either end: take them modulo `columns`) of the
    beams whose azimuths, in the sensor frame, can meet a geom's local bounding box.
    All columns when the sensor's z axis passes through that box (or for a plane)."""
    full = (0, columns - 1)
    if kind == _PLANE:
        return full
    if kind == _SPHERE:
        h0 = h1 = h2 = s0
    elif kind == _CYLINDER:
        h0, h1, h2 = s0, s0, s1
    elif kind == _CAPSULE:
        h0, h1, h2 = s0, s0, s1 + s0
    else:
        h0, h1, h2 = s0, s1, s2
    # the sensor's z line (unbounded both ways) against the box: then every azimuth can hit
    near, far = -np.inf, np.inf
    for p, v, h in ((lp[0], m[0, 2], h0), (lp[1], m[1, 2], h1), (lp[2], m[2, 2], h2)):
        if abs(v) > _MINVAL:
            t1 = (-h - p) / v
            t2 = (h - p) / v
            if t1 > t2:
                t1, t2 = t2, t1
            near = max(near, t1)
            far = min(far, t2)
        elif abs(p) > h:
            near, far = 1.0, -1.0
    if near <= far:
        return full
    # otherwise the corners' azimuths span less than half a turn: measure from the first
    first, lo, hi = 0.0, 0.0, 0.0
    for k in range(8):
        d0 = (h0 if k & 1 else -h0) - lp[0]
        d1 = (h1 if k & 2 else -h1) - lp[1]
        d2 = (h2 if k & 4 else -h2) - lp[2]
        a = np.arctan2(
            m[0, 1] * d0 + m[1, 1] * d1 + m[2, 1] * d2, m[0, 0] * d0 + m[1, 0] * d1 + m[2, 0] * d2
        )
        if k == 0:
            first = a
            continue
        rel = a - first
        if rel > np.pi:
            rel -= 2 * np.pi
        elif rel < -np.pi:
            rel += 2 * np.pi
        lo, hi = min(lo, rel), max(hi, rel)
    step = 2 * np.pi / columns
    c_lo = int(np.floor((first + lo + np.pi) / step)) - 1
    c_hi = int(np.ceil((first + hi + np.pi) / step)) + 1
    if c_hi - c_lo + 1 >= columns:
        return full
    return c_lo, c_hi


@numba.njit(cache=True)
def keep_nearer(dist, geom, other_dist, other_geom):
    """Where the other cast hit something nearer (or the first hit nothing), take it."""
    for i in range(dist.shape[0]):
        if other_geom[i] >= 0 and (geom[i] < 0 or other_dist[i] < dist[i]):
            dist[i] = other_dist[i]
            geom[i] = other_geom[i]


@numba.njit(cache=True)
def valid_ranges(dist, geom, noise, sigma, rmin, rmax, out):
    """Ranges plus sigma * noise (standard normal draws, None: none); inf where nothing
    was hit or the range falls outside [rmin, rmax]."""
    for i in range(dist.shape[0]):
        r = dist[i]
        if noise is not None:
            r += sigma * noise[i]
        if geom[i] < 0 or r < rmin or r > rmax:
            r = np.inf
        out[i] = r
