"""The arm's collision scene from the depth camera: a voxel occupancy map (layer 4).

As MoveIt's occupancy map monitor does, every depth frame first loses the points that
fall on the robot itself (`RobotBody`: its collision shapes at the joint readings, padded,
and an object it holds), then marks the voxels its points fall in and frees the voxels
it sees through (a stored voxel whose centre projects in front of the depth measured at
its pixel is empty now). The points of a support surface the detector found (a table
top) become a slab instead: cells of the surface's outline at the fitted plane's height,
5 cm thick, so the arm may come as close to a table top as the plane fit says and not a
voxel's edge closer. The map lives in the map frame, so what one look saw stays for the
next; the planner gets what lies within the arm's reach as boxes in the base frame
(`VoxelMap.boxes`): voxel runs and slab cells merged into larger boxes, so the compiled
checks test tens to a few hundred boxes instead of thousands of cubes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy import ndimage

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
from robotrial.kinematics.reference import link_poses
from robotrial.model.robot import RobotModel
from robotrial.onboard.camera import RgbdFrame
from robotrial.onboard.perception import Surface

RESOLUTION = 0.02  # m, voxel edge
SELF_PADDING = 0.03  # m, grown around the robot's own shapes before their points go
FLOOR = 0.03  # m, points lower than this are the floor (the planner has its own)
SEE_THROUGH = 0.03  # m, a voxel this far in front of the measured depth is free
SLAB_CELL = 0.04  # m, the cells of a support surface's slab
SLAB_DEPTH = 0.05  # m, a slab's thickness below the surface
ON_SURFACE = 0.015  # m: points this close to a surface's plane are the surface

Obstacles = list[tuple[str, Shape, Pose]]


def _local(shape: Shape) -> tuple[str, np.ndarray]:
    """A shape as a kind and half extents (box), radius and half length (cylinder) or
    radius (sphere); a mesh by its bounding box."""
    if isinstance(shape, Box):
        return "box", np.asarray(shape.size, dtype=float) / 2
    if isinstance(shape, Cylinder):
        return "cylinder", np.array([shape.radius, shape.length / 2])
    if isinstance(shape, Sphere):
        return "sphere", np.array([shape.radius])
    if isinstance(shape, Mesh) and shape.data is not None:
        v = np.asarray(shape.data.vertices) * np.asarray(shape.scale)
        return "box", np.maximum(np.abs(v.min(axis=0)), np.abs(v.max(axis=0)))
    raise ValueError(f"robot body: shape {type(shape).__name__} without data")


def inside(points: np.ndarray, kind: str, dims: np.ndarray, pose: np.ndarray, pad: float):
    """(N,) True where points (N, 3) lie within `pad` of a shape at `pose` (4x4)."""
    inv = np.linalg.inv(pose)
    p = points @ inv[:3, :3].T + inv[:3, 3]
    if kind == "box":
        return np.all(np.abs(p) <= dims + pad, axis=1)
    if kind == "cylinder":
        return (np.hypot(p[:, 0], p[:, 1]) <= dims[0] + pad) & (np.abs(p[:, 2]) <= dims[1] + pad)
    return np.linalg.norm(p, axis=1) <= dims[0] + pad


class RobotBody:
    """The robot's collision shapes, to cut its own body out of what its cameras see."""

    def __init__(self, model: RobotModel, padding: float = SELF_PADDING) -> None:
        self.model = model
        self.padding = float(padding)
        self.shapes = [
            (link.name, *_local(c.geometry), c.origin.matrix())
            for link in model.links
            for c in link.collisions
            if not isinstance(c.geometry, Mesh) or c.geometry.data is not None
        ]

    def mask(
        self,
        points: np.ndarray,
        joints: Mapping[str, float],
        held: Sequence[tuple[Shape, np.ndarray]] = (),
        padding: float | None = None,
    ) -> np.ndarray:
        """(N,) True where base-frame points fall on the robot at `joints` or on a held
        shape (shape, 4x4 pose in the base frame), grown by `padding` (default: the
        body's)."""
        pad = self.padding if padding is None else float(padding)
        poses = link_poses(self.model, dict(joints))
        placed = [(kind, dims, poses[link] @ origin) for link, kind, dims, origin in self.shapes]
        placed += [(*_local(shape), pose) for shape, pose in held]
        # only the points inside the box around every shape's bounding sphere are tested
        centres = np.array([pose[:3, 3] for _, _, pose in placed])
        reach = np.array([np.linalg.norm(dims) + pad for _, dims, _ in placed])
        lo, hi = (centres - reach[:, None]).min(axis=0), (centres + reach[:, None]).max(axis=0)
        near = np.nonzero(np.all((points >= lo) & (points <= hi), axis=1))[0]
        out = np.zeros(len(points), dtype=bool)
        sub = points[near]
        hit = np.zeros(len(sub), dtype=bool)
        for (kind, dims, pose), c, r in zip(placed, centres, reach, strict=True):
            close = np.nonzero(np.sum((sub - c) ** 2, axis=1) <= r * r)[0]
            if len(close):
                hit[close] |= inside(sub[close], kind, dims, pose, pad)
        out[near] = hit
        return out


