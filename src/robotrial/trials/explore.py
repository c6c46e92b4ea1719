"""The exploration trial: a robot maps a home it has never seen, on its own or along a
route given in advance, and the map is scored against the truth (layer 5: the world
side).

The world side builds the world in MuJoCo (`SimNode`: LiDAR, odometry, joints), starts
the robot side (`onboard.robot.Robot` with its SLAM, and `onboard.explore.Explorer`, or
`follow_route` for the given route: the carry trial's `ROUTES`, else a tour of the
plan's rooms), steps the world and watches for contacts. The robot side hears only the
sensor topics; it is told nothing of the home (not even the route, in the frontier
mode). After the run:

- coverage: the share of the reachable free area the map knows (as free or occupied).
  The reachable free area is the free cells of the true grid (`world_map`, 5 cm) that the
  footprint covers at some pose it reaches from its start (`nav.reachable`: every clear
  pose joined to the start, each grown to the rectangle's inscribed circle);
- ATE: the RMS distance between the true path and SLAM's estimate of it (the online
  estimate, as the robot used it), the map frame laid on the world at the start;
- time (simulated), path length (the true path), contacts, and whether the robot
  stopped by itself.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from robotrial.model import load_robot
from robotrial.model.gridmap import world_map
from robotrial.model.world import World
from robotrial.nav import DEFAULT_PLANNER
from robotrial.nav.amcl import compose, inverse
from robotrial.nav.costmap import Costmap
from robotrial.nav.reachable import reachable_poses
from robotrial.onboard.explore import Explorer, follow_route
from robotrial.onboard.robot import Robot, RobotSetup
from robotrial.onboard.skills import MAPPING_SPEED
from robotrial.ros.bus import Bus
from robotrial.ros.sim_node import SimNode
from robotrial.sim import SimOptions, Simulation, StreamSettings
from robotrial.sim.controllers import DriveLimits
from robotrial.trials.carry import ROUTES, draw_map, exploration_route
from robotrial.trials.nav import ContactWatch, footprint_of, navigator_config
from robotrial.trials.nav_goals import named_world
from robotrial.trials.slam import make_slam

MODES = ("frontier", "route")


@dataclass(frozen=True)
class ExploreSetup:
    """One mapping run: the world (a name as `trials.nav_goals.named_world` takes it, or
    a World), how it is mapped ('frontier': on its own; 'route': the given route), the
    SLAM method, the top speed (m/s) and the time limit (simulated s)."""

    world: str | World = "apartment"
    mode: str = "frontier"
    slam: str = "graph"
    speed: float = MAPPING_SPEED
    robot: str = "mobile_manipulator"
    time_limit: float = 900.0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"explore: no mode {self.mode!r}; choose from {', '.join(MODES)}")
        if not self.speed > 0:
            raise ValueError(f"explore: speed must be positive, got {self.speed} m/s")


@dataclass
class ExploreResult:
    """What a run gave (see the module docstring); the map as ROS values in its frame,
    which lies at `map_in_world`."""

    world: str
    mode: str
    seed: int
    finished: bool = False
    stopped: str = ""
    sim_time: float = 0.0
    wall_time: float = 0.0
    path_length: float = 0.0
    contacts: int = 0
    touched: str = ""
    contact_at: list[tuple[float, float, float]] = field(default_factory=list)  # t, x, y
    coverage: float = 0.0
    reachable_area: float = 0.0
    ate: float = 0.0
    goals: list[dict[str, Any]] = field(default_factory=list)
    blacklisted: int = 0
    truth: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    estimate: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    map_values: np.ndarray | None = None
    map_origin: tuple[float, float] = (0.0, 0.0)
    map_resolution: float = 0.05
    map_in_world: tuple[float, float, float] = (0.0, 0.0, 0.0)
    missed: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    def summary(self) -> dict[str, Any]:
        return {
            "world": self.world,
            "mode": self.mode,
            "seed": self.seed,
            "finished": self.finished,
            "stopped": self.stopped,
            "coverage": round(self.coverage, 4),
            "reachable_area_m2": round(self.reachable_area, 2),
            "ate_m": round(self.ate, 4),
            "sim_time": round(self.sim_time, 1),
            "wall_time": round(self.wall_time, 1),
            "path_length": round(self.path_length, 2),
            "contacts": self.contacts,
            "touched": self.touched,
            "contact_at": self.contact_at[:5],
            "goals": len(self.goals),
            "blacklisted": self.blacklisted,
        }


def run_explore(
    setup: ExploreSetup,
    seed: int = 0,
    on_progress: Callable[[float], None] | None = None,
) -> ExploreResult:
    """One mapping run, scored (see the module docstring)."""
    world = setup.world if isinstance(setup.world, World) else named_world(setup.world)
    name = setup.world if isinstance(setup.world, str) else world.name
    model = load_robot(setup.robot)
    off = StreamSettings(enabled=False)
    streams = {s.name: off for s in model.sensors if s.type not in ("lidar",)}
    sim = Simulation.create(
        world, model, seed=seed, spawn="default", options=SimOptions(cameras=False, streams=streams)
    )
    bus = Bus()
    sim_node = SimNode(bus, sim)
    spawn_pose = world.spawn("default")
    spawn = np.array([spawn_pose.xyz[0], spawn_pose.xyz[1], spawn_pose.yaw], dtype=float)
    limits = DriveLimits.from_metadata(model.metadata.get("drive", {}) or {})
    speed = min(setup.speed, limits.max_speed)
    footprint = footprint_of(sim)
    robot = Robot(
        bus,
        RobotSetup(
            model=model,
            footprint=footprint,
            slam=make_slam(setup.slam),
            navigator=navigator_config(
                speed, limits.max_yaw_rate, limits.max_accel, DEFAULT_PLANNER, limits.max_yaw_accel
            ),
            seed=seed,
        ),
    )
    result = ExploreResult(name, setup.mode, seed)
    result.map_in_world = tuple(float(v) for v in spawn)  # type: ignore[assignment]
    explorer = None
    if setup.mode == "frontier":
        explorer = Explorer(robot, speed)
        steps = explorer.run()
    else:
        route = list(ROUTES[name]) if name in ROUTES else exploration_route(world, footprint)
        to_map = inverse(spawn)
        in_map = [tuple(compose(to_map, np.array([x, y, 0.0]))[:2]) for x, y in route]
        steps = follow_route(robot, in_map, speed)  # type: ignore[arg-type]
    watch = ContactWatch(sim)
    truth: list[tuple[float, float, float]] = []
    estimate: list[tuple[float, float, float]] = []
    touching = False
    wall0 = time.perf_counter()
    sim_node.start_streams()
    n = 0
    try:
        while True:
            sim_node.step()
            n += 1
            hit = watch.touching(sim.world.data)
            if hit is not None and not touching:
                result.contacts += 1
                result.touched = result.touched or hit
                x, y, _ = sim.world.base_pose2d()
                result.contact_at.append((round(sim.world.time, 2), round(x, 2), round(y, 2)))
            touching = hit is not None
            t = sim.world.time
            if n % 5 == 0:
                x, y, _ = sim.world.base_pose2d()
                e = compose(spawn, robot.pose())
                truth.append((t, x, y))
                estimate.append((t, float(e[0]), float(e[1])))
                if on_progress is not None and n % 50 == 0:
                    on_progress(t)
            if t > setup.time_limit:
                result.stopped = f"time limit ({setup.time_limit:.0f} s)"
                break
            try:
                next(steps)
            except StopIteration:
                result.finished = True
                break
        assert robot.slam_node is not None
        robot.slam_node.settle()
        grid = robot.slam_node.slam.grid.copy()
    finally:
        result.wall_time = time.perf_counter() - wall0
        result.sim_time = sim.world.time
        robot.destroy()
        sim.close()
    if explorer is not None:
        result.stopped = result.stopped or explorer.log.stopped
        result.goals, result.blacklisted = explorer.log.goals, explorer.log.blacklisted
    elif result.finished:
        result.stopped = "route driven"
    result.truth = np.array(truth) if truth else np.zeros((0, 3))
    result.estimate = np.array(estimate) if estimate else np.zeros((0, 3))
    if len(truth) > 1:
        result.path_length = float(np.hypot(*np.diff(result.truth[:, 1:], axis=0).T).sum())
        err = np.hypot(*(result.truth[:, 1:] - result.estimate[:, 1:]).T)
        result.ate = float(np.sqrt(np.mean(err**2)))
    result.map_values = grid.ros_values().copy()
    result.map_origin, result.map_resolution = grid.origin, grid.resolution
    score_map(result, world, footprint)
    return result


def reachable_free(world: World, footprint, start: np.ndarray) -> tuple[np.ndarray, Any]:
    """The free cells of the world's true grid that the footprint's inscribed circle
    covers at some pose reached from `start` (x, y, yaw), and the grid."""
    truth = world_map(world)
    cm = Costmap(truth.occupied, truth.origin, truth.resolution, footprint)
    centres = reachable_poses(cm, tuple(start)).mask.any(axis=0)
    near = ndimage.distance_transform_edt(~centres) * truth.resolution
    return (near <= footprint.inscribed_radius) & ~truth.occupied, truth


def score_map(result: ExploreResult, world: World, footprint) -> None:
    """Coverage of the reachable free area by the built map (see the module docstring);
    the cells missed go to `result.missed` (world x, y)."""
    spawn = np.asarray(result.map_in_world, dtype=float)
    reach, truth = reachable_free(world, footprint, spawn)
    rows, cols = np.nonzero(reach)
    xy = np.column_stack(
        [
            truth.origin[0] + (cols + 0.5) * truth.resolution,
            truth.origin[1] + (rows + 0.5) * truth.resolution,
        ]
    )
    c, s = np.cos(spawn[2]), np.sin(spawn[2])
    d = xy - spawn[:2]
    mx, my = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    values = result.map_values
    assert values is not None
    mc = np.floor((mx - result.map_origin[0]) / result.map_resolution).astype(np.int64)
    mr = np.floor((my - result.map_origin[1]) / result.map_resolution).astype(np.int64)
    inside = (mr >= 0) & (mr < values.shape[0]) & (mc >= 0) & (mc < values.shape[1])
    known = np.zeros(len(xy), dtype=bool)
    known[inside] = values[mr[inside], mc[inside]] >= 0
    result.reachable_area = float(len(xy) * truth.resolution**2)
    result.coverage = float(known.mean()) if len(xy) else 0.0
    result.missed = xy[~known]


def plot_explore(png: Path, results: list[ExploreResult]) -> Path:
    """Each run's built map in the world frame with the true and estimated paths, the
    frontier goals and the reachable cells the map missed (red)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(6 * len(results), 6), squeeze=False)
    for ax, r in zip(axes[0], results, strict=True):
        if r.map_values is not None:
            draw_map(ax, r.map_values, r.map_origin, r.map_resolution, r.map_in_world)
        if len(r.missed):
            ax.plot(r.missed[:, 0], r.missed[:, 1], "r.", ms=1, label="reachable, not mapped")
        if len(r.truth):
            ax.plot(r.truth[:, 1], r.truth[:, 2], "g-", lw=1.2, label="driven (truth)")
            ax.plot(r.estimate[:, 1], r.estimate[:, 2], "b--", lw=0.8, label="estimated")
        if r.goals:
            g = np.array(
                [compose(np.asarray(r.map_in_world), np.array(x["goal"])) for x in r.goals]
            )
            ax.plot(g[:, 0], g[:, 1], "mo", ms=4, label="frontier goals")
        ax.plot(r.map_in_world[0], r.map_in_world[1], "k*", ms=10, label="start")
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.legend(loc="lower right", fontsize=7)
        ax.set_title(
            f"{r.world} ({r.mode}): {100 * r.coverage:.1f} % mapped, {r.sim_time:.0f} s, "
            f"{r.path_length:.1f} m, {r.contacts} contacts",
            fontsize=9,
        )
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=100)
    plt.close(fig)
    return png
