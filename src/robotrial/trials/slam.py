"""The SLAM trial: run GMapping- or Hector-class SLAM over a recording or the live
simulator, and score the map and trajectory against the world's ground truth (layer 5).

Scores (the platform paper's SLAM experiment, plus the usual trajectory metrics):

- map precision and recall of occupied cells with a one-cell tolerance: a map cell is
  right if a true occupied cell lies within one cell of it; a true surface cell (an
  occupied cell next to free space the robot could reach) is found if a map cell lies
  within one cell of it;
- room dimensions measured on the map (the distance between opposite walls' inner
  faces, found on the map alone) against the true interior (7.78 x 7.62 m in rooms A-C);
- ATE (RMSE of positions after the rigid alignment that fits best, Umeyama, as `evo_ape`
  with `--align`) and RPE (RMSE of the translation error of consecutive relative poses,
  as `evo_rpe` with delta 1 frame).

The map frame is the robot's base at the first scan; the true pose at that instant puts
the map in the world for the map scores.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from robotrial.model.gridmap import world_occupancy
from robotrial.model.world import World
from robotrial.slam.gmapping import GMappingSlam, OdometryRequired
from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.hector import HectorSlam
from robotrial.slam.params import GMappingParams, HectorParams
from robotrial.slam.scan import beams, relative, wrap

METHODS = ("gmapping", "hector")
SCAN_BAND = (-0.2, 0.5)  # sim.lidar.ScanConfig's default height band around the laser


@dataclass
class ScanSample:
    stamp: float
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float


@dataclass
class Recording:
    """What SLAM needs from a recording: scans, odometry and true poses (stamps, x, y,
    yaw), where the laser sits on the base (x, y, yaw) and how high."""

    scans: list[ScanSample]
    odom: np.ndarray
    truth: np.ndarray
    laser_pose: tuple[float, float, float]
    laser_height: float
    source: str = ""

    @property
    def duration(self) -> float:
        if len(self.scans) < 2:
            return 0.0
        return self.scans[-1].stamp - self.scans[0].stamp

    def odom_at(self, t: float) -> np.ndarray | None:
        return interpolate_poses(self.odom, t)

    def truth_at(self, t: float) -> np.ndarray | None:
        return interpolate_poses(self.truth, t)


def interpolate_poses(track: np.ndarray, t: float) -> np.ndarray | None:
    """Pose (x, y, yaw) at time t from rows (stamp, x, y, yaw), linear between samples;
    None outside the track."""
    if track.shape[0] == 0 or t < track[0, 0] - 1e-6 or t > track[-1, 0] + 1e-6:
        return None
    i = int(np.searchsorted(track[:, 0], t))
    if i <= 0:
        return track[0, 1:].copy()
    if i >= track.shape[0]:
        return track[-1, 1:].copy()
    a, b = track[i - 1], track[i]
    f = 0.0 if b[0] == a[0] else (t - a[0]) / (b[0] - a[0])
    return np.array(
        [a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]), wrap(a[3] + f * wrap(b[3] - a[3]))]
    )


def _yaw(q: Any) -> float:
    return float(np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))


def _matrix(tr: Any) -> np.ndarray:
    m = np.eye(4)
    r = tr.rotation
    m[:3, :3] = Rotation.from_quat([r.x, r.y, r.z, r.w]).as_matrix()
    m[:3, 3] = [tr.translation.x, tr.translation.y, tr.translation.z]
    return m


def laser_mount(static: dict[str, tuple[str, np.ndarray]], laser: str, base: str) -> np.ndarray:
    """4x4 pose of frame `laser` in frame `base` from static transforms (child ->
    (parent, matrix)); identity when they are the same frame."""
    m = np.eye(4)
    frame = laser
    seen = set()
    while frame != base:
        if frame not in static or frame in seen:
            raise ValueError(
                f"recording: no static transform chain from the scan frame {laser!r} to the "
                f"base frame {base!r} in /tf_static"
            )
        seen.add(frame)
        parent, t = static[frame]
        m = t @ m
        frame = parent
    return m


def load_recording(path: str | Path) -> Recording:
    """Scans, odometry, ground truth and the laser mount from a .mcap or .bag."""
    from robotrial.ros.playback import read_recording

    scans: list[ScanSample] = []
    odom: list[tuple[float, ...]] = []
    truth: list[tuple[float, ...]] = []
    static: dict[str, tuple[str, np.ndarray]] = {}
    scan_frame = None
    base_frame = None
    for topic, msg, _ in read_recording(path, ["/scan", "/odom", "/ground_truth", "/tf_static"]):
        if topic == "/scan":
            st = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            scan_frame = scan_frame or msg.header.frame_id
            scans.append(
                ScanSample(
                    st,
                    np.asarray(msg.ranges, dtype=np.float64),
                    float(msg.angle_min),
                    float(msg.angle_increment),
                    float(msg.range_min),
                    float(msg.range_max),
                )
            )
        elif topic in ("/odom", "/ground_truth"):
            st = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            p = msg.pose.pose
            row = (st, p.position.x, p.position.y, _yaw(p.orientation))
            (odom if topic == "/odom" else truth).append(row)
            base_frame = base_frame or msg.child_frame_id
        else:
            for tr in msg.transforms:
                static[tr.child_frame_id] = (tr.header.frame_id, _matrix(tr.transform))
    if not scans:
        raise ValueError(f"{path}: the recording has no /scan messages")
    mount = np.eye(4)
    if scan_frame and base_frame and scan_frame != base_frame:
        mount = laser_mount(static, scan_frame, base_frame)
    yaw = float(np.arctan2(mount[1, 0], mount[0, 0]))
    return Recording(
        scans=sorted(scans, key=lambda s: s.stamp),
        odom=np.array(sorted(odom), dtype=np.float64).reshape(-1, 4),
        truth=np.array(sorted(truth), dtype=np.float64).reshape(-1, 4),
        laser_pose=(float(mount[0, 3]), float(mount[1, 3]), yaw),
        laser_height=float(mount[2, 3]),
        source=str(path),
    )


def make_slam(method: str, params: dict[str, Any] | None = None) -> GMappingSlam | HectorSlam:
    """A SLAM object by method name, with ROS-named parameter overrides."""
    if method == "gmapping":
        return GMappingSlam(GMappingParams.from_dict(params))
    if method == "hector":
        return HectorSlam(HectorParams.from_dict(params))
    raise ValueError(f"unknown SLAM method {method!r}; choose from {', '.join(METHODS)}")


@dataclass
class SlamRun:
    """What a run produced: the map, the trajectory (stamps, poses in the map frame) and
    the processing time of every scan (s)."""

    method: str
    grid: LogOddsGrid
    stamps: np.ndarray
    poses: np.ndarray
    scan_times: np.ndarray
    wall_time: float
    duration: float
    map_bytes: int
    extra: dict[str, Any] = field(default_factory=dict)


def scan_beams(slam: GMappingSlam | HectorSlam, s: ScanSample, laser_pose) -> Any:
    return beams(
        s.ranges,
        s.angle_min,
        s.angle_increment,
        max(s.range_min, slam.min_range),
        min(s.range_max, slam.usable_range) if s.range_max > 0 else slam.usable_range,
        laser_pose,
    )


def run_slam(
    method: str,
    rec: Recording,
    params: dict[str, Any] | None = None,
    on_scan: Callable[[int], None] | None = None,
) -> SlamRun:
    """Run a method over every scan of a recording, as fast as it goes."""
    slam = make_slam(method, params)
    if slam.uses_odometry and rec.odom.shape[0] == 0:
        raise OdometryRequired(
            f"{rec.source or 'recording'}: gmapping needs odometry but the recording has no "
            "/odom messages; record /odom, or use --method hector (scans alone)"
        )
    times = np.zeros(len(rec.scans))
    wall0 = time.perf_counter()
    for i, s in enumerate(rec.scans):
        odom = rec.odom_at(s.stamp) if slam.uses_odometry else None
        if slam.uses_odometry and odom is None:
            times[i] = np.nan
            continue
        t0 = time.perf_counter()
        slam.process(scan_beams(slam, s, rec.laser_pose), s.stamp, odom)
        times[i] = time.perf_counter() - t0
        if on_scan is not None:
            on_scan(i)
    wall = time.perf_counter() - wall0
    stamps, poses = slam.trajectory()
    extra: dict[str, Any] = {}
    if isinstance(slam, GMappingSlam):
        nbytes = sum(m.logodds.nbytes for m in slam.maps)
        extra = {"updates": slam.updates, "resamples": slam.resamples}
    else:
        nbytes = slam.grid.logodds.nbytes
        extra = {"map_updates": slam.map_updates}
    return SlamRun(
        method,
        slam.grid,
        stamps,
        poses,
        times[~np.isnan(times)],
        wall,
        rec.duration,
        int(nbytes),
        extra,
    )


# --- trajectory metrics ------------------------------------------------------------------


def umeyama_2d(est: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (2x2) and translation that best map `est` (N, 2) onto `ref` (least
    squares, no scale)."""
    me, mr = est.mean(axis=0), ref.mean(axis=0)
    cov = (ref - mr).T @ (est - me) / est.shape[0]
    u, _, vt = np.linalg.svd(cov)
    s = np.eye(2)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[1, 1] = -1
    rot = u @ s @ vt
    return rot, mr - rot @ me


