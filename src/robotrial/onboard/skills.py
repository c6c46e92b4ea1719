"""The robot's skills: map, navigate, look, search, pick, place (layer 4).

Each skill is a generator that yields once per control period (the world steps between
yields) and ends with its result, or raises `SkillFailed` with a named cause:

| cause | what happened |
| --- | --- |
| `not_seen` | the object was not in view where the robot looked |
| `misclassified` | what was taken for the object from afar is something else up close |
| `no_base_pose` | no free base pose on the map from which the arm reaches |
| `navigation` | the navigator gave up (its reason follows) |
| `no_grasp_pose` | no collision-free arm motion to the grasp, or the object is too wide |
| `grasp_missed` | the fingers closed without the object between them |
| `slipped` | the object slid out of the fingers after the grasp |
| `place_not_seen` | no support surface was seen at the place point |
| `arm_planning` | another arm motion found no path |

What the skills know comes from the robot's sensors: the object from the head camera
(`perception`), the arm's obstacles from the voxels the camera saw (`voxels`), the base's
pose from SLAM, then AMCL on the built map and scans matched to it when docked; the
object in the hand from the fingers' joint readings and where the grasp put the hand.
The arm moves through `planning.task.TaskPlanner` with the voxels as its obstacles.
"""

from __future__ import annotations

import logging
from collections.abc import Generator, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from robotrial.collision.voxels import VoxelChecker
from robotrial.geometry import Box, Pose
from robotrial.kinematics.ik import solve_ik
from robotrial.kinematics.reference import link_poses
from robotrial.nav.amcl import compose, inverse
from robotrial.nav.navigator import Status
from robotrial.nav.tour import open_spot
from robotrial.onboard.catalogue import Catalogue, ObjectKind
from robotrial.onboard.explore import MARGIN as EXPLORE_MARGIN
from robotrial.onboard.explore import Explorer, follow_route, navigation_values
from robotrial.onboard.held import bottom, fit_held, lowest, upright_pitch
from robotrial.onboard.perception import (
    Detection,
    ObjectDetector,
    Surface,
)
from robotrial.onboard.robot import Robot
from robotrial.onboard.voxels import SLAB_DEPTH, Obstacles, RobotBody, VoxelMap, merge_runs
from robotrial.planning.smoothing import densify
from robotrial.planning.task import TaskPlanner, TaskRequest, TaskResult, robot_spheres
from robotrial.planning.timing import Trajectory, time_parameterize
from robotrial.ros.plan_task import joint_trajectory
from robotrial.ros.slam_node import scan_to_beams
from robotrial.slam.keyframes import Keyframes
from robotrial.slam.matcher import ScanMatcher
from robotrial.slam.scan import wrap

log = logging.getLogger(__name__)

STANDOFF = 0.35  # m driven straight in to a work site and back out
BASE_CLEAR = 0.04  # m a work site's footprint keeps clear of the map's occupied cells
# occupancy probability from which the built map is sure of a cell: the occupied cells
# next to a sure one and less sure than it are the scans' noise and the pose's error at
# the surface's face (a 2.5 cm cell in front of it, in 4 of 10 such cells by the plan's
# truth), not more of the surface, and a work site keeps its margin from the sure cells
SURE = 0.9
# m, arm base to the object, in the plane, in this order: the side grasp and its lift
# reach 0.65 m over tops 0.75-0.9 m high (the mobile manipulator's shoulder at 0.9 m)
REACHES = (0.5, 0.45, 0.55, 0.6, 0.65)
# deg between the headings of the work sites tried
HEADING_STEP = 5
# rad the object may lie off a work site's heading, in turn (the arm turns to it)
ASIDE = tuple(np.deg2rad((0.0, 15.0, -15.0, 30.0, -30.0)))
# work sites the arm's checks are asked about before the approach gives up
SITE_CHECKS = 40
# m, tried to say how far the nearest free pose is
FAR_REACHES = np.arange(max(REACHES) + 0.05, 1.3, 0.05)
GRASP_BACKOFF = 0.1  # m, pre-grasp distance along the approach
LINE_STEP = 0.005  # m between the IK solutions of a motion kept on a line
LINE_PERIOD = 0.1  # s between the samples of such a motion's trajectory
LINE_CHECK = 0.01  # s between the positions checked on the way
LINE_TOLERANCE = 0.002  # m the tool point may stray from the line
LINE_TURN = 0.05  # rad the hand may turn from its orientation on the way
GRASP_MARGIN = 0.003  # m kept between the object and the palm
BASE_SHIFT = 0.003  # m the object seems to move as the base is measured again before a grasp
LIFT = 0.06  # m
# m the hand draws back towards the arm while it lifts: straight up from a grasp at the
# edge of reach is out of reach (over a 0.9 m top, from 0.45 m out)
LIFT_BACK = 0.1
SETTLE = 0.3  # s after each arm motion
RELEASE_HEIGHTS = (0.005, 0.015, 0.025)  # m above the surface the object is let go, in turn
# m: an object the camera sees farther than this off the place point once set down is
# taken again and set down on it (the camera sees a set-down object's centre to ~5 mm)
PLACE_CHECK = 0.01
RESET_LIFT = 0.005  # m the object is lifted off the top to be set down again
MAPPING_SPEED = 0.3  # m/s, the top speed while the map is being built
DOCK_SCANS = 5  # scans matched to the map for the pose at a work site
KEYFRAME_RADIUS = 4.0  # m, nodes whose scans a work site's scans are matched to
KEYFRAME_POINTS = 100  # a scan's hits on the nodes' lines, fewer and the map's match stands
HEADINGS = 6  # looks per turn on the spot while searching
SEARCH_SPOTS = 3  # places in a room to search from
LOOK_HERE = 0.3  # m: a place to look from this near the robot is looked from where it stands
WALL_INSET = 0.1  # m in from a room's sides where the map's occupied cells are furniture
FURNITURE_CELLS = 6  # occupied cells a piece of furniture shows on the map at least
LOOK_AT = (0.7, 1.8)  # m from a piece of furniture's nearest cell a look at its top is taken
LOOK_MARGINS = (0.1, 0.02)  # m of clearance beyond the footprint's turning circle, tried in turn
ON_TOP = 0.3  # m: an object this near a piece's cells stands on it
NAV_TRIES = 3  # work sites the navigator may fail to reach before a skill gives up
FAR_LOOK = 1  # pixel stride of a look from afar (every other pixel: none found past 2.2 m)
NEAR_LOOK = 1  # pixel stride of a look at the object up close
LOOK_BACK = (0.1, 0.2)  # m backed up to look again when the object is out of view up close
SAME_OBJECT = 0.15  # m: a detection this close to the expected place is the object
GRIP_SETTLE = 0.25  # s the fingers must stand still to count as closed
GRIP_SLACK = 0.012  # m: fingers closed this much narrower than the object missed it
SLIP = 0.008  # m the fingers may close further once holding before it counts as slipping
VIEW_RANGE = 4.0  # m, farther points are too coarse to classify
# m the seen centre of an object may lie off its true one (a box's centre from its top
# face, seen from a metre or more at a slant), and so its own voxels off the seen outline
SEEN_ERROR = 0.02
HELD_SEARCH = 0.025  # m beyond the held object's outline where its points are looked for
HELD_CUT = 0.01  # m, the robot's body grown by this when the held object is measured
# m aside of and above the place where the held object is shown to the head camera: held
# out ahead, the arm (pitched down as the line of sight is) hides it; 15 cm aside, the
# camera sees a third of the side that faces it and some of its top
SHOW_ASIDE = 0.15
SHOW_UP = 0.15
FLOOR_THICKNESS = 0.1  # m
COLUMN_HEIGHT = 2.0  # m, how tall what the LiDAR mapped is taken to be
COLUMN_CLEAR = 0.03  # m round the arm where a mapped cell is not taken for a column

# The side grasp's approach pitched down (rad), tried in turn. Level, the wrist behind the
# hand hangs below an object's centre and meets the top it stands on when the object is
# more than 5 cm in from the top's edge. The pitch a grasp takes is kept to the place: with
# the shoulder 0.75 m up, an object held level cannot be set down on a 0.45-0.5 m top (a
# bed, a coffee table), held at 30 degrees it can, so the steepest comes first.
PITCHES = (np.deg2rad(30.0), np.deg2rad(15.0), 0.0)

# m the torso lift (the robot's `lift` group) may stand at while the arm moves; it is
# lowered (0) while the base drives. The lift a work site takes is the first of the
# LIFT_TRIES nearest the shoulder at SHOULDER_OVER_TOP above the top (`lift_order`) with
# which the arm finds its way in.
LIFTS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3)
LIFT_TRIES = 3
LIFT_SPEED = 0.08  # m/s
# m: the arm reaches furthest in over a top with its shoulder level with the top
# (`robotrial bench reach`: a book 0.45 m in over a 0.8 m top with the lift at 0.05 m
# only, over a 0.9 m top at 0.15 m only)
SHOULDER_OVER_TOP = 0.0

