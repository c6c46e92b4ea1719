"""`robotrial bench sim`: how fast the simulator runs, and what each sensor costs (layer 5).

The mobile manipulator drives a square in room C. Real-time factor (simulated seconds per
wall second, and per CPU second of this process, which a busy machine disturbs less) for:
physics and controllers alone; plus odometry, ground truth and joint states; plus the
VLP-16 at 10 Hz and its 2D scan (the target: >= 20); plus the depth and RGB cameras.
Then the cost of each sensor alone (ms per reading and per simulated second), the
odometry drift over a 10 m drive (in the simulator, on an open floor) and the arm's
tracking error. The baseline is the seed
paper's Gazebo, which runs this platform near real time (factor 1).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

from robotrial.console import add_json_flag, emit, print_table, progress

HELP = "real-time factor of the mobile manipulator in room C, sensors off and on; sensor costs"

GAZEBO_RTF = 1.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--duration", type=float, default=10.0, help="simulated s per config")
    parser.add_argument(
        "--camera-duration",
        type=float,
        default=1.0,
        help="simulated s for the configuration with cameras",
    )
    parser.add_argument(
        "--lidar-resolution",
        type=float,
        nargs="+",
        default=[0.4, 0.2],
        metavar="DEG",
        help="LiDAR horizontal steps to measure",
    )
    parser.add_argument("--threads", type=int, default=1, help="LiDAR ray-casting threads")
    parser.add_argument("--seeds", type=int, default=10, help="runs of the 10 m odometry drive")
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    add_json_flag(parser)


def _robot(resolution_deg: float):
    from robotrial.model import load_robot

    robot = load_robot("mobile_manipulator")
    sensors = []
    for s in robot.sensors:
        if s.type == "lidar":
            params = dict(s.params, horizontal_resolution=math.radians(resolution_deg))
            s = type(s)(s.name, s.type, s.link, s.origin, s.rate_hz, params)
        sensors.append(s)
    return robot.with_changes(sensors=tuple(sensors))


def _sim(resolution_deg: float, streams: dict, cameras: bool, threads: int):
    from robotrial.sim.simulation import SimOptions, Simulation, StreamSettings

    opts = SimOptions(
        cameras=cameras,
        lidar_threads=threads,
        streams={k: StreamSettings(enabled=v) for k, v in streams.items()},
    )
    return Simulation.create("room_c", _robot(resolution_deg), options=opts)


def _run(sim, duration: float) -> dict:
    from robotrial.sim.drives import SquareDrive

    drive = SquareDrive(2.0, 0.5)
    sim.start()
    steps = round(duration / sim.control_dt)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        sim.drive(*drive.command(sim.world.time))
        sim.control_step()
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    sim_time = steps * sim.control_dt
    return {
        "sim_s": sim_time,
        "wall_s": wall,
        "rtf_wall": sim_time / wall,
        "rtf_cpu": sim_time / cpu,
    }


def _run_recorded(sim, duration: float) -> dict:
    """The sim node on a bus with every topic recorded to MCAP (what `robotrial sim
    --record` does)."""
    import tempfile

    from robotrial.ros.bus import Bus
    from robotrial.ros.recorder import BusRecorder, Recorder
    from robotrial.ros.sim_node import SimNode
    from robotrial.sim.drives import SquareDrive

    drive = SquareDrive(2.0, 0.5)
    bus = Bus()
    node = SimNode(bus, sim)
    topics = sorted({t for t, _ in node.topics.values()} | {"/tf", "/tf_static"})
    with tempfile.TemporaryDirectory() as tmp:
        rec = Recorder(Path(tmp) / "bench.mcap")
        BusRecorder(bus, rec, topics)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        node.run(duration, on_step=lambda t: sim.drive(*drive.command(t)))
        rec.close()
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    sim_time = sim.world.time
    return {
        "sim_s": sim_time,
        "wall_s": wall,
        "rtf_wall": sim_time / wall,
        "rtf_cpu": sim_time / cpu,
    }


def _sensor_costs(resolution_deg: float, threads: int) -> list[dict]:
    """ms per reading of each stream alone, at the robot's rates."""
    sim = _sim(resolution_deg, {}, True, threads)
    sim.start()
    sim.drive(0.3, 0.1)
    sim.advance(0.2)
    out = []
    for s in sim.streams:
        n = 3 if s.kind == "image" else 20
        s.read(sim.world.time)
        t0 = time.process_time()
        for _ in range(n):
            s.read(sim.world.time)
        ms = (time.process_time() - t0) / n * 1e3
        rate = 1.0 / s.period
        out.append(
            {"stream": s.name, "rate_hz": rate, "ms_per_reading": ms, "ms_per_sim_s": ms * rate}
        )
    sim.close()
    return out


