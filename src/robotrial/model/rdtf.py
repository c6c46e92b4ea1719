"""RDTF: a robot as glTF 2.0 binary with physics, the format the browser loads.

Layer 1 (descriptions). `write_rdtf` turns a RobotModel into a `.glb`; `read_rdtf`
turns one back, keeping every field. docs/rdtf.md is the specification. In short:

- one node per link, named as the link, nested as the kinematic tree; a child link's
  local transform is its joint origin; the root link's node is the scene's root;
- visuals are child nodes `LINK/visual/I` holding triangle meshes and PBR materials;
- collision shapes are child nodes `LINK/collision/I` carrying a
  `KHR_physics_rigid_bodies` collider (box, sphere, cylinder from
  `KHR_implicit_shapes`, meshes through a node outside the scene);
- a link with mass carries a `KHR_physics_rigid_bodies` motion (mass, centre of mass,
  principal inertia);
- the root-level `RDTF_robot` extension holds the whole model in float64 JSON (joints,
  sensors, spheres, metadata, materials, exact inertials and origins, mesh files), so
  reading never depends on float32 accessors except for mesh vertices.

Coordinates are the robot's own (metres, z up); a y-up viewer rotates the scene.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pygltflib
from scipy.spatial.transform import Rotation

from robotrial.geometry import Box, Cylinder, Mesh, MeshData, Pose, Shape, Sphere
from robotrial.model.gltf import (
    PHYSICS_EXTENSION,
    SHAPES_EXTENSION,
    Y_TO_Z,
    GltfBuilder,
    accessor_array,
    parse_glb,
    parse_gltf_json,
    primitive_triangles,
)
from robotrial.model.meshes import load_mesh
from robotrial.model.robot import (
    Collision,
    CollisionSphere,
    Inertial,
    Joint,
    JointDynamics,
    JointLimit,
    Link,
    Material,
    Mimic,
    ModelError,
    RobotModel,
    Sensor,
    Visual,
)

RDTF_EXTENSION = "RDTF_robot"
RDTF_VERSION = 1
DEFAULT_RGBA = (0.7, 0.7, 0.7, 1.0)


# --- JSON encoding of model fields (float64, exact) ----------------------------------


def _num(x: float) -> float | str:
    """A float for JSON; non-finite values become the strings "inf", "-inf", "nan"."""
    x = float(x)
    if math.isfinite(x):
        return x
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def _nums(values) -> list[float | str]:
    return [_num(v) for v in values]


def _exact_pose(xyz, quat) -> Pose:
    """A Pose holding exactly these float64 values: a unit quaternion is not normalised
    again (that could change its last bits); any other is."""
    p = Pose(xyz, quat)
    object.__setattr__(p, "xyz", tuple(float(v) for v in xyz))
    if np.allclose(p.quat, quat, rtol=0.0, atol=1e-12):
        object.__setattr__(p, "quat", tuple(float(v) for v in quat))
    return p


def _pose_json(p: Pose) -> dict:
    return {"xyz": _nums(p.xyz), "quat": _nums(p.quat)}


def _pose_from(d: Mapping, where: str) -> Pose:
    try:
        xyz = [float(v) for v in d["xyz"]]
        quat = [float(v) for v in d["quat"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"{where}: a pose needs xyz (3 numbers) and quat (4 numbers)") from exc
    if len(xyz) != 3 or len(quat) != 4:
        raise ModelError(f"{where}: a pose needs xyz (3 numbers) and quat (4 numbers)")
    return _exact_pose(xyz, quat)


def _plain(value: Any, where: str) -> Any:
    """Metadata and sensor parameters as JSON values; tuples become lists."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist(), where)
    if isinstance(value, np.generic):
        return _plain(value.item(), where)
    if isinstance(value, bool) or value is None or isinstance(value, int | str):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ModelError(f"{where}: {value} cannot be stored in RDTF (JSON has no inf/nan)")
        return value
    raise ModelError(f"{where}: a {type(value).__name__} cannot be stored in RDTF")


# --- writing ------------------------------------------------------------------------


