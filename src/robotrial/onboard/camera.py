"""RGB-D frames from sensor_msgs images: pixels to arrays, depth to points (layer 4).

A frame is a depth image (metres, NaN where nothing returned), the colour image taken
from the same optical frame (an RGB-D unit), the pinhole intrinsics from CameraInfo and
where the optical frame was in the robot's base frame when the frame was taken (the
robot's own kinematics: /tf_static and the joint states).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robotrial.msgs.sensor_msgs import CameraInfo, Image


def image_array(msg: Image) -> np.ndarray:
    """The pixels of an rgb8 (H, W, 3 uint8) or 32FC1 (H, W float32) image."""
    if msg.encoding == "rgb8":
        return np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.width, 3)
    if msg.encoding == "32FC1":
        dtype = ">f4" if msg.is_bigendian else "<f4"
        return np.frombuffer(bytes(msg.data), dtype).reshape(msg.height, msg.width)
    raise ValueError(f"image encoding {msg.encoding!r}: expected rgb8 or 32FC1")


def intrinsics(info: CameraInfo) -> tuple[float, float, float, float]:
    """fx, fy, cx, cy (pixels) of a pinhole camera."""
    k = info.k
    return float(k[0]), float(k[4]), float(k[2]), float(k[5])


@dataclass
class RgbdFrame:
    """One RGB-D frame: depth (H, W) in m, colour (H, W, 3) or None, intrinsics, the
    optical frame in the base frame (4x4), the stamp (s)."""

    depth: np.ndarray
    rgb: np.ndarray | None
    k: tuple[float, float, float, float]
    camera: np.ndarray
    stamp: float

    @property
    def viewpoint(self) -> np.ndarray:
        """The camera's position in the base frame."""
        return self.camera[:3, 3]

    def points(self, stride: int = 1) -> tuple[np.ndarray, np.ndarray | None]:
        """(N, 3) points in the base frame and their colours (N, 3) uint8 (or None)."""
        d = self.depth[::stride, ::stride]
        fx, fy, cx, cy = self.k
        ok = np.isfinite(d)
        z = d[ok]
        rows, cols = np.nonzero(ok)
        x = (cols * stride - cx).astype(np.float32) / np.float32(fx) * z
        y = (rows * stride - cy).astype(np.float32) / np.float32(fy) * z
        rot = self.camera[:3, :3].astype(np.float32)
        pts = (np.column_stack([x, y, z]) @ rot.T).astype(float) + self.camera[:3, 3]
        colours = None
        if self.rgb is not None and self.rgb.shape[:2] == self.depth.shape:
            colours = self.rgb[::stride, ::stride][ok]
        return pts, colours

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel columns, rows and depths (m along the optical axis) of base-frame
        points (N, 3)."""
        inv = np.linalg.inv(self.camera)
        local = np.asarray(points) @ inv[:3, :3].T + inv[:3, 3]
        fx, fy, cx, cy = self.k
        z = local[:, 2]
        safe = np.where(z > 1e-6, z, np.nan)
        return fx * local[:, 0] / safe + cx, fy * local[:, 1] / safe + cy, z
