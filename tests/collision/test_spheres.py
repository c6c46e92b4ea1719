"""Sphere covers: every cover holds its whole shape, and no sphere bulges out far."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from robotrial.benchmarks.planning import panda_path
from robotrial.collision.spheres import (
    link_fine_spheres,
    link_spheres,
    shape_spheres,
)
from robotrial.geometry import Box, Cylinder, Mesh, MeshData, Sphere
from robotrial.model import load_robot


def _uncovered(points: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """The points no sphere holds."""
    d = np.linalg.norm(points[:, None] - centres[None], axis=-1)
    return points[~np.any(d <= radii[None] + 1e-9, axis=1)]


def _box_surface(size: np.ndarray, n: int = 4000) -> np.ndarray:
    """Random points on a box's faces, its edges and its corners."""
    rng = np.random.default_rng(0)
    half = np.asarray(size) / 2
    pts = rng.uniform(-1, 1, (n, 3))
    axis = rng.integers(0, 3, n)
    pts[np.arange(n), axis] = rng.choice([-1.0, 1.0], n)  # onto a face
    pts[: n // 4, (axis[: n // 4] + 1) % 3] = rng.choice([-1.0, 1.0], n // 4)  # onto an edge
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    return np.vstack([pts, corners]) * half


def _box_bulge(size, centres: np.ndarray, radii: np.ndarray) -> float:
    """How far any sphere may reach outside the box: radius minus its centre's depth."""
    depth = np.min(np.asarray(size) / 2 - np.abs(centres), axis=1)
    assert np.all(depth >= -1e-12), "a centre lies outside the box"
    return float(np.max(radii - depth))


size = st.floats(0.005, 0.5)


@settings(max_examples=25, deadline=None)
@given(sx=size, sy=size, sz=size)
def test_box_spheres_cover_the_box(sx: float, sy: float, sz: float) -> None:
    extent = np.array([sx, sy, sz])
    centres, radii = shape_spheres(Box(extent))
    assert 1 <= len(radii) <= 16
    rng = np.random.default_rng(1)
    inside = rng.uniform(-0.5, 0.5, (1000, 3)) * extent
    assert len(_uncovered(np.vstack([_box_surface(extent), inside]), centres, radii)) == 0
    # never much worse than one sphere around the whole box (the tolerance grows in
    # steps of 1.25)
    whole = np.linalg.norm(extent) / 2 - extent.min() / 2
    assert _box_bulge(extent, centres, radii) <= 1.25 * whole + 1e-9


def test_long_shapes_get_spheres_that_hug_them() -> None:
    # the old cell covers reached 24 mm past the ends of this box, 31 mm past the caps
    # of this cylinder
    extent = (0.04, 0.04, 0.12)
    centres, radii = shape_spheres(Box(extent))
    assert _box_bulge(extent, centres, radii) <= 0.012
    centres, radii = shape_spheres(Cylinder(0.04, 0.3))
    depth = np.minimum(0.04 - np.hypot(centres[:, 0], centres[:, 1]), 0.15 - np.abs(centres[:, 2]))
    assert np.max(radii - depth) <= 0.02


def test_a_thin_long_box_gets_small_spheres_along_it() -> None:
    # a finger: 1 x 1.2 x 4.5 cm
    extent = (0.012, 0.01, 0.045)
    centres, radii = shape_spheres(Box(extent))
    assert len(radii) > 2
    assert _box_bulge(extent, centres, radii) <= 0.008
    assert radii.max() < 0.013  # the old cell cover used one 13 mm sphere per third


@settings(max_examples=25, deadline=None)
@given(r=size, length=size)
def test_cylinder_spheres_cover_the_cylinder(r: float, length: float) -> None:
    centres, radii = shape_spheres(Cylinder(r, length))
    rng = np.random.default_rng(0)
    ang = rng.uniform(0, 2 * np.pi, 4000)
    rho = r * np.sqrt(rng.uniform(0, 1, 4000))
    rho[:1500] = r  # the side and the rims
    z = rng.uniform(-length / 2, length / 2, 4000)
    z[1000:2500] = rng.choice([-length / 2, length / 2], 1500)  # caps and rims
    pts = np.stack([rho * np.cos(ang), rho * np.sin(ang), z], axis=1)
    assert len(_uncovered(pts, centres, radii)) == 0
    depth = np.minimum(
        r - np.hypot(centres[:, 0], centres[:, 1]), length / 2 - np.abs(centres[:, 2])
    )
    assert np.all(depth >= -1e-12)
    whole = np.hypot(r, length / 2) - min(r, length / 2)
    assert np.max(radii - depth) <= 1.25 * whole + 1e-9


def _hull_depth(hull: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    offsets = np.einsum("ij,ij->i", hull.face_normals, hull.triangles[:, 0])
    return np.min(offsets[None] - points @ hull.face_normals.T, axis=1)


@pytest.mark.parametrize(
    ("subdivisions", "scale", "bulge"),
    [
        # a flat 20 x 10 x 40 cm ellipsoid: one sphere around it would reach out 15 cm
        (2, (1.0, 0.5, 2.0), 0.035),
        # 20480 faces, 12 x 8 x 24 cm (one sphere: 8 cm out): a patch of its surface
        # holds dozens of corners, held through the octagon around them
        (5, (0.6, 0.4, 1.2), 0.025),
    ],
)
def test_mesh_spheres_cover_the_hull_and_hug_it(subdivisions, scale, bulge) -> None:
    tm = trimesh.creation.icosphere(subdivisions=subdivisions, radius=0.1)
    tm.apply_scale(scale)
    centres, radii = shape_spheres(Mesh(data=MeshData(tm.vertices, tm.faces)))
    pts, _ = trimesh.sample.sample_surface(tm, 20000, seed=1)
    assert len(_uncovered(np.vstack([pts, tm.vertices]), centres, radii)) == 0
    depth = _hull_depth(tm, centres)
    assert np.all(depth >= -1e-9)
    assert np.max(radii - depth) < bulge
    centres, radii = shape_spheres(Sphere(0.2))
    assert radii[0] == 0.2 and np.all(centres == 0)


def test_non_convex_mesh_is_covered_through_its_hull() -> None:
    # an L of two boxes: MuJoCo collides the hull, so the corner between the arms counts
    a = trimesh.creation.box((0.2, 0.04, 0.04))
    b = trimesh.creation.box((0.04, 0.2, 0.04))
    a.apply_translation((0.08, 0, 0))
    b.apply_translation((0, 0.08, 0))
    tm = trimesh.util.concatenate([a, b])
    centres, radii = shape_spheres(Mesh(data=MeshData(tm.vertices, tm.faces)))
    hull = tm.convex_hull
    pts, _ = trimesh.sample.sample_surface(hull, 20000, seed=2)
    assert len(_uncovered(np.vstack([pts, hull.vertices]), centres, radii)) == 0


@pytest.fixture(scope="module")
def panda():
    return load_robot(panda_path())  # example-robot-data's Panda, with its meshes


def test_panda_links_get_tight_covers(panda) -> None:
    spheres = link_spheres(panda)
    per_link = Counter(s.link for s in spheres)
    assert max(per_link.values()) <= 12
    # the long middle links were one 14.5 cm sphere each: now several that hug the hull
    for name in ("panda_link3", "panda_link4"):
        assert per_link[name] >= 8
        link = next(lk for lk in panda.links if lk.name == name)
        (col,) = link.collisions
        hull = trimesh.load(col.geometry.filename, force="mesh").convex_hull
        centres = np.array([s.center for s in spheres if s.link == name])
        radii = np.array([s.radius for s in spheres if s.link == name])
        depth = _hull_depth(hull, centres)
        assert np.all(depth >= -1e-9)
        assert np.max(radii - depth) < 0.025
        pts, _ = trimesh.sample.sample_surface(hull, 20000, seed=3)
        assert len(_uncovered(np.vstack([pts, hull.vertices]), centres, radii)) == 0
    # the four boxes of a finger share one budget
    assert per_link["panda_leftfinger"] <= 12


def test_panda_fine_cover_holds_the_hull_and_bulges_less(panda) -> None:
    """The fine cover asked near obstacles: still the whole hull, but standing off it
    by under a centimetre where the coarse cover stands off two (links 5 and 6 of the
    Panda were called touching shelf boards their meshes clear)."""
    coarse, fine = link_spheres(panda), link_fine_spheres(panda)
    for name in ("panda_link5", "panda_link6"):
        link = next(lk for lk in panda.links if lk.name == name)
        (col,) = link.collisions
        hull = trimesh.load(col.geometry.filename, force="mesh").convex_hull
        pts, _ = trimesh.sample.sample_surface(hull, 20000, seed=4)
        bulge = {}
        for kind, cover in (("coarse", coarse), ("fine", fine)):
            centres = np.array([s.center for s in cover if s.link == name])
            radii = np.array([s.radius for s in cover if s.link == name])
            depth = _hull_depth(hull, centres)
            assert np.all(depth >= -1e-9)
            assert len(_uncovered(np.vstack([pts, hull.vertices]), centres, radii)) == 0
            bulge[kind] = float(np.max(radii - depth))
        assert bulge["fine"] < 0.01 < 0.015 < bulge["coarse"]


def test_bad_shapes_are_named() -> None:
    with pytest.raises(ValueError, match="box size"):
        shape_spheres(Box((0.1, 0.0, 0.1)))
    with pytest.raises(ValueError, match="cylinder"):
        shape_spheres(Cylinder(-0.1, 0.2))
    with pytest.raises(ValueError, match=r"no_such_mesh\.stl"):
        shape_spheres(Mesh(filename="/nonexistent/no_such_mesh.stl"))
    flat = MeshData(
        np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), [[0, 1, 2], [0, 2, 3]]
    )
    with pytest.raises(ValueError, match="flat"):
        shape_spheres(Mesh(data=flat))
    with pytest.raises(TypeError, match="no sphere cover"):
        shape_spheres("box")  # type: ignore[arg-type]
