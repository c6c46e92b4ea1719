"""MJCF out: a RobotModel and/or a World as a MuJoCo model (XML text plus mesh files).

Layer 1. The same document loads in PyPI `mujoco` and in the browser's `mujoco-js`
(MuJoCo 3.3.8 compiled to WebAssembly), so it uses only long-standing MJCF features.
Names follow the shared convention (docs/mjcf.md): one body per link named as the link,
joints named as the URDF joints, a site `tcp`, one actuator per actuated joint named as
the joint, `wall/NAME`, `obstacle/NAME`, `object/NAME`, `floor`.
"""

from __future__ import annotations

import hashlib
import struct
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from robotrial.geometry import (
    Box,
    Cylinder,
    Mesh,
    MeshData,
    Pose,
    Shape,
    Sphere,
    quat_from_rotation,
)
from robotrial.model.meshes import load_mesh
from robotrial.model.robot import Inertial, Joint, ModelError, RobotModel, Sensor
from robotrial.model.stand import stand
from robotrial.model.world import Light, Obstacle, World

if TYPE_CHECKING:
    import mujoco

BaseKind = Literal["fixed", "free", "planar"]
ActuatorKind = Literal["motor", "position", "velocity", "none"]
BASES: tuple[str, ...] = ("fixed", "free", "planar")
ACTUATORS: tuple[str, ...] = ("motor", "position", "velocity", "none")

MASSLESS_MASS = 1e-5
"""kg: the mass given to a link that has no inertial (URDF: massless), so MuJoCo accepts it."""
MASSLESS_INERTIA = 1e-8
"""kg m^2: the principal moments given to a link that has no inertial."""
MIN_INERTIA = 1e-10
"""kg m^2: principal moments below this (zero, negative) are raised to it."""
MAX_MESH_FACES = 200_000
"""MuJoCo's STL reader refuses more triangles than this; bigger meshes are simplified."""
KP_PER_EFFORT = 50.0
"""Default position gain per unit of effort limit: full effort at 0.02 rad (or m) error."""
KP_MAX = 5000.0
"""Upper bound of the default position gain, so light links stay stable at 2 ms steps."""
BASE_KP = 100.0
"""Default position gain of a planar base joint per kg of robot (N/m; a quarter for yaw)."""
BASE_KV = 20.0
"""Default velocity gain of a planar base joint per kg of robot (N s/m; a quarter for yaw)."""
FREE_JOINT = "base_free"
"""The name of the free joint of a robot written with base="free"."""
PLANAR_JOINTS = ("base_x", "base_y", "base_yaw")

# Contact bits: robot collision geoms (contype 1) touch world geoms (conaffinity 3) but
# not each other (conaffinity 2) unless self_collision is on; world geoms touch everything.
ROBOT_CONTYPE = 1
ROBOT_CONAFFINITY = 2
ROBOT_SELF_CONAFFINITY = 3
WORLD_CONTYPE = 3
WORLD_CONAFFINITY = 3
VISUAL_GROUP = 2
COLLISION_GROUP = 3
DEFAULT_VISUAL_RGBA = (0.7, 0.7, 0.7, 1.0)
COLLISION_RGBA = (0.45, 0.55, 0.75, 0.5)


@dataclass(frozen=True)
class MjcfDocument:
    """An MJCF model: the XML text and the mesh files it names (binary STL bytes).

    `notes` lists what the writer changed to make the description acceptable to MuJoCo
    (e.g. a massless link given a tiny mass), one sentence each. `excluded`: the robot
    link pairs kept from colliding with each other (with self-collision on).
    """

    name: str
    xml: str
    assets: Mapping[str, bytes] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    excluded: tuple[tuple[str, str], ...] = ()

    def compile(self) -> mujoco.MjModel:
        """The compiled MuJoCo model; ModelError with MuJoCo's message if it is refused."""
        import mujoco

        try:
            return mujoco.MjModel.from_xml_string(self.xml, dict(self.assets))
        except ValueError as exc:
            raise ModelError(f"MJCF of {self.name!r} does not compile in MuJoCo: {exc}") from None

    def save(self, folder: str | Path, filename: str = "") -> Path:
        """Write the XML and its meshes into `folder`; returns the XML file's path.

        Mesh file names are relative to the XML, so MuJoCo (and a browser fetching the
        folder) finds them next to it.
        """
        out = Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        for name, data in self.assets.items():
            (out / name).write_bytes(data)
        path = out / (filename or f"{_file_stem(self.name)}.xml")
        path.write_text(self.xml)
        return path


