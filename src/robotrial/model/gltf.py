"""glTF 2.0 binary files in general: building one (buffers, accessors, meshes,
materials) and reading one back (the JSON document, the binary chunk, accessor values).

Layer 1 (descriptions). Knows nothing of robots or worlds: `model/rdtf.py` (robots) and
`model/scene_gltf.py` (worlds) write their formats with `GltfBuilder` and read them
with `parse_glb` and `accessor_array`.
"""

from __future__ import annotations

import base64
import json
import math
import struct
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import numpy as np
import pygltflib
import trimesh

from robotrial.geometry import Box, Cylinder, Pose, Shape, Sphere
from robotrial.model.robot import ModelError

PHYSICS_EXTENSION = "KHR_physics_rigid_bodies"
SHAPES_EXTENSION = "KHR_implicit_shapes"
CYLINDER_SEGMENTS = 32
SPHERE_SUBDIVISIONS = 2
# glTF cylinders run along y; URDF cylinders along z. Rotating +90 deg about x maps y to z.
Y_TO_Z = Pose((0.0, 0.0, 0.0), (math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)))


# --- mesh data ----------------------------------------------------------------------


def primitive_triangles(shape: Shape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Display triangles (vertices, normals, faces) for a box, cylinder or sphere."""
    if isinstance(shape, Box):
        tm = trimesh.creation.box(extents=shape.size)
        tm = tm.copy()
        tm.unmerge_vertices()
    elif isinstance(shape, Cylinder):
        tm = trimesh.creation.cylinder(
            radius=shape.radius, height=shape.length, sections=CYLINDER_SEGMENTS
        ).smooth_shaded
    elif isinstance(shape, Sphere):
        tm = trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=shape.radius)
    else:
        raise TypeError(shape)
    return np.asarray(tm.vertices), np.asarray(tm.vertex_normals), np.asarray(tm.faces)


def _vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals; vertices with no area get +z."""
    n = np.zeros_like(vertices)
    if len(faces):
        tri = vertices[faces]
        fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        corners = faces.reshape(-1)
        for axis in range(3):
            weights = np.repeat(fn[:, axis], 3)
            n[:, axis] = np.bincount(corners, weights, minlength=len(vertices))
    length = np.linalg.norm(n, axis=1)
    bad = ~(length > 1e-20)
    n[bad] = (0.0, 0.0, 1.0)
    length[bad] = 1.0
    return n / length[:, None]


class GltfBuilder:
    """Collects buffer views, accessors, meshes and materials for one glTF file."""

    def __init__(self) -> None:
        self.gltf = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0", generator="robotrial"))
        self.blob = bytearray()
        self.material_index: dict[tuple, int] = {}
        self.mesh_index: dict[tuple, int] = {}

    def _view(self, data: bytes, target: int) -> int:
        while len(self.blob) % 4:
            self.blob.append(0)
        self.gltf.bufferViews.append(
            pygltflib.BufferView(
                buffer=0, byteOffset=len(self.blob), byteLength=len(data), target=target
            )
        )
        self.blob.extend(data)
        return len(self.gltf.bufferViews) - 1

    def _vec3_accessor(self, values: np.ndarray, with_bounds: bool) -> int:
        arr = np.ascontiguousarray(values, dtype=np.float32)
        view = self._view(arr.tobytes(), pygltflib.ARRAY_BUFFER)
        acc = pygltflib.Accessor(
            bufferView=view,
            componentType=pygltflib.FLOAT,
            count=len(arr),
            type=pygltflib.VEC3,
        )
        if with_bounds:
            acc.min = [float(v) for v in arr.min(axis=0)]
            acc.max = [float(v) for v in arr.max(axis=0)]
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1

    def _index_accessor(self, faces: np.ndarray, vertex_count: int) -> int:
        small = vertex_count <= 65535
        arr = np.ascontiguousarray(faces, dtype=np.uint16 if small else np.uint32).reshape(-1)
        view = self._view(arr.tobytes(), pygltflib.ELEMENT_ARRAY_BUFFER)
        self.gltf.accessors.append(
            pygltflib.Accessor(
                bufferView=view,
                componentType=pygltflib.UNSIGNED_SHORT if small else pygltflib.UNSIGNED_INT,
                count=len(arr),
                type=pygltflib.SCALAR,
            )
        )
        return len(self.gltf.accessors) - 1

    def material(self, name: str, rgba) -> int:
        key = (name, tuple(float(c) for c in rgba))
        if key not in self.material_index:
            r, g, b, a = (min(max(float(c), 0.0), 1.0) for c in rgba)
            self.gltf.materials.append(
                pygltflib.Material(
                    name=name or "default",
                    pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
                        baseColorFactor=[r, g, b, a], metallicFactor=0.0, roughnessFactor=0.7
                    ),
                    alphaMode=pygltflib.BLEND if a < 1.0 else pygltflib.OPAQUE,
                    doubleSided=False,
                )
            )
            self.material_index[key] = len(self.gltf.materials) - 1
        return self.material_index[key]

    def triangles(
        self, vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray | None = None
    ) -> tuple[int, int, int] | None:
        """Accessors (POSITION, NORMAL, indices) for a triangle mesh; None if it is empty.
        Vertices and faces are stored as given, so they read back unchanged."""
        vertices = np.asarray(vertices, dtype=float)
        faces = np.asarray(faces, dtype=np.int64)
        if len(vertices) == 0 or len(faces) == 0:
            return None
        if normals is None:
            normals = _vertex_normals(vertices, faces)
        else:
            normals = np.asarray(normals, dtype=float)
            length = np.linalg.norm(normals, axis=1)
            bad = ~(np.abs(length - 1.0) < 1e-3)
            normals = normals.copy()
            normals[bad] = (0.0, 0.0, 1.0)
        return (
            self._vec3_accessor(vertices, with_bounds=True),
            self._vec3_accessor(normals, with_bounds=False),
            self._index_accessor(faces, len(vertices)),
        )

    def mesh(self, name: str, accessors: tuple[int, int, int], material: int | None) -> int:
        """A glTF mesh with one triangle primitive over `accessors` (shareable)."""
        key = (accessors, material)
        if key not in self.mesh_index:
            pos, nrm, idx = accessors
            prim = pygltflib.Primitive(
                attributes=pygltflib.Attributes(POSITION=pos, NORMAL=nrm),
                indices=idx,
                mode=pygltflib.TRIANGLES,
            )
            if material is not None:
                prim.material = material
            self.gltf.meshes.append(pygltflib.Mesh(name=name, primitives=[prim]))
            self.mesh_index[key] = len(self.gltf.meshes) - 1
        return self.mesh_index[key]

    def node(self, name: str, pose: Pose = Pose(), **fields: Any) -> int:
        node = pygltflib.Node(name=name, **fields)
        if any(v != 0.0 for v in pose.xyz):
            node.translation = [float(v) for v in pose.xyz]
        if pose.quat != (0.0, 0.0, 0.0, 1.0):
            node.rotation = [float(v) for v in pose.quat]
        self.gltf.nodes.append(node)
        return len(self.gltf.nodes) - 1

    def finish(self, extensions_used: list[str]) -> bytes:
        """The GLB container: header, JSON chunk, and a BIN chunk when there is data."""
        self.gltf.extensionsUsed = extensions_used
        if self.blob:
            self.gltf.buffers = [pygltflib.Buffer(byteLength=len(self.blob))]
        doc = self.gltf.gltf_to_json(separators=(",", ":"), indent=None).encode("utf-8")
        doc += b" " * (-len(doc) % 4)
        chunks = [struct.pack("<II", len(doc), 0x4E4F534A), doc]
        if self.blob:
            binary = bytes(self.blob) + b"\0" * (-len(self.blob) % 4)
            chunks += [struct.pack("<II", len(binary), 0x004E4942), binary]
        body = b"".join(chunks)
        return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