class VoxelMap:
    """Occupied voxels in the map frame, made and cleared by depth frames."""

    def __init__(self, resolution: float = RESOLUTION) -> None:
        if not resolution > 0:
            raise ValueError(f"voxel map: resolution must be positive, got {resolution}")
        self.resolution = float(resolution)
        self.keys = np.zeros((0, 3), dtype=np.int64)
        self.slabs: dict[tuple[int, int], float] = {}  # slab cell (map) -> top height

    def __len__(self) -> int:
        return len(self.keys)

    def centres(self) -> np.ndarray:
        return (self.keys + 0.5) * self.resolution

    def integrate(
        self,
        frame: RgbdFrame,
        points: np.ndarray,
        base: np.ndarray,
        surfaces: Sequence[Surface] = (),
    ) -> None:
        """Add a frame's points (N, 3, base frame, the robot already cut out) taken with
        the base at `base` (x, y, yaw on the map): free what the frame sees through,
        mark what it hits; the points of `surfaces` (base frame) become slabs."""
        to_map = _planar(base)
        if len(self.keys):
            centres = self.centres()
            in_base = (centres - to_map[:3, 3]) @ to_map[:3, :3]
            u, v, z = frame.project(in_base)
            h, w = frame.depth.shape
            ok = np.isfinite(u) & (z > 0) & (u >= 0) & (u < w - 0.5) & (v >= 0) & (v < h - 0.5)
            free = np.zeros(len(centres), dtype=bool)
            idx = np.nonzero(ok)[0]
            measured = frame.depth[np.round(v[idx]).astype(int), np.round(u[idx]).astype(int)]
            free[idx] = np.isfinite(measured) & (z[idx] < measured - SEE_THROUGH)
            self.keys = self.keys[~free]
        on = np.zeros(len(points), dtype=bool)
        for surface in surfaces:
            if surface.height < FLOOR:
                continue
            mine = surface.covers(points[:, :2]) & (
                np.abs(points[:, 2] - surface.height_at(points[:, :2])) < ON_SURFACE
            )
            self._add_slab(points[mine], surface, to_map)
            on |= mine
        pts = points[(points[:, 2] >= FLOOR) & ~on]
        world = pts @ to_map[:3, :3].T + to_map[:3, 3]
        keys = np.floor(world / self.resolution).astype(np.int64)
        self.keys = np.unique(np.vstack([self.keys, keys]), axis=0)

    def _add_slab(self, points: np.ndarray, surface: Surface, to_map: np.ndarray) -> None:
        """The cells under a surface's points (holes where objects stand filled), at the
        plane's height."""
        if len(points) < 10:
            return
        world = points @ to_map[:3, :3].T + to_map[:3, 3]
        ij = np.floor(world[:, :2] / SLAB_CELL).astype(np.int64)
        lo = ij.min(axis=0) - 1
        grid = np.zeros(ij.max(axis=0) - lo + 2, dtype=bool)
        grid[ij[:, 0] - lo[0], ij[:, 1] - lo[1]] = True
        grid = ndimage.binary_fill_holes(ndimage.binary_closing(grid))
        cells = np.argwhere(grid) + lo
        centres = (cells + 0.5) * SLAB_CELL
        inv = np.linalg.inv(to_map)
        local = centres @ inv[:2, :2].T + inv[:2, 3]
        heights = surface.height_at(local)
        for (i, j), h in zip(cells.tolist(), heights.tolist(), strict=True):
            self.slabs[(i, j)] = max(h, self.slabs.get((i, j), -np.inf))

    def clear_body(
        self,
        body: RobotBody,
        base: np.ndarray,
        joints: Mapping[str, float],
        held: Sequence[tuple[Shape, np.ndarray]] = (),
        padding: float = 0.04,
    ) -> None:
        """Forget the voxels where the robot (and what it holds) is now, with the base at
        `base` (map): what stands there cannot be an obstacle (a piece of the robot, or
        of its load, the self filter missed)."""
        if not len(self.keys):
            return
        to_map = _planar(base)
        local = (self.centres() - to_map[:3, 3]) @ to_map[:3, :3]
        self.keys = self.keys[~body.mask(local, joints, held, padding)]

    def remove(self, centre: np.ndarray, radius: float, z: tuple[float, float]) -> None:
        """Forget the voxels in an upright cylinder (map frame): where an object was."""
        c = self.centres()
        gone = (np.hypot(c[:, 0] - centre[0], c[:, 1] - centre[1]) <= radius) & (
            (c[:, 2] >= z[0]) & (c[:, 2] <= z[1])
        )
        self.keys = self.keys[~gone]

    def boxes(
        self,
        base: np.ndarray,
        centre: np.ndarray,
        radius: float,
        keep_out: Sequence[tuple[np.ndarray, float, float, float]] = (),
    ) -> Obstacles:
        """The voxels within `radius` of `centre` (base frame: where the arm reaches
        from) with the base at `base` (x, y, yaw on the map) as boxes in the base frame:
        one-voxel gaps closed (depth noise leaves them in a surface), runs merged;
        `keep_out` cylinders (centre x, y in the base frame, radius, z from, z to) are
        left out (the object to grasp), of the voxels those whose centre lies inside, of
        the slabs the cells whose top does and whose square comes within the radius (the
        top an object stands on, when it is lifted off it)."""
        to_map = _planar(base)
        inb = (self.centres() - to_map[:3, 3]) @ to_map[:3, :3]
        near = np.linalg.norm(inb - np.asarray(centre), axis=1) <= radius
        for (cx, cy), r, z0, z1 in ((k[0][:2], k[1], k[2], k[3]) for k in keep_out):
            near &= ~(
                (np.hypot(inb[:, 0] - cx, inb[:, 1] - cy) <= r)
                & (inb[:, 2] >= z0)
                & (inb[:, 2] <= z1)
            )
        inv = np.linalg.inv(to_map)
        yaw = -float(base[2])
        out: Obstacles = []

        def add(name: str, centre_map: np.ndarray, size: np.ndarray) -> None:
            c = inv[:3, :3] @ centre_map + inv[:3, 3]
            pose = Pose.from_xyz_rpy(tuple(float(v) for v in c), (0.0, 0.0, yaw))
            out.append((f"{name}/{len(out)}", Box(tuple(float(v) for v in size)), pose))

        keys = closed(self.keys[near])
        res = self.resolution
        for lo, hi in merge_runs(keys) if len(keys) else []:
            add("voxels", (lo + hi + 1) * res / 2, (hi - lo + 1) * res)
        # slabs: cells of one height (to the cm) merged like voxels of one layer
        cells = np.array(list(self.slabs), dtype=np.int64).reshape(-1, 2)
        if len(cells):
            tops = np.array(list(self.slabs.values()))
            c = (cells + 0.5) * SLAB_CELL
            local = (np.column_stack([c, tops]) - to_map[:3, 3]) @ to_map[:3, :3]
            reach = np.linalg.norm(local - np.asarray(centre), axis=1) <= radius + SLAB_CELL
            for axis, r, z0, z1 in ((k[0], k[1], k[2], k[3]) for k in keep_out):
                # a cell goes when any of its square comes within r of the axis
                a = to_map[:2, :2] @ np.asarray(axis[:2], dtype=float) + to_map[:2, 3]
                off = np.maximum(np.abs(c - a) - SLAB_CELL / 2, 0.0)
                reach &= ~((np.hypot(off[:, 0], off[:, 1]) <= r) & (tops >= z0) & (tops <= z1))
            level = np.round(tops / 0.01).astype(np.int64)
            for lvl in np.unique(level[reach]):
                pick = reach & (level == lvl)
                top = float(np.max(tops[pick]))
                keys3 = np.column_stack([cells[pick], np.zeros(int(pick.sum()), dtype=np.int64)])
                for lo, hi in merge_runs(keys3):
                    xy = (lo[:2] + hi[:2] + 1) * SLAB_CELL / 2
                    size = np.array([*(hi[:2] - lo[:2] + 1) * SLAB_CELL, SLAB_DEPTH])
                    add("surface", np.array([xy[0], xy[1], top - SLAB_DEPTH / 2]), size)
        return out


