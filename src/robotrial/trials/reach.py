"""What the arm reaches in a home: the arm part of a buyer's verdict (layer 5).

Every piece of furniture (a world body of kind `furniture`, an upright box or cylinder)
offers its top as a surface. Around it, the base parks: poses facing each side, and
side-on to it, its edge `STANDOFFS[0]` m from the furniture's (or the next of `STANDOFFS`
where the base cannot park so near), every `PARK_SPACING` m along the side (round a
cylinder, every `PARK_SPACING` m of its rim); a pose counts when the footprint is clear
there and the base can get there from the dock (`nav/reachable.py`: the free component
of the dock's (x, y, yaw) space). From each such pose the hand is asked to reach points
`HOVER` m above the surface on a `SPACING` m grid (`planning/reach.py`: IK seeded from a
bank of the arm's configurations, each solution checked against the furniture, walls and
floor with the arm's collision spheres). A point's heat is the number of parked poses
that reach it; a surface's share is the part of its points reached at all.

Heights: with the base in the open, the hand is asked to reach points straight ahead of
the base's front edge (`AHEAD`), every `HEIGHT_STEP` m from the floor up; the lowest and
highest reached say which shelves the arm can serve.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robotrial.collision.sphere_model import CollisionChecker, Environment
from robotrial.geometry import Box, Cylinder, Pose, Sphere
from robotrial.kinematics.chain import Kinematics, default_planning_joints
from robotrial.model.robot import RobotModel
from robotrial.model.world import Obstacle, World
from robotrial.nav.costmap import Footprint
from robotrial.nav.reachable import ReachablePoses
from robotrial.planning.reach import SEED_GAP, ReachBank, reached
from robotrial.planning.task import FLOOR_THICKNESS, robot_spheres

SPACING = 0.05  # m between the points asked on a surface
HOVER = 0.05  # m above the surface: where the hand holds a small object set down there
STANDOFFS = (0.1, 0.25)  # m between the base's edge and the furniture's when parked
PARK_SPACING = 0.3  # m between parked poses along a side
AHEAD = (0.05, 0.15, 0.3)  # m ahead of the base's front edge, for the height sweep
HEIGHT_STEP = 0.02  # m
TOP_HEIGHT = 2.5  # m, the highest point asked in the height sweep
YES, PARTLY = 0.5, 0.0  # share of a surface above which the verdict is yes, partly
NEARBY = 1.6  # m: static bodies this near a parked base enter the arm's collision scene
NO_ARM = "no arm: reach not checked"
# arm configurations that seed the IK: against full IK (96 random starts) on 1,025 points
# near the apartment's furniture, 40,000 missed 15 of the 95 points it reached, 120,000
# missed 9 (and reached 2 that full IK did not)
BANK = 120_000


@dataclass
class Surface:
    """A furniture top: `pose` (4x4) of its centre (z the top, upright, the body's yaw),
    `size` (x, y) edge lengths in that frame for a box, or `radius` for a round top."""

    name: str
    pose: np.ndarray
    size: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0

    @property
    def height(self) -> float:
        return float(self.pose[2, 3])

    @property
    def area(self) -> float:
        return np.pi * self.radius**2 if self.radius else self.size[0] * self.size[1]

    def local_points(self, spacing: float = SPACING) -> np.ndarray:
        """(N, 2) grid points on the top in its own frame, cell centres `spacing` apart."""
        half = (self.radius, self.radius) if self.radius else (self.size[0] / 2, self.size[1] / 2)
        axes = [
            np.linspace(-h + spacing / 2, h - spacing / 2, max(1, round(2 * h / spacing)))
            for h in half
        ]
        xx, yy = np.meshgrid(*axes, indexing="ij")
        pts = np.column_stack([xx.ravel(), yy.ravel()])
        if self.radius:
            pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= self.radius]
        return pts

    def to_world(self, local: np.ndarray, dz: float = 0.0) -> np.ndarray:
        """(N, 3) world points of local (N, 2) points, `dz` m above the top."""
        p = np.column_stack([local, np.full(len(local), dz), np.ones(len(local))])
        return (p @ self.pose.T)[:, :3]

    def outline(self) -> np.ndarray:
        """(K, 2) world x, y of the top's outline (closed)."""
        if self.radius:
            a = np.linspace(0, 2 * np.pi, 41)
            local = self.radius * np.column_stack([np.cos(a), np.sin(a)])
        else:
            hx, hy = self.size[0] / 2, self.size[1] / 2
            local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]])
        return self.to_world(local)[:, :2]


