"""Mapping a home the robot has never seen: frontier exploration, or a route given in
advance (layer 4).

`Explorer` maps by itself. It reads the map its own SLAM builds, asks
`nav.frontier.FrontierPlanner` where the most unknown area is to be seen for the least
driving, and drives there with the navigator (`nav.navigator.Navigator`, the default
stack: Hybrid-A* for the footprint, the speed profile), localized by SLAM. Every
`RECHECK` s of driving the navigator gets the grown map; a goal whose frontier has been
seen meanwhile, or whose pose the map now shows blocked, is given up for the next best.
A goal the navigator cannot reach, or one reached with its frontier still unseen, is
blacklisted. It stops when no frontier with a reachable goal is left (or after
`MAX_GOALS` goals), and with `return_home` drives back to where it started.

`follow_route` drives a route given in advance (a teleoperated mapping run), as the
carry trial did before the robot could explore.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import ndimage

from robotrial.nav.amcl import compose
from robotrial.nav.frontier import Frontier, FrontierConfig, FrontierPlanner, view_gain
from robotrial.nav.hybrid import HybridAStar
from robotrial.nav.navigator import Navigator, Status
from robotrial.nav.planners import NoPath, StartBlocked
from robotrial.onboard.drive import RouteDrive
from robotrial.onboard.robot import Robot
from robotrial.ros.slam_node import scan_to_beams

RECHECK = 2.0  # s of driving between looks at the grown map
MAX_GOALS = 60
SCAN_RANGE = 8.0  # m of each scan the navigator's obstacle layer takes
GOAL_YAW_TOLERANCE = 0.6  # rad: the heading at a frontier goal matters little
SPECKLE = 3
OCCUPIED = 0.55  # probability from which the explorer takes a cell as occupied
FREE = 0.45  # and up to which as free: the pose graph maps from its nodes, few scans a cell
MARGIN = 0.01  # m the rectangle keeps from what SLAM mapped
PLAN_TRIES = 5  # goals (twice) the footprint planner is asked about before exploring stops
CHECK_EXPANSIONS = 60_000
ARRIVED_LOOK = 0.8  # s of scans at a reached goal before its frontier is judged


def follow_route(robot: Robot, route: list[tuple[float, float]], speed: float) -> Iterator[None]:
    """Drive the route (map frame) like a careful teleoperator, localized by SLAM."""
    follow = RouteDrive(route, speed)
    while not follow.done:
        v, w = follow.command(*robot.pose())
        robot.drive(v, w)
        yield
    robot.drive(0.0, 0.0)


def map_cells(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Occupied and free cells (the rest unknown) of a map of occupancy probabilities
    `p` (0.5: never seen), as the explorer reads it. The navigation after exploring
    reads it so too: at a map's usual 0.35 / 0.65 thresholds, floor that few of the
    pose graph's nodes saw stays unknown, and the way the explorer drove may be closed
    to the footprint planner."""
    # what the scans saw as often as not (a low table top that beams at some
    # distances pass over) is an obstacle; cells between beams far off that no beam
    # crossed count as free where the gap is under SPECKLE cells wide
    occupied = p >= OCCUPIED
    never = ndimage.binary_opening(p == 0.5, np.ones((SPECKLE, SPECKLE), dtype=bool))
    unknown = never | ((p > FREE) & ~occupied & (p != 0.5))
    return occupied, ~(occupied | unknown)


def navigation_values(p: np.ndarray) -> np.ndarray:
    """The map of occupancy probabilities `p` as ROS values (100 occupied, 0 free, -1
    unknown) read as `map_cells` reads it: what the navigation after exploring plans on."""
    occupied, free = map_cells(p)
    return np.where(occupied, 100, np.where(free, 0, -1)).astype(np.int8)


@dataclass
class ExploreLog:
    """What exploring did: each goal (pose, gain m2, travel m, how it ended), why it
    stopped, the goals blacklisted, and whether it drove back to where it started."""

    goals: list[dict[str, Any]] = field(default_factory=list)
    stopped: str = ""
    blacklisted: int = 0
    returned: bool = False


