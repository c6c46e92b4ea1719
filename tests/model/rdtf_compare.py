"""The round-trip contract of RDTF, checked field by field (the tests' comparison)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from robotrial.geometry import Mesh, Shape
from robotrial.model.meshes import load_mesh
from robotrial.model.robot import Collision, ModelError, RobotModel, Visual


def _with_triangles(shape: Shape) -> Shape:
    """A mesh shape with its file's triangles loaded, as an RDTF holds it."""
    if isinstance(shape, Mesh) and shape.data is None and shape.filename:
        try:
            return Mesh(shape.filename, shape.scale, load_mesh(shape, scaled=False))
        except ModelError:
            return shape
    return shape


def model_differences(original: RobotModel, other: RobotModel) -> list[str]:
    """Every field in which `other` differs from `original`, in words; [] if none.

    This is the round-trip contract of RDTF: poses, joints and inertials compare
    exactly; mesh triangles compare as MeshData (vertices within 1e-6); a mesh held
    lazily (`data` None) in `original` compares by its file's triangles; metadata and
    sensor parameters compare as JSON (tuples equal lists).
    """
    out: list[str] = []

    def check(what: str, a: Any, b: Any) -> None:
        if a != b:
            out.append(f"{what}: {a!r} != {b!r}"[:400])

    def as_json(value: Any, where: str) -> Any:
        return json.loads(json.dumps(value, default=lambda v: np.asarray(v).tolist()))

    check("name", original.name, other.name)
    check("link names", [lk.name for lk in original.links], [lk.name for lk in other.links])
    for la, lb in zip(original.links, other.links, strict=False):
        check(f"link {la.name} inertial", la.inertial, lb.inertial)
        check(f"link {la.name} visual count", len(la.visuals), len(lb.visuals))
        for k, (va, vb) in enumerate(zip(la.visuals, lb.visuals, strict=False)):
            va = Visual(_with_triangles(va.geometry), va.origin, va.material, va.name)
            for f in ("geometry", "origin", "material", "name"):
                check(f"link {la.name} visual {k} {f}", getattr(va, f), getattr(vb, f))
        check(f"link {la.name} collision count", len(la.collisions), len(lb.collisions))
        for k, (ca, cb) in enumerate(zip(la.collisions, lb.collisions, strict=False)):
            ca = Collision(_with_triangles(ca.geometry), ca.origin, ca.name)
            for f in ("geometry", "origin", "name"):
                check(f"link {la.name} collision {k} {f}", getattr(ca, f), getattr(cb, f))
    check("joint names", [j.name for j in original.joints], [j.name for j in other.joints])
    for ja, jb in zip(original.joints, other.joints, strict=False):
        check(f"joint {ja.name}", ja, jb)
    check("materials", dict(original.materials), dict(other.materials))
    check("sensor names", [x.name for x in original.sensors], [x.name for x in other.sensors])
    for sa, sb in zip(original.sensors, other.sensors, strict=False):
        for f in ("type", "link", "origin", "rate_hz"):
            check(f"sensor {sa.name} {f}", getattr(sa, f), getattr(sb, f))
        check(
            f"sensor {sa.name} params",
            as_json(dict(sa.params), "params"),
            as_json(dict(sb.params), "params"),
        )
    check("spheres", original.spheres, other.spheres)
    check("tcp", original.tcp, other.tcp)
    check(
        "metadata",
        as_json(dict(original.metadata), "metadata"),
        as_json(dict(other.metadata), "metadata"),
    )
    check("source", original.source, other.source)
    check("repairs", original.repairs, other.repairs)
    return out
