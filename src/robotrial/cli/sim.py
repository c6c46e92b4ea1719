"""`robotrial sim`: run a robot in a world headless, drive it, record, summarize (layer 5).

    robotrial sim --world room_c --robot mobile_manipulator --duration 60 \\
        --drive square --record run.mcap

prints (or with --json emits) simulated time, wall time, real-time factor, messages per
topic and the odometry drift; `--plot PNG` writes ground truth vs odometry.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from robotrial.cli.robot_source import add_robot_source_arguments, load_robot_from_args
from robotrial.cli.zenoh_options import add_zenoh_arguments, zenoh_bridge
from robotrial.console import add_json_flag, console, print_json, print_table, progress

HELP = "simulate a robot in a world headless (LiDAR, scan, odometry, cameras), record a bag"

KEYS_HELP = "w/s: faster/slower  a/d: turn left/right  space: stop  q: quit"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", default="room_c", help="built-in world name or YAML file")
    add_robot_source_arguments(parser, default="mobile_manipulator")
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument(
        "--drive",
        choices=("square", "keys", "none"),
        default=None,
        help="scripted square (default for a mobile robot), keyboard teleop, "
        "or standing still (default for an arm)",
    )
    parser.add_argument("--side", type=float, default=2.0, help="side of the square (m)")
    parser.add_argument("--speed", type=float, default=0.5, help="driving speed (m/s)")
    parser.add_argument("--spawn", default="default", help="spawn pose name in the world")
    parser.add_argument("--seed", type=int, default=0, help="seed of all sensor noise")
    parser.add_argument("--record", metavar="FILE", help="write a .mcap (ROS 2) or .bag (ROS 1)")
    parser.add_argument("--plot", metavar="PNG", help="ground truth vs odometry plot")
    parser.add_argument(
        "--compression",
        choices=("lz4", "zstd", "none"),
        default="lz4",
        help="chunk compression of the recording (default lz4; zstd is smaller, .bag: lz4/none)",
    )
    parser.add_argument(
        "--realtime",
        type=float,
        metavar="X",
        default=None,
        help="pace at X times real time (default: as fast as possible)",
    )
    parser.add_argument(
        "--cameras",
        action="store_true",
        help="render the depth and RGB cameras (slow without a GPU)",
    )
    parser.add_argument(
        "--lidar-resolution",
        type=float,
        metavar="DEG",
        help="override the LiDAR's horizontal step (0.1 to 0.4 deg)",
    )
    parser.add_argument(
        "--foxglove-port",
        type=int,
        default=0,
        metavar="PORT",
        help="serve the topics live over the Foxglove WebSocket protocol on this port "
        "(e.g. 8765; paced at real time unless --realtime says otherwise; default 0: off)",
    )
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address the Foxglove server listens on (default 127.0.0.1: this computer only)",
    )
    add_zenoh_arguments(parser)
    add_json_flag(parser)


def _options(args: argparse.Namespace, robot):
    from robotrial.sim.simulation import SimOptions

    if args.lidar_resolution is not None:
        if not 0 < args.lidar_resolution <= 5:
            raise ValueError(
                f"--lidar-resolution must be in (0, 5] deg, got {args.lidar_resolution}"
            )
        sensors = []
        for s in robot.sensors:
            if s.type == "lidar":
                params = dict(s.params, horizontal_resolution=math.radians(args.lidar_resolution))
                s = type(s)(s.name, s.type, s.link, s.origin, s.rate_hz, params)
            sensors.append(s)
        robot = robot.with_changes(sensors=tuple(sensors))
    return robot, SimOptions(cameras=args.cameras)


class KeyTeleop:
    """Reads single keys from the terminal without blocking (raw mode while active)."""

    def __init__(self, max_speed: float, max_yaw_rate: float) -> None:
        if not sys.stdin.isatty():
            raise ValueError("--drive keys needs an interactive terminal")
        import termios
        import tty

        self._fd = sys.stdin.fileno()
        self._saved = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)
        self.v = 0.0
        self.w = 0.0
        self.quit = False
        self.dv, self.dw = max_speed / 5, max_yaw_rate / 5

    def poll(self) -> tuple[float, float]:
        import select

        while select.select([sys.stdin], [], [], 0)[0]:
            k = sys.stdin.read(1)
            if k == "w":
                self.v += self.dv
            elif k == "s":
                self.v -= self.dv
            elif k == "a":
                self.w += self.dw
            elif k == "d":
                self.w -= self.dw
            elif k == " ":
                self.v = self.w = 0.0
            elif k == "q":
                self.quit = True
        return self.v, self.w

    def close(self) -> None:
        import termios

        termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)


def plot_trajectories(path: Path, truth: list, odom: list, title: str) -> None:
    """Ground truth and odometry (both in the world frame) as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 6))
    if truth:
        ax.plot(*zip(*truth, strict=True), label="ground truth", lw=2)
    if odom:
        ax.plot(*zip(*odom, strict=True), label="odometry", lw=1.2, ls="--")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _write_failure(path: Path, error: OSError, sim_time: float) -> str:
    """One line: which file failed, why, and what of it can be read or rescued."""
    from robotrial.ros.playback import contents

    why = error.strerror or str(error)
    head = f"robotrial sim: cannot write {path}: {why}; the run stopped at {sim_time:.2f} s"
    try:
        n = sum(count for _, count in contents(path).values())
        return f"{head}; the {n} messages written before are readable"
    except Exception:  # no index: the writer could not finish the file
        return (
            f"{head}; rescue what was written with: robotrial bag recover {path} "
            f"-o FIXED{path.suffix} (on a disk with room)"
        )