def ate(est: np.ndarray, ref: np.ndarray, align: bool = True) -> dict[str, float]:
    """Absolute trajectory error of positions (est, ref: (N, 3) x, y, yaw at the same
    stamps): RMSE, mean, max (m), after the best rigid alignment if `align`."""
    p = est[:, :2]
    if align and len(p) >= 2:
        rot, t = umeyama_2d(p, ref[:, :2])
        p = p @ rot.T + t
    err = np.linalg.norm(p - ref[:, :2], axis=1)
    return {
        "rmse": float(np.sqrt(np.mean(err**2))),
        "mean": float(err.mean()),
        "max": float(err.max()),
    }


def rpe(est: np.ndarray, ref: np.ndarray, delta: int = 1) -> dict[str, float]:
    """Relative pose error: RMSE and max of the translation (m) and rotation (rad) error
    of each relative motion over `delta` frames."""
    if len(est) <= delta:
        return {"rmse": 0.0, "max": 0.0, "rot_rmse": 0.0}
    t_err, r_err = [], []
    for i in range(len(est) - delta):
        de = relative(est[i], est[i + delta])
        dr = relative(ref[i], ref[i + delta])
        e = relative(dr, de)
        t_err.append(np.hypot(e[0], e[1]))
        r_err.append(abs(e[2]))
    t = np.asarray(t_err)
    return {
        "rmse": float(np.sqrt(np.mean(t**2))),
        "max": float(t.max()),
        "rot_rmse": float(np.sqrt(np.mean(np.square(r_err)))),
    }