# --- number formatting ----------------------------------------------------------------


def _num(x: float) -> str:
    v = float(x)
    if v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


def _nums(values) -> str:
    return " ".join(_num(v) for v in np.asarray(values, dtype=float).reshape(-1))


def _wxyz(quat) -> tuple[float, float, float, float]:
    x, y, z, w = quat
    return (w, x, y, z)


def _set_pose(el: ET.Element, pose: Pose) -> None:
    if any(pose.xyz):
        el.set("pos", _nums(pose.xyz))
    if pose.quat != (0.0, 0.0, 0.0, 1.0):
        el.set("quat", _nums(_wxyz(pose.quat)))


def _file_stem(name: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
    return safe or "model"


# --- meshes ---------------------------------------------------------------------------


def stl_bytes(data: MeshData) -> bytes:
    """Binary STL of a triangle mesh (MuJoCo and three.js both read it)."""
    v = np.asarray(data.vertices, dtype=np.float64)
    f = np.asarray(data.faces, dtype=np.int64)
    tri = v[f]  # (M, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
    rec = np.zeros(len(f), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = n
    rec["v"] = tri
    return b"robotrial".ljust(80, b" ") + struct.pack("<I", len(f)) + rec.tobytes()


def simplify_mesh(data: MeshData, max_faces: int = MAX_MESH_FACES) -> MeshData:
    """Fewer triangles by vertex clustering: merge vertices that share a grid cell.

    The grid is refined as far as `max_faces` allows, so the shape changes by at most
    about one cell (a fraction of a percent of the mesh's size for the meshes met here).
    """
    v, f = data.vertices, data.faces
    if len(f) <= max_faces:
        return data
    lo = v.min(axis=0)
    size = float(np.ptp(v, axis=0).max()) or 1.0
    cells = 1024.0
    while True:
        n = int(cells) + 1
        k = np.floor((v - lo) / (size / cells)).astype(np.int64)
        _, inverse = np.unique((k[:, 0] * n + k[:, 1]) * n + k[:, 2], return_inverse=True)
        inverse = inverse.reshape(-1)
        count = np.bincount(inverse)
        merged = np.stack([np.bincount(inverse, v[:, i]) for i in range(3)], axis=1)
        merged /= count[:, None]
        nf = inverse[f]
        keep = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
        nf = nf[keep]
        s = np.sort(nf, axis=1)
        m = len(merged)
        _, first = np.unique((s[:, 0] * m + s[:, 1]) * m + s[:, 2], return_index=True)
        nf = nf[np.sort(first)]
        if len(nf) <= max_faces:
            return MeshData(merged, nf)
        # a surface's cell count grows with the square of the resolution
        cells *= min(0.9, 0.95 * np.sqrt(max_faces / len(nf)))


@dataclass(frozen=True)
class _Stl:
    """A mesh made ready for MuJoCo: STL bytes (None if unusable) and what was done to it."""

    blob: bytes | None
    digest: str
    faces_before: int
    faces_after: int


_stl_cache: dict[tuple, _Stl] = {}
_STL_CACHE_BYTES = 512 * 2**20


def _mesh_key(mesh: Mesh) -> tuple | None:
    """A key for meshes read from files (None for in-memory triangles)."""
    if mesh.data is not None or not mesh.filename:
        return None
    try:
        st = Path(mesh.filename).stat()
    except OSError:
        return None
    return (mesh.filename, st.st_mtime_ns, st.st_size, mesh.scale)


def _stl(mesh: Mesh, max_faces: int) -> _Stl:
    """The STL of a mesh: scaled (mirrored ones still facing out), degenerate faces dropped,
    simplified to at most `max_faces`. Cached per file, so repeated documents are cheap."""
    key = _mesh_key(mesh)
    key = None if key is None else (*key, max_faces)
    if key is not None and key in _stl_cache:
        return _stl_cache[key]
    data = load_mesh(mesh)
    before = len(data.faces)
    if before > max_faces:
        data = simplify_mesh(data, max_faces)
    faces = data.faces  # load_mesh already reversed them if the scale mirrors
    tri = data.vertices[faces]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    faces = faces[area > 1e-14]
    extent = np.ptp(data.vertices, axis=0) if len(data.vertices) else np.zeros(3)
    if len(faces) == 0 or np.count_nonzero(extent > 1e-9) < 3:
        out = _Stl(None, "", before, 0)
    else:
        blob = stl_bytes(MeshData(data.vertices, faces))
        out = _Stl(blob, hashlib.sha1(blob).hexdigest()[:10], before, len(faces))
    if key is not None:
        if sum(len(v.blob or b"") for v in _stl_cache.values()) > _STL_CACHE_BYTES:
            _stl_cache.clear()
        _stl_cache[key] = out
    return out


class _MeshTable:
    """Mesh assets of one document: one STL per distinct (file, scale) or in-memory mesh."""

    def __init__(self, max_faces: int) -> None:
        self.max_faces = max_faces
        self.assets: dict[str, bytes] = {}
        self._by_key: dict[object, _Stl | ModelError] = {}
        self._by_digest: dict[str, str] = {}
        self.elements: list[ET.Element] = []

    def add(self, mesh: Mesh, where: str, notes: list[str]) -> str | None:
        """The asset name of `mesh`, or None (with a note) if it has no usable triangles.

        A mesh file that cannot be read is left out of visuals (with a note) and is an
        error for collisions and world bodies.
        """
        key: object = (mesh.filename, mesh.scale) if mesh.data is None else id(mesh.data)
        if key not in self._by_key:
            try:
                self._by_key[key] = _stl(mesh, self.max_faces)
            except ModelError as exc:
                self._by_key[key] = exc
        found = self._by_key[key]
        label = mesh.filename or "(in memory)"
        if isinstance(found, ModelError):
            if "/visual/" not in where:
                raise ModelError(f"{where}: {found}")
            notes.append(f"{where}: left out ({found})")
            return None
        if found.blob is None:
            notes.append(f"{where}: mesh {label} is flat or empty; left out")
            return None
        if found.faces_before > self.max_faces:
            notes.append(
                f"{where}: mesh {label} simplified from {found.faces_before} to "
                f"{found.faces_after} triangles (limit {self.max_faces})"
            )
        if found.digest not in self._by_digest:
            stem = _file_stem(Path(mesh.filename).stem if mesh.filename else "mesh")
            name = f"{stem}_{found.digest}"
            self.assets[f"{name}.stl"] = found.blob
            self._by_digest[found.digest] = name
            self.elements.append(ET.Element("mesh", name=name, file=f"{name}.stl"))
        return self._by_digest[found.digest]


# --- inertia ----------------------------------------------------------------------------


def _inertial_element(inertial: Inertial | None, where: str, notes: list[str]) -> ET.Element:
    """A body's <inertial>: the link's own, rotated into the link frame, made acceptable."""
    if inertial is None or not inertial.mass > 0:
        if inertial is not None:
            notes.append(f"{where}: mass {inertial.mass} kg replaced by {MASSLESS_MASS} kg")
        return ET.Element(
            "inertial",
            pos="0 0 0",
            mass=_num(MASSLESS_MASS),
            diaginertia=_nums([MASSLESS_INERTIA] * 3),
        )
    rot = inertial.origin.rotation()
    tensor = rot @ inertial.tensor() @ rot.T
    moments, axes = np.linalg.eigh(tensor)
    if np.linalg.det(axes) < 0:
        axes[:, 0] = -axes[:, 0]
    fixed = np.maximum(moments, MIN_INERTIA)
    a, b, c = np.sort(fixed)
    if a + b < c:
        order = np.argsort(fixed)
        fixed[order[:2]] += (c - a - b) / 2 + c * 1e-9
    if not np.allclose(fixed, moments, rtol=1e-9, atol=1e-15):
        notes.append(
            f"{where}: principal moments {np.round(moments, 12).tolist()} raised to "
            f"{np.round(fixed, 12).tolist()} (positive, triangle inequality)"
        )
    quat = quat_from_rotation(axes)
    el = ET.Element("inertial", pos=_nums(inertial.origin.xyz), mass=_num(inertial.mass))
    el.set("quat", _nums(_wxyz(quat)))
    el.set("diaginertia", _nums(fixed))
    return el


# --- geoms ------------------------------------------------------------------------------


def _geom(
    name: str,
    shape: Shape,
    origin: Pose,
    meshes: _MeshTable,
    notes: list[str],
) -> ET.Element | None:
    el = ET.Element("geom", name=name)
    if isinstance(shape, Box):
        if min(shape.size) <= 0:
            notes.append(f"{name}: box of size {shape.size} left out")
            return None
        el.set("type", "box")
        el.set("size", _nums(np.asarray(shape.size) / 2))
    elif isinstance(shape, Cylinder):
        if shape.radius <= 0 or shape.length <= 0:
            notes.append(f"{name}: cylinder r={shape.radius} l={shape.length} left out")
            return None
        el.set("type", "cylinder")
        el.set("size", _nums([shape.radius, shape.length / 2]))
    elif isinstance(shape, Sphere):
        if shape.radius <= 0:
            notes.append(f"{name}: sphere r={shape.radius} left out")
            return None
        el.set("type", "sphere")
        el.set("size", _num(shape.radius))
    elif isinstance(shape, Mesh):
        mesh_name = meshes.add(shape, name, notes)
        if mesh_name is None:
            return None
        el.set("type", "mesh")
        el.set("mesh", mesh_name)
    else:
        raise ModelError(f"{name}: unknown shape {shape!r}")
    _set_pose(el, origin)
    return el


# --- the writer -------------------------------------------------------------------------


@dataclass
class _Options:
    actuators: ActuatorKind | Mapping[str, ActuatorKind]
    kp: float | Mapping[str, float] | None
    kv: float | Mapping[str, float] | None
    armature: float
    self_collision: bool
    visuals: bool
    collisions: bool
    max_mesh_faces: int


def _per_joint(value, joint: str, default):
    if isinstance(value, Mapping):
        return value.get(joint, default)
    return default if value is None else value


class _Writer:
    def __init__(self, opts: _Options) -> None:
        self.opts = opts
        self.notes: list[str] = []
        self.meshes = _MeshTable(opts.max_mesh_faces)
        self.actuators: list[ET.Element] = []
        self.equalities: list[ET.Element] = []
        self.sensors: list[ET.Element] = []

    # robot -----------------------------------------------------------------------------

    def robot(self, parent: ET.Element, model: RobotModel, base: str, spawn: Pose) -> None:
        if not model.links:
            raise ModelError(f"robot {model.name!r} has no links")
        for j in model.joints:
            if j.type in ("revolute", "continuous", "prismatic"):
                if not np.linalg.norm(j.axis) > 1e-12:
                    raise ModelError(f"robot {model.name!r}: joint {j.name!r} has a zero axis")
        if model.root != "world" and any(lk.name == "world" for lk in model.links):
            raise ModelError(
                f"robot {model.name!r}: link 'world' is not the root; MuJoCo reserves the "
                "name for its world body"
            )
        taken = {"tcp"}
        for s in model.sensors:
            if s.name in taken:
                raise ModelError(
                    f"robot {model.name!r}: sensor name {s.name!r} is used twice in MJCF "
                    "(sites are named as sensors, and the end-effector site is 'tcp')"
                )
            taken.add(s.name)
        root = model.root
        if root == "world":
            # The URDF's `world` link is MuJoCo's world body: its children hang from it.
            kids = model.child_joints(root)
            self._link_geoms(parent, model, root)
            if base != "fixed":
                if len(kids) != 1 or kids[0].type not in ("fixed", "floating"):
                    raise ModelError(
                        f"robot {model.name!r}: its root link is 'world'; base={base!r} "
                        "needs exactly one fixed or floating joint below it"
                    )
                self._subtree(parent, model, kids[0].child, spawn @ kids[0].origin, base)
                return
            for j in kids:
                self._joint_subtree(parent, model, j, spawn)
            return
        self._subtree(parent, model, root, spawn, base)

    def _subtree(
        self, parent: ET.Element, model: RobotModel, link: str, pose: Pose, base: str
    ) -> None:
        body = ET.SubElement(parent, "body", name=link)
        _set_pose(body, pose)
        if base == "free":
            ET.SubElement(body, "freejoint", name=FREE_JOINT)
        elif base == "planar":
            self._planar(body, pose, model.total_mass)
        self._fill(body, model, link)

    def _planar(self, body: ET.Element, pose: Pose, mass: float) -> None:
        # Joint axes live in the body frame; express world x, y, z there so that the
        # joint values are the base's world x, y and yaw (ref = the spawn pose).
        rot_t = pose.rotation().T
        names = PLANAR_JOINTS
        for name, axis, kind, ref in (
            (names[0], (1.0, 0.0, 0.0), "slide", pose.xyz[0]),
            (names[1], (0.0, 1.0, 0.0), "slide", pose.xyz[1]),
            (names[2], (0.0, 0.0, 1.0), "hinge", pose.yaw),
        ):
            el = ET.SubElement(body, "joint", name=name, type=kind, axis=_nums(rot_t @ axis))
            if ref != 0.0:
                el.set("ref", _num(ref))
            # Driven only when named in an actuator mapping; default gains scale with mass.
            if isinstance(self.opts.actuators, Mapping) and name in self.opts.actuators:
                joint = Joint(name, "prismatic" if kind == "slide" else "continuous", "", "")
                per = max(mass, 1.0) * (1.0 if kind == "slide" else 0.25)
                self._actuator(joint, gains=(BASE_KP * per, BASE_KV * per))

    def _joint_subtree(self, parent: ET.Element, model: RobotModel, j: Joint, at: Pose) -> None:
        body = ET.SubElement(parent, "body", name=j.child)
        _set_pose(body, at @ j.origin if not at.is_identity() else j.origin)
        self._joint(body, model, j, top_level=parent.tag == "worldbody")
        self._fill(body, model, j.child)

    def _fill(self, body: ET.Element, model: RobotModel, link: str) -> None:
        lk = model.link(link)
        body.insert(0, _inertial_element(lk.inertial, f"link {link!r}", self.notes))
        self._link_geoms(body, model, link)
        if link == model.end_effector:
            ET.SubElement(body, "site", name="tcp", size="0.005")
        for s in model.sensors:
            if s.link == link:
                self._sensor(body, s)
        for j in model.child_joints(link):
            self._joint_subtree(body, model, j, Pose())

    def _link_geoms(self, body: ET.Element, model: RobotModel, link: str) -> None:
        lk = model.link(link)
        if self.opts.visuals:
            for i, v in enumerate(lk.visuals):
                g = _geom(f"{link}/visual/{i}", v.geometry, v.origin, self.meshes, self.notes)
                if g is None:
                    continue
                g.set("class", "visual")
                mat = model.materials.get(v.material) if v.material else None
                g.set("rgba", _nums(mat.rgba if mat else DEFAULT_VISUAL_RGBA))
                body.append(g)
        if self.opts.collisions:
            for i, c in enumerate(lk.collisions):
                g = _geom(f"{link}/collision/{i}", c.geometry, c.origin, self.meshes, self.notes)
                if g is None:
                    continue
                g.set("class", "collision")
                body.append(g)

    def _joint(self, body: ET.Element, model: RobotModel, j: Joint, top_level: bool) -> None:
        if j.type == "fixed":
            return
        if j.type == "floating":
            if not top_level:
                raise ModelError(
                    f"robot {model.name!r}: floating joint {j.name!r} is below link "
                    f"{j.parent!r}; MuJoCo allows free joints only on bodies of the world"
                )
            ET.SubElement(body, "freejoint", name=j.name)
            return
        if j.type == "planar":
            raise ModelError(
                f"robot {model.name!r}: planar joint {j.name!r} is not supported in MJCF; "
                "write the robot with base='planar' instead"
            )
        kind = "slide" if j.type == "prismatic" else "hinge"
        el = ET.SubElement(body, "joint", name=j.name, type=kind, axis=_nums(j.axis))
        if self.opts.armature > 0:
            el.set("armature", _num(self.opts.armature))
        if j.type in ("revolute", "prismatic") and j.limit is not None:
            lo, hi = sorted((j.limit.lower, j.limit.upper))
            if hi - lo < 1e-6:
                self.notes.append(
                    f"joint {j.name!r}: range [{lo}, {hi}] widened to +-1e-6 around its middle"
                )
                mid = (lo + hi) / 2
                lo, hi = mid - 1e-6, mid + 1e-6
            el.set("limited", "true")
            el.set("range", _nums([lo, hi]))
        else:
            el.set("limited", "false")
        if j.dynamics is not None:
            if j.dynamics.damping > 0:
                el.set("damping", _num(j.dynamics.damping))
            if j.dynamics.friction > 0:
                el.set("frictionloss", _num(j.dynamics.friction))
        if j.mimic is not None:
            self.equalities.append(
                ET.Element(
                    "joint",
                    name=f"mimic/{j.name}",
                    joint1=j.name,
                    joint2=j.mimic.joint,
                    polycoef=_nums([j.mimic.offset, j.mimic.multiplier, 0, 0, 0]),
                )
            )
            return
        self._actuator(j)

    def _actuator(self, j: Joint, gains: tuple[float, float] | None = None) -> None:
        """The joint's actuator; `gains` = default (kp, kv) when the joint has no effort."""
        kind = _per_joint(self.opts.actuators, j.name, "none")
        if kind not in ACTUATORS:
            raise ModelError(f"joint {j.name!r}: unknown actuator kind {kind!r} ({ACTUATORS})")
        if kind == "none":
            return
        effort = j.limit.effort if j.limit is not None else 0.0
        limited = j.type != "continuous" and j.limit is not None
        el = ET.Element(kind, name=j.name, joint=j.name)
        if kind == "motor":
            if effort > 0:
                el.set("ctrllimited", "true")
                el.set("ctrlrange", _nums([-effort, effort]))
        elif kind == "position":
            kp = _per_joint(self.opts.kp, j.name, None)
            if kp is None and effort > 0:
                kp = float(np.clip(KP_PER_EFFORT * effort, 10.0, KP_MAX))
            elif kp is None:
                kp = gains[0] if gains else 100.0
            el.set("kp", _num(kp))
            kv = _per_joint(self.opts.kv, j.name, None)
            if kv is not None:
                el.set("kv", _num(kv))
            else:
                el.set("dampratio", "1")
            if limited:
                lo, hi = sorted((j.limit.lower, j.limit.upper))
                el.set("ctrllimited", "true")
                el.set("ctrlrange", _nums([lo, hi]))
            if effort > 0:
                el.set("forcelimited", "true")
                el.set("forcerange", _nums([-effort, effort]))
        else:  # velocity
            kv = _per_joint(self.opts.kv, j.name, None)
            if kv is None and effort > 0:
                kv = float(np.clip(effort, 1.0, 1e4))
            elif kv is None:
                kv = gains[1] if gains else 10.0
            el.set("kv", _num(kv))
            speed = j.limit.velocity if j.limit is not None else 0.0
            if speed > 0:
                el.set("ctrllimited", "true")
                el.set("ctrlrange", _nums([-speed, speed]))
            if effort > 0:
                el.set("forcelimited", "true")
                el.set("forcerange", _nums([-effort, effort]))
        self.actuators.append(el)

    def _sensor(self, body: ET.Element, s: Sensor) -> None:
        """A site at the sensor's frame (LiDARs cast their rays from it), plus what its
        type needs from MuJoCo (`_SENSOR_ELEMENTS`)."""
        site = ET.SubElement(body, "site", name=s.name, size="0.01")
        _set_pose(site, s.origin)
        add = _SENSOR_ELEMENTS.get(s.type)
        if add is not None:
            add(self, body, s)

    def _camera(self, body: ET.Element, s: Sensor) -> None:
        # A sensor frame looks along +x with z up (ROS body convention); a MuJoCo
        # camera looks along -z with y up.
        to_cam = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        rot = s.origin.rotation() @ to_cam
        from scipy.spatial.transform import Rotation

        cam = ET.SubElement(body, "camera", name=s.name, pos=_nums(s.origin.xyz))
        cam.set("quat", _nums(_wxyz(Rotation.from_matrix(rot).as_quat())))
        fov = float(s.params.get("fov", np.deg2rad(45.0)))
        cam.set("fovy", _num(np.rad2deg(fov)))

    def _imu(self, body: ET.Element, s: Sensor) -> None:
        self.sensors.append(ET.Element("gyro", name=f"{s.name}/gyro", site=s.name))
        self.sensors.append(
            ET.Element("accelerometer", name=f"{s.name}/accelerometer", site=s.name)
        )

    # world -----------------------------------------------------------------------------

    def world(self, worldbody: ET.Element, world: World) -> None:
        fl = world.floor
        floor = ET.SubElement(worldbody, "geom", name="floor", type="plane")
        floor.set("class", "world")
        floor.set("size", _nums([fl.size[0] / 2, fl.size[1] / 2, 0.05]))
        floor.set("pos", _nums([fl.center[0], fl.center[1], fl.height]))
        floor.set("rgba", _nums(fl.rgba))
        floor.set("friction", _nums([fl.friction, 0.005, 0.0001]))
        for light in world.lights:
            self._light(worldbody, light)
        for ob in world.walls:
            self._static(worldbody, ob, "wall")
        for ob in world.obstacles:
            self._static(worldbody, ob, "obstacle")

    def objects(self, worldbody: ET.Element, world: World) -> None:
        for ob in world.objects:
            name = f"object/{ob.name}"
            body = ET.SubElement(worldbody, "body", name=name)
            _set_pose(body, ob.pose)
            ET.SubElement(body, "freejoint", name=name)
            g = _geom(name, ob.geometry, Pose(), self.meshes, self.notes)
            if g is None:
                raise ModelError(f"world object {ob.name!r} has no usable shape")
            g.set("class", "world")
            g.set("rgba", _nums(ob.rgba))
            g.set("mass", _num(ob.mass if ob.mass > 0 else 0.1))
            body.append(g)

    def _static(self, worldbody: ET.Element, ob: Obstacle, prefix: str) -> None:
        g = _geom(f"{prefix}/{ob.name}", ob.geometry, ob.pose, self.meshes, self.notes)
        if g is None:
            raise ModelError(f"world {prefix} {ob.name!r} has no usable shape")
        g.set("class", "world")
        g.set("rgba", _nums(ob.rgba))
        worldbody.append(g)

    def _light(self, worldbody: ET.Element, light: Light) -> None:
        el = ET.SubElement(worldbody, "light", name=f"light/{light.name}")
        el.set("pos", _nums(light.pose.xyz))
        direction = np.asarray(light.direction, dtype=float)
        if light.type == "directional":
            el.set("directional", "true")
        if np.linalg.norm(direction) > 0:
            el.set("dir", _nums(direction))
        color = np.clip(np.asarray(light.color) * light.intensity, 0.0, 1.0)
        el.set("diffuse", _nums(color))
        el.set("specular", "0.1 0.1 0.1")


_SENSOR_ELEMENTS = {"camera": _Writer._camera, "depth_camera": _Writer._camera, "imu": _Writer._imu}
"""What each sensor type adds to MJCF besides its site (LiDARs need only the site)."""


def to_mjcf(
    robot: RobotModel | None = None,
    world: World | None = None,
    *,
    base: BaseKind = "fixed",
    spawn: Pose | None = None,
    actuators: ActuatorKind | Mapping[str, ActuatorKind] = "motor",
    kp: float | Mapping[str, float] | None = None,
    kv: float | Mapping[str, float] | None = None,
    timestep: float = 0.002,
    armature: float = 0.01,
    self_collision: bool = False,
    visuals: bool = True,
    collisions: bool = True,
    max_mesh_faces: int = MAX_MESH_FACES,
    name: str = "",
    excludes: tuple[tuple[str, str], ...] | None = None,
) -> MjcfDocument:
    """Build the MJCF of a robot, a world, or a robot standing in a world.

    `base`: the robot's root is welded to the world ("fixed"), has a free joint
    ("free", named `base_free`) or moves in the floor plane ("planar": slides `base_x`,
    `base_y` and hinge `base_yaw`, whose values are the base's world x, y and yaw).
    `spawn`: where the robot's root stands (default: the world's `default` spawn, else
    the origin; a fixed robot whose legs reach below the floor stands on it, `stand`).
    `actuators`: one kind for every actuated joint, or a mapping joint -> kind ("motor"
    torque/force, "position" servo, "velocity" servo, "none"); joints
    missing from a mapping get none. `kp`/`kv`: servo gains (a number or per joint).
    `armature` (kg m^2 or kg) is added to every robot joint for numerical stability.
    `self_collision`: let the robot's non-adjacent links collide with each other
    (pairs already touching in the zero configuration are excluded). `max_mesh_faces`:
    meshes with more triangles are simplified (at most MuJoCo's STL limit, 200,000; less
    makes lighter documents for a browser). `excludes`: with self-collision, the link
    pairs to exclude when already known (a document's `excluded`); None finds them,
    which builds the model twice.
    """
    if robot is None and world is None:
        raise ModelError("to_mjcf needs a robot, a world or both")
    if base not in BASES:
        raise ModelError(f"base must be one of {BASES}, got {base!r}")
    if not timestep > 0:
        raise ModelError(f"timestep must be positive, got {timestep}")
    if isinstance(actuators, str) and actuators not in ACTUATORS:
        raise ModelError(f"actuators must be one of {ACTUATORS} or a mapping, got {actuators!r}")
    if isinstance(actuators, Mapping) and robot is not None:
        known = {j.name for j in robot.joints} | (set(PLANAR_JOINTS) if base == "planar" else set())
        unknown = sorted(set(actuators) - known)
        if unknown:
            raise ModelError(f"actuators name joints the robot does not have: {unknown}")
    if spawn is None:
        spawn = world.spawns.get("default", Pose()) if world is not None else Pose()
        if robot is not None and base == "fixed":  # on the floor if its legs reach below
            spawn = spawn @ stand(robot, world, spawn)
    if not 4 <= max_mesh_faces <= MAX_MESH_FACES:
        raise ModelError(f"max_mesh_faces must be in [4, {MAX_MESH_FACES}], got {max_mesh_faces}")
    opts = _Options(
        actuators, kp, kv, armature, self_collision, visuals, collisions, max_mesh_faces
    )
    doc_name = name or "+".join(x.name for x in (robot, world) if x is not None)
    if self_collision and robot is not None and excludes is not None:
        return _build(doc_name, robot, world, base, spawn, opts, timestep, excludes)
    doc = _build(doc_name, robot, world, base, spawn, opts, timestep, excludes=())
    if self_collision and robot is not None:
        pairs = _touching_pairs(doc, robot)
        if pairs:
            doc = _build(doc_name, robot, world, base, spawn, opts, timestep, excludes=pairs)
    return doc


def _build(
    name: str,
    robot: RobotModel | None,
    world: World | None,
    base: str,
    spawn: Pose,
    opts: _Options,
    timestep: float,
    excludes: tuple[tuple[str, str], ...],
) -> MjcfDocument:
    w = _Writer(opts)
    root = ET.Element("mujoco", model=name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    ET.SubElement(root, "option", timestep=_num(timestep), integrator="implicitfast")
    _defaults(root, opts)
    asset = ET.SubElement(root, "asset")
    worldbody = ET.SubElement(root, "worldbody")
    if world is not None:
        w.world(worldbody, world)
    if robot is not None:
        w.robot(worldbody, robot, base, spawn)
    if world is not None:
        w.objects(worldbody, world)
    for el in w.meshes.elements:
        asset.append(el)
    if not len(asset):
        root.remove(asset)
    if excludes:
        contact = ET.SubElement(root, "contact")
        for a, b in excludes:
            ET.SubElement(contact, "exclude", body1=a, body2=b)
    for tag, items in (("equality", w.equalities), ("actuator", w.actuators)):
        if items:
            ET.SubElement(root, tag).extend(items)
    if w.sensors:
        ET.SubElement(root, "sensor").extend(w.sensors)
    ET.indent(root)
    xml = ET.tostring(root, encoding="unicode")
    return MjcfDocument(
        name=name, xml=xml, assets=w.meshes.assets, notes=tuple(w.notes), excluded=excludes
    )


def _defaults(root: ET.Element, opts: _Options) -> None:
    default = ET.SubElement(root, "default")
    visual = ET.SubElement(default, "default", {"class": "visual"})
    ET.SubElement(
        visual, "geom", contype="0", conaffinity="0", group=str(VISUAL_GROUP), density="0"
    )
    collision = ET.SubElement(default, "default", {"class": "collision"})
    affinity = ROBOT_SELF_CONAFFINITY if opts.self_collision else ROBOT_CONAFFINITY
    ET.SubElement(
        collision,
        "geom",
        contype=str(ROBOT_CONTYPE),
        conaffinity=str(affinity),
        group=str(COLLISION_GROUP),
        rgba=_nums(COLLISION_RGBA),
    )
    world = ET.SubElement(default, "default", {"class": "world"})
    ET.SubElement(world, "geom", contype=str(WORLD_CONTYPE), conaffinity=str(WORLD_CONAFFINITY))


def _touching_pairs(doc: MjcfDocument, robot: RobotModel) -> tuple[tuple[str, str], ...]:
    """Pairs of robot links whose collision shapes touch in the zero configuration."""
    import mujoco

    model = doc.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    links = {lk.name for lk in robot.links}
    pairs: set[tuple[str, str]] = set()
    for c in data.contact[: data.ncon]:
        a = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[c.geom1])
        b = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[c.geom2])
        if a in links and b in links and a != b:
            pairs.add((min(a, b), max(a, b)))
    return tuple(sorted(pairs))


__all__ = [
    "ACTUATORS",
    "BASES",
    "FREE_JOINT",
    "PLANAR_JOINTS",
    "MjcfDocument",
    "simplify_mesh",
    "stl_bytes",
    "to_mjcf",
]