def closed(keys: np.ndarray) -> np.ndarray:
    """Integer voxels (N, 3) with the one-voxel gaps between them filled (a
    morphological closing), so that a noisy surface merges into few boxes."""
    if not len(keys):
        return keys
    lo = keys.min(axis=0) - 2
    grid = np.zeros(keys.max(axis=0) - lo + 3, dtype=bool)
    k = keys - lo
    grid[k[:, 0], k[:, 1], k[:, 2]] = True
    grid |= ndimage.binary_closing(grid, structure=ndimage.generate_binary_structure(3, 1))
    return np.argwhere(grid) + lo


def merge_runs(keys: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Cover integer voxels (N, 3) with boxes (lowest and highest voxel, inclusive):
    runs along x, equal runs of neighbouring rows merged along y, then along z."""
    lo = keys.min(axis=0)
    grid = np.zeros(keys.max(axis=0) - lo + 1, dtype=bool)
    k = keys - lo
    grid[k[:, 0], k[:, 1], k[:, 2]] = True
    # runs along x in each (y, z) row
    runs: dict[tuple[int, int], list[tuple[int, int]]] = {}
    padded = np.zeros((grid.shape[0] + 2, grid.shape[1], grid.shape[2]), dtype=np.int8)
    padded[1:-1] = grid
    edges = np.diff(padded, axis=0)
    starts = np.argwhere(edges == 1)
    ends = np.argwhere(edges == -1)
    order_s = np.lexsort((starts[:, 0], starts[:, 1], starts[:, 2]))
    order_e = np.lexsort((ends[:, 0], ends[:, 1], ends[:, 2]))
    for (x0, y, z), (x1, _, _) in zip(starts[order_s], ends[order_e], strict=True):
        runs.setdefault((int(z), int(y)), []).append((int(x0), int(x1) - 1))
    # rows: equal runs in consecutive y merge into rectangles, per z
    rects: dict[int, dict[tuple[int, int, int], int]] = {}
    for z in sorted({z for z, _ in runs}):
        open_: dict[tuple[int, int], tuple[int, int]] = {}  # (x0, x1) -> (y0, y_last)
        done: dict[tuple[int, int, int], int] = {}
        for y in range(grid.shape[1] + 1):
            row = set(runs.get((z, y), []))
            for key in list(open_):
                if key not in row:
                    y0, y1 = open_.pop(key)
                    done[(key[0], key[1], y0)] = y1
            for key in row:
                if key in open_:
                    open_[key] = (open_[key][0], y)
                else:
                    open_[key] = (y, y)
        rects[z] = done
    # rectangles: equal ones in consecutive z merge into boxes
    out = []
    open_b: dict[tuple[int, int, int, int], int] = {}
    for z in range(grid.shape[2] + 1):
        layer = {(x0, x1, y0, y1) for (x0, x1, y0), y1 in rects.get(z, {}).items()}
        for key in list(open_b):
            if key not in layer:
                z0 = open_b.pop(key)
                out.append((np.array([key[0], key[2], z0]), np.array([key[1], key[3], z - 1])))
        for key in layer:
            open_b.setdefault(key, z)
    return [(a + lo, b + lo) for a, b in out]


def _planar(pose: np.ndarray) -> np.ndarray:
    """4x4 of a planar pose (x, y, yaw)."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    m[:2, 3] = pose[:2]
    return m