def surfaces(world: World) -> list[Surface]:
    """The tops of the world's furniture (upright boxes and cylinders)."""
    out = []
    for ob in world.obstacles:
        if ob.kind != "furniture":
            continue
        m = ob.pose.matrix()
        if m[2, 2] < 0.999:  # tipped over: no flat top to speak of
            continue
        g = ob.geometry
        yaw = float(np.arctan2(m[1, 0], m[0, 0]))
        if isinstance(g, Box):
            top = Pose.from_xy_yaw(m[0, 3], m[1, 3], yaw, m[2, 3] + g.size[2] / 2).matrix()
            out.append(Surface(ob.name, top, size=(float(g.size[0]), float(g.size[1]))))
        elif isinstance(g, Cylinder):
            top = Pose.from_xy_yaw(m[0, 3], m[1, 3], yaw, m[2, 3] + g.length / 2).matrix()
            out.append(Surface(ob.name, top, radius=float(g.radius)))
    return out


def parking_poses(surface: Surface, footprint: Footprint) -> np.ndarray:
    """(len(STANDOFFS), N, 3) base poses (x, y, yaw) around the surface: N places facing
    it and side-on (either side), the base's edge at each of `STANDOFFS` m from the
    furniture's (a place is used at its first standoff where the base can park)."""
    return np.stack([_parking(surface, footprint, gap) for gap in STANDOFFS])


def first_usable(poses: np.ndarray, reachable: ReachablePoses) -> np.ndarray:
    """(M, 3): each place's pose at the first standoff the base can get to (places where
    it can get to none are left out)."""
    ok = reachable.contains(poses.reshape(-1, 3)).reshape(poses.shape[:2])
    first = np.argmax(ok, axis=0)
    keep = ok.any(axis=0)
    return poses[first[keep], np.flatnonzero(keep)]


def _parking(surface: Surface, footprint: Footprint, gap: float) -> np.ndarray:
    facing_d = footprint.length / 2 + gap
    side_d = footprint.width / 2 + gap
    rows = []
    if surface.radius:
        n = max(8, int(np.ceil(2 * np.pi * surface.radius / PARK_SPACING)))
        for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
            normal = np.array([np.cos(a), np.sin(a)])
            rows.append((*(normal * (surface.radius + facing_d)), a + np.pi))
            for turn in (np.pi / 2, -np.pi / 2):
                rows.append((*(normal * (surface.radius + side_d)), a + np.pi + turn))
    else:
        hx, hy = surface.size[0] / 2, surface.size[1] / 2
        for normal, along, depth, half in (
            ((1, 0), (0, 1), hx, hy),
            ((-1, 0), (0, 1), hx, hy),
            ((0, 1), (1, 0), hy, hx),
            ((0, -1), (1, 0), hy, hx),
        ):
            n_, u = np.array(normal, float), np.array(along, float)
            a = float(np.arctan2(n_[1], n_[0]))
            count = max(1, int(np.ceil(2 * half / PARK_SPACING)))
            for s in np.linspace(-half, half, count + 2)[1:-1] if count > 1 else [0.0]:
                rows.append((*(n_ * (depth + facing_d) + u * s), a + np.pi))
                for turn in (np.pi / 2, -np.pi / 2):
                    rows.append((*(n_ * (depth + side_d) + u * s), a + np.pi + turn))
    local = np.array(rows, dtype=float).reshape(-1, 3)
    m = surface.pose
    yaw = float(np.arctan2(m[1, 0], m[0, 0]))
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.empty_like(local)
    out[:, 0] = m[0, 3] + c * local[:, 0] - s * local[:, 1]
    out[:, 1] = m[1, 3] + s * local[:, 0] + c * local[:, 1]
    out[:, 2] = (local[:, 2] + yaw + np.pi) % (2 * np.pi) - np.pi
    return out