def true_poses(rec: Recording, stamps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """True poses at `stamps` in the map frame (relative to the true pose at the first
    scan), and a mask of the stamps the ground truth covers."""
    if rec.truth.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(len(stamps), dtype=bool)
    start = rec.truth_at(rec.scans[0].stamp)
    out, ok = [], []
    for t in stamps:
        p = rec.truth_at(float(t))
        ok.append(p is not None and start is not None)
        if p is not None and start is not None:
            out.append(relative(start, p))
    return np.asarray(out).reshape(-1, 3), np.asarray(ok, dtype=bool)


# --- map metrics -------------------------------------------------------------------------


def _cell_centres(grid: LogOddsGrid, mask: np.ndarray) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    res = grid.resolution
    return np.stack(
        [grid.origin[0] + (cols + 0.5) * res, grid.origin[1] + (rows + 0.5) * res], axis=1
    )


def map_accuracy(
    grid: LogOddsGrid, map_in_world: np.ndarray, world: World, spawn_xy: tuple[float, float]
) -> dict[str, float]:
    """Precision and recall of the map's occupied cells against the world's ground truth
    with a one-cell tolerance (see the module docstring)."""
    occ = grid.ros_values() == 100
    res = grid.resolution
    lo = SCAN_BAND
    z0 = float(map_in_world[3]) if len(map_in_world) > 3 else 0.0
    gt = world_occupancy(world, res, (z0 + lo[0], z0 + lo[1]), include_objects=True)
    truth = gt.occupied
    near_truth = ndimage.binary_dilation(truth, np.ones((3, 3), bool))
    pose = map_in_world[:3]
    pts = _cell_centres(grid, occ)
    world_pts = np.empty_like(pts)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    world_pts[:, 0] = pose[0] + c * pts[:, 0] - s * pts[:, 1]
    world_pts[:, 1] = pose[1] + s * pts[:, 0] + c * pts[:, 1]
    rr = np.floor((world_pts[:, 1] - gt.origin[1]) / res).astype(int)
    cc = np.floor((world_pts[:, 0] - gt.origin[0]) / res).astype(int)
    inside = (rr >= 0) & (cc >= 0) & (rr < truth.shape[0]) & (cc < truth.shape[1])
    correct = np.zeros(len(pts), bool)
    correct[inside] = near_truth[rr[inside], cc[inside]]
    precision = float(correct.mean()) if len(pts) else 0.0

    # Surfaces the robot could see: occupied cells next to free space reachable from spawn.
    free = ~truth
    labels, _ = ndimage.label(free)
    sr, sc = gt.cell_of(*spawn_xy)
    reach = (
        labels == labels[sr, sc] if 0 <= sr < free.shape[0] and 0 <= sc < free.shape[1] else free
    )
    cross = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool)
    surface = truth & ndimage.binary_dilation(reach, cross)
    near_map = ndimage.binary_dilation(occ, np.ones((3, 3), bool))
    xs, ys = gt.cell_centers()
    sx, sy = xs[surface], ys[surface]
    dx, dy = sx - pose[0], sy - pose[1]
    mx = c * dx + s * dy
    my = -s * dx + c * dy
    r2 = np.floor((my - grid.origin[1]) / res).astype(int)
    c2 = np.floor((mx - grid.origin[0]) / res).astype(int)
    ok = (r2 >= 0) & (c2 >= 0) & (r2 < occ.shape[0]) & (c2 < occ.shape[1])
    found = np.zeros(len(sx), bool)
    found[ok] = near_map[r2[ok], c2[ok]]
    recall = float(found.mean()) if len(sx) else 0.0
    return {
        "precision": precision,
        "recall": recall,
        "occupied_cells": len(pts),
        "surface_cells": len(sx),
    }