def _motion(inertial: Inertial) -> dict:
    """KHR_physics_rigid_bodies motion: mass, centre of mass, principal inertia in link frame."""
    rot = inertial.origin.rotation()
    tensor = rot @ inertial.tensor() @ rot.T
    moments, axes = np.linalg.eigh(tensor)
    if np.linalg.det(axes) < 0:
        axes[:, 0] = -axes[:, 0]
    q = Rotation.from_matrix(axes).as_quat()
    # zero would mean "infinite" to a physics engine; a point mass gets a tiny inertia
    moments = np.maximum(moments, 1e-12)
    return {
        "mass": float(inertial.mass),
        "centerOfMass": [float(v) for v in inertial.origin.xyz],
        "inertiaDiagonal": [float(v) for v in moments],
        "inertiaOrientation": [float(v) for v in q / np.linalg.norm(q)],
    }


def _shape_json(shape: Shape) -> dict:
    if isinstance(shape, Box):
        return {"type": "box", "size": _nums(shape.size)}
    if isinstance(shape, Cylinder):
        return {"type": "cylinder", "radius": _num(shape.radius), "length": _num(shape.length)}
    if isinstance(shape, Sphere):
        return {"type": "sphere", "radius": _num(shape.radius)}
    if isinstance(shape, Mesh):
        return {"type": "mesh", "filename": shape.filename, "scale": _nums(shape.scale)}
    raise ModelError(f"unknown shape {shape!r}")