# The hand's orientation for a side grasp approaching along base +x: the gripper's
# approach axis (z) forward, its x axis up, fingers closing sideways.
SIDE_GRASP = Rotation.from_matrix([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


# a room's rectangle on the map: (x min, y min), (x max, y max)
Room = tuple[tuple[float, float], tuple[float, float]]


class SkillFailed(RuntimeError):
    """A skill could not do its job: `cause` (one of the table above) and why."""

    def __init__(self, cause: str, reason: str) -> None:
        super().__init__(f"{cause}: {reason}")
        self.cause = cause
        self.reason = reason


@dataclass
class Sighting:
    """An object seen: its kind, centre (m, map frame), the detection it came from and,
    for a box with a square top, the direction of one of its sides (rad, map frame): the
    grasp approaches square to a face (its fingers open little wider than such a box)."""

    kind: ObjectKind
    position: np.ndarray
    detection: Detection
    face: float | None = None


@dataclass
class Look:
    """One look: where the base stood (map x, y, yaw), the surfaces (base frame) and the
    objects seen (map frame)."""

    base: np.ndarray
    surfaces: list[Surface]
    sightings: list[Sighting]
    unknown: int = 0


@dataclass(frozen=True)
class Way:
    """How the arm gets to an object at a work site: the grasp's pitch down (rad) and the
    torso lift's height (m)."""

    pitch: float
    lift: float = 0.0


@dataclass
class Held:
    """What the hand holds: its kind, its centre in the tool frame (m), the fingers'
    opening on it, the pitch of the grasp and its orientation in the hand."""

    kind: ObjectKind
    in_hand: np.ndarray
    width: float
    pitch: float = 0.0  # rad the grasp's approach was pitched down
    # its orientation in the tool frame (3x3); None: standing upright, as when grasped
    rotation: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.rotation is None:
            upright = SIDE_GRASP.inv() * Rotation.from_euler("y", -self.pitch)
            self.rotation = upright.as_matrix()


@dataclass
class SkillLog:
    """What the skills did, for the report: arm plans, looks, the grasp, the object's
    centre as seen before the grasp."""

    arm_plans: list[dict[str, Any]] = field(default_factory=list)
    looks: list[dict[str, Any]] = field(default_factory=list)
    grasp: str = ""
    phase: str = ""
    target: np.ndarray | None = None  # the object's centre (map) as seen before the grasp
    held_correction: float | None = None  # m the head camera moved the object in the hand
    exploration: list[dict[str, Any]] = field(default_factory=list)  # frontier goals driven
    # where the search found the object: room, the furniture's centre (map; None when
    # the map shows none under it), the object (map), the top's height
    found: dict[str, Any] | None = None
    not_on: str = ""  # the furniture named in the order, looked at without the object
    set_off: float | None = None  # m the camera saw the object off the point once set down
    set_again: bool = False  # taken again and set down on the point


class Skills:
    """The skills of one robot on the bus (`Robot`), knowing the objects of `catalogue`."""

    def __init__(self, robot: Robot, catalogue: Catalogue) -> None:
        self.robot = robot
        self.model = robot.model
        self.catalogue = catalogue
        lift = (self.model.metadata.get("groups") or {}).get("lift") or []
        self.lift_joint = str(lift[0]) if lift else ""
        # a planner and a checking planner per height of the lift, the lift held there,
        # made when first asked
        self.planners: dict[float, tuple[TaskPlanner, TaskPlanner]] = {}
        self.lifts = LIFTS if self.lift_joint else (0.0,)
        self.lift = 0.0
        self.planner, self.feasible = self._planners_at(0.0)
        self.arm_names = self.planner.joint_names
        self.detector = ObjectDetector(catalogue)
        self.voxels = VoxelMap()
        self.body = RobotBody(self.model)
        self.matcher = ScanMatcher()
        self.log = SkillLog()
        self.held: Held | None = None
        poses = dict(self.model.metadata.get("poses") or {})
        self.poses = {k: np.array([v[n] for n in self.arm_names]) for k, v in poses.items()}
        grip = self.model.metadata.get("gripper") or {}
        self.finger = str((grip.get("joints") or [""])[0])
        self.finger_open = float(grip.get("open", 0.0))
        self.finger_closed = float(grip.get("closed", 0.0))
        zero = link_poses(self.model, {})
        arm_base = zero[self.model.joint(self.arm_names[0]).parent]
        self.arm_offset, self.arm_height = float(arm_base[0, 3]), float(arm_base[2, 3])
        self.shoulder, self.reach = arm_reach(self.planner)
        self.palm = palm_depth(self.model, zero, self.model.end_effector)
        self.footprint = robot.setup.footprint
        self.explored = False  # mapped by frontiers (not along a route)

    # --- time and the base -------------------------------------------------------------

    def wait(self, seconds: float) -> Iterator[None]:
        end = self.robot.now + seconds
        while self.robot.now < end:
            yield

    def explore(self, route: list[tuple[float, float]], speed: float) -> Iterator[None]:
        """Map the home: along the route (map frame) when one is given, else by
        frontiers until nothing reachable is left to see; localized by SLAM as it builds
        the map."""
        if route:
            yield from follow_route(self.robot, route, min(speed, MAPPING_SPEED))
        else:
            # back to the start: the rest of the task begins where the route would end it
            explorer = Explorer(self.robot, min(speed, MAPPING_SPEED), return_home=True)
            yield from explorer.run()
            self.log.exploration = explorer.log.goals
            self.explored = True
        yield from self.wait(0.1)

    def start_navigation(self) -> Iterator[None]:
        """From mapping to navigating on the built map (AMCL from SLAM's last pose)."""
        nav = self.robot.setup.navigator
        assert nav is not None
        # on SLAM's own cells, as exploring drove (a map coarsened to 5 cm narrows a
        # doorway of 0.8 m by up to 10 cm, too narrow for the footprint)
        self.robot.start_navigation(
            xy_tolerance=0.08,
            yaw_tolerance=0.08,
            costmap_resolution=None,
            hybrid=replace(nav.hybrid, margin=EXPLORE_MARGIN),
        )
        yield from self.wait(0.05)  # the navigation node hears the odometry first
        grid = self.robot.grid
        assert grid is not None
        # after exploring, the map as the explorer read it, so the way it drove stays open
        values = navigation_values(grid.probability()) if self.explored else grid.ros_values()
        self.robot.publish_map(values)
        self.map_blocked = (values == 100) | (values < 0)
        self.map_walls = values == 100
        self.map_origin, self.map_res = np.asarray(grid.origin, dtype=float), grid.resolution
        self.clearance = ndimage.distance_transform_edt(~self.map_blocked) * self.map_res
        self.site_clearance = site_clearance(
            values, grid.probability(), self.map_res, self.map_blocked
        )

    def navigate(self, goal: np.ndarray) -> Generator[None, None, str]:
        """Drive to `goal` (map x, y, yaw) with the navigator; its status or reason."""
        nav = self.robot.nav_node
        assert nav is not None and nav.navigator is not None
        self.robot.send_goal(goal)
        while nav.goal_pending or nav.navigator.status is Status.ACTIVE:
            yield
        self.robot.drive(0.0, 0.0)
        yield from self.wait(0.1)
        st = nav.navigator
        return st.status.value if st.status is Status.SUCCEEDED else st.message

    def reach_stage(
        self, stage: np.ndarray, why: str, failed: list[np.ndarray]
    ) -> Generator[None, None, bool]:
        """Navigate to a staging pose; when the navigator gives up, note the pose in
        `failed` and say so (False), so the caller tries another work site; the
        NAV_TRIES-th failure ends the skill (`navigation`)."""
        status = yield from self.navigate(stage)
        if status == "succeeded":
            return True
        failed.append(stage)
        log.info("navigation to %s failed (%s); %d tries so far", why, status, len(failed))
        if len(failed) >= NAV_TRIES:
            raise SkillFailed("navigation", f"to {why}, {len(failed)} tries: {status}")
        return False

    def _near_failed(self, stage: np.ndarray, failed: list[np.ndarray]) -> bool:
        return any(np.hypot(*(stage[:2] - f[:2])) < 0.3 for f in failed)

    def straight(self, distance: float, speed: float = 0.12) -> Iterator[None]:
        """Drive `distance` m straight ahead (negative: back), holding the heading."""
        start = self.robot.pose()
        heading = start[2]
        direction = np.sign(distance)
        while True:
            p = self.robot.pose()
            along = (p[0] - start[0]) * np.cos(heading) + (p[1] - start[1]) * np.sin(heading)
            left = abs(distance) - direction * along
            if left <= 0.005:
                break
            v = direction * min(speed, max(0.03, 1.5 * left))
            self.robot.drive(v, 2.0 * wrap(heading - p[2]))
            yield
        self.robot.drive(0.0, 0.0)
        yield from self.wait(0.1)

    def drive_in(self, base: np.ndarray) -> Iterator[None]:
        """From the staging pose, straight ahead to the work site `base` (as far as the
        navigator's stop left it, not a fixed distance)."""
        p = self.robot.pose()
        ahead = (base[0] - p[0]) * np.cos(p[2]) + (base[1] - p[1]) * np.sin(p[2])
        yield from self.straight(float(ahead))

    def turn_to(self, yaw: float) -> Iterator[None]:
        """Turn on the spot to heading `yaw` (map frame)."""
        while True:
            err = wrap(yaw - self.robot.pose()[2])
            if abs(err) < 0.03:
                break
            self.robot.drive(0.0, float(np.clip(1.5 * err, -0.6, 0.6)))
            yield
        self.robot.drive(0.0, 0.0)
        yield from self.wait(0.2)

    def docked_pose(self) -> Generator[None, None, np.ndarray]:
        """The pose at a work site from scans matched to the built map (AMCL's particles
        settle a few cm off; standing still, the scans say better), then to the raw
        scans of the SLAM's nodes around, when it kept them (the map's cells round the
        walls' places by up to half a cell)."""
        grid = self.robot.grid
        assert grid is not None
        poses = []
        guess = self.robot.pose()
        keyframes = None
        if self.robot.keyframes[0]:
            try:
                keyframes = Keyframes(*self.robot.keyframes, guess, KEYFRAME_RADIUS)
            except ValueError:  # no node near: the map's match stands
                pass
        for _ in range(DOCK_SCANS):
            seen = self.robot.scan
            while self.robot.scan is seen:
                yield
            assert self.robot.scan is not None
            b = scan_to_beams(self.robot.scan, self.robot.laser, 0.1, 12.0)
            pose = self.matcher.match(grid, b.hits, guess).pose
            if keyframes is not None:
                # from the map's match to the raw scans of the nodes around: no cells
                refined, used = keyframes.match(b.hits, pose)
                d = refined - pose
                if used >= KEYFRAME_POINTS and np.hypot(d[0], d[1]) < 0.05 and abs(d[2]) < 0.03:
                    pose = refined
            poses.append(pose)
        p = np.array(poses)
        mean_yaw = float(np.arctan2(np.sin(p[:, 2]).mean(), np.cos(p[:, 2]).mean()))
        return np.array([p[:, 0].mean(), p[:, 1].mean(), mean_yaw])

    # --- looking -----------------------------------------------------------------------

    def look(self, base: np.ndarray | None = None, stride: int = FAR_LOOK) -> Look:
        """One RGB-D frame from the head: the robot's own body cut out, the voxel map
        updated, surfaces and objects found (objects in the map frame)."""
        base = self.robot.pose() if base is None else base
        frame = self.robot.capture()
        pts, colours = frame.points(stride)
        near = np.linalg.norm(pts - frame.viewpoint, axis=1) <= VIEW_RANGE
        held = self._held_shapes()
        keep = near & ~self.body.mask(pts, self.robot.joints, held)
        pts = pts[keep]
        colours = colours[keep] if colours is not None else None
        surfaces = self.detector.surfaces(pts)
        self.voxels.integrate(frame, pts, base, surfaces)
        self.voxels.clear_body(self.body, base, self.robot.joints, held)
        found = self.detector.detect(pts, colours, frame.viewpoint, surfaces, stride / frame.k[0])
        sightings = []
        for d in found:
            if d.kind:
                p = compose(base, np.array([d.position[0], d.position[1], 0.0]))
                xyz = np.array([p[0], p[1], d.position[2]])
                kind = self.catalogue.kind(d.kind)
                square = kind.shape == "box" and abs(kind.size[0] - kind.size[1]) < 1e-3
                face = float(base[2] + d.yaw) if square else None
                sightings.append(Sighting(kind, xyz, d, face))
        log.info(
            "look at %.1f s from (%.2f, %.2f, %.2f): %s; %d unknown",
            self.robot.now,
            *base,
            ", ".join(f"{s.kind.name} at {np.round(s.position, 3).tolist()}" for s in sightings),
            len(found) - len(sightings),
        )
        self.log.looks.append(
            {
                "phase": self.log.phase,
                "time": round(self.robot.now, 2),
                "objects": [s.kind.name for s in sightings],
                "unknown": len(found) - len(sightings),
            }
        )
        return Look(base, surfaces, sightings, len(found) - len(sightings))

    def search(
        self,
        kind: ObjectKind,
        room: str,
        bounds: tuple[tuple[float, float], tuple[float, float]],
        on: tuple[str, tuple[tuple[float, float], tuple[float, float]]] | None = None,
    ) -> Generator[None, None, Sighting]:
        """Find an object of `kind` in a room (bounds in the map frame): first on the
        furniture tops the built map shows in the room, each looked at from a free pose
        facing it, nearest first (the pieces under `on`, a named piece's rectangle in the
        map frame, before all others); then from a few open spots of the room, turning on
        the spot. `log.found` says where it was found; `not_seen` says where it was not."""
        yield from self.arm_to_pose("stow")
        pieces = furniture_tops(self.map_walls, self.map_origin, self.map_res, bounds)
        named = [k for k, p in enumerate(pieces) if on is not None and overlaps(p, on[1])]
        views = []
        for index, piece in enumerate(pieces):
            for extra in LOOK_MARGINS:  # room to turn to spare, else just room to turn
                margin = self.footprint.circumscribed_radius + extra
                at = (self.clearance, self.map_origin, self.map_res, bounds, margin)
                pose = look_pose(piece, *at)
                if pose is not None:
                    views.append((piece, pose, index))
                    break
        looks = places = 0
        failed: list[np.ndarray] = []
        here = self.robot.pose()[:2]
        self.log.not_on = ""
        while views:
            first = [i for i, v in enumerate(views) if v[2] in named] or range(len(views))
            k = min(first, key=lambda i: np.hypot(*(views[i][1][:2] - here)))
            piece, pose, index = views.pop(k)
            if on is not None and index not in named and named and not self.log.not_on:
                self.log.not_on = on[0]  # every view of the named piece was taken
            if not (
                yield from self._look_from(
                    pose, f"a place to look at furniture in the {room}", failed
                )
            ):
                continue
            here = self.robot.pose()[:2]
            looks += 1
            places += 1
            best = self._look_for(kind, pieces, room, bounds, on)
            if best is not None:
                return best
        if named and on is not None:
            self.log.not_on = on[0]
        spots = self._spots(bounds)
        for spot in spots:
            centre = np.mean(np.asarray(bounds), axis=0)
            yaw = float(np.arctan2(centre[1] - spot[1], centre[0] - spot[0]))
            if np.hypot(*(spot - centre)) < 0.3:
                yaw = self.robot.pose()[2]
            if not (
                yield from self._look_from(
                    np.array([spot[0], spot[1], yaw]), f"a place to look from in the {room}", failed
                )
            ):
                continue
            places += 1
            yaw = float(self.robot.pose()[2])
            for k in range(HEADINGS):
                if k:
                    yield from self.turn_to(yaw + 2 * np.pi * k / HEADINGS)
                looks += 1
                best = self._look_for(kind, pieces, room, bounds, on)
                if best is not None:
                    return best
        raise SkillFailed(
            "not_seen",
            f"the {kind.name} is not in the {room}: not on its {len(pieces)} furniture tops "
            f"the map shows, nor seen in {looks} looks from {places} places"
            + (f" (the {on[0]} is not on the map in the {room})" if on and not named else ""),
        )

    def _look_for(
        self, kind: ObjectKind, pieces: list[np.ndarray], room: str, bounds, on
    ) -> Sighting | None:
        """One look for an object of `kind` in the room: the best match, noted where
        found, or None."""
        best = best_in_room(self.look().sightings, kind, bounds)
        if best is None:
            return None
        self._found(best, pieces, room, on)
        return best

    def _look_from(
        self, pose: np.ndarray, why: str, failed: list[np.ndarray]
    ) -> Generator[None, None, bool]:
        """Go to a pose to look from (map x, y, yaw): drive there, or when it is this
        near (LOOK_HERE; no motion of the footprint plans so short a move) turn where the
        robot stands. False when the navigator gave up (`reach_stage`)."""
        if np.hypot(*(pose[:2] - self.robot.pose()[:2])) < LOOK_HERE:
            yield from self.turn_to(float(pose[2]))
            return True
        return (yield from self.reach_stage(pose, why, failed))

    def _found(self, seen: Sighting, pieces: list[np.ndarray], room: str, on) -> None:
        """Note where the object was found: on which furniture top of the map (its
        centre; the named one when it lies under `on`), how high, in which room, and
        whether the named furniture was looked at without it."""
        at = seen.position[:2]
        near = [p for p in pieces if np.min(np.hypot(*(p - at).T)) < ON_TOP]
        self.log.found = {
            "on": on[0] if on is not None and near and overlaps(near[0], on[1]) else "",
            "not_on": self.log.not_on,
            "room": room,
            "furniture": near[0].mean(axis=0) if near else None,
            "at": np.array(at, dtype=float),
            "top": float(seen.detection.surface),
        }
        log.info("found the %s in the %s: %s", seen.kind.name, room, self.log.found)

    def _spots(self, bounds) -> list[np.ndarray]:
        """Places to search a room from: its most open spot, then those of its halves
        (the more open first)."""
        (x0, y0), (x1, y1) = bounds
        rects = [bounds]
        if x1 - x0 >= y1 - y0:
            xm = (x0 + x1) / 2
            rects += [((x0, y0), (xm, y1)), ((xm, y0), (x1, y1))]
        else:
            ym = (y0 + y1) / 2
            rects += [((x0, y0), (x1, ym)), ((x0, ym), (x1, y1))]
        out: list[np.ndarray] = []
        for r in rects:
            try:
                p = np.array(open_spot(self.clearance, self.map_origin, self.map_res, r))
            except ValueError:
                continue
            if self._clear_at(p) < self.footprint.circumscribed_radius + 0.1:
                continue
            if all(np.hypot(*(p - q)) > 0.8 for q in out):
                out.append(p)
        return out[:SEARCH_SPOTS]

    def _clear_at(self, xy: np.ndarray) -> float:
        col = int((xy[0] - self.map_origin[0]) / self.map_res)
        row = int((xy[1] - self.map_origin[1]) / self.map_res)
        rows, cols = self.clearance.shape
        if not (0 <= row < rows and 0 <= col < cols):
            return 0.0
        return float(self.clearance[row, col])

    # --- the arm -----------------------------------------------------------------------

    def arm_q(self) -> np.ndarray:
        return np.array([self.robot.joints.get(n, 0.0) for n in self.arm_names])

    def opening(self) -> float:
        return float(self.robot.joints.get(self.finger, self.finger_open))

    def _obstacles(self, base: np.ndarray, keep_out=()) -> Obstacles:
        """The floor and the voxels the arm (and what it holds) can reach, in the base
        frame."""
        floor = ("floor", Box((4.0, 4.0, FLOOR_THICKNESS)), Pose((0.0, 0.0, -FLOOR_THICKNESS / 2)))
        reach = self.reach + (self.held.kind.width + self.held.kind.height if self.held else 0.0)
        shoulder = self.shoulder + np.array([0.0, 0.0, self.lift])
        boxes = self.voxels.boxes(base, shoulder, reach + 0.05, keep_out=keep_out)
        return [floor, *boxes]

    def _held_pose(self, q: np.ndarray) -> np.ndarray:
        """The held object's pose (4x4, base frame) with the arm at `q`: where it sits and
        how it is turned in the hand, carried along with the tool."""
        assert self.held is not None and self.held.rotation is not None
        tcp = self.planner.kin.link_pose(q)
        pose = tcp.copy()
        pose[:3, :3] = tcp[:3, :3] @ self.held.rotation
        pose[:3, 3] = tcp[:3, :3] @ self.held.in_hand + tcp[:3, 3]
        return pose

    def _held_shapes(self) -> list[tuple[Box, np.ndarray]]:
        """The held object as a shape and its pose in the base frame (none: [])."""
        if self.held is None:
            return []
        return [(Box(self.held.kind.size), self._held_pose(self.arm_q()))]

    def _held_object(self, q: np.ndarray) -> tuple[str, Box, Pose] | None:
        if self.held is None:
            return None
        pose = Pose.from_matrix(self._held_pose(q))
        return self.held.kind.name, Box(self.held.kind.size), pose

    def plan(
        self,
        start: np.ndarray,
        obstacles: Obstacles,
        local: np.ndarray | None = None,
        orientation: Rotation | None = None,
        joints: np.ndarray | None = None,
        check_only: bool = False,
    ) -> TaskResult:
        """Plan the hand to `local` (base frame) with `orientation` (default: a side grasp
        facing the point from the arm), or the arm to `joints`, holding what it holds."""
        if joints is None:
            assert local is not None
            orientation = orientation or self.orientation(local)
        request = TaskRequest(
            positions=np.asarray(start, dtype=float),
            joint_names=list(self.arm_names),
            goal_position=np.zeros(3) if local is None else np.asarray(local, dtype=float),
            goal_orientation=None if orientation is None else orientation.as_quat(),
            goal_joints=joints,
            obstacles=obstacles,
            object=self._held_object(start),
            planner=self.robot.setup.planner,
            time_limit=0.0,  # the default: 2 s for the planner, set-up and checks unbounded
        )
        planner = self.feasible if check_only else self.planner
        res = planner.plan(request, seed=self.robot.setup.seed)
        log.info(
            "arm plan%s to %s: %s (%d obstacles, %.2f s)",
            " (check)" if check_only else "",
            "joints" if joints is not None else np.round(local, 3).tolist(),
            res.message[:90],
            len(obstacles),
            res.planning_time,
        )
        if not check_only:
            self._log_plan(res, obstacles)
        return res

    def _log_plan(self, res: TaskResult, obstacles: Obstacles) -> None:
        """Keep an arm motion's outcome in the run's log."""
        self.log.arm_plans.append(
            {
                "phase": self.log.phase,
                "success": res.success,
                "planning_time": round(res.planning_time, 4),
                "obstacles": len(obstacles),
                "message": res.message,
            }
        )

    def follow(self, res: TaskResult) -> Iterator[None]:
        """Send a planned trajectory to the arm and wait for it to end."""
        assert res.trajectory is not None
        self.robot.ref_pub.publish(joint_trajectory(self.arm_names, res.trajectory))
        yield from self.wait(res.trajectory.duration + SETTLE)

    def move_arm(
        self,
        base: np.ndarray,
        cause: str,
        local: np.ndarray | None = None,
        orientation: Rotation | None = None,
        joints: np.ndarray | None = None,
        keep_out=(),
        straight: bool = False,
    ) -> Iterator[None]:
        """Plan and follow an arm motion in the voxel scene, the robot standing at `base`;
        `cause` names the failure. With `straight`, the hand keeps its orientation on the
        line to `local` (`_along_line`) where the arm can; else any free motion."""
        self.voxels.clear_body(self.body, base, self.robot.joints, self._held_shapes())
        obstacles = self._obstacles(base, keep_out)
        res = None
        if straight and local is not None and orientation is not None:
            res = self._line_motion(local, orientation, obstacles)
        if res is None:
            res = self.plan(self.arm_q(), obstacles, local, orientation, joints)
        if not res.success:
            raise SkillFailed(cause, f"arm planning: {res.message}")
        yield from self.follow(res)

    def _line_motion(
        self, goal: np.ndarray, orientation: Rotation, obstacles: Obstacles
    ) -> TaskResult | None:
        """A motion of the hand from where it is along the line to `goal` (base frame),
        keeping `orientation`, free in `obstacles`; None when the arm cannot keep to the
        line. A plan to an IK goal moves the joints straight, and where the line passes
        near the wrist's singularity (two of its joints turning 2 rad each way over a
        10 cm approach 15 degrees down) the hand swings 1 cm aside on the way, into the
        object it is to grasp, or onto its top."""
        q = self.arm_q()
        kin = self.planner.kin
        start = kin.link_pose(q)[:3, 3]
        path = self._along_line(q, start, goal, orientation)
        if path is None:
            return None
        planner = self.planner
        trajectory = time_parameterize(path, planner.vmax, planner.amax, LINE_PERIOD)
        moved = trajectory.tracked(LINE_CHECK)
        tcp = kin.fk(moved)[:, kin.link_index[kin.model.end_effector]]
        off = np.linalg.norm(np.cross(tcp[:, :3, 3] - start, goal - start), axis=1)
        off /= max(float(np.linalg.norm(goal - start)), 1e-9)
        turn = (Rotation.from_matrix(tcp[:, :3, :3]) * orientation.inv()).magnitude()
        if off.max() > LINE_TOLERANCE or turn.max() > LINE_TURN:
            log.info("off the line by %.1f mm, %.3f rad", 1e3 * off.max(), turn.max())
            return None
        # the end checked free and the scene's checker made by the planner
        res = self.plan(q, obstacles, joints=path[-1], check_only=True)
        if not res.success or res.checker is None:
            return None
        if not np.all(res.checker.valid(densify(moved, float(np.min(res.checker.resolution))))):
            return None
        res.trajectory = trajectory
        res.message = f"along a line, {len(path)} waypoints"
        self._log_plan(res, obstacles)
        return res

    def _along_line(
        self, q: np.ndarray, start: np.ndarray, goal: np.ndarray, orientation: Rotation
    ) -> np.ndarray | None:
        """The arm's joints at small steps of the hand from `start` (where it is at `q`)
        along the line to `goal` (base frame), at `orientation`, each solved from the one
        before; None when a step finds no solution."""
        kin = self.planner.kin
        steps = max(1, int(np.ceil(np.linalg.norm(goal - start) / LINE_STEP)))
        pose = np.eye(4)
        pose[:3, :3] = orientation.as_matrix()
        path = [q]
        for k in range(1, steps + 1):
            pose[:3, 3] = start + (np.asarray(goal) - start) * k / steps
            res = solve_ik(kin, pose, path[-1], restarts=1, batch=1, wanted=1)
            if not res.success:
                return None
            path.append(res.q)
        return np.array(path)

    def arm_to_pose(self, name: str) -> Iterator[None]:
        """Move the arm to one of the robot's named poses (stow, carry) unless there."""
        if name not in self.poses:
            raise SkillFailed("arm_planning", f"the robot's description names no {name!r} pose")
        goal = self.poses[name]
        if np.max(np.abs(self.arm_q() - goal)) < 0.02:
            return
        base = self.robot.pose()
        self.voxels.clear_body(self.body, base, self.robot.joints, self._held_shapes())
        # folding the arm swings it beside the robot, where the camera may not have
        # looked: what the LiDAR mapped there stands in as columns
        obstacles = self._obstacles(base) + self._map_columns(base)
        res = self.plan(self.arm_q(), obstacles, joints=goal)
        if not res.success:
            raise SkillFailed("arm_planning", f"arm planning: {res.message}")
        yield from self.follow(res)

    def _map_columns(self, base: np.ndarray) -> Obstacles:
        """The occupied cells of the built map within the arm's reach, as columns from the
        floor up to COLUMN_HEIGHT, in the base frame (merged rows of cells)."""
        if not hasattr(self, "map_walls"):
            return []
        rows, cols = np.nonzero(self.map_walls)
        xy = self.map_origin + (np.column_stack([cols, rows]) + 0.5) * self.map_res
        c, s = np.cos(base[2]), np.sin(base[2])
        d = xy - base[:2]
        local = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
        near = np.hypot(*(local - self.shoulder[:2]).T) <= self.reach + 0.1
        # a cell the arm (or what it holds) is over or in, above the base, is a top the
        # camera saw it reach over, not a column: a lifted object held out over a table
        idx = np.nonzero(near)[0]
        heights = np.arange(self.arm_height, COLUMN_HEIGHT, self.voxels.resolution)
        up = np.column_stack(
            [np.repeat(local[idx], len(heights), axis=0), np.tile(heights, len(idx))]
        )
        under = self.body.mask(up, self.robot.joints, self._held_shapes(), COLUMN_CLEAR)
        near[idx[under.reshape(len(idx), len(heights)).any(axis=1)]] = False
        keys = np.column_stack([cols[near], rows[near], np.zeros(int(near.sum()), dtype=int)])
        out: Obstacles = []
        for lo, hi in merge_runs(keys) if len(keys) else []:
            centre = self.map_origin + (lo[:2] + hi[:2] + 1) * self.map_res / 2
            size = ((hi[0] - lo[0] + 1) * self.map_res, (hi[1] - lo[1] + 1) * self.map_res)
            c = to_base(base, np.array([centre[0], centre[1], COLUMN_HEIGHT / 2]))
            pose = Pose.from_xyz_rpy(tuple(float(v) for v in c), (0.0, 0.0, -float(base[2])))
            out.append((f"map/{len(out)}", Box((*map(float, size), COLUMN_HEIGHT)), pose))
        return out

    def orientation(
        self, local: np.ndarray, pitch: float = 0.0, face: float | None = None
    ) -> Rotation:
        """A side grasp facing the point `local` (base frame) from the arm's base, its
        approach pitched down by `pitch` (rad); with `face` (a side's direction, base
        frame), square to the face of a square box nearest that way."""
        d = np.asarray(local[:2]) - np.array([self.arm_offset, 0.0])
        heading = float(np.arctan2(d[1], d[0]))
        if face is not None:
            heading += wrap(face - heading + np.pi / 4) % (np.pi / 2) - np.pi / 4
        return Rotation.from_euler("z", heading) * Rotation.from_euler("y", pitch) * SIDE_GRASP

    def _approach(self, local: np.ndarray, back: float) -> np.ndarray:
        d = np.asarray(local[:2]) - np.array([self.arm_offset, 0.0])
        d = d / max(float(np.linalg.norm(d)), 1e-9)
        return np.array([local[0] - back * d[0], local[1] - back * d[1], local[2]])

    def _lifted(self, local: np.ndarray) -> np.ndarray:
        """The point LIFT above `local` (base frame) and LIFT_BACK nearer the arm: where a
        grasped object is lifted to, and a held one is lowered from."""
        return self._approach(local, LIFT_BACK) + np.array([0.0, 0.0, LIFT])

    # --- going to a work site ----------------------------------------------------------

    def _footprint_clearance(self, pose: np.ndarray, site: bool = False) -> float:
        """How far (m) the footprint's outline at `pose` (map x, y, yaw) stands from the
        built map's blocked cells (with `site`, as a work site keeps clear of them:
        `site_clearance`); -1 when it leaves the map."""
        half_l, half_w = self.footprint.length / 2, self.footprint.width / 2
        u = np.linspace(-1, 1, 9)
        outline = np.concatenate(
            [
                np.column_stack([half_l * u, np.full_like(u, half_w)]),
                np.column_stack([half_l * u, np.full_like(u, -half_w)]),
                np.column_stack([np.full_like(u, half_l), half_w * u]),
                np.column_stack([np.full_like(u, -half_l), half_w * u]),
            ]
        )
        c, s = np.cos(pose[2]), np.sin(pose[2])
        px = pose[0] + c * outline[:, 0] - s * outline[:, 1]
        py = pose[1] + s * outline[:, 0] + c * outline[:, 1]
        col = np.floor((px - self.map_origin[0]) / self.map_res).astype(int)
        row = np.floor((py - self.map_origin[1]) / self.map_res).astype(int)
        clearance = self.site_clearance if site else self.clearance
        rows, cols = clearance.shape
        inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        if not inside.all():
            return -1.0
        return float(clearance[row, col].min())

    def base_candidates(
        self, xy: np.ndarray, reaches: Sequence[float] = REACHES, room: Room | None = None
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Base poses (and their staging poses STANDOFF behind) from which the arm's base
        is one of `reaches` from `xy`, the object straight ahead or up to ASIDE off the
        heading (between furniture, a base turned from the object often fits where one
        facing it does not), free on the built map (`site_clearance`), with `room` (a
        rectangle, map frame) only those whose base stands in it (a table 5 cm off a wall
        leaves a free pose behind the wall, in the next room, from which the arm would
        reach across the wall): those at the edge
        of the arm's reach (max REACHES: the object seen again 2 cm further from there is
        out of reach) after every other, then those whose stage has room to turn first,
        then by reach in the order given, the object nearest straight ahead, the most
        clearance first."""
        clearance = self._footprint_clearance
        turn = self.footprint.circumscribed_radius + 0.1  # room to turn at a stage
        out = []
        headings = np.deg2rad(np.arange(0, 360, HEADING_STEP))
        for k, reach in enumerate(reaches):
            for aside in ASIDE:
                for th in headings:
                    d = np.array([np.cos(th), np.sin(th)])
                    towards = np.array([np.cos(th + aside), np.sin(th + aside)])
                    centre = xy - reach * towards - self.arm_offset * d
                    if room is not None and not in_rect(centre, room):
                        continue
                    base = np.array([centre[0], centre[1], th])
                    stage = np.array([*(centre - STANDOFF * d), th])
                    c1 = clearance(base, site=True)
                    if c1 < BASE_CLEAR:
                        continue
                    c2 = clearance(stage)
                    if c2 >= 0.15:
                        # a stage without room to turn on the spot comes after every other:
                        # the navigator gets there and away by arcs, where the room allows
                        cramped = self._clear_at(stage[:2]) < turn
                        rank = -min(c1, 0.2) - 0.5 * min(c2, 0.5)
                        edge = reach >= max(REACHES)
                        out.append((edge, cramped, k, abs(aside), rank, base, stage))
        out.sort(key=lambda r: r[:5])
        return [(b, s) for *_, b, s in out]

    def _out_of_reach(self, xy: np.ndarray, what: str, room: Room | None = None) -> str:
        """Why no base pose (in `room`, if given) serves `xy` (map), in a buyer's words:
        how far from the arm's base the nearest free pose facing it would leave it, how
        far the arm reaches and so how far in from a top's edge it takes things."""
        reach = next((r for r in FAR_REACHES if self.base_candidates(xy, (float(r),), room)), None)
        arm = self._arm_reach()
        if reach is None:
            return (
                f"the {what} is out of the robot's reach: no free spot on its map lets the "
                f"robot face it from within {FAR_REACHES[-1]:.2f} m; {arm}"
            )
        return (
            f"the {what} is out of the robot's reach: the nearest the robot can stand "
            f"facing it (clear of what is around it on its map) leaves it {reach:.2f} m "
            f"from the arm's base, {reach - max(REACHES):.2f} m too far; {arm}"
        )

    def _arm_reach(self) -> str:
        """How far the arm reaches, in a buyer's words: from its base, and so in from the
        edge of a top."""
        front = self.footprint.length / 2 - self.arm_offset  # the arm's base behind the front
        edge = np.floor((max(REACHES) - front - BASE_CLEAR) / 0.05 + 1e-6) * 0.05
        return (
            f"the arm reaches {max(REACHES):.2f} m from its base, about {edge:.2f} m in "
            "from the edge of a top the robot stands square to"
        )

    def _reaches(
        self, base: np.ndarray, target: np.ndarray, kind: ObjectKind, face: float | None = None
    ) -> Way | None:
        """The way (of PITCHES, of the lift's heights) with which the arm finds the way in
        at a work site with the base at `base`: to grasp an object of `kind` centred at
        `target` (map frame) and lift it (`_lifted`), or, holding one, to set it down there
        (from its `_lifted` point, at the pitch it was grasped with), in the voxels seen
        so far; None when with none. `face`: the object's side's direction (map frame), if
        any."""
        local = to_base(base, target)
        face = None if face is None else face - float(base[2])
        top = float(target[2]) - kind.height / 2
        for lift in lift_order(top, self.lifts, float(self.shoulder[2])):
            with self._lift_at(lift):
                pitch = self._pitch_at(base, local, kind, face)
            if pitch is not None:
                return Way(pitch, lift)
        return None

    def _pitch_at(
        self, base: np.ndarray, local: np.ndarray, kind: ObjectKind, face: float | None
    ) -> float | None:
        """`_reaches` with the lift where the planners hold it: the pitch, or None."""
        if self.held is not None:
            obstacles = self._obstacles(base)
            pitches: tuple[float, ...] = (self.held.pitch,)
        else:
            obstacles = self._obstacles(base, self._keep_out(local, kind))
            pitches = PITCHES
        for pitch in pitches:
            orientation = self.orientation(local, pitch, None if self.held else face)
            if self.held is not None:  # let go from as high as the place may
                hand = self._set_down_at(local, orientation)
                hand[2] += RELEASE_HEIGHTS[-1]
                points = (self._lifted(hand), hand)
            else:
                pre, grasp = self._grasp_points(local, kind, pitch, face)
                points = (pre, grasp, self._lifted(grasp))
            if self._plans_through(points, orientation, obstacles):
                return pitch
        return None

    @contextmanager
    def _lift_at(self, lift: float) -> Iterator[None]:
        """Plan (within the block) with the lift held at `lift`, wherever it stands."""
        was = self.lift
        self._use_lift(lift)
        try:
            yield
        finally:
            self._use_lift(was)

    def _use_lift(self, lift: float) -> None:
        self.lift = lift
        self.planner, self.feasible = self._planners_at(lift)

    def _planners_at(self, lift: float) -> tuple[TaskPlanner, TaskPlanner]:
        """The planner and the checking planner with the lift held at `lift`."""
        if lift not in self.planners:
            fixed = {self.lift_joint: lift} if self.lift_joint else None
            planner = TaskPlanner(self.model, checker=VoxelChecker, fixed=fixed)
            feasible = TaskPlanner(self.model, validate=False, checker=VoxelChecker, fixed=fixed)
            # both covers, from the disk when made before (`robotrial warm`): the fine one
            # is asked where a goal grazes a table top, and making it costs seconds
            spheres = robot_spheres(planner.kin, fine=True)
            planner.spheres = feasible.spheres = spheres
            self.planners[lift] = (planner, feasible)
        return self.planners[lift]

    def move_lift(self, lift: float) -> Iterator[None]:
        """Raise or lower the torso lift to `lift` (m) and plan the arm from there on; the
        arm holds its pose meanwhile (stowed or in the carry pose, above the base)."""
        now = float(self.robot.joints.get(self.lift_joint, self.lift))
        if not self.lift_joint or abs(now - lift) < 0.002:
            self._use_lift(lift)
            return
        duration = max(1.5 * abs(lift - now) / LIFT_SPEED, 0.2)
        ends = Trajectory(
            np.array([0.0, duration]), np.array([[now], [lift]]), np.zeros((2, 1)), np.zeros((2, 1))
        )
        self.robot.ref_pub.publish(joint_trajectory([self.lift_joint], ends))
        yield from self.wait(duration + SETTLE)
        self._use_lift(lift)

    def _plans_through(self, points, orientation: Rotation, obstacles: Obstacles) -> bool:
        """Whether the arm, from where it is, gets to each of `points` (base frame) in
        turn with the hand at `orientation`."""
        q = self.arm_q()
        for point in points:
            res = self.plan(q, obstacles, point, orientation, check_only=True)
            if not res.success:
                return False
            q = res.trajectory.q[-1]
        return True

    def _grasp_points(
        self, local: np.ndarray, kind: ObjectKind, pitch: float = 0.0, face: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The pre-grasp and grasp positions of the tool point for an object of `kind`
        centred at `local` (base frame), along the approach pitched down by `pitch`: the
        palm stops GRASP_MARGIN short of it."""
        along = self.orientation(local, pitch, face).apply([0.0, 0.0, 1.0])
        grasp = local - (kind.grip_width / 2 + self.palm + GRASP_MARGIN) * along
        return grasp - GRASP_BACKOFF * along, grasp

    # --- pick --------------------------------------------------------------------------

    def _keep_out(self, local: np.ndarray, kind: ObjectKind, support: bool = False):
        """The upright cylinder around an object of `kind` centred at `local` (base
        frame) left out of the arm's obstacles: its own voxels (with `support`, also the
        top it stands on, which it leaves when lifted)."""
        bottom = local[2] - kind.height / 2
        below = bottom - SLAB_DEPTH if support else bottom + 0.008
        return [(local, self._object_radius(kind), below, bottom + kind.height + 0.03)]

    def _object_radius(self, kind: ObjectKind) -> float:
        """How far (m) from an object's seen centre its voxels lie: its outline's
        farthest point (a box's corner), a voxel's edge and SEEN_ERROR beyond it."""
        half = np.hypot(*kind.size[:2]) / 2 if kind.shape == "box" else kind.width / 2
        return float(half + self.voxels.resolution + SEEN_ERROR)

    def approach(
        self, target: Sighting, room: Room | None = None
    ) -> Generator[None, None, Sighting]:
        """Drive to a work site (in `room`, the object's, when given) from which the arm
        reaches the object, looking at it again from the staging pose on the way; the
        sighting, refreshed."""
        kind = target.kind
        if kind.grip_width > 2 * abs(self.finger_open - self.finger_closed) - 0.005:
            raise SkillFailed(
                "no_grasp_pose",
                f"the {kind.name} is {100 * kind.grip_width:.1f} cm across; the gripper "
                f"opens {200 * abs(self.finger_open - self.finger_closed):.1f} cm",
            )
        candidates = self.base_candidates(target.position[:2], room=room)
        if not candidates:
            reason = self._out_of_reach(target.position[:2], kind.name, room)
            raise SkillFailed("no_base_pose", reason)
        failed: list[np.ndarray] = []
        reached = checked = 0
        for base, stage in candidates:
            if self._near_failed(stage, failed):
                continue
            if checked == SITE_CHECKS:
                break
            checked += 1
            if self._reaches(base, target.position, kind, target.face) is None:
                continue
            reached += 1
            if not (yield from self.reach_stage(stage, f"the pose before the {kind.name}", failed)):
                continue
            seen = self._find(self.look(), target)
            if seen is not None:
                target = seen
            yield from self.drive_in(base)
            return target
        gave_up = f"; the navigator gave up on the way to {len(failed)}" if failed else ""
        arm = "" if reached else f" ({self._arm_reach()})"
        raise SkillFailed(
            "no_base_pose",
            f"the arm reaches the {kind.name} from {reached or 'none'} of the "
            f"{checked} free base poses tried around it{arm}{gave_up}",
        )

    def _find(self, look: Look, target: Sighting) -> Sighting | None:
        """The sighting of `target` in a new look: the same kind near where it was."""
        near = [
            s
            for s in look.sightings
            if np.hypot(*(s.position[:2] - target.position[:2])) < SAME_OBJECT
        ]
        same = [s for s in near if s.kind.name == target.kind.name]
        if same:
            return min(same, key=lambda s: np.hypot(*(s.position[:2] - target.position[:2])))
        if near:
            raise SkillFailed(
                "misclassified",
                f"what was taken for the {target.kind.name} from afar is a {near[0].kind.name} "
                "up close",
            )
        return None

    def _look_back(self, target: Sighting) -> Generator[None, None, Sighting | None]:
        """Back up and look again, then drive back in: an object classified from the
        staging pose can come out unclassified up close (a can 0.7 m ahead, seen from
        above, measured 10 cm across instead of 6.6: more of the table around it joined
        its cluster)."""
        for back in LOOK_BACK:
            yield from self.straight(-back)
            base = yield from self.docked_pose()
            seen = self._find(self.look(base, NEAR_LOOK), target)
            yield from self.straight(back)
            if seen is not None:
                return seen
        return None

    def pick(self, target: Sighting) -> Iterator[None]:
        """Grasp the object from the work site, by friction, lift it, back out, and hold
        it in the carry pose."""
        for moves in range(len(REACHES) + 1):
            base = yield from self.docked_pose()
            seen = self._find(self.look(base, NEAR_LOOK), target)
            if seen is None:
                seen = yield from self._look_back(target)
                base = yield from self.docked_pose()
            if seen is None:
                raise SkillFailed(
                    "not_seen",
                    f"the {target.kind.name} seen from the approach is not in view at the "
                    f"work site, nor from {100 * LOOK_BACK[-1]:.0f} cm behind it",
                )
            way = self._reaches(base, seen.position, seen.kind, seen.face)
            if moves == len(REACHES) or way is not None:
                break
            yield from self._reach(to_base(base, seen.position), base, seen.kind, seen.face)
            target = seen
        kind = seen.kind
        self.log.target = seen.position.copy()
        local = to_base(base, seen.position)
        keep_out = self._keep_out(local, kind)
        if way is None:  # tried anyway: level, the lift where it serves this top best
            top = float(seen.position[2]) - kind.height / 2
            way = Way(0.0, lift_order(top, self.lifts, float(self.shoulder[2]))[0])
        pitch = way.pitch
        yield from self.move_lift(way.lift)
        face = None if seen.face is None else seen.face - float(base[2])
        pre, grasp = self._grasp_points(local, kind, pitch, face)
        orientation = self.orientation(local, pitch, face)
        self.robot.grip(self.finger_open, self.robot.setup.grip_force)
        yield from self.move_arm(base, "no_grasp_pose", pre, orientation, keep_out=keep_out)
        # the lift's and the arm's motions can turn the base a little (0.3 degrees put the
        # hand 6 mm aside at 1 m, more than the 5 mm the fingers open wider than a can):
        # the grasp from the base's pose measured again
        now = yield from self.docked_pose()
        if np.linalg.norm(to_base(now, seen.position) - local) > BASE_SHIFT:
            log.info("the base moved %s before the grasp", np.round(now - base, 4).tolist())
            base, local = now, to_base(now, seen.position)
            face = None if seen.face is None else seen.face - float(base[2])
            _, grasp = self._grasp_points(local, kind, pitch, face)
            orientation = self.orientation(local, pitch, face)
        yield from self.move_arm(
            base, "no_grasp_pose", grasp, orientation, keep_out=keep_out, straight=True
        )
        width = yield from self.close()
        if width < kind.grip_width - GRIP_SLACK:
            raise SkillFailed(
                "grasp_missed",
                f"the fingers closed to {100 * width:.1f} cm; the {kind.name} is "
                f"{100 * kind.grip_width:.1f} cm across",
            )
        # the object's centre in the hand: where the grasp put the hand around the seen
        # centre, centred between the fingers (they close symmetrically)
        tcp = self.planner.kin.link_pose(self.arm_q())
        centre = np.linalg.inv(tcp) @ np.append(local, 1.0)
        in_hand = centre[:3].copy()
        in_hand[1] = 0.0
        self.held = Held(kind, in_hand, width, pitch)
        self.log.grasp = (
            f"by friction: the fingers closed on the {kind.name} with "
            f"{self.robot.setup.grip_force:g} N at {100 * width:.1f} cm; it sits "
            f"{100 * in_hand[2]:.1f} cm beyond the tool point"
        )
        self.voxels.remove(seen.position, self._object_radius(kind), (-1.0, 5.0))
        # the object rests on the top until it is lifted: the lift starts there
        lift_keep_out = self._keep_out(local, kind, support=True)
        yield from self.move_arm(
            base,
            "arm_planning",
            self._lifted(grasp),
            orientation,
            keep_out=lift_keep_out,
            straight=True,
        )
        self.check_grip("lifting")
        yield from self.straight(-STANDOFF)
        yield from self.arm_to_pose("carry")
        self.check_grip("moving to the carry pose")
        yield from self.move_lift(0.0)
        self.check_grip("lowering the lift")

    def close(self) -> Generator[None, None, float]:
        """Close the fingers with the grip force until they stand still; the opening
        between them (m)."""
        self.robot.grip(self.finger_closed, self.robot.setup.grip_force)
        last, still = self.opening(), 0.0
        deadline = self.robot.now + 3.0
        while self.robot.now < deadline and still < GRIP_SETTLE:
            yield
            now = self.opening()
            still = still + 0.01 if abs(now - last) < 2e-4 else 0.0
            last = now
        return 2 * abs(self.opening() - self.finger_closed)

    def check_grip(self, doing: str) -> None:
        """Raise `slipped` when the fingers closed further than on the grasp (nothing
        between them any more)."""
        if self.held is None:
            return
        width = 2 * abs(self.opening() - self.finger_closed)
        if width < self.held.width - SLIP:
            kind = self.held.kind.name
            self.held = None
            raise SkillFailed(
                "slipped",
                f"the {kind} slipped out of the fingers while {doing} (they closed to "
                f"{100 * width:.1f} cm)",
            )

    # --- place -------------------------------------------------------------------------

    def carry_to(self, point: np.ndarray, room: Room | None = None) -> Generator[None, None, float]:
        """Drive to a work site (in `room`, the place's, when given) from which the held
        object can be set down at `point` (map x, y): look at the point from each staging
        pose to find the surface there and drive in when the arm reaches; the surface's
        height."""
        assert self.held is not None
        kind = self.held.kind
        candidates = self.base_candidates(point, room=room)
        if not candidates:
            raise SkillFailed("no_base_pose", "no free base pose on the map near the place")
        height = None
        tried = 0
        failed: list[np.ndarray] = []
        for base, stage in candidates:
            if self._near_failed(stage, failed):
                continue
            if height is not None:
                target = np.array([point[0], point[1], height + kind.height / 2])
                if self._reaches(base, target, kind) is None:
                    continue
            tried += 1
            if not (yield from self.reach_stage(stage, "the pose before the place", failed)):
                continue
            self.check_grip("carrying")
            surface = self._surface_at(self.look(), point)
            if surface is None:
                if tried >= 3:
                    break
                continue
            height = surface
            target = np.array([point[0], point[1], height + kind.height / 2])
            if self._reaches(base, target, kind) is not None:
                yield from self.drive_in(base)
                return height
        if height is None:
            raise SkillFailed("place_not_seen", "no surface was seen at the place point")
        raise SkillFailed(
            "no_base_pose",
            f"the arm reaches the place from none of the {len(candidates)} free base poses",
        )

    def measure_held(self) -> bool:
        """Where the held object sits and how it is turned in the hand, from the head
        camera: its pose fitted to the points seen of it, its top and sides, round where
        it should be (the robot's own body cut out close, 1 cm; `held.fit_held`); False
        (nothing changed) when too few are seen or no pose fits them."""
        held = self.held
        if held is None:
            return False
        kind = held.kind
        frame = self.robot.capture()
        pts, _ = frame.points(1)
        q = self.arm_q()
        tcp = self.planner.kin.link_pose(q)
        expected = self._held_pose(q)[:3, 3]
        reach = float(np.linalg.norm(kind.size)) / 2 + HELD_SEARCH
        pts = pts[np.linalg.norm(pts - expected, axis=1) < reach]
        pts = pts[~self.body.mask(pts, self.robot.joints, padding=HELD_CUT)]
        assert held.rotation is not None
        fit = fit_held(pts, kind, tcp, held.rotation, held.in_hand)
        if fit is None:
            log.info("held %s: no pose fits the %d points round it", kind.name, len(pts))
            return False
        centre = tcp[:3, :3] @ fit.centre + tcp[:3, 3]
        moved = float(np.linalg.norm(centre - expected))
        if moved > kind.width / 2:
            raise SkillFailed(
                "slipped",
                f"the {kind.name} moved {100 * moved:.1f} cm in the hand since the grasp "
                "(seen by the head camera by the place)",
            )
        held.in_hand, held.rotation = fit.centre, fit.rotation
        log.info(
            "held %s measured %.1f mm from where it was believed, turned %.1f deg in the hand "
            "(%d points, %.1f mm off its surface)",
            kind.name,
            1e3 * moved,
            np.rad2deg(fit.turn),
            fit.points,
            1e3 * fit.rms,
        )
        self.log.held_correction = moved
        return True

    def _surface_at(self, look: Look, point: np.ndarray) -> float | None:
        """The height (m) of the highest surface of a look that covers `point` (map)."""
        local = to_base(look.base, np.array([point[0], point[1], 0.0]))
        under = [s for s in look.surfaces if s.covers(local[None, :2])[0] and s.height > 0.05]
        if not under:
            return None
        return float(max(s.height_at(local[None, :2])[0] for s in under))

    def place(self, point: np.ndarray, height: float) -> Iterator[None]:
        """Set the held object down upright with the middle of its bottom over `point`
        (map x, y) on the surface at `height`, let go, and back out: measured in the hand
        by the head camera first (`_show_held`)."""
        held = self.held
        assert held is not None
        target = np.array([point[0], point[1], height + held.kind.height / 2])
        for moves in range(len(REACHES) + 1):
            base = yield from self.docked_pose()
            local = to_base(base, target)
            way = self._reaches(base, target, held.kind)
            if moves == len(REACHES) or way is not None:
                break
            yield from self._reach(local, base, held.kind)
        look = self.look(base)
        seen = self._surface_at(look, point)
        if seen is not None and abs(seen - height) < 0.03:
            target[2] = seen + held.kind.height / 2
            local = to_base(base, target)
        yield from self.move_lift(way.lift if way is not None else 0.0)
        # the camera's measure of the object in the hand; the hand pitched so that it
        # then stands upright comes first
        ways = [self.orientation(local, held.pitch)]
        if (yield from self._show_held(base, local)):
            assert held.rotation is not None
            pitch = upright_pitch(held.rotation, SIDE_GRASP.as_matrix())
            ways.insert(0, self.orientation(local, pitch))
        # straight down from where it was shown (the object creeps out of the fingers
        # with every motion held pitched), else by the point above the place
        for orientation in ways:
            hand = self._set_down_at(local, orientation)
            self.voxels.clear_body(self.body, base, self.robot.joints, self._held_shapes())
            obstacles = self._obstacles(base)
            res = self._release_plan(obstacles, hand, orientation)
            if res.success:
                break
            res = self.plan(self.arm_q(), obstacles, self._lifted(hand), orientation)
            if not res.success:
                continue
            yield from self.follow(res)
            self.check_grip("lowering it")
            res = self._release_plan(obstacles, hand, orientation)
            if res.success:
                break
        if not res.success:
            raise SkillFailed("arm_planning", f"arm planning: {res.message}")
        yield from self.follow(res)
        self.robot.grip(self.finger_open, self.robot.setup.grip_force)
        yield from self.wait(0.6)
        self.held = None
        self.voxels.remove(target, self._object_radius(held.kind), (-1.0, 5.0))
        back = hand - GRASP_BACKOFF * orientation.apply([0.0, 0.0, 1.0])
        res = self.plan(
            self.arm_q(), self._obstacles(base, self._keep_out(local, held.kind)), back, orientation
        )
        if not res.success:
            res = self.plan(
                self.arm_q(),
                self._obstacles(base, self._keep_out(local, held.kind)),
                self._lifted(hand),
                orientation,
            )
        if res.success:
            yield from self.follow(res)
        yield from self._set_again(held, target, base)
        yield from self.straight(-STANDOFF)

    def _set_again(self, held: Held, target: np.ndarray, base: np.ndarray) -> Iterator[None]:
        """Look at the object just set down (the arm folded out of view) and, when the
        camera sees it more than PLACE_CHECK off the point (`target`, its centre on the
        surface, map frame), grasp it where it stands and set it down again on the point,
        once. While held the object creeps along the fingers unseen (a cube shows the
        camera no face that says how far out it sits); on the top, the camera sees its
        centre to about 5 mm. The base's own pose error is the same in both, so it stays.
        When a motion of it is not found, the object stays where it was set down."""
        kind = held.kind
        try:
            yield from self.arm_to_pose("carry")
        except SkillFailed:
            return
        look = self.look(base, NEAR_LOOK)
        near = [
            s
            for s in look.sightings
            if s.kind.looks_like(kind) and np.hypot(*(s.position[:2] - target[:2])) < SAME_OBJECT
        ]
        if not near:
            return
        seen = min(near, key=lambda s: float(np.hypot(*(s.position[:2] - target[:2]))))
        off = float(np.hypot(*(seen.position[:2] - target[:2])))
        self.log.set_off = off
        if off <= PLACE_CHECK:
            return
        log.info("the %s stands %.1f cm off the place: set down again", kind.name, 100 * off)
        local = to_base(base, seen.position)
        face = None if seen.face is None else seen.face - float(base[2])
        pre, grasp = self._grasp_points(local, kind, held.pitch, face)
        orientation = self.orientation(local, held.pitch, face)
        try:
            yield from self.move_arm(
                base, "arm_planning", pre, orientation, keep_out=self._keep_out(local, kind)
            )
            yield from self.move_arm(
                base,
                "arm_planning",
                grasp,
                orientation,
                keep_out=self._keep_out(local, kind),
                straight=True,
            )
            width = yield from self.close()
            if width < kind.grip_width - GRIP_SLACK:
                raise SkillFailed("grasp_missed", "the fingers closed on nothing")
            tcp = self.planner.kin.link_pose(self.arm_q())
            in_hand = (np.linalg.inv(tcp) @ np.append(local, 1.0))[:3]
            in_hand[1] = 0.0
            self.held = Held(kind, in_hand, width, held.pitch)
            goal = to_base(base, target)
            hand = self._set_down_at(goal, orientation)
            # slid across the top 5 mm up: the object lifted off it, not dragged
            up = np.array([0.0, 0.0, RESET_LIFT])
            support = self._keep_out(local, kind, True) + self._keep_out(goal, kind, True)
            for point in (grasp + up, hand + up):
                yield from self.move_arm(
                    base, "arm_planning", point, orientation, keep_out=support, straight=True
                )
            self.log.set_again = True
        except SkillFailed as failed:
            log.info("the %s stays where it was set down: %s", kind.name, failed.reason)
        self.held = None
        self.robot.grip(self.finger_open, self.robot.setup.grip_force)
        yield from self.wait(0.6)
        back = self.planner.kin.link_pose(self.arm_q())[:3, 3] - GRASP_BACKOFF * orientation.apply(
            [0.0, 0.0, 1.0]
        )
        res = self.plan(
            self.arm_q(), self._obstacles(base, self._keep_out(local, kind)), back, orientation
        )
        if res.success:
            yield from self.follow(res)

    def _release_plan(self, obstacles: Obstacles, hand: np.ndarray, orientation: Rotation):
        """The arm's motion from where it is to let the held object go with the tool point
        at `hand`, or a little higher where the arm would graze the top there."""
        for drop in RELEASE_HEIGHTS:
            res = self.plan(self.arm_q(), obstacles, hand + np.array([0.0, 0.0, drop]), orientation)
            if res.success:
                break
        return res

    def _show_held(self, base: np.ndarray, local: np.ndarray) -> Generator[None, None, bool]:
        """Hold the object up beside the place (`local`, base frame), where the head
        camera sees it (held out straight ahead, the arm hides it from the head), and
        measure it in the hand there (`measure_held`); from where the arm is when it
        gets to neither side."""
        held = self.held
        assert held is not None
        for side in (SHOW_ASIDE, -SHOW_ASIDE):
            centre = local + np.array([0.0, side, SHOW_UP])
            orientation = self.orientation(centre, held.pitch)
            hand = centre - orientation.apply(held.in_hand)
            self.voxels.clear_body(self.body, base, self.robot.joints, self._held_shapes())
            res = self.plan(self.arm_q(), self._obstacles(base), hand, orientation)
            if res.success:
                yield from self.follow(res)
                self.check_grip("holding it up to the camera")
                break
        return self.measure_held()

    def _set_down_at(self, local: np.ndarray, orientation: Rotation) -> np.ndarray:
        """Where the tool point goes (base frame), the hand at `orientation`, to set the
        held object down with the middle of the face it comes to stand on over `local`
        (the object's centre standing upright, base frame) and its lowest point on the
        surface under it."""
        held = self.held
        assert held is not None and held.rotation is not None
        rot = orientation.as_matrix() @ held.rotation
        surface = local[2] - held.kind.height / 2
        centre = local - bottom(held.kind, rot)
        centre[2] = surface + lowest(held.kind, rot)
        return centre - orientation.apply(held.in_hand)

    def _reach(
        self, local: np.ndarray, base: np.ndarray, kind: ObjectKind, face: float | None = None
    ) -> Iterator[None]:
        """Drive straight so that the arm reaches `local` (base frame) at one of REACHES,
        when the docking left it a little far or too close."""
        ahead = float(np.hypot(local[0] - self.arm_offset, local[1]))
        target = compose(base, np.array([local[0], local[1], 0.0]))
        point = np.array([target[0], target[1], local[2]])
        for shift in (ahead - r for r in REACHES):
            if abs(shift) < 0.005:
                continue
            moved = compose(base, np.array([shift, 0.0, 0.0]))
            # a move nearer must leave the footprint clear of the top it faces: the arm's
            # reach alone would put the bumper on a counter
            if shift > 0 and self._footprint_clearance(moved, site=True) < BASE_CLEAR:
                continue
            if self._reaches(moved, point, kind, face) is not None:
                yield from self.straight(shift, speed=0.06)
                return


def site_clearance(
    values: np.ndarray, probability: np.ndarray, res: float, blocked: np.ndarray
) -> np.ndarray:
    """How far (m) each cell of the built map stands from what a work site keeps clear
    of: the `blocked` cells (occupied, 100 in `values`, or unknown) but for the occupied
    ones less sure than SURE next to one the map is sure of (`probability`)."""
    occupied = values == 100
    sure = occupied & (probability >= SURE)
    fringe = occupied & ~sure & ndimage.binary_dilation(sure, structure=np.ones((3, 3), bool))
    return ndimage.distance_transform_edt(~(blocked & ~fringe)) * res


def furniture_tops(
    occupied: np.ndarray, origin: np.ndarray, res: float, bounds
) -> list[np.ndarray]:
    """The pieces of furniture of a room on a built map: the connected occupied cells
    (`occupied`, rows y) inside the room's rectangle (`bounds`, map frame) shrunk by
    WALL_INSET, so its walls are left out, each of FURNITURE_CELLS cells or more; each
    piece as its cells' centres (N, 2)."""
    (x0, y0), (x1, y1) = bounds
    c0 = max(int(np.ceil((x0 + WALL_INSET - origin[0]) / res)), 0)
    r0 = max(int(np.ceil((y0 + WALL_INSET - origin[1]) / res)), 0)
    c1 = min(int(np.floor((x1 - WALL_INSET - origin[0]) / res)), occupied.shape[1])
    r1 = min(int(np.floor((y1 - WALL_INSET - origin[1]) / res)), occupied.shape[0])
    if c1 <= c0 or r1 <= r0:
        return []
    labels, n = ndimage.label(occupied[r0:r1, c0:c1], structure=np.ones((3, 3)))
    pieces = []
    for k in range(1, n + 1):
        rows, cols = np.nonzero(labels == k)
        if len(rows) >= FURNITURE_CELLS:
            xy = np.column_stack([cols + c0 + 0.5, rows + r0 + 0.5]) * res + origin
            pieces.append(xy)
    return pieces


def in_rect(xy: np.ndarray, rect: Room) -> bool:
    """Whether the point `xy` (x, y first) lies in the rectangle `rect`."""
    (x0, y0), (x1, y1) = rect
    return bool(x0 <= xy[0] <= x1 and y0 <= xy[1] <= y1)


def best_in_room(
    sightings: Sequence[Sighting],
    kind: ObjectKind,
    bounds: tuple[tuple[float, float], tuple[float, float]],
) -> Sighting | None:
    """The sighting of an object that looks like `kind` (the detector names one of twins
    for both) that best matches it among those whose centre lies in the room (`bounds`,
    map frame), or None: an object alike seen through a doorway in another room is not
    the one the order names."""
    inside = [s for s in sightings if s.kind.looks_like(kind) and in_rect(s.position, bounds)]
    return min(inside, key=lambda s: s.detection.error) if inside else None


def overlaps(piece: np.ndarray, rect: tuple[tuple[float, float], tuple[float, float]]) -> bool:
    """Whether any cell of a piece of furniture (N, 2) lies in a rectangle grown by
    ON_TOP (a named piece's outline on the plan, in the map frame)."""
    (x0, y0), (x1, y1) = rect
    inside = (
        (piece[:, 0] >= x0 - ON_TOP)
        & (piece[:, 0] <= x1 + ON_TOP)
        & (piece[:, 1] >= y0 - ON_TOP)
        & (piece[:, 1] <= y1 + ON_TOP)
    )
    return bool(inside.any())


def look_pose(
    piece: np.ndarray,
    clearance: np.ndarray,
    origin: np.ndarray,
    res: float,
    bounds,
    margin: float,
) -> np.ndarray | None:
    """A pose (map x, y, yaw) to look at a piece of furniture's top from: a cell of the
    room with `margin` of clearance, LOOK_AT from the piece's nearest cell (of those the
    one with the most clearance, so the base stops clear of everything), facing the
    piece's centre; None when the room has no such cell."""
    (x0, y0), (x1, y1) = bounds
    c0, r0 = max(int((x0 - origin[0]) / res), 0), max(int((y0 - origin[1]) / res), 0)
    c1 = min(int(np.ceil((x1 - origin[0]) / res)), clearance.shape[1])
    r1 = min(int(np.ceil((y1 - origin[1]) / res)), clearance.shape[0])
    rows, cols = np.nonzero(clearance[r0:r1, c0:c1] >= margin)
    if not len(rows):
        return None
    xy = np.column_stack([cols + c0 + 0.5, rows + r0 + 0.5]) * res + origin
    gap = np.min(np.linalg.norm(xy[:, None, :] - piece[None, ::4, :], axis=2), axis=1)
    ok = (gap >= LOOK_AT[0]) & (gap <= LOOK_AT[1])
    if not ok.any():
        return None
    room = clearance[r0:r1, c0:c1][rows, cols]
    i = int(np.flatnonzero(ok)[np.argmax(room[ok])])
    centre = piece.mean(axis=0)
    yaw = float(np.arctan2(centre[1] - xy[i, 1], centre[0] - xy[i, 0]))
    return np.array([xy[i, 0], xy[i, 1], yaw])


def arm_reach(planner: TaskPlanner) -> tuple[np.ndarray, float]:
    """Where the arm reaches from (its second joint, the shoulder, in the base frame) and
    how far (m): the tool point's farthest over random configurations, plus 5 cm of
    fingers beyond it."""
    kin = planner.kin
    zero = link_poses(kin.model, {})
    shoulder = zero[kin.model.joint(planner.joint_names[1]).child][:3, 3]
    tips = kin.fk(kin.random(np.random.default_rng(0), 400))
    tcp = tips[:, kin.link_index[kin.model.end_effector], :3, 3]
    return shoulder, float(np.max(np.linalg.norm(tcp - shoulder, axis=1))) + 0.05


def lift_order(top: float, lifts: Sequence[float], shoulder: float) -> list[float]:
    """The LIFT_TRIES heights of `lifts` a work site tries for a top `top` m high, in
    turn, the shoulder `shoulder` m up with the lift lowered: the one that puts the
    shoulder SHOULDER_OVER_TOP above the top first, then the nearer, the lower first."""
    best = top + SHOULDER_OVER_TOP - shoulder
    return sorted(lifts, key=lambda h: (round(abs(h - best), 6), h))[:LIFT_TRIES]


def to_base(base: np.ndarray, point: np.ndarray) -> np.ndarray:
    """A map-frame point (x, y, z) in the base frame of a base pose (x, y, yaw)."""
    d = compose(inverse(base), np.array([point[0], point[1], 0.0]))
    return np.array([d[0], d[1], point[2]])


def palm_depth(model, zero: dict[str, np.ndarray], tcp: str) -> float:
    """How far (m) in front of the tool point the palm reaches along the approach axis
    (negative: behind it): the hand link's collision shapes, the fingers excluded."""
    grip = model.metadata.get("gripper") or {}
    hand = str(grip.get("link") or "")
    if not hand:
        return 0.0
    inv = np.linalg.inv(zero[tcp])
    front = -np.inf
    for c in model.link(hand).collisions:
        m = inv @ zero[hand] @ c.origin.matrix()
        shape = c.geometry
        half = np.asarray(getattr(shape, "size", (0.0, 0.0, 0.0)), dtype=float) / 2
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        pts = (corners * half) @ m[:3, :3].T + m[:3, 3]
        front = max(front, float(pts[:, 2].max()))
    return front if np.isfinite(front) else 0.0