@dataclass
class SurfaceReach:
    """One surface: its top's height (m) and area (m^2), the room it stands in, the part
    of its points the hand reaches (`share`), the verdict (yes, partly, no), how many
    parked poses were usable, why nothing was reached; the heat map (`points` (N, 2)
    world x, y, `heat` (N,) parked poses reaching each)."""

    surface: str
    room: str
    height: float
    area: float
    share: float
    verdict: str
    parked: int
    reason: str = ""
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), repr=False)
    heat: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int), repr=False)
    outline: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), repr=False)
    park: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    yaw: float = 0.0  # rad, the top's orientation: its grid runs along it

    def squares(self) -> np.ndarray:
        """(N, 4, 2) world corners of each point's grid cell, for drawing the heat map."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        h = SPACING / 2
        corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]]) @ np.array([[c, s], [-s, c]])
        return self.points[:, None, :] + corners[None]

    def to_dict(self) -> dict[str, Any]:
        return {
            "surface": self.surface,
            "room": self.room,
            "height": round(self.height, 3),
            "area": round(self.area, 3),
            "share": round(self.share, 3),
            "verdict": self.verdict,
            "parked": self.parked,
            "reason": self.reason,
            "heat_map": {
                "spacing": SPACING,
                "xy": np.round(self.points, 3).tolist(),
                "poses": self.heat.astype(int).tolist(),
            },
        }


@dataclass
class HeightReach:
    """The height sweep: for each distance ahead of the front edge (m), the lowest and
    highest points (m above the floor) the hand reaches, None when none."""

    ahead: list[float]
    lowest: list[float | None]
    highest: list[float | None]

    @property
    def span(self) -> tuple[float, float] | None:
        lo = [v for v in self.lowest if v is not None]
        hi = [v for v in self.highest if v is not None]
        return (min(lo), max(hi)) if lo else None

    def to_dict(self) -> dict[str, Any]:
        span = self.span
        return {
            "ahead": self.ahead,
            "lowest": self.lowest,
            "highest": self.highest,
            "span": None if span is None else list(span),
        }


@dataclass
class ReachVerdict:
    """The arm part: checked or why not, every surface, the height sweep, seconds."""

    checked: bool
    reason: str = ""
    surfaces: list[SurfaceReach] = field(default_factory=list)
    heights: HeightReach | None = None
    seconds: float = 0.0

    @property
    def summary(self) -> str:
        if not self.checked:
            return self.reason
        if not self.surfaces:
            return "reaches: no furniture to reach"
        parts = []
        yes = [s.surface for s in self.surfaces if s.verdict == "yes"]
        if yes:
            parts.append(f"{', '.join(yes)} yes")
        partly = sorted((s for s in self.surfaces if s.verdict == "partly"), key=lambda s: -s.share)
        if partly:
            parts.append(", ".join(f"{s.surface} {100 * s.share:.0f} %" for s in partly))
        no = [s.surface for s in self.surfaces if s.verdict == "no"]
        if no:
            parts.append(f"{', '.join(no)} no")
        return "reaches: " + "; ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {
            "checked": self.checked,
            "reason": self.reason,
            "summary": self.summary,
            "surfaces": [s.to_dict() for s in self.surfaces],
            "heights": None if self.heights is None else self.heights.to_dict(),
            "seconds": round(self.seconds, 3),
        }


def arm_joints(robot: RobotModel) -> list[str]:
    """The arm's planning joints, none for a robot without an arm."""
    try:
        return default_planning_joints(robot)
    except (KeyError, ValueError):
        return []


