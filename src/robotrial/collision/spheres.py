"""Sphere approximations of shapes: the planner's view of a robot's links (layer 2).

Every sphere set COVERS its shape (never cuts a corner), so a configuration the spheres
call free is free for the exact shapes too; that keeps the planner's answers valid
under MuJoCo's exact check. Boxes and cylinders are cut into near-cubic cells, one
sphere per cell; spheres are themselves; meshes are covered through their convex hull
(what MuJoCo collides with), clustered in cells of the hull's surface points.
"""

from __future__ import annotations

import numpy as np

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
from robotrial.model.robot import CollisionSphere, RobotModel


def _cells(extent: np.ndarray, max_cells: int) -> np.ndarray:
    """Number of cells along each axis of a box with full `extent`, cells near-cubic."""
    counts = np.ones(3, dtype=int)
    while int(np.prod(counts)) < max_cells:
        cell = extent / counts
        i = int(np.argmax(cell))
        if cell[i] <= 1.6 * np.min(extent / counts):  # cells are already near-cubic
            break
        counts[i] += 1
    return counts


def box_spheres(size, max_spheres: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Centres (n, 3) and radii (n,) of spheres covering a box centred at the origin.

    The box is cut into cells as thick as its smallest edge across, about as wide along
    its middle edge, and thin (half the smallest edge) along its longest edge, so each
    sphere hugs the cross-section rather than a cube around it.
    """
    extent = np.asarray(size, dtype=float)
    order = np.argsort(extent)
    s0, s1, s2 = extent[order]
    k1 = max(round(float(s1) / max(float(s0), 1e-9)), 1)
    k2 = max(int(np.ceil(s2 / max(0.5 * s0, 1e-9))), 1)
    while k1 * k2 > max_spheres and k2 > 1:
        k2 -= 1
    while k1 * k2 > max_spheres and k1 > 1:
        k1 -= 1
    counts = np.ones(3, dtype=int)
    counts[order[1]], counts[order[2]] = k1, k2
    cell = extent / counts
    axes = [(-extent[i] / 2 + cell[i] * (np.arange(counts[i]) + 0.5)) for i in range(3)]
    centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    radius = 0.5 * float(np.linalg.norm(cell))
    return centres, np.full(len(centres), radius)


def cylinder_spheres(
    radius: float, length: float, max_spheres: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """Spheres covering a cylinder along z centred at the origin.

    A long cylinder gets one sphere per thin slice (half a radius thick, so each sphere
    is barely wider than the cylinder); a flat one (a disc) gets a grid of square cells
    as wide as it is thick, keeping the cells that meet the disc.
    """
    if length >= radius:
        n = int(np.clip(np.ceil(2 * length / max(radius, 1e-6)), 1, max_spheres))
        h = length / n
        z = -length / 2 + h * (np.arange(n) + 0.5)
        centres = np.zeros((n, 3))
        centres[:, 2] = z
        return centres, np.full(n, float(np.hypot(radius, h / 2)))
    cell = max(length, 1e-6)
    while True:
        k = int(np.ceil(2 * radius / cell))
        grid = -k * cell / 2 + cell * (np.arange(k) + 0.5)
        x, y = np.meshgrid(grid, grid, indexing="ij")
        # distance from the disc's axis to the nearest point of each cell
        near = np.hypot(np.maximum(np.abs(x) - cell / 2, 0), np.maximum(np.abs(y) - cell / 2, 0))
        keep = near <= radius
        if keep.sum() <= max_spheres:
            break
        cell *= 1.25
    centres = np.stack([x[keep], y[keep], np.zeros(int(keep.sum()))], axis=1)
    r = 0.5 * float(np.sqrt(2 * cell * cell + length * length))
    return centres, np.full(len(centres), r)


def point_spheres(points: np.ndarray, max_spheres: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Spheres covering a point cloud: the points' bounding box cut into near-cubic
    cells; one sphere per occupied cell, centred on its points, reaching the farthest."""
    pts = np.asarray(points, dtype=float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    extent = np.maximum(hi - lo, 1e-6)
    counts = _cells(extent, max_spheres)
    idx = np.minimum(((pts - lo) / extent * counts).astype(int), counts - 1)
    key = (idx[:, 0] * counts[1] + idx[:, 1]) * counts[2] + idx[:, 2]
    centres, radii = [], []
    for k in np.unique(key):
        cell_pts = pts[key == k]
        c = 0.5 * (cell_pts.min(axis=0) + cell_pts.max(axis=0))
        centres.append(c)
        radii.append(float(np.max(np.linalg.norm(cell_pts - c, axis=1))))
    return np.array(centres), np.array(radii)


def _hull_points(mesh: Mesh) -> np.ndarray:
    """Points on the surface of a mesh's (scaled) convex hull, dense enough to cover it."""
    import trimesh

    if mesh.data is not None:
        tm = trimesh.Trimesh(mesh.data.vertices, mesh.data.faces, process=False)
    else:
        loaded = trimesh.load(mesh.filename, force="mesh")
        tm = loaded if isinstance(loaded, trimesh.Trimesh) else loaded.to_mesh()
    tm.apply_scale(np.asarray(mesh.scale))
    hull = tm.convex_hull
    rng = np.random.default_rng(0)
    pts, _ = trimesh.sample.sample_surface(hull, 3000, seed=int(rng.integers(1 << 31)))
    return np.vstack([hull.vertices, pts])


def shape_spheres(shape: Shape, max_spheres: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Spheres (centres in the shape's frame, radii) that cover `shape`."""
    if isinstance(shape, Sphere):
        return np.zeros((1, 3)), np.array([float(shape.radius)])
    if isinstance(shape, Box):
        return box_spheres(shape.size, max_spheres)
    if isinstance(shape, Cylinder):
        return cylinder_spheres(shape.radius, shape.length, max_spheres)
    if isinstance(shape, Mesh):
        pts = _hull_points(shape)
        centres, radii = point_spheres(pts, max_spheres)
        # surface samples leave gaps between them; widen each sphere by the sample spacing
        area = np.ptp(pts, axis=0)
        spacing = float(
            np.sqrt(2 * (area[0] * area[1] + area[1] * area[2] + area[0] * area[2]) / len(pts))
        )
        return centres, radii + spacing
    raise TypeError(f"no sphere cover for shape {shape!r}")


def link_spheres(model: RobotModel, max_per_shape: int = 16) -> list[CollisionSphere]:
    """Spheres covering every collision shape of every link, in the links' frames."""
    out: list[CollisionSphere] = []
    for link in model.links:
        for col in link.collisions:
            centres, radii = shape_spheres(col.geometry, max_per_shape)
            m = col.origin.matrix()
            world = centres @ m[:3, :3].T + m[:3, 3]
            out.extend(
                CollisionSphere(link.name, tuple(map(float, c)), float(r))  # type: ignore[arg-type]
                for c, r in zip(world, radii, strict=True)
            )
    return out


def pose_spheres(shape: Shape, pose: Pose, max_spheres: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Spheres covering `shape` placed at `pose`: centres in the pose's parent frame."""
    centres, radii = shape_spheres(shape, max_spheres)
    m = pose.matrix()
    return centres @ m[:3, :3].T + m[:3, 3], radii