class _RobotWriter:
    def __init__(self, model: RobotModel) -> None:
        self.model = model
        self.b = GltfBuilder()
        self.shapes: list[dict] = []
        self.triangles: dict[int, tuple[tuple[int, int, int] | None, MeshData]] = {}
        self.joint_specs: dict[str, int] = {}

    def _mesh_data(self, shape: Mesh, where: str) -> MeshData:
        if shape.data is not None:
            return shape.data
        if not shape.filename:
            raise ModelError(f"{where}: mesh has neither a file nor triangles")
        return load_mesh(shape, scaled=False)

    def _file_mesh(self, shape: Mesh, where: str, material: int | None) -> tuple[int | None, dict]:
        """The glTF mesh for a mesh shape; the same triangles are stored once."""
        geom = _shape_json(shape)
        try:
            data = self._mesh_data(shape, where)
        except ModelError as exc:
            # an unreadable file: its name and scale are kept, there is nothing to draw
            warnings.warn(f"{where}: {exc}; written without triangles", stacklevel=4)
            geom["mesh"] = None
            return None, geom
        if id(data) not in self.triangles:
            self.triangles[id(data)] = (self.b.triangles(data.vertices, data.faces), data)
        accessors, _ = self.triangles[id(data)]
        if accessors is None:
            geom["mesh"] = None
            geom["vertices"] = [_nums(v) for v in data.vertices]
            geom["faces"] = data.faces.tolist()
            return None, geom
        if material is None:  # a collider: any mesh over these triangles will do
            material = next((m for a, m in self.b.mesh_index if a == accessors), None)
        index = self.b.mesh(where, accessors, material)
        geom["mesh"] = index
        return index, geom

    def _visual(self, link: Link, i: int, visual: Visual) -> tuple[int, dict]:
        name = f"{link.name}/visual/{i}"
        mat = self.model.materials.get(visual.material)
        rgba = mat.rgba if mat is not None else DEFAULT_RGBA
        material = self.b.material(visual.material, rgba)
        shape = visual.geometry
        fields: dict[str, Any] = {}
        if isinstance(shape, Mesh):
            index, geom = self._file_mesh(shape, name, material)
            if shape.scale != (1.0, 1.0, 1.0):
                fields["scale"] = [float(v) for v in shape.scale]
        else:
            index = None
            if _has_volume(shape):
                v, n, f = primitive_triangles(shape)
                accessors = self.b.triangles(v, f, n)
                index = None if accessors is None else self.b.mesh(name, accessors, material)
            geom = _shape_json(shape)
        pose = visual.origin
        if index is not None:
            fields["mesh"] = index
        node = self.b.node(name, pose, **fields)
        record = {
            "name": visual.name,
            "node": node,
            "origin": _pose_json(visual.origin),
            "material": visual.material,
            "geometry": geom,
        }
        return node, record

    def _implicit_shape(self, spec: dict) -> dict | None:
        """`{"shape": index}` for a KHR_implicit_shapes entry; None for a degenerate one
        (the extension forbids zero sizes; such a shape stays only in RDTF_robot)."""
        values = [v for k, v in spec[spec["type"]].items() if k != "radiusBottom"]
        flat = [x for v in values for x in (v if isinstance(v, list) else [v])]
        if not all(math.isfinite(x) and x > 0 for x in flat):
            return None
        self.shapes.append(spec)
        return {"shape": len(self.shapes) - 1}

    def _collision(self, link: Link, i: int, col: Collision) -> tuple[int, dict]:
        name = f"{link.name}/collision/{i}"
        shape = col.geometry
        pose = col.origin
        geom = _shape_json(shape)
        geometry: dict | None = None
        if isinstance(shape, Box):
            geometry = self._implicit_shape({"type": "box", "box": {"size": list(shape.size)}})
        elif isinstance(shape, Sphere):
            geometry = self._implicit_shape({"type": "sphere", "sphere": {"radius": shape.radius}})
        elif isinstance(shape, Cylinder):
            r = shape.radius
            cyl = {"height": shape.length, "radiusTop": r, "radiusBottom": r}
            geometry = self._implicit_shape({"type": "cylinder", "cylinder": cyl})
            pose = pose @ Y_TO_Z
        else:
            index, geom = self._file_mesh(shape, name, None)
            if index is not None:
                scale = [float(v) for v in shape.scale] if shape.scale != (1.0, 1.0, 1.0) else None
                holder = self.b.node(f"{name}/mesh", mesh=index, scale=scale)
                geometry = {"node": holder, "convexHull": False}
        fields: dict[str, Any] = {}
        if geometry is not None:
            fields["extensions"] = {PHYSICS_EXTENSION: {"collider": {"geometry": geometry}}}
        node = self.b.node(name, pose, **fields)
        record = {
            "name": col.name,
            "node": node,
            "origin": _pose_json(col.origin),
            "geometry": geom,
        }
        return node, record

    def _link(self, link: Link, records: list[dict]) -> int:
        kids: list[int] = []
        visuals = []
        for i, v in enumerate(link.visuals):
            node, rec = self._visual(link, i, v)
            kids.append(node)
            visuals.append(rec)
        collisions = []
        for i, c in enumerate(link.collisions):
            node, rec = self._collision(link, i, c)
            kids.append(node)
            collisions.append(rec)
        parent = self.model.parent_joint(link.name)
        fields: dict[str, Any] = {}
        if link.inertial is not None and link.inertial.mass > 0:
            fields["extensions"] = {PHYSICS_EXTENSION: {"motion": _motion(link.inertial)}}
        node = self.b.node(link.name, parent.origin if parent else Pose(), **fields)
        record: dict[str, Any] = {
            "name": link.name,
            "node": node,
            "inertial": _inertial_json(link.inertial),
            "visuals": visuals,
            "collisions": collisions,
        }
        records.append(record)
        for j in self.model.child_joints(link.name):
            child = self._link(self.model.link(j.child), records)
            kids.append(child)
            joint_node = self._physics_joint(j, child)
            if joint_node is not None:
                kids.append(joint_node)
        if kids:
            self.b.gltf.nodes[node].children = kids
        return node

    def _physics_joint(self, joint: Joint, child: int) -> int | None:
        """KHR_physics_rigid_bodies joint: a node `JOINT/joint` under the parent link and
        an anchor `JOINT/joint/child` under the child link, both with x along the axis;
        they coincide at joint value 0. None for floating and planar joints."""
        spec = _joint_limits(joint)
        if spec is None:
            return None
        key = json.dumps(spec, sort_keys=True)
        if key not in self.joint_specs:
            self.joint_specs[key] = len(self.joint_specs)
        frame = _x_to_axis(joint.axis)
        anchor = self.b.node(f"{joint.name}/joint/child", frame)
        node = self.b.gltf.nodes[child]
        node.children = [*(node.children or []), anchor]
        link = {"connectedNode": anchor, "joint": self.joint_specs[key]}
        return self.b.node(
            f"{joint.name}/joint",
            joint.origin @ frame,
            extensions={PHYSICS_EXTENSION: {"joint": link}},
        )

    def write(self) -> bytes:
        m = self.model
        if not m.links:
            raise ModelError(f"robot {m.name!r} has no links; nothing to write")
        records: list[dict] = []
        root = self._link(m.link(m.root), records)
        by_name = {r["name"]: r for r in records}
        link_nodes = {r["name"]: r["node"] for r in records}
        self.b.gltf.scenes = [pygltflib.Scene(name=m.name, nodes=[root])]
        self.b.gltf.scene = 0
        robot = {
            "version": RDTF_VERSION,
            "name": m.name,
            "root": m.root,
            "tcp": m.tcp,
            "end_effector": m.end_effector,
            "source": m.source,
            "repairs": list(m.repairs),
            "links": [by_name[lk.name] for lk in m.links],
            "joints": [_joint_json(j, link_nodes[j.child]) for j in m.joints],
            "actuated_joints": m.joint_names,
            "sensors": [_sensor_json(s) for s in m.sensors],
            "spheres": [
                {"link": s.link, "center": _nums(s.center), "radius": _num(s.radius)}
                for s in m.spheres
            ],
            "materials": [
                {
                    "name": mat.name,
                    "key": key,
                    "rgba": _nums(mat.rgba),
                    "texture": mat.texture,
                }
                for key, mat in m.materials.items()
            ],
            "metadata": _plain(dict(m.metadata), "metadata"),
        }
        used = [RDTF_EXTENSION]
        ext: dict[str, Any] = {RDTF_EXTENSION: robot}
        if any(PHYSICS_EXTENSION in (n.extensions or {}) for n in self.b.gltf.nodes):
            used.append(PHYSICS_EXTENSION)
        if self.shapes:
            ext[SHAPES_EXTENSION] = {"shapes": self.shapes}
            used.append(SHAPES_EXTENSION)
        if self.joint_specs:
            ext[PHYSICS_EXTENSION] = {"physicsJoints": [json.loads(k) for k in self.joint_specs]}
        self.b.gltf.extensions = ext
        return self.b.finish(sorted(used))


