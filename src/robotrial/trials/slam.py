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

from robotrial.model.gridmap import world_occupancy
from robotrial.model.world import World
from robotrial.onboard.drive import RouteDrive
from robotrial.ros.slam_node import frame_in, odom_pose, planar, stamp_of, transform_matrix
from robotrial.sim.lidar import ScanConfig
from robotrial.slam.gmapping import GMappingSlam, OdometryRequired
from robotrial.slam.grid import LogOddsGrid
from robotrial.slam.hector import HectorSlam
from robotrial.slam.metrics import ate, cell_centres, room_dimensions, rpe
from robotrial.slam.params import GMappingParams, HectorParams, PoseGraphParams
from robotrial.slam.posegraph import PoseGraphSlam
from robotrial.slam.scan import beams, relative, wrap
from robotrial.slam.tiled import TiledGrid

METHODS = ("gmapping", "hector", "graph")
Slam = GMappingSlam | HectorSlam | PoseGraphSlam
# The height band (m, around the laser) the simulator flattens into the 2D scan.
SCAN_BAND = (ScanConfig.min_height, ScanConfig.max_height)


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
    # The odometry pose (N, 3) that came with each scan, when the recording holds one per
    # scan (a CARMEN log's laser lines); otherwise `odom` is interpolated at its stamp.
    scan_odom: np.ndarray | None = None

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


class RecordingBuilder:
    """Collects /scan, /odom, /ground_truth and /tf_static messages (from a file or the
    live bus) into a Recording."""

    def __init__(self, source: str = "") -> None:
        self.source = source
        self.scans: list[ScanSample] = []
        self.odom: list[tuple[float, float, float, float]] = []
        self.truth: list[tuple[float, float, float, float]] = []
        self.static: dict[str, tuple[str, np.ndarray]] = {}
        self.scan_frame: str | None = None
        self.base_frame: str | None = None

    def add(self, topic: str, msg: Any) -> None:
        if topic == "/scan":
            self.scan_frame = self.scan_frame or msg.header.frame_id
            self.scans.append(
                ScanSample(
                    stamp_of(msg.header),
                    np.asarray(msg.ranges, dtype=np.float64),
                    float(msg.angle_min),
                    float(msg.angle_increment),
                    float(msg.range_min),
                    float(msg.range_max),
                )
            )
        elif topic in ("/odom", "/ground_truth"):
            row = (stamp_of(msg.header), *odom_pose(msg))
            (self.odom if topic == "/odom" else self.truth).append(row)
            self.base_frame = self.base_frame or msg.child_frame_id
        elif topic == "/tf_static":
            for tr in msg.transforms:
                self.static[tr.child_frame_id] = (
                    tr.header.frame_id,
                    transform_matrix(tr.transform),
                )

    def build(self) -> Recording:
        if not self.scans:
            raise ValueError(f"{self.source or 'recording'}: there are no /scan messages")
        mount = np.eye(4)
        if self.scan_frame and self.base_frame and self.scan_frame != self.base_frame:
            try:
                mount = frame_in(self.static, self.scan_frame, self.base_frame)
            except ValueError as exc:
                raise ValueError(f"{self.source or 'recording'}: {exc}") from exc
        return Recording(
            scans=sorted(self.scans, key=lambda s: s.stamp),
            odom=np.array(sorted(self.odom), dtype=np.float64).reshape(-1, 4),
            truth=np.array(sorted(self.truth), dtype=np.float64).reshape(-1, 4),
            laser_pose=planar(mount),
            laser_height=float(mount[2, 3]),
            source=self.source,
        )


TOPICS = ("/scan", "/odom", "/ground_truth", "/tf_static")


def load_recording(path: str | Path) -> Recording:
    """Scans, odometry, ground truth and the laser mount from a .mcap or .bag."""
    from robotrial.ros.playback import read_recording

    builder = RecordingBuilder(str(path))
    for topic, msg, _ in read_recording(path, TOPICS):
        builder.add(topic, msg)
    return builder.build()


