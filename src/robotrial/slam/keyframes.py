"""A scan's pose against the raw scans of a SLAM's nodes, by point-to-line ICP (layer 3).

A grid map holds each wall at its cells, so a scan matched to it can sit up to half a
cell off wherever the walls it sees happen to fall inside their cells; at 2.5 cm cells
that is 1 cm or more at a work site. The nodes' own scans, at the nodes' poses, carry
no such rounding: matched to them point to line (each reference point with the normal
of its neighbours), a standing robot's pose is as good as the SLAM's trajectory there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from robotrial.slam.scan import transform_points

NEIGHBOURS = 6  # reference points that give each one its normal
FLAT = 0.1  # a neighbourhood is a line when its spread across is below this share along
REACH = 0.05  # m, scan points farther than this from the reference are left out
CAUCHY = 0.01  # m, the robust kernel's scale
ITERATIONS = 30


class Keyframes:
    """The hits of node scans (poses (N, 3), scans (N, 2) points each, base frame) near
    `centre` (within `radius` m), in the map frame, with their normals."""

    def __init__(
        self, poses: list[np.ndarray], scans: list[np.ndarray], centre: np.ndarray, radius: float
    ) -> None:
        pts = [
            transform_points(q, s)
            for q, s in zip(poses, scans, strict=True)
            if len(s) and np.hypot(q[0] - centre[0], q[1] - centre[1]) < radius
        ]
        self.points = np.concatenate(pts) if pts else np.zeros((0, 2))
        if len(self.points) < NEIGHBOURS:
            raise ValueError(f"keyframes: {len(self.points)} points within {radius} m")
        self.tree = cKDTree(self.points)
        _, idx = self.tree.query(self.points, k=NEIGHBOURS)
        near = self.points[idx]
        self.mean = near.mean(axis=1)
        d = near - self.mean[:, None, :]
        w, v = np.linalg.eigh(np.einsum("nki,nkj->nij", d, d))
        self.normal = v[:, :, 0]
        self.line = w[:, 0] < FLAT * w[:, 1]

    def match(self, hits: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, int]:
        """The pose (x, y, yaw) that puts `hits` ((N, 2), base frame) on the reference's
        lines, from `guess`; and how many points it used."""
        pose = np.asarray(guess, dtype=np.float64).copy()
        used = 0
        for _ in range(ITERATIONS):
            x = transform_points(pose, hits)
            dist, j = self.tree.query(x)
            keep = (dist < REACH) & self.line[j]
            used = int(keep.sum())
            if used < 10:
                break
            x, n, q = x[keep], self.normal[j[keep]], self.mean[j[keep]]
            r = np.einsum("ni,ni->n", x - q, n)
            turn = np.column_stack([-(x[:, 1] - pose[1]), x[:, 0] - pose[0]])
            jac = np.column_stack([n, np.einsum("ni,ni->n", turn, n)])
            w = 1.0 / (1.0 + (r / CAUCHY) ** 2)
            step = -np.linalg.solve(jac.T @ (jac * w[:, None]) + 1e-9 * np.eye(3), jac.T @ (w * r))
            pose += step
            if np.abs(step).max() < 1e-5:
                break
        return pose, used
