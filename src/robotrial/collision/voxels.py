"""The planner's checker for scenes the depth camera made: many small boxes (layer 2).

A voxel scene holds hundreds of boxes (runs of voxels and slabs of table tops,
`onboard.voxels`) where a world file holds ten. The compiled checks take them as boxes
like any other obstacle (`CollisionChecker`); what does not scale is the set-up: which
shapes the arm's first links can never reach is found by sweeping those links against
every shape, one shape at a time. `VoxelChecker` gives the same table sooner: a box
farther from the middle of a link's sweep than the sweep reaches is out of its reach
without a look at each sphere, and only the boxes near the sweep are measured, all at
once. `TaskPlanner(checker=VoxelChecker)` plans with it.
"""

from __future__ import annotations

import numpy as np

from robotrial.collision import kernels
from robotrial.collision.sphere_model import OBJECT, CollisionChecker

CHUNK = 200_000  # point-box pairs per step, to bound the memory of one sweep


def box_gaps(points: np.ndarray, box_inv: np.ndarray, box_half: np.ndarray) -> np.ndarray:
    """(points, boxes) distance from each point (N, 3) to each box (inverse poses (B, 4, 4),
    half extents (B, 3)); 0 inside."""
    n_box = len(box_inv)
    out = np.empty((len(points), n_box))
    step = max(1, CHUNK // max(n_box, 1))
    rows = np.ascontiguousarray(box_inv[:, :3, :3].reshape(3 * n_box, 3).T)  # one GEMM
    shift = box_inv[:, :3, 3].reshape(-1)
    half = box_half.reshape(-1)
    for s in range(0, len(points), step):
        local = points[s : s + step] @ rows + shift
        d = np.maximum(np.abs(local) - half, 0.0).reshape(-1, n_box, 3)
        out[s : s + step] = np.sqrt(np.einsum("nbi,nbi->nb", d, d))
    return out


class VoxelChecker(CollisionChecker):
    """A `CollisionChecker` whose set-up measures against all boxes at once."""

    def _reachable_env(self) -> kernels.Shapes:
        if any(k != "box" for k in self.env.kinds):
            return super()._reachable_env()
        reach = self.robot.reach + self.padding + 1e-3
        for b in self.bodies:
            if b.name == OBJECT:
                reach += float(np.max(np.linalg.norm(b.centres, axis=1) + b.radii))
        if not len(self.env):
            return self.env.arrays([])
        inv = np.array([np.linalg.inv(m) for m in self.env.poses])
        half = np.array(self.env.dims)[:, :3]
        gaps = box_gaps(np.asarray(self.robot.origin, dtype=float)[None], inv, half)[0]
        return self.env.arrays(np.nonzero(gaps <= reach)[0].tolist())

    def _never_touching(self, env: kernels.Shapes, samples: int = 512) -> np.ndarray:
        n_box = len(env.box_inv)
        n_shapes = n_box + len(env.cyl_inv) + len(env.sph_c)
        if n_shapes == n_box == 0:
            return np.zeros((len(self.env_bodies), 0), dtype=bool)
        if n_shapes != n_box:  # other shapes too: the general way
            return super()._never_touching(env, samples)
        out = np.zeros((len(self.env_bodies), n_shapes), dtype=bool)
        rates = self._travel[0]
        for e, bi in enumerate(self.env_bodies):
            joints = np.nonzero(rates[bi] > 0)[0]
            if self.bodies[bi].name == OBJECT or not 1 <= len(joints) <= 2:
                continue
            pts, radii, margin = self.robot.sweep(
                self.bodies[bi], joints, rates[bi], self.padding, samples
            )
            # boxes beyond the sweep's bounding sphere are out of reach; the rest are
            # measured point by point
            centre = pts.mean(axis=0)
            bound = float(np.max(np.linalg.norm(pts - centre, axis=1) + radii)) + margin
            far = box_gaps(centre[None], env.box_inv, env.box_half)[0] > bound
            out[e, far] = True
            near = np.nonzero(~far)[0]
            if len(near):
                gaps = box_gaps(pts, env.box_inv[near], env.box_half[near])
                out[e, near] = np.min(gaps - radii[:, None], axis=0) > margin
        return out