def room_dimensions(grid: LogOddsGrid) -> tuple[float, float, float]:
    """(width along the room's x, depth along its y, yaw of the room's axes in the map)
    measured on the map alone: the room's axes are the rotation that makes occupied
    cells line up best; each wall's inner face is the mean of the occupied cells in the
    outermost dense row of cells on its side."""
    pts = _cell_centres(grid, grid.ros_values() == 100)
    if len(pts) < 20:
        raise ValueError("the map has too few occupied cells to measure a room")
    pts = pts - pts.mean(axis=0)

    def sharpness(a: float) -> float:
        c, s = np.cos(a), np.sin(a)
        x = c * pts[:, 0] + s * pts[:, 1]
        y = -s * pts[:, 0] + c * pts[:, 1]
        hx = np.bincount(np.floor((x - x.min()) / 0.02).astype(int))
        hy = np.bincount(np.floor((y - y.min()) / 0.02).astype(int))
        return float(np.sum(hx.astype(float) ** 2) + np.sum(hy.astype(float) ** 2))

    angles = np.deg2rad(np.arange(-45.0, 45.0, 0.5))
    best = angles[int(np.argmax([sharpness(a) for a in angles]))]
    fine = best + np.deg2rad(np.arange(-0.5, 0.5001, 0.02))
    best = float(fine[int(np.argmax([sharpness(a) for a in fine]))])
    c, s = np.cos(best), np.sin(best)
    x = c * pts[:, 0] + s * pts[:, 1]
    y = -s * pts[:, 0] + c * pts[:, 1]
    res = grid.resolution
    return _extent(x, y, res), _extent(y, x, res), best