# --- reading ------------------------------------------------------------------------


_COMPONENT_DTYPES = {
    pygltflib.FLOAT: np.float32,
    pygltflib.UNSIGNED_INT: np.uint32,
    pygltflib.UNSIGNED_SHORT: np.uint16,
    pygltflib.UNSIGNED_BYTE: np.uint8,
}
_TYPE_WIDTHS = {pygltflib.SCALAR: 1, pygltflib.VEC2: 2, pygltflib.VEC3: 3, pygltflib.VEC4: 4}


def parse_glb(data: bytes, where: str = "glTF") -> tuple[dict, bytes]:
    """The JSON document and the binary chunk of a glTF binary (.glb) file."""
    if len(data) < 20 or data[:4] != b"glTF":
        raise ModelError(f"{where}: not a glTF binary file (it does not start with 'glTF')")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2 or length > len(data):
        raise ModelError(f"{where}: not a glTF 2.0 binary file (version {version})")
    doc, blob, offset = None, b"", 12
    while offset + 8 <= length:
        size, kind = struct.unpack_from("<II", data, offset)
        chunk = data[offset + 8 : offset + 8 + size]
        if kind == 0x4E4F534A:
            try:
                doc = json.loads(chunk)
            except ValueError as exc:
                raise ModelError(f"{where}: the JSON chunk is not valid JSON ({exc})") from None
        elif kind == 0x004E4942:
            blob = chunk
        offset += 8 + size
    if not isinstance(doc, dict):
        raise ModelError(f"{where}: not a glTF binary file (no JSON chunk)")
    return doc, blob


def accessor_array(doc: Mapping, blob: bytes, index: int) -> np.ndarray:
    """The values of accessor `index` as an (count,) or (count, width) array."""
    acc = doc["accessors"][index]
    view = doc["bufferViews"][acc["bufferView"]]
    width = _TYPE_WIDTHS[acc["type"]]
    dtype = np.dtype(_COMPONENT_DTYPES[acc["componentType"]])
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", 0)
    count = acc["count"]
    if stride and stride != width * dtype.itemsize:
        raw = np.frombuffer(blob, np.uint8, count=stride * count, offset=start).reshape(count, -1)
        arr = raw[:, : width * dtype.itemsize].copy().view(dtype)
    else:
        arr = np.frombuffer(blob, dtype=dtype, count=count * width, offset=start)
    return arr.reshape(count, width) if width > 1 else arr.reshape(count)


def parse_gltf_json(data: bytes, path: Path) -> tuple[dict, bytes]:
    """The document and buffer 0 of a .gltf (JSON) file: the form other tools make when
    they re-save our .glb; the buffer is a data: URI or a file next to it."""
    try:
        doc = json.loads(data)
        buffers = doc.get("buffers") or []
        if not buffers:
            return doc, b""
        uri = buffers[0].get("uri", "")
        if uri.startswith("data:"):
            return doc, base64.b64decode(uri.split(",", 1)[1])
        return doc, (path.parent / unquote(uri)).read_bytes()
    except (ValueError, AttributeError, IndexError) as exc:
        raise ModelError(f"{path}: not a readable glTF file ({exc})") from None
    except OSError as exc:
        raise ModelError(f"{path}: its buffer file cannot be read ({exc})") from None