def run(args: argparse.Namespace) -> int:
    from robotrial.model import ModelError, load_world
    from robotrial.msgs.nav_msgs import Odometry
    from robotrial.ros.bus import Bus
    from robotrial.ros.recorder import BusRecorder, Recorder, format_of
    from robotrial.ros.sim_node import ROBOT_DESCRIPTION, SimNode
    from robotrial.sim.drives import SquareDrive
    from robotrial.sim.simulation import Simulation

    if args.duration < 0:
        console.print(f"[red]--duration must be >= 0, got {args.duration}")
        return 2
    try:
        if args.record:
            if format_of(args.record) == "bag" and args.compression == "zstd":
                raise ValueError(f"{args.record}: a .bag takes --compression lz4 or none")
        world = load_world(args.world)
        robot, options = _options(args, load_robot_from_args(args))
        spawn = world.spawn(args.spawn)
        if args.realtime is not None and not args.realtime > 0:
            raise ValueError(f"--realtime must be positive, got {args.realtime}")
        if not 0 <= args.foxglove_port <= 65535:
            raise ValueError(f"--foxglove-port must be 0 (off) to 65535, got {args.foxglove_port}")
        sim = Simulation.create(world, robot, seed=args.seed, spawn=spawn, options=options)
        if args.drive is None:
            args.drive = "square" if sim.base is not None else "none"
        square = SquareDrive(args.side, args.speed) if args.drive == "square" else None
    except (ModelError, ValueError, KeyError) as exc:
        console.print(f"[red]robotrial sim: {exc}")
        return 2
    if args.drive != "none" and sim.base is None:
        console.print(
            f"[red]robotrial sim: robot {robot.name!r} has no mobile base to drive; "
            "use --drive none"
        )
        return 2

    bus = Bus()
    node = SimNode(bus, sim)
    topics = sorted({t for t, _ in node.topics.values()} | {"/tf", "/tf_static", ROBOT_DESCRIPTION})
    recorder = Recorder(args.record, args.compression) if args.record else None
    writer = BusRecorder(bus, recorder, topics) if recorder is not None else None
    x0, y0, yaw0 = spawn.xyz[0], spawn.xyz[1], spawn.yaw
    truth: list[tuple[float, float]] = []
    odom: list[tuple[float, float]] = []

    def on_truth(m: Odometry) -> None:
        truth.append((m.pose.pose.position.x, m.pose.pose.position.y))

    def on_odom(m: Odometry) -> None:
        p = m.pose.pose.position
        c, s = math.cos(yaw0), math.sin(yaw0)
        odom.append((x0 + c * p.x - s * p.y, y0 + s * p.x + c * p.y))

    bus.subscribe("/ground_truth", on_truth)
    bus.subscribe("/odom", on_odom)

    foxglove = None
    if args.foxglove_port:
        from robotrial.ros.foxglove_bridge import FoxgloveBridge
        from robotrial.ros.rosbridge.access import Access

        try:
            foxglove = FoxgloveBridge(
                bus,
                host=args.host,
                port=args.foxglove_port,
                robot=robot,
                access=Access(listen_host=args.host),
            )
        except OSError as exc:
            console.print(f"[red]robotrial sim: {exc}")
            sim.close()
            return 2
        console.print(f"Foxglove and Lichtblick: open connection {foxglove.url}")

    try:
        zenoh = zenoh_bridge(args, bus)
    except (ValueError, OSError) as exc:
        console.print(f"[red]robotrial sim: {exc}")
        if foxglove is not None:
            foxglove.destroy()
        sim.close()
        return 2
    teleop = None
    realtime = args.realtime
    if (foxglove is not None or zenoh is not None) and realtime is None:
        realtime = 1.0
    if args.drive == "keys":
        lim = sim.base.limits if sim.base else None
        try:
            teleop = KeyTeleop(lim.max_speed if lim else 1.0, lim.max_yaw_rate if lim else 1.0)
        except ValueError as exc:
            console.print(f"[red]robotrial sim: {exc}")
            return 2
        realtime = realtime or 1.0
        console.print(KEYS_HELP)

    last_bar = [0.0]
    wall0 = time.perf_counter()
    cpu0 = time.process_time()
    interrupted = False
    try:
        with progress(
            "simulating", total=round(args.duration, 1), enabled=not args.json
        ) as advance:

            def on_step(t: float) -> None:
                if writer is not None and writer.error is not None:
                    node.stop()  # the recording cannot go on: neither does the run
                if square is not None:
                    sim.drive(*square.command(t))
                elif teleop is not None:
                    sim.drive(*teleop.poll())
                    if teleop.quit:
                        node.stop()
                if t - last_bar[0] >= 0.1:
                    advance(round(t - last_bar[0], 1))
                    last_bar[0] = round(t, 1)

            if square is not None:
                sim.drive(*square.command(0.0))
            try:
                node.run(args.duration, realtime=realtime, on_step=on_step)
            except KeyboardInterrupt:
                interrupted = True
    finally:
        if zenoh is not None:
            zenoh.destroy()
        if foxglove is not None:
            foxglove.destroy()
        if teleop is not None:
            teleop.close()
        if recorder is not None:
            try:
                recorder.close()
            except OSError as exc:
                writer.error = writer.error or exc
        sim.close()
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    sim_time = sim.world.time
    if writer is not None and writer.error is not None:
        console.print(
            f"[red]{_write_failure(Path(args.record), writer.error, sim_time)}", soft_wrap=True
        )
        return 1
    drift = math.dist(truth[-1], odom[-1]) if truth and odom else 0.0
    result = {
        "world": world.name,
        "robot": robot.name,
        "drive": args.drive,
        "seed": args.seed,
        "sim_time_s": round(sim_time, 4),
        "wall_time_s": round(wall, 4),
        "real_time_factor": round(sim_time / wall, 3) if wall > 0 else None,
        "cpu_real_time_factor": round(sim_time / cpu, 3) if cpu > 0 else None,
        "distance_m": round(sim.odometry.distance, 3),
        "odometry_drift_m": round(drift, 4),
        "messages": dict(sorted(node.counts.items())),
        "interrupted": interrupted,
    }
    png = Path(args.plot) if args.plot else None
    if png is not None and truth:
        plot_trajectories(png, truth, odom, f"{robot.name} in {world.name}: {args.drive} drive")
        result["plot"] = str(png)
    if args.record:
        result["recording"] = args.record
    if args.json:
        print_json(result)
        return 0
    print_table(
        f"robotrial sim: {robot.name} in {world.name}",
        ["quantity", "value"],
        [(k, v) for k, v in result.items() if k != "messages"],
    )
    print_table("messages per topic", ["topic", "messages"], sorted(node.counts.items()))
    return 0