def _drift(seeds: int = 10) -> dict:
    """Odometry vs ground truth after a 10 m straight drive at 0.5 m/s on an open floor
    (the rooms are 7.8 m across), default slip, one run per seed."""
    from robotrial.geometry import Pose
    from robotrial.model.world import Floor, World
    from robotrial.sim.drives import StraightDrive
    from robotrial.sim.simulation import SimOptions, Simulation, StreamSettings

    off = StreamSettings(enabled=False)
    world = World(name="open_floor", floor=Floor(size=(30.0, 30.0)))
    drive = StraightDrive(10.0, 0.5)
    errors = []
    for seed in range(seeds):
        opts = SimOptions(cameras=False, streams={"velodyne": off, "imu": off})
        sim = Simulation.create(
            world,
            "mobile_manipulator",
            seed=seed,
            spawn=Pose.from_xy_yaw(-6.0, 0.0, 0.0),
            options=opts,
        )
        sim.start()
        while sim.world.time < 22.0:
            sim.drive(*drive.command(sim.world.time))
            sim.control_step()
        truth, odom = sim.latest["ground_truth"].data, sim.latest["odom"].data
        errors.append(math.hypot(truth.x - (-6.0 + odom.x), truth.y - odom.y))
        sim.close()
    return {
        "distance_m": 10.0,
        "mean_m": float(np.mean(errors)),
        "max_m": float(np.max(errors)),
        "percent": float(np.mean(errors)) / 10.0 * 100,
    }


def _arm_tracking() -> dict:
    from robotrial.sim.controllers import JointReference

    sim = _sim(0.4, {"velodyne": False}, False, 1)
    arm = list(sim.robot.metadata.get("groups", {}).get("arm", sim.arm_joints[:6]))
    q0 = np.array([sim.joint_values()[n] for n in arm])
    t = np.linspace(0, 4.0, 81)
    shape = 0.5 * (1 - np.cos(2 * np.pi * t / 4.0))
    dshape = 0.5 * (2 * np.pi / 4.0) * np.sin(2 * np.pi * t / 4.0)
    amp = 0.5 * np.resize([1.0, -1.0, 1.0], len(arm))
    ref = JointReference(arm, t, q0 + amp * shape[:, None], amp * dshape[:, None])
    sim.follow(ref)
    err = []
    for _ in range(round(4.0 / sim.control_dt)):
        sim.control_step()
        q = np.array([sim.joint_values()[n] for n in arm])
        err.append(q - ref.sample(sim.world.time)[0])
    e = np.asarray(err)
    return {
        "joints": len(arm),
        "rms_rad": float(np.sqrt(np.mean(e**2))),
        "max_rad": float(np.abs(e).max()),
    }


def run(args: argparse.Namespace) -> int:
    configs = [
        (
            "physics + controllers",
            {
                "odom": False,
                "ground_truth": False,
                "joint_states": False,
                "imu": False,
                "velodyne": False,
            },
            False,
        ),
        ("+ odometry, ground truth, joints", {"imu": False, "velodyne": False}, False),
        ("+ VLP-16 10 Hz + scan", {"imu": False}, False),
        ("+ sim node on the bus, MCAP recording", {"imu": False}, False),
        ("+ IMU, depth and RGB cameras", {}, True),
    ]
    rows = []
    total = len(configs) * len(args.lidar_resolution) + 2
    with progress("bench sim", total=total, enabled=not args.json) as advance:
        for res in args.lidar_resolution:
            for label, streams, cameras in configs:
                sim = _sim(res, streams, cameras, args.threads)
                if label.startswith("+ sim node"):
                    r = _run_recorded(sim, args.duration)
                else:
                    r = _run(sim, args.camera_duration if cameras else args.duration)
                sim.close()
                rows.append({"config": label, "lidar_deg": res, **r})
                advance()
        costs = _sensor_costs(args.lidar_resolution[0], args.threads)
        advance()
        drift = _drift(args.seeds)
        tracking = _arm_tracking()
        advance()
    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, no GPU (osmesa)",
        "date": time.strftime("%Y-%m-%d"),
        "baseline_gazebo_rtf": GAZEBO_RTF,
        "rtf": rows,
        "sensor_costs": costs,
        "odometry_drift_10m": drift,
        "arm_tracking": tracking,
    }
    if emit(result, args):
        return 0
    print_table(
        "real-time factor, mobile manipulator in room C (Gazebo: ~1)",
        ["configuration", "lidar step (deg)", "sim s", "RTF wall", "RTF cpu"],
        [(r["config"], r["lidar_deg"], r["sim_s"], r["rtf_wall"], r["rtf_cpu"]) for r in rows],
    )
    print_table(
        f"cost of each stream alone (lidar step {args.lidar_resolution[0]} deg)",
        ["stream", "rate (Hz)", "ms per reading", "ms per sim s"],
        [(c["stream"], c["rate_hz"], c["ms_per_reading"], c["ms_per_sim_s"]) for c in costs],
    )
    print_table(
        "accuracy",
        ["figure", "value"],
        [
            (f"odometry drift after a 10 m drive (mean of {args.seeds} seeds, m)", drift["mean_m"]),
            ("odometry drift after a 10 m drive (worst seed, m)", drift["max_m"]),
            (f"arm tracking RMS ({tracking['joints']} joints, rad)", tracking["rms_rad"]),
            ("arm tracking max (rad)", tracking["max_rad"]),
        ],
    )
    return 0