def _x_to_axis(axis) -> Pose:
    """The rotation taking +x onto `axis` (identity for a zero axis)."""
    a = np.asarray(axis, dtype=float)
    n = float(np.linalg.norm(a))
    if not n > 1e-12:
        return Pose()
    rot, _ = Rotation.align_vectors([a / n], [[1.0, 0.0, 0.0]])
    return Pose((0.0, 0.0, 0.0), rot.as_quat())


def _joint_limits(joint: Joint) -> dict | None:
    """The physicsJoints entry of a URDF joint in a frame whose x is the joint axis:
    locked degrees of freedom as zero-range limits, the free one with the URDF limits,
    and the URDF damping as a drive towards zero velocity."""
    lock_linear = {"linearAxes": [0, 1, 2], "min": 0.0, "max": 0.0}
    lock_angular = {"angularAxes": [0, 1, 2], "min": 0.0, "max": 0.0}
    if joint.type == "fixed":
        return {"limits": [lock_linear, lock_angular]}
    if joint.type not in ("revolute", "continuous", "prismatic"):
        return None
    angular = joint.type != "prismatic"
    free = "angularAxes" if angular else "linearAxes"
    limits = [
        {"linearAxes": [1, 2] if not angular else [0, 1, 2], "min": 0.0, "max": 0.0},
        {"angularAxes": [1, 2] if angular else [0, 1, 2], "min": 0.0, "max": 0.0},
    ]
    if joint.type != "continuous" and joint.limit is not None:
        bound: dict[str, Any] = {free: [0]}
        if math.isfinite(joint.limit.lower):
            bound["min"] = float(joint.limit.lower)
        if math.isfinite(joint.limit.upper):
            bound["max"] = float(joint.limit.upper)
        if len(bound) > 1:
            limits.append(bound)
    spec: dict[str, Any] = {"limits": limits}
    damping = joint.dynamics.damping if joint.dynamics is not None else 0.0
    if damping > 0 and math.isfinite(damping):
        kind = "angular" if angular else "linear"
        drive = {"type": kind, "mode": "force", "axis": 0, "velocityTarget": 0.0}
        spec["drives"] = [{**drive, "damping": float(damping)}]
    return spec


def _has_volume(shape: Box | Cylinder | Sphere) -> bool:
    """Whether a primitive has positive, finite sizes (messy files have zeros)."""
    if isinstance(shape, Box):
        sizes = list(shape.size)
    elif isinstance(shape, Cylinder):
        sizes = [shape.radius, shape.length]
    else:
        sizes = [shape.radius]
    return all(math.isfinite(x) and x > 0 for x in sizes)