def make_slam(method: str, params: dict[str, Any] | None = None) -> Slam:
    """A SLAM object by method name, with ROS-named parameter overrides."""
    if method == "gmapping":
        return GMappingSlam(GMappingParams.from_dict(params))
    if method == "hector":
        return HectorSlam(HectorParams.from_dict(params))
    if method == "graph":
        return PoseGraphSlam(PoseGraphParams.from_dict(params))
    raise ValueError(f"unknown SLAM method {method!r}; choose from {', '.join(METHODS)}")


@dataclass
class SlamRun:
    """What a run produced: the map, the trajectory (stamps, poses in the map frame), the
    processing time of every scan (s, wall clock; `cpu_times` the thread's CPU time) and
    which scans updated the map."""

    method: str
    grid: LogOddsGrid | TiledGrid
    stamps: np.ndarray
    poses: np.ndarray
    scan_times: np.ndarray
    wall_time: float
    duration: float
    map_bytes: int
    extra: dict[str, Any] = field(default_factory=dict)
    cpu_times: np.ndarray | None = None
    updated: np.ndarray | None = None


def scan_beams(slam: Slam, s: ScanSample, laser_pose) -> Any:
    """A scan's beams in the base frame with the method's range limits."""
    low, top, usable = slam.range_limits(s.range_max)
    return beams(
        s.ranges,
        s.angle_min,
        s.angle_increment,
        max(s.range_min, low),
        min(s.range_max, usable) if s.range_max > 0 else usable,
        laser_pose,
        top,
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
    times = np.full(len(rec.scans), np.nan)
    cpu = np.full(len(rec.scans), np.nan)
    updated = np.zeros(len(rec.scans), bool)
    wall0 = time.perf_counter()
    for i, s in enumerate(rec.scans):
        odom = rec.scan_odom[i] if rec.scan_odom is not None else rec.odom_at(s.stamp)
        if not (slam.uses_odometry and odom is None):
            before = _updates(slam)
            t0, c0 = time.perf_counter(), time.thread_time()
            slam.process(scan_beams(slam, s, rec.laser_pose), s.stamp, odom)
            times[i], cpu[i] = time.perf_counter() - t0, time.thread_time() - c0
            updated[i] = _updates(slam) > before
        if on_scan is not None:
            on_scan(i)
    wall = time.perf_counter() - wall0
    ok = ~np.isnan(times)
    run = finish_run(method, slam, times[ok], wall, rec.duration)
    run.cpu_times = cpu[ok]
    run.updated = updated[ok]
    return run


def _updates(slam: Slam) -> int:
    return slam.updates if isinstance(slam, GMappingSlam) else slam.map_updates


def finish_run(method: str, slam: Slam, times: np.ndarray, wall: float, duration: float) -> SlamRun:
    """A SlamRun from a SLAM object that has seen its scans. A pose graph's back end is
    waited for and its pending closures optimised first; that wait (`settle_ms`) is not
    a scan's time: the scans were not held up by it."""
    settle_ms = 0.0
    if isinstance(slam, PoseGraphSlam):
        t0 = time.perf_counter()
        slam.settle()
        settle_ms = (time.perf_counter() - t0) * 1e3
        slam.close()
    stamps, poses = slam.trajectory()
    if isinstance(slam, GMappingSlam):
        nbytes = slam.map_bytes
        extra: dict[str, Any] = {"updates": slam.updates, "resamples": slam.resamples}
    elif isinstance(slam, PoseGraphSlam):
        nbytes = slam.grid.nbytes
        extra = {
            "map_updates": slam.map_updates,
            "nodes": len(slam.nodes),
            "closures": slam.closures,
            "closures_rejected": slam.rejected,
            "closures_removed": slam.removed,
            "loop_attempts": slam.loop_attempts,
            "optimizations": slam.optimizations,
            "correlative_searches": slam.searches,
            "optimize_ms_total": slam.optimize_time * 1e3,
            "backend_ms_total": slam.backend_time * 1e3,
            "background": slam.params.background,
            "lockstep": slam.params.lockstep,
            "settle_ms": settle_ms,
        }
    else:
        nbytes = slam.grid.nbytes
        extra = {"map_updates": slam.map_updates}
    return SlamRun(method, slam.grid, stamps, poses, times, wall, duration, int(nbytes), extra)


# Routes across each built-in room's workspace (world x, y in m), from its default spawn:
# a loop along the walls of rooms A and B, out and back around room C's partition, the
# living room and the kitchen of the apartment, and a tour of all five of its rooms.
ROUTES: dict[str, list[tuple[float, float]]] = {
    "room_a": [(6.6, 1.0), (6.6, 6.5), (1.2, 6.5), (1.0, 1.3), (2.5, 1.0)],
    "room_b": [(6.6, 1.0), (6.6, 6.5), (1.2, 6.5), (1.0, 1.3), (2.5, 1.0)],
    "room_c": [(6.4, 1.0), (6.4, 6.5), (1.2, 6.5), (6.4, 6.5), (6.4, 1.2), (1.5, 1.0)],
    "apartment": [
        (5.6, 3.2),
        (6.0, 2.5),
        (7.4, 2.5),
        (7.6, 3.4),
        (7.4, 2.5),
        (6.0, 2.5),
        (5.6, 3.2),
        (2.6, 3.2),
    ],
    # Every room of the apartment and back to the start: through the kitchen doorway,
    # up into the corridor, the study, west along the corridor, the bedroom, and down
    # into the living room. Turns on the spot happen where the base's 1.2 m turning
    # circle fits (at doorways, in rooms), never mid-corridor.
    "apartment_tour": [
        (5.6, 3.2),
        (6.0, 2.5),
        (7.4, 2.5),
        (8.3, 3.2),
        (8.5, 4.73),
        (6.5, 4.87),
        (6.5, 6.4),
        (6.5, 4.87),
        (2.6, 4.8),
        (2.2, 6.2),
        (2.6, 4.8),
        (2.6, 3.2),
        (3.0, 2.8),
    ],
}


def route_world(name: str) -> str:
    """The world a route named in ROUTES drives in ("apartment_tour" -> "apartment")."""
    if name not in ROUTES:
        raise ValueError(f"no SLAM route {name!r}; known: {', '.join(sorted(ROUTES))}")
    return name.removesuffix("_tour")


def record_drive(
    world: World | str,
    path: str | Path | None = None,
    duration: float = 30.0,
    side: float = 2.0,
    speed: float = 0.3,
    seed: int = 0,
    lidar_resolution_deg: float | None = None,
    robot: str = "mobile_manipulator",
    spawn: str = "default",
    on_step: Callable[[float], None] | None = None,
    extra_nodes: Callable[[Any], None] | None = None,
    route: list[tuple[float, float]] | None = None,
) -> Recording:
    """Drive the robot in the simulator and collect what SLAM needs (written to `path`,
    .mcap or .bag, when given): /scan, /odom, /ground_truth, /tf_static. The drive is
    `route` (waypoints, ending the run when reached, `duration` at most) or else an open
    loop square of `side` m. `extra_nodes(bus)` may attach nodes (a live SlamNode)."""
    from robotrial.model import load_robot, load_world
    from robotrial.ros.bus import Bus
    from robotrial.ros.recorder import BusRecorder, Recorder
    from robotrial.ros.sim_node import SimNode
    from robotrial.sim.drives import SquareDrive
    from robotrial.sim.simulation import SimOptions, Simulation, StreamSettings

    w = load_world(world) if isinstance(world, str) else world
    r = load_robot(robot)
    if lidar_resolution_deg is not None:
        sensors = tuple(
            type(s)(
                s.name,
                s.type,
                s.link,
                s.origin,
                s.rate_hz,
                dict(s.params, horizontal_resolution=float(np.deg2rad(lidar_resolution_deg))),
            )
            if s.type == "lidar"
            else s
            for s in r.sensors
        )
        r = r.with_changes(sensors=sensors)
    off = StreamSettings(enabled=False)
    streams = {s.name: off for s in r.sensors if s.type not in ("lidar",)}
    streams["joint_states"] = off
    sim = Simulation.create(
        w, r, seed=seed, spawn=spawn, options=SimOptions(cameras=False, streams=streams)
    )
    bus = Bus()
    node = SimNode(bus, sim)
    builder = RecordingBuilder(str(path or f"live {w.name}"))
    for topic in TOPICS:
        bus.subscribe(topic, lambda m, t=topic: builder.add(t, m))
    recorder = Recorder(path) if path is not None else None
    if recorder is not None:
        BusRecorder(bus, recorder, list(TOPICS))
    if extra_nodes is not None:
        extra_nodes(bus)
    square = SquareDrive(side, speed)
    follow = RouteDrive(route, speed) if route else None

    def command(t: float) -> tuple[float, float]:
        if follow is None:
            return square.command(t)
        v, yr = follow.command(*sim.world.base_pose2d())
        if follow.done:
            node.stop()
        return v, yr

    def step(t: float) -> None:
        sim.drive(*command(t))
        if on_step is not None:
            on_step(t)

    try:
        sim.drive(*command(0.0))
        node.run(duration, on_step=step)
    finally:
        if recorder is not None:
            recorder.close()
        sim.close()
        node.destroy()
    return builder.build()


def write_outputs(
    run: SlamRun, rec: Recording, world: World | None, stem: str | Path
) -> dict[str, str]:
    """STEM.pgm + STEM.yaml (map_server; where the recording holds the true poses, the
    YAML also says where the map frame lies in the world), STEM.tum (the trajectory, TUM
    format: stamp x y z qx qy qz qw, what evo reads) and STEM.png (the map, the estimated
    trajectory and the ground truth)."""
    from robotrial.model.mapfile import OccupancyMap, write_map

    stem = Path(stem)
    g = run.grid
    values = g.ros_values()
    frame = map_pose_in_world(rec)
    pgm, yml = write_map(
        stem,
        OccupancyMap(
            values,
            g.resolution,
            (*g.origin, 0.0),
            world.name if world is not None else None,
            None if frame is None else tuple(float(v) for v in frame),
        ),
    )
    tum = stem.with_name(stem.name + ".tum")
    with open(tum, "w") as f:
        for t, p in zip(run.stamps, run.poses, strict=True):
            f.write(
                f"{t:.6f} {p[0]:.6f} {p[1]:.6f} 0 0 0 {np.sin(p[2] / 2):.9f} "
                f"{np.cos(p[2] / 2):.9f}\n"
            )
    png = stem.with_name(stem.name + ".png")
    plot_map(run, rec, world, png, values)
    return {"pgm": str(pgm), "yaml": str(yml), "trajectory": str(tum), "png": str(png)}


PLOT_CELLS = 2400


def _shrunk(vals: np.ndarray, k: int) -> np.ndarray:
    """ROS map values with k x k cells a pixel: occupied if any of its cells is, else
    free if any is; a band of rows at a time (no copy of a large map)."""
    rows, cols = -(-vals.shape[0] // k), -(-vals.shape[1] // k)
    out = np.full((rows, cols), -1, dtype=np.int8)
    band = max(1, 1024 // k)
    for r0 in range(0, rows, band):
        part = vals[r0 * k : (r0 + band) * k]
        padded = np.full((-(-part.shape[0] // k) * k, cols * k), -1, dtype=np.int8)
        padded[: part.shape[0], : part.shape[1]] = part
        blocks = padded.reshape(-1, k, cols, k)
        out[r0 : r0 + blocks.shape[0]] = np.where(
            (blocks == 100).any(axis=(1, 3)), 100, np.where((blocks == 0).any(axis=(1, 3)), 0, -1)
        )
    return out


def plot_map(
    run: SlamRun,
    rec: Recording,
    world: World | None,
    png: Path,
    values: np.ndarray | None = None,
) -> None:
    """The map in its own frame, the true walls and path moved into that frame
    (`values`: the map's ROS values, when already at hand)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g = run.grid
    vals = g.ros_values() if values is None else values
    # A large map (a building, a campus) is drawn at most PLOT_CELLS cells a side.
    k = max(1, -(-max(vals.shape) // PLOT_CELLS))
    if k > 1:
        vals = _shrunk(vals, k)
    img = np.full(vals.shape, 0.8, dtype=np.float32)
    img[vals == 0] = 1.0
    img[vals == 100] = 0.0
    x0, y0, x1, y1 = g.extent()
    fig, ax = plt.subplots(figsize=(7, 7) if k == 1 else (12, 12))
    ax.imshow(img, cmap="gray", origin="lower", extent=(x0, x1, y0, y1), vmin=0, vmax=1)
    start = map_pose_in_world(rec)
    if start is not None and world is not None:
        gt = world_occupancy(
            world,
            g.resolution,
            (rec.laser_height + SCAN_BAND[0], rec.laser_height + SCAN_BAND[1]),
        )
        xs, ys = gt.cell_centers()
        pts = np.stack([xs[gt.occupied], ys[gt.occupied]], axis=1)
        c, s = np.cos(start[2]), np.sin(start[2])
        d = pts - start[:2]
        ax.scatter(
            c * d[:, 0] + s * d[:, 1],
            -s * d[:, 0] + c * d[:, 1],
            s=1.5,
            c="tab:red",
            alpha=0.35,
            label="true obstacles",
        )
    ref, _ = true_poses(rec, run.stamps)
    if len(ref):
        ax.plot(ref[:, 0], ref[:, 1], c="tab:green", lw=2, label="true path")
    if len(run.poses):
        ax.plot(run.poses[:, 0], run.poses[:, 1], c="tab:blue", lw=1, ls="--", label=run.method)
    ax.set_xlabel("x (m, map frame)")
    ax.set_ylabel("y (m, map frame)")
    ax.set_title(f"{run.method}: {Path(rec.source).name}")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)
    plt.close(fig)


# --- trajectory metrics ------------------------------------------------------------------


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


def map_accuracy(
    grid: LogOddsGrid | TiledGrid, map_in_world: np.ndarray, world: World, laser_height: float
) -> dict[str, float]:
    """Precision and recall of the map's occupied cells against the world's ground truth
    with a one-cell tolerance (see the module docstring). `map_in_world` is the map
    frame's pose (x, y, yaw) in the world, also where the robot started."""
    occ = grid.ros_values() == 100
    res = grid.resolution
    band = (laser_height + SCAN_BAND[0], laser_height + SCAN_BAND[1])
    gt = world_occupancy(world, res, band, include_objects=True)
    truth = gt.occupied
    near_truth = ndimage.binary_dilation(truth, np.ones((3, 3), bool))
    pose = np.asarray(map_in_world, dtype=np.float64)
    spawn_xy = (float(pose[0]), float(pose[1]))
    pts = cell_centres(grid, occ)
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
    start = map_pose_in_world(rec)
    if world is not None and start is not None:
        out["map"] = map_accuracy(run.grid, start, world, rec.laser_height)
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
    out["time_per_scan_ms"] = _ms(times)
    if run.cpu_times is not None:
        out["cpu_per_scan_ms"] = _ms(run.cpu_times)
    if run.updated is not None and run.updated.any():
        out["time_per_update_ms"] = _ms(times[run.updated])
        if run.cpu_times is not None:
            out["cpu_per_update_ms"] = _ms(run.cpu_times[run.updated])
    out["scans"] = len(times)
    out["real_time_factor"] = run.duration / run.wall_time if run.wall_time > 0 else None
    out["map_memory_mb"] = run.map_bytes / 1e6
    out.update(run.extra)
    return out


def _ms(times: np.ndarray) -> dict[str, float]:
    if len(times) == 0:
        return {"mean": 0.0, "p95": 0.0, "max": 0.0}
    return {
        "mean": float(times.mean() * 1e3),
        "p95": float(np.percentile(times, 95) * 1e3),
        "max": float(times.max() * 1e3),
    }


def room_size(world: World) -> tuple[float, float] | None:
    """The interior size of a world (width, depth) when it is one rectangular room."""
    if world.interior is None:
        return None
    (x0, y0), (x1, y1) = world.interior
    return float(x1 - x0), float(y1 - y0)


def map_pose_in_world(rec: Recording) -> np.ndarray | None:
    """Where the map frame lies in the world: the true base pose at the first scan."""
    return rec.truth_at(rec.scans[0].stamp)