def _extent(u: np.ndarray, v: np.ndarray, res: float) -> float:
    """Distance between the two outermost walls across u (walls run along v)."""
    edges = np.arange(u.min() - res, u.max() + 2 * res, res)
    hist, _ = np.histogram(u, edges)
    span = max(1.0, float(v.max() - v.min()))
    # A wall is a column of cells holding at least a third of the room's length.
    dense = np.nonzero(hist * res >= span / 3)[0]
    if len(dense) < 2:
        raise ValueError("could not find two opposite walls on the map")
    faces = []
    for k in (dense[0], dense[-1]):
        centre = 0.5 * (edges[k] + edges[k + 1])
        sel = np.abs(u - centre) <= 0.75 * res
        faces.append(float(u[sel].mean()))
    return faces[1] - faces[0]


def score(
    run: SlamRun,
    rec: Recording,
    world: World | None,
    true_size: tuple[float, float] | None = None,
) -> dict[str, Any]:
    """Map accuracy, room dimensions, ATE and RPE of a run (what can be scored: no world,
    no map scores; no ground truth, no trajectory scores)."""
    out: dict[str, Any] = {}
    ref, ok = true_poses(rec, run.stamps)
    if ref.shape[0] >= 2:
        est = run.poses[ok]
        out["ate"] = ate(est, ref)
        out["rpe"] = rpe(est, ref)
    start = rec.truth_at(rec.scans[0].stamp)
    if world is not None and start is not None:
        pose = np.array([*start, 0.0])
        spawn_xy = (float(start[0]), float(start[1]))
        z = rec.laser_height
        out["map"] = map_accuracy(run.grid, np.array([*pose[:3], z]), world, spawn_xy)
    if true_size is not None:
        try:
            w, d, yaw = room_dimensions(run.grid)
        except ValueError as exc:
            out["room"] = {"error": str(exc)}
        else:
            # The map's x may run along the room's y: pair each measure with the nearer.
            straight = abs(w - true_size[0]) + abs(d - true_size[1])
            crossed = abs(d - true_size[0]) + abs(w - true_size[1])
            pairs = (w, d) if straight <= crossed else (d, w)
            out["room"] = {
                "width": pairs[0],
                "depth": pairs[1],
                "true_width": true_size[0],
                "true_depth": true_size[1],
                "error": max(abs(pairs[0] - true_size[0]), abs(pairs[1] - true_size[1])),
                "axes_yaw_deg": float(np.rad2deg(yaw)),
            }
    times = run.scan_times
    out["time_per_scan_ms"] = {
        "mean": float(times.mean() * 1e3) if len(times) else 0.0,
        "p95": float(np.percentile(times, 95) * 1e3) if len(times) else 0.0,
        "max": float(times.max() * 1e3) if len(times) else 0.0,
    }
    out["scans"] = len(times)
    out["real_time_factor"] = run.duration / run.wall_time if run.wall_time > 0 else None
    out["map_memory_mb"] = run.map_bytes / 1e6
    out.update(run.extra)
    return out


def room_size(world: World) -> tuple[float, float] | None:
    """The interior size of a world (width, depth) when it is one rectangular room."""
    if world.interior is None:
        return None
    (x0, y0), (x1, y1) = world.interior
    return float(x1 - x0), float(y1 - y0)


def map_pose_in_world(rec: Recording) -> np.ndarray | None:
    """Where the map frame lies in the world: the true base pose at the first scan."""
    return rec.truth_at(rec.scans[0].stamp)


__all__ = [
    "METHODS",
    "Recording",
    "SlamRun",
    "ate",
    "load_recording",
    "make_slam",
    "map_accuracy",
    "room_dimensions",
    "rpe",
    "run_slam",
    "score",
]