def _inertial_json(inertial: Inertial | None) -> dict | None:
    if inertial is None:
        return None
    return {
        "mass": _num(inertial.mass),
        "origin": _pose_json(inertial.origin),
        "ixx": _num(inertial.ixx),
        "ixy": _num(inertial.ixy),
        "ixz": _num(inertial.ixz),
        "iyy": _num(inertial.iyy),
        "iyz": _num(inertial.iyz),
        "izz": _num(inertial.izz),
    }


def _joint_json(j: Joint, node: int) -> dict:
    return {
        "name": j.name,
        "type": j.type,
        "parent": j.parent,
        "child": j.child,
        "node": node,
        "origin": _pose_json(j.origin),
        "axis": _nums(j.axis),
        "limit": None
        if j.limit is None
        else {
            "lower": _num(j.limit.lower),
            "upper": _num(j.limit.upper),
            "effort": _num(j.limit.effort),
            "velocity": _num(j.limit.velocity),
        },
        "dynamics": None
        if j.dynamics is None
        else {"damping": _num(j.dynamics.damping), "friction": _num(j.dynamics.friction)},
        "mimic": None
        if j.mimic is None
        else {
            "joint": j.mimic.joint,
            "multiplier": _num(j.mimic.multiplier),
            "offset": _num(j.mimic.offset),
        },
    }


def _sensor_json(s: Sensor) -> dict:
    return {
        "name": s.name,
        "type": s.type,
        "link": s.link,
        "origin": _pose_json(s.origin),
        "rate_hz": _num(s.rate_hz),
        "params": _plain(dict(s.params), f"sensor {s.name}.params"),
    }


def write_rdtf(model: RobotModel, path: str | Path | None = None) -> bytes:
    """The RDTF (.glb) bytes of `model`; also written to `path` when one is given."""
    data = _RobotWriter(model).write()
    if path is not None:
        Path(path).write_bytes(data)
    return data


# --- reading ------------------------------------------------------------------------