class ArmReach:
    """One arm's reach questions: its kinematics, collision spheres and seed bank, built
    once and asked for many base poses."""

    def __init__(self, robot: RobotModel, footprint: Footprint) -> None:
        self.robot = robot
        self.footprint = footprint
        self.kin = Kinematics(robot, arm_joints(robot))
        self.spheres = robot_spheres(self.kin)
        self.bank = ReachBank(self.kin, CollisionChecker(self.spheres, Environment()), samples=BANK)

    def checker(self, world: World | None, base: np.ndarray) -> CollisionChecker:
        """The arm's checker with the base at (x, y, yaw): the floor and the static bodies
        near it, in the base frame."""
        inv = np.linalg.inv(Pose.from_xy_yaw(*base).matrix())
        env = Environment()
        size = (20.0, 20.0) if world is None else world.floor.size
        height = 0.0 if world is None else world.floor.height
        floor = Pose((0.0, 0.0, height - FLOOR_THICKNESS / 2))
        env.add("floor", Box((*size, FLOOR_THICKNESS)), inv @ floor.matrix())
        for ob in () if world is None else world.static_bodies:
            if _plan_distance(ob, base[:2]) <= NEARBY:
                env.add(ob.name, ob.geometry, inv @ ob.pose.matrix())
        return CollisionChecker(self.spheres, env)

    def surface(self, world: World, s: Surface, reachable: ReachablePoses) -> SurfaceReach:
        """The heat map of one surface from the parked poses the base can get to."""
        local = s.local_points()
        world_pts = s.to_world(local, HOVER)
        poses = parking_poses(s, self.footprint)
        usable = first_usable(poses, reachable)
        heat = np.zeros(len(local), dtype=int)
        for base in usable:
            inv = np.linalg.inv(Pose.from_xy_yaw(*base).matrix())
            pts = world_pts @ inv[:3, :3].T + inv[:3, 3]
            near = self.bank.tree.query(pts, k=1, distance_upper_bound=SEED_GAP)[0] < np.inf
            if not near.any():
                continue
            hit = reached(self.bank, self.checker(world, base), pts[near])
            heat[np.flatnonzero(near)[hit]] += 1
        share = float(np.mean(heat > 0)) if len(heat) else 0.0
        verdict = "yes" if share >= YES else "partly" if share > PARTLY else "no"
        reason = ""
        if share == 0.0:
            if len(usable) == 0 and not reachable.clear(poses.reshape(-1, 3)).any():
                reason = "the base cannot park next to it (no clear pose)"
            elif len(usable) == 0:
                reason = "the base cannot get next to it from the dock"
            else:
                reason = f"out of the arm's reach from {len(usable)} parked poses"
        room = next((r.name for r in world.rooms if r.contains(s.pose[0, 3], s.pose[1, 3])), "")
        return SurfaceReach(
            s.name,
            room,
            s.height,
            s.area,
            share,
            verdict,
            len(usable),
            reason,
            s.to_world(local)[:, :2],
            heat,
            s.outline(),
            usable,
            float(np.arctan2(s.pose[1, 0], s.pose[0, 0])),
        )

    def heights(self) -> HeightReach:
        """The height sweep ahead of the base standing in the open."""
        front = self.footprint.length / 2
        zs = np.arange(0.0, TOP_HEIGHT + 1e-9, HEIGHT_STEP)
        checker = self.checker(None, np.zeros(3))
        lowest: list[float | None] = []
        highest: list[float | None] = []
        for d in AHEAD:
            pts = np.column_stack([np.full(len(zs), front + d), np.zeros(len(zs)), zs])
            hit = reached(self.bank, checker, pts)
            lowest.append(round(float(zs[hit].min()), 3) if hit.any() else None)
            highest.append(round(float(zs[hit].max()), 3) if hit.any() else None)
        return HeightReach(list(AHEAD), lowest, highest)


def _plan_distance(ob: Obstacle, xy: np.ndarray) -> float:
    """A lower bound of the distance (m) in the plane from `xy` to a body."""
    g = ob.geometry
    if isinstance(g, Box):
        r = 0.5 * float(np.hypot(g.size[0], g.size[1]))
    elif isinstance(g, (Cylinder, Sphere)):
        r = float(g.radius)
    else:  # a mesh: its extent is not at hand, so it always counts as near
        return 0.0
    return max(0.0, float(np.hypot(*(np.asarray(ob.pose.xyz[:2]) - xy))) - r)


def check_reach(
    world: World,
    robot: RobotModel,
    footprint: Footprint,
    reachable: ReachablePoses | None,
    progress: Callable[[float, str], None] | None = None,
) -> ReachVerdict:
    """The arm part of the verdict (see the module doc) from the base poses `reachable`
    from the dock; a robot without an arm gets `NO_ARM`, not an error."""
    t0 = time.perf_counter()
    if not arm_joints(robot):
        return ReachVerdict(False, NO_ARM)
    if reachable is None:
        raise ValueError(f"robot {robot.name!r} has an arm: the reach needs its parking poses")
    arm = ArmReach(robot, footprint)
    tops = surfaces(world)
    out = []
    for i, s in enumerate(tops):
        if progress is not None:
            progress(i / (len(tops) + 1), f"reach: {s.name}")
        out.append(arm.surface(world, s, reachable))
    if progress is not None:
        progress(len(tops) / (len(tops) + 1), "reach: heights")
    heights = arm.heights()
    return ReachVerdict(True, "", out, heights, time.perf_counter() - t0)