class Explorer:
    """Frontier exploration for the robot on the bus (see the module docstring)."""

    def __init__(
        self,
        robot: Robot,
        speed: float,
        config: FrontierConfig | None = None,
        return_home: bool = False,
    ) -> None:
        setup = robot.setup
        if setup.navigator is None or setup.footprint is None or robot.slam_node is None:
            raise ValueError(
                "explorer: exploring needs SLAM, the navigator's settings and a footprint"
            )
        self.robot = robot
        self.return_home = return_home
        self.home = robot.pose().copy()
        nav = setup.navigator
        self.nav_config = replace(
            nav,
            dwa=replace(nav.dwa, max_speed=min(nav.dwa.max_speed, speed)),
            profile=replace(nav.profile, max_speed=min(nav.profile.max_speed, speed)),
            yaw_tolerance=GOAL_YAW_TOLERANCE,
            # SLAM's own cells: a map coarsened to the costmaps' usual 5 cm narrows an
            # 0.8 m doorway by up to 10 cm; and walls SLAM drew are a cell or two
            # thicker than they are, so the rectangle keeps a smaller margin
            costmap_resolution=None,
            hybrid=replace(nav.hybrid, margin=MARGIN),
        )
        self.frontiers = FrontierPlanner(
            setup.footprint,
            config or FrontierConfig(),
            planner=HybridAStar(self.nav_config.hybrid),
        )
        self.log = ExploreLog()
        # is a goal reachable now? (bounded searches; a start within the margin too)
        hybrid = replace(self.nav_config.hybrid, max_expansions=CHECK_EXPANSIONS)
        self._checks = (HybridAStar(hybrid), HybridAStar(replace(hybrid, margin=0.0)))
        self._reverse = self._checks[0].reversing()
        self.navigator: Navigator | None = None
        self._scan_seen: object = None

    def _map(self) -> tuple[np.ndarray, np.ndarray, tuple[float, float], float]:
        """SLAM's map as it stands: occupied and free cells, origin, resolution."""
        grid = self.robot.slam_node.slam.grid  # type: ignore[union-attr]
        occupied, free = map_cells(grid.probability())
        return occupied, free, grid.origin, grid.resolution

    def _gain_at(self, xy: np.ndarray) -> float:
        occupied, free, origin, res = self._map()
        unknown = ~(occupied | free)
        cfg = self.frontiers.config
        return view_gain(occupied, unknown, origin, res, xy, cfg.view_range, cfg.rays)

    def run(self) -> Iterator[None]:
        """Explore until nothing reachable is left to see (a generator: one step a
        control period)."""
        robot = self.robot
        end = robot.now + 0.5  # SLAM's first scans
        while robot.now < end or robot.slam_node.slam.grid.logodds.size == 0:  # type: ignore[union-attr]
            yield
        while len(self.log.goals) < MAX_GOALS:
            occupied, free, origin, res = self._map()
            pose = robot.pose()
            choices = self.frontiers.choose(occupied, free, origin, res, pose)
            if not choices:
                self.log.stopped = "no reachable frontier left"
                break
            nav = self._navigator(occupied, free, origin, res)
            target, backwards = self._first_reachable(nav, choices, pose)
            assert target is not None and target.goal is not None
            nav.set_goal(*target.goal, now=robot.now)
            if backwards:
                nav.back_out(robot.now, tuple(pose))
            entry = self._entry(target)
            entry["backs_out"] = backwards
            entry["end"] = yield from self._drive(nav, target.goal)
            if entry["end"] == "unreachable":
                entry["why"] = nav.message
            if entry["end"] in ("unreachable", "unseen"):
                self.frontiers.blacklist(target.goal[:2])
                self.log.blacklisted += 1
        else:
            self.log.stopped = f"{MAX_GOALS} goals driven"
        if self.return_home and self.navigator is not None:
            occupied, free, origin, res = self._map()
            nav = self._navigator(occupied, free, origin, res)
            nav.set_goal(*self.home, now=robot.now)
            self.log.returned = (yield from self._drive(nav, self.home, False)) == "reached"
        robot.drive(0.0, 0.0)
        yield

    def _entry(self, target: Frontier) -> dict[str, Any]:
        """A goal's line in the log."""
        entry = {
            "goal": [round(float(v), 3) for v in target.goal],  # type: ignore[union-attr]
            "gain": round(target.gain, 2),
            "travel": round(target.travel, 2),
            "start": round(self.robot.now, 2),
        }
        self.log.goals.append(entry)
        return entry

    def _first_reachable(
        self, nav: Navigator, choices: list[Frontier], pose: np.ndarray
    ) -> tuple[Frontier, bool]:
        """The first the footprint planner finds a way to from `pose` of the
        `PLAN_TRIES` best choices, then of the `PLAN_TRIES` nearest (nearer ones show
        more of the way to the others; the map may open it later); failing that, the
        first a plan that may also reverse reaches, else the best (then True: the base
        backs out first, from a pocket it drove into and cannot turn in)."""
        near = sorted(choices, key=lambda c: c.travel)
        tries = [*choices[:PLAN_TRIES], *near[:PLAN_TRIES]]
        for target in tries:
            assert target.goal is not None
            for check in self._checks:
                try:
                    check.plan_poses(nav.global_costmap, tuple(pose), tuple(target.goal))
                    return target, False
                except StartBlocked:
                    if check is self._checks[-1]:
                        return target, False  # the navigator plans its way out on the grid
                except NoPath:
                    break
        for target in tries[:PLAN_TRIES]:
            try:
                self._reverse.plan_poses(nav.global_costmap, tuple(pose), tuple(target.goal))
                return target, True
            except NoPath:
                continue
        # the bounded searches found none: the navigator tries the best with its full
        # search, backing out first; if it gives up, the goal is blacklisted
        return choices[0], True

    def _navigator(self, occupied, free, origin, res) -> Navigator:
        unknown = ~(occupied | free)
        if self.navigator is None:
            self.navigator = Navigator(
                occupied, origin, res, self.robot.setup.footprint, self.nav_config, unknown
            )
        else:
            self.navigator.set_map(occupied, origin, res, unknown)
        return self.navigator

    def _drive(self, nav: Navigator, goal: np.ndarray, frontier: bool = True) -> Iterator[None]:
        """Drive towards a goal until it is reached, given up or (a `frontier` goal) no
        longer worth it; returns how it ended: 'reached', 'unseen' (reached, frontier
        still unseen), 'seen' (seen on the way), 'blocked' (the map now shows it
        blocked), 'unreachable' (the navigator gave up)."""
        robot, cfg = self.robot, self.frontiers.config
        check = robot.now + RECHECK
        next_control = -np.inf
        while nav.status is Status.ACTIVE:
            self._observe(nav)
            if robot.now >= next_control:
                next_control = robot.now + self.nav_config.dwa.period
                v, w = nav.step(robot.now, tuple(robot.pose()), robot.velocity)
                robot.drive(v, w)
            if frontier and robot.now >= check and nav.status is Status.ACTIVE:
                check = robot.now + RECHECK
                occupied, free, origin, res = self._map()
                unknown = ~(occupied | free)
                if view_gain(occupied, unknown, origin, res, goal, cfg.view_range, cfg.rays) < (
                    cfg.min_gain
                ):
                    return "seen"
                nav.set_map(occupied, origin, res, unknown)
                cm = nav.global_costmap
                if self.frontiers.planner.collides(cm, goal[None, :])[0]:
                    return "blocked"
            yield
        robot.drive(0.0, 0.0)
        if nav.status is not Status.SUCCEEDED:
            return "unreachable"
        if not frontier:
            return "reached"
        end = robot.now + ARRIVED_LOOK
        while robot.now < end:
            yield
        return "unseen" if self._gain_at(goal) >= cfg.min_gain else "reached"

    def _observe(self, nav: Navigator) -> None:
        """Give the navigator's obstacle layer the newest scan."""
        scan = self.robot.scan
        if scan is None or scan is self._scan_seen:
            return
        self._scan_seen = scan
        b = scan_to_beams(scan, self.robot.laser, 0.1, SCAN_RANGE)
        pose = self.robot.pose()
        c, s = np.cos(pose[2]), np.sin(pose[2])
        hits = b.hits
        pts = pose[:2] + hits @ np.array([[c, s], [-s, c]])
        sensor = compose(pose, np.array([b.origin[0], b.origin[1], 0.0]))
        nav.observe((float(sensor[0]), float(sensor[1])), pts)