class _Reader:
    def __init__(self, doc: Mapping, blob: bytes, where: str) -> None:
        self.doc = doc
        self.blob = blob
        self.where = where
        self.mesh_cache: dict[int, MeshData] = {}

    def mesh_data(self, index: int) -> MeshData:
        if index not in self.mesh_cache:
            try:
                prim = self.doc["meshes"][index]["primitives"][0]
                vertices = accessor_array(self.doc, self.blob, prim["attributes"]["POSITION"])
                faces = accessor_array(self.doc, self.blob, prim["indices"])
            except (IndexError, KeyError, TypeError, ValueError) as exc:
                raise ModelError(f"{self.where}: mesh {index} cannot be read ({exc!r})") from None
            self.mesh_cache[index] = MeshData(
                vertices.astype(float), faces.astype(np.int64).reshape(-1, 3)
            )
        return self.mesh_cache[index]

    def shape(self, d: Mapping, where: str) -> Shape:
        kind = d.get("type")
        try:
            if kind == "box":
                return Box(tuple(float(v) for v in d["size"]))
            if kind == "cylinder":
                return Cylinder(float(d["radius"]), float(d["length"]))
            if kind == "sphere":
                return Sphere(float(d["radius"]))
            if kind == "mesh":
                if d.get("mesh") is not None:
                    data = self.mesh_data(int(d["mesh"]))
                elif "vertices" not in d:  # the file was unreadable when written
                    data = None
                else:
                    data = MeshData(
                        np.array([[float(x) for x in v] for v in d.get("vertices", [])]).reshape(
                            -1, 3
                        ),
                        np.array(d.get("faces", []), dtype=np.int64).reshape(-1, 3),
                    )
                return Mesh(str(d.get("filename", "")), tuple(float(v) for v in d["scale"]), data)
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"{self.where}: {where}: bad {kind} geometry ({exc})") from None
        raise ModelError(f"{self.where}: {where}: unknown geometry type {kind!r}")

    def link(self, d: Mapping) -> Link:
        name = str(d["name"])
        inertial = None
        if d.get("inertial") is not None:
            i = d["inertial"]
            inertial = Inertial(
                mass=float(i["mass"]),
                origin=_pose_from(i["origin"], f"{self.where}: link {name} inertial"),
                **{k: float(i[k]) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")},
            )
        visuals = tuple(
            Visual(
                geometry=self.shape(v["geometry"], f"link {name} visual {k}"),
                origin=_pose_from(v["origin"], f"{self.where}: link {name} visual {k}"),
                material=str(v.get("material", "")),
                name=str(v.get("name", "")),
            )
            for k, v in enumerate(d.get("visuals", []))
        )
        collisions = tuple(
            Collision(
                geometry=self.shape(c["geometry"], f"link {name} collision {k}"),
                origin=_pose_from(c["origin"], f"{self.where}: link {name} collision {k}"),
                name=str(c.get("name", "")),
            )
            for k, c in enumerate(d.get("collisions", []))
        )
        return Link(name, inertial, visuals, collisions)


def _joint_from(d: Mapping, where: str) -> Joint:
    lim, dyn, mim = d.get("limit"), d.get("dynamics"), d.get("mimic")
    return Joint(
        name=str(d["name"]),
        type=str(d["type"]),  # type: ignore[arg-type]
        parent=str(d["parent"]),
        child=str(d["child"]),
        origin=_pose_from(d["origin"], f"{where}: joint {d['name']}"),
        axis=tuple(float(v) for v in d["axis"]),  # type: ignore[arg-type]
        limit=None
        if lim is None
        else JointLimit(*(float(lim[k]) for k in ("lower", "upper", "effort", "velocity"))),
        dynamics=None
        if dyn is None
        else JointDynamics(float(dyn["damping"]), float(dyn["friction"])),
        mimic=None
        if mim is None
        else Mimic(str(mim["joint"]), float(mim["multiplier"]), float(mim["offset"])),
    )


def _sensor_from(d: Mapping, where: str) -> Sensor:
    return Sensor(
        name=str(d["name"]),
        type=str(d["type"]),  # type: ignore[arg-type]
        link=str(d["link"]),
        origin=_pose_from(d["origin"], f"{where}: sensor {d['name']}"),
        rate_hz=float(d["rate_hz"]),
        params=dict(d.get("params", {})),
    )


def rdtf_from_bytes(data: bytes, where: str = "RDTF") -> RobotModel:
    """A RobotModel from RDTF (.glb) bytes; `where` names the source in errors."""
    doc, blob = parse_glb(data, where)
    return _model_from_gltf(doc, blob, where)


def _model_from_gltf(doc: Mapping, blob: bytes, where: str) -> RobotModel:
    robot = (doc.get("extensions") or {}).get(RDTF_EXTENSION)
    if not isinstance(robot, Mapping):
        raise ModelError(
            f"{where}: a plain glTF file, not RDTF: it has no {RDTF_EXTENSION} extension"
        )
    version = robot.get("version")
    if version != RDTF_VERSION:
        raise ModelError(f"{where}: RDTF version {version!r}; this reader knows {RDTF_VERSION}")
    reader = _Reader(doc, blob, where)
    try:
        links = tuple(reader.link(d) for d in robot["links"])
        joints = tuple(_joint_from(d, where) for d in robot["joints"])
        sensors = tuple(_sensor_from(d, where) for d in robot.get("sensors", []))
        spheres = tuple(
            CollisionSphere(
                str(s["link"]),
                tuple(float(v) for v in s["center"]),  # type: ignore[arg-type]
                float(s["radius"]),
            )
            for s in robot.get("spheres", [])
        )
        materials = {
            str(m["key"]): Material(
                str(m["name"]),
                tuple(float(v) for v in m["rgba"]),  # type: ignore[arg-type]
                str(m.get("texture", "")),
            )
            for m in robot.get("materials", [])
        }
        return RobotModel(
            name=str(robot["name"]),
            links=links,
            joints=joints,
            materials=materials,
            sensors=sensors,
            spheres=spheres,
            tcp=str(robot.get("tcp", "")),
            metadata=dict(robot.get("metadata", {})),
            source=str(robot.get("source", "")),
            repairs=tuple(str(r) for r in robot.get("repairs", [])),
        )
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, ModelError):
            raise
        raise ModelError(
            f"{where}: {RDTF_EXTENSION} is incomplete or malformed ({exc!r})"
        ) from None


def read_rdtf(path: str | Path) -> RobotModel:
    """A RobotModel from an RDTF (.glb) file written by `write_rdtf`."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise ModelError(f"{p}: cannot read RDTF file ({exc.strerror})") from None
    if p.suffix.lower() == ".gltf" and data[:4] != b"glTF":
        return _model_from_gltf(*parse_gltf_json(data, p), str(p))
    return rdtf_from_bytes(data, str(p))
