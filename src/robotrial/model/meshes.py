"""Mesh files to triangles: STL, OBJ, DAE (through pycollada), PLY, OFF and glTF via trimesh.

Layer 1. The URDF loader only resolves where a mesh file is (`Mesh.filename`); the
triangles are read on first use by `load_mesh`, which caches them per file, so a robot
whose meshes nobody looks at loads fast.
"""

from __future__ import annotations

import io
import re
import threading
from pathlib import Path

import numpy as np

from robotrial.geometry import Mesh, MeshData
from robotrial.model.robot import ModelError

# file suffixes trimesh reads into triangles
MESH_SUFFIXES: frozenset[str] = frozenset({".stl", ".obj", ".dae", ".ply", ".off", ".glb", ".gltf"})

_cache: dict[tuple[str, int, int], MeshData] = {}
_lock = threading.Lock()


def mesh_format_supported(filename: str | Path) -> bool:
    """Whether `load_mesh` can read a file with this name (by its suffix)."""
    return Path(str(filename)).suffix.lower() in MESH_SUFFIXES


_DAE_COUNT = re.compile(
    rb"<(triangles|polylist|polygons|tristrips|trifans)\b[^>]*?\bcount\s*=\s*[\"'](\d+)"
)
_PLY_FACES = re.compile(rb"^element\s+face\s+(\d+)", re.M)


def triangle_count(path: str | Path) -> int:
    """How many triangles a mesh file holds, read from its headers or counted in its
    text without building the mesh (polygons count as one): what a server checks before
    it spends memory on a file someone sent. 0 for a format it cannot tell."""
    p = Path(path)
    suffix = p.suffix.lower()
    try:
        size = p.stat().st_size
        with open(p, "rb") as f:
            if suffix == ".stl":
                head = f.read(84)
                n = int.from_bytes(head[80:84], "little") if len(head) == 84 else 0
                if 84 + 50 * n == size:
                    return n
                return (head + f.read()).count(b"endfacet")
            data = f.read()
    except OSError:
        return 0
    if suffix == ".obj":
        return data.count(b"\nf ") + data.startswith(b"f ")
    if suffix == ".dae":
        return sum(int(m.group(2)) for m in _DAE_COUNT.finditer(data))
    if suffix == ".ply":
        m = _PLY_FACES.search(data[:4096])
        return int(m.group(1)) if m else 0
    if suffix == ".off":
        lines = [ln for ln in data[:4096].splitlines() if ln.strip() and not ln.startswith(b"#")]
        parts = (lines[1] if lines and lines[0].strip() == b"OFF" else b"").split()
        return int(parts[1]) if len(parts) > 1 and parts[1].isdigit() else 0
    return 0


def forget(folder: str | Path) -> None:
    """Drop the cached triangles of every file under `folder` (an upload removed)."""
    root = str(Path(folder).resolve())
    with _lock:
        for key in [k for k in _cache if k[0].startswith(root + "/")]:
            del _cache[key]


def read_mesh_file(path: str | Path) -> MeshData:
    """The triangles of a mesh file, in the file's own units and frame (cached per file).

    A file holding several parts (a DAE or glTF scene) gives one mesh with every part
    placed by the scene's transforms. ModelError if the file cannot be read or is empty.
    """
    p = Path(path)
    try:
        st = p.stat()
    except OSError as exc:
        raise ModelError(f"mesh file {str(p)!r}: {exc.strerror or exc}") from exc
    key = (str(p.resolve()), st.st_mtime_ns, st.st_size)
    with _lock:
        hit = _cache.get(key)
    if hit is not None:
        return hit
    data = _read(p)
    with _lock:
        _cache[key] = data
    return data


def _read(p: Path) -> MeshData:
    if not mesh_format_supported(p):
        raise ModelError(
            f"mesh file {str(p)!r}: format {p.suffix!r} is not supported "
            f"(supported: {', '.join(sorted(MESH_SUFFIXES))})"
        )
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise ModelError(f"mesh file {str(p)!r}: {exc.strerror or exc}") from exc
    suffix = p.suffix.lower()
    vertices, faces = _triangles(data, suffix, p)
    if suffix == ".dae":
        if len(faces) == 0:
            # a broken material reference makes pycollada drop the whole geometry
            # instance; materials do not matter for triangles, so read without them
            vertices, faces = _triangles(_DAE_BIND_MATERIAL.sub(b"", data), suffix, p)
        vertices = vertices * _dae_unit(data)
    if len(vertices) == 0 or len(faces) == 0:
        raise ModelError(f"mesh file {str(p)!r} holds no triangles")
    if not np.all(np.isfinite(vertices)):
        raise ModelError(f"mesh file {str(p)!r} has non-finite vertex coordinates")
    return MeshData(vertices, faces)


_DAE_BIND_MATERIAL = re.compile(rb"<bind_material>.*?</bind_material>", re.S)
_DAE_UNIT = re.compile(rb"<unit\b[^>]*\bmeter\s*=\s*[\"']([^\"']+)[\"']")


def _dae_unit(data: bytes) -> float:
    """Metres per unit of a COLLADA file (its <asset><unit meter=...>), 1 if not given."""
    head = data[: data.find(b"</asset>") + 1 or 8192]
    m = _DAE_UNIT.search(head)
    try:
        unit = float(m.group(1)) if m else 1.0
    except ValueError:
        return 1.0
    return unit if np.isfinite(unit) and unit > 0 else 1.0


def _triangles(data: bytes, suffix: str, p: Path) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    try:
        loaded = trimesh.load(
            io.BytesIO(data),
            file_type=suffix.lstrip("."),
            force="mesh",
            process=False,
            resolver=trimesh.resolvers.FilePathResolver(str(p)),
        )
    except Exception as exc:  # trimesh and pycollada raise many kinds
        raise ModelError(f"mesh file {str(p)!r} cannot be read: {exc}") from exc
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=float)
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), dtype=np.int64)
    return vertices.reshape(-1, 3), faces.reshape(-1, 3)


def load_mesh(mesh: Mesh, scaled: bool = True) -> MeshData:
    """The triangles of a Mesh shape: its `data` if held, else read from `filename`.

    With `scaled` (the default) the vertices are multiplied by `mesh.scale`, giving the
    shape as it sits in its link (a mirroring scale also reverses the triangles'
    winding, so normals still point out); `scaled=False` gives the file's own
    coordinates.
    """
    if mesh.data is not None:
        raw = mesh.data
    elif mesh.filename:
        raw = read_mesh_file(mesh.filename)
    else:
        raise ModelError("mesh shape has neither a file name nor triangles")
    if not scaled or mesh.scale == (1.0, 1.0, 1.0):
        return raw
    scale = np.asarray(mesh.scale)
    # a mirroring scale turns the triangles inside out; reverse them to keep normals outward
    faces = raw.faces[:, ::-1] if np.prod(scale) < 0 else raw.faces
    return MeshData(raw.vertices * scale, faces)


def mesh_bounds(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the scaled mesh's axis-aligned bounding box."""
    v = load_mesh(mesh).vertices
    return v.min(axis=0), v.max(axis=0)


def clear_cache() -> None:
    """Forget every mesh read so far (files are read again on next use)."""
    with _lock:
        _cache.clear()


__all__ = [
    "MESH_SUFFIXES",
    "clear_cache",
    "load_mesh",
    "mesh_bounds",
    "mesh_format_supported",
    "read_mesh_file",
]
