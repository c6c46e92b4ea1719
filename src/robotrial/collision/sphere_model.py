"""The planner's collision model: robot spheres, self-collision pairs, environment shapes.

Layer 2. `RobotSpheres` is what a robot contributes once (its link spheres, which link
pairs can ever collide, the joint-space check resolution); `Environment` holds the
obstacles of one request as boxes, cylinders and spheres with any orientation;
`CollisionChecker` joins them, with an optional object held in the hand and a padding,
and answers the planners' batched questions `valid(qs)` and `motion_valid(a, b)`.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from robotrial.collision import kernels
from robotrial.collision.self_pairs import rigid_groups, self_collision_pairs
from robotrial.collision.spheres import (
    inscribed_radii,
    link_fine_spheres,
    link_spheres,
    shape_spheres,
)
from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
from robotrial.kinematics.chain import PRISMATIC, Kinematics
from robotrial.model.robot import CollisionSphere

OBJECT = "object"  # the body name of the object held in the hand
WALL_SAMPLES = 512  # grid values of a joint's range where its walls are looked for
SHAPES_KEPT = 16384  # (body, shape) answers of `RobotSpheres.reach_into` kept per robot


@dataclass(frozen=True)
class Wall:
    """Values `low`..`high` of planning joint `joint` (an index) that no motion passes:
    at each of them `body`, which no other planning joint moves, is inside `obstacle`
    (its fine cover, by more than it moves between grid values). `sure` when the link
    itself is, somewhere in the range (the balls it holds inside its shapes are:
    `RobotSpheres.inner_body`); else it may pass closer than `bulge` (m: how far its fine
    spheres stand out of it, at most) without touching, which the planner's spheres do
    not tell apart from a contact. (The walls of links two planning joints move,
    `CollisionChecker._pair_walls`, are taken as sure.)"""

    joint: int
    low: float
    high: float
    body: str
    obstacle: str
    sure: bool = True
    bulge: float = 0.0

    def crossed(self, a: np.ndarray, qs: np.ndarray) -> np.ndarray:
        """(N,) bool: which configurations of `qs` (N, d) a motion from `a` reaches only
        through this wall."""
        lo = np.minimum(qs[:, self.joint], a[self.joint])
        hi = np.maximum(qs[:, self.joint], a[self.joint])
        return (lo <= self.high) & (hi >= self.low)


@dataclass(frozen=True)
class Body:
    """A named rigid set of spheres on link `link` (centres in that link's frame), and
    optionally a finer cover of the same shapes, asked where the first one touches an
    obstacle (see `link_fine_spheres`), with the radius of the ball the link holds around
    each of its centres (`inscribed_radii`)."""

    name: str
    link: str
    centres: np.ndarray
    radii: np.ndarray
    fine_centres: np.ndarray | None = None
    fine_radii: np.ndarray | None = None
    fine_inner: np.ndarray | None = None


class RobotSpheres:
    """A robot's side of the collision model, computed once per robot and joint group.

    Link pairs are disabled the way MoveIt's Setup Assistant does it, over `samples`
    random configurations (collision/self_pairs.py): `reasons` says why for each.

    `spheres` cover the links (default `link_spheres`); `fine`, a tighter cover asked
    only where those touch an obstacle (default `link_fine_spheres` when `spheres` is
    not given, else none): those of the links one planning joint moves made here (the
    walls of any request's obstacles ask them), the others on first use by `refine()`,
    link by link (0.1-0.3 s each): a request makes those of the links its start
    touches with. A given `fine` cover stands for the links' shapes (walls take its
    spheres whole, not shrunk to what the shapes hold: `inner_body`). `fine_self`
    names the links of close pairs (`self_pairs.CLOSE`: pairs whose spheres touch where
    the links do not, as a forearm passing a wrist): every check asks their fine
    covers, once made, where their coarse spheres touch another link's.
    """

    def __init__(
        self,
        kin: Kinematics,
        spheres: Sequence[CollisionSphere] | None = None,
        samples: int = 3000,
        seed: int = 0,
        step: float = 0.015,
        fine: Sequence[CollisionSphere] | None = None,
    ) -> None:
        self.kin = kin
        sph = list(spheres) if spheres is not None else link_spheres(kin.model)
        by_link = _by_link(sph)
        self.bodies: list[Body] = [
            Body(name, name, *_arrays(by_link[name])) for name in kin.link_names if name in by_link
        ]
        self._fine: Sequence[CollisionSphere] | None = fine
        self.has_fine = fine is not None or spheres is None
        self.refined = False
        # what every checker of this robot computes alike, by (what, body, padding):
        # a request builds a checker, and these took half its time
        self._memo: dict[tuple, Any] = {}
        self._shapes: OrderedDict[tuple, tuple[bool, np.ndarray]] = OrderedDict()
        self.disabled, self.reasons, self.close = self._disable_pairs(samples, seed)
        self.fine_self: set[str] = set()
        if self.has_fine:
            self.fine_self = {link for pair in self.close for link in pair}
        self.step = float(step)
        self.resolution = self._resolution(step, seed)
        # a request's obstacle near a link one planning joint moves makes `walls` ask
        # its fine cover: made with the robot, not in a request (0.1-0.3 s a link)
        if self.has_fine:
            self._add_fine(self._one_joint_links())
        self._sweep_ahead(self._one_joint_links())

    def fine_body(self, name: str) -> Body | None:
        """The body `name` with its fine cover as its spheres (named "... (fine)"), or
        None while that cover is not made."""
        own = next(b for b in self.bodies if b.name == name)
        if own.fine_centres is None:
            return None
        return replace(
            own, name=f"{own.name} (fine)", centres=own.fine_centres, radii=own.fine_radii
        )

    def inner_body(self, name: str) -> Body | None:
        """The body `name` as the balls its link surely holds: its fine spheres, each
        shrunk by how far it stands out of the link (named "... (inner)"); where they
        reach into something, the link does. None while its fine cover is not made."""
        own = next(b for b in self.bodies if b.name == name)
        if own.fine_centres is None or own.fine_inner is None:
            return None
        keep = own.fine_inner > 0.0
        return replace(
            own,
            name=f"{own.name} (inner)",
            centres=own.fine_centres[keep],
            radii=own.fine_inner[keep],
            fine_centres=None,
            fine_radii=None,
            fine_inner=None,
        )

    def refine(self, links: Collection[str] | None = None) -> None:
        """Give the bodies of `links` (default: every body) their fine covers (made here
        unless given), once each."""
        if self.refined or not self.has_fine:
            return
        wanted = None if links is None else set(links)
        self._add_fine(
            {
                b.link
                for b in self.bodies
                if b.fine_centres is None and (wanted is None or b.link in wanted)
            }
        )
        self.refined = all(b.fine_centres is not None for b in self.bodies)

    def fine_links(self) -> frozenset[str]:
        """The links whose fine covers are made."""
        return frozenset(b.link for b in self.bodies if b.fine_centres is not None)

    def _add_fine(self, links: set[str]) -> None:
        """Give the bodies of `links` their fine covers."""
        if not links:
            return
        given = self._fine is not None
        fine = self._fine if given else link_fine_spheres(self.kin.model, links)
        by_link = _by_link(s for s in fine if s.link in links)
        # given spheres stand for the links' shapes: nothing of them stands out
        inner = {
            link: _arrays(group)[1] if given else inscribed_radii(self.kin.model, group)
            for link, group in by_link.items()
        }
        self.bodies = [
            replace(b, fine_centres=centres, fine_radii=radii, fine_inner=inner.get(b.link))
            if b.link in links
            else b
            for b in self.bodies
            for centres, radii in [_arrays(by_link.get(b.link))]
        ]

    def _one_joint_links(self) -> set[str]:
        """The links of bodies exactly one planning joint moves (a torso's lift carrying
        the other arm and the head)."""
        kin = self.kin
        joints = kin.ancestors & (kin.src >= 0)[None, :]
        return {
            b.link
            for b in self.bodies
            if len(set(kin.src[joints[kin.link_index[b.link]]].tolist())) == 1
        }

    def _rigid_group(self) -> np.ndarray:
        """Index of the rigid group of each link: links no planning joint separates."""
        return rigid_groups(self.kin)

    def _disable_pairs(
        self, samples: int, seed: int
    ) -> tuple[set[tuple[str, str]], dict, set[tuple[str, str]]]:
        """The self-collision matrix (collision/self_pairs.py): pairs left out, why, and
        the close pairs."""
        reasons, close = self_collision_pairs(
            self.kin,
            [b.link for b in self.bodies],
            [(b.centres, b.radii) for b in self.bodies],
            samples,
            seed,
        )
        return set(reasons), reasons, close

    def _reach(self, poses: np.ndarray) -> None:
        """`origin`: the root's position; `reach`: how far from it any moving sphere
        gets (sampled maximum plus a margin), to drop unreachable obstacles."""
        kin = self.kin
        self.origin = poses[0, 0, :3, 3].copy()
        far = 0.0
        for b in self.bodies:
            lb = kin.link_index[b.link]
            m = poses[:, lb]
            world = _placed(m, b.centres)
            far = max(far, float(np.max(np.linalg.norm(world - self.origin, axis=-1) + b.radii)))
        self.reach = 1.1 * far + 0.05

    def _resolution(self, step: float, seed: int) -> np.ndarray:
        """Joint steps (rad or m) such that one joint moving one step moves no sphere
        surface point farther than `step` metres."""
        kin = self.kin
        rng = np.random.default_rng(seed)
        qs = kin.random(rng, 200)
        poses = kin.fk(qs)
        self._reach(poses)
        self._poses = poses
        lever = np.full(kin.d, 1e-3)
        for k in range(len(kin.link_names)):
            s = kin.src[k]
            if s < 0:
                continue
            if kin.jtype[k] == PRISMATIC:
                lever[s] = max(lever[s], abs(kin.mult[k]))
                continue
            for b in self.bodies:
                lb = kin.link_index[b.link]
                if not kin.ancestors[lb, k]:
                    continue
                m = poses[:, lb]
                world = _placed(m, b.centres)
                # from the joint's origin, not its axis: a finer grid than the travel needs
                r = np.linalg.norm(world - poses[:, k, None, :3, 3], axis=-1) + b.radii
                lever[s] = max(lever[s], float(r.max()) * abs(kin.mult[k]))
        # the sampled maximum may miss the true one by a little: keep a margin
        return step / (1.1 * lever)

    def arms(self, body: Body, padding: float = 0.0) -> np.ndarray:
        """(links,) how far a surface point of `body` (spheres grown by `padding`) may move
        per unit of each link's joint: the farthest it gets from the joint's axis (the
        sampled maximum plus 10 %) for a revolute joint, 1 for a prismatic one, 0 for
        joints that do not move it. Times |mult| (mimic joints)."""
        kin = self.kin
        levers = self._levers(body)
        moved = (kin.src >= 0) & kin.ancestors[kin.link_index[body.link]]
        out = np.where(kin.jtype == PRISMATIC, 1.0, 1.1 * (levers + padding)) * np.abs(kin.mult)
        return np.where(moved, out, 0.0)

    def _levers(self, body: Body) -> np.ndarray:
        """(links,) the farthest a surface point of `body` gets from each joint's axis over
        the sampled configurations (0 for joints that do not move it): `arms` less its
        padding and margin, kept per body."""
        key = ("levers", body.name)
        if body.name != OBJECT and key in self._memo:
            return self._memo[key]
        kin = self.kin
        lb = kin.link_index[body.link]
        out = np.zeros(len(kin.link_names))
        world = _placed(self._poses[:, lb], body.centres)
        for k in range(len(kin.link_names)):
            if kin.src[k] < 0 or not kin.ancestors[lb, k] or kin.jtype[k] == PRISMATIC:
                continue
            u = self._poses[:, k, :3, :3] @ kin.axis[k]
            arm = np.cross(world - self._poses[:, k, None, :3, 3], u[:, None, :])
            out[k] = float((np.linalg.norm(arm, axis=-1) + body.radii).max())
        if body.name != OBJECT:
            self._memo[key] = out
        return out

    def sweep(
        self, body: Body, joints: np.ndarray, rates: np.ndarray, padding: float, samples: int
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """Where `body`'s spheres go while `joints` (one or two) sweep their ranges on a
        grid, the others at mid-range: the sphere centres (N, 3), their radii grown by
        `padding`, and how far a sphere may move between grid points (`rates`: the body's
        travel per unit of each planning joint)."""
        kin = self.kin
        qs, per = self._grid(joints, samples)
        key = ("sweep", body.name, samples, tuple(int(j) for j in joints))
        pts = self._memo.get(key) if body.name != OBJECT else None
        if pts is None:
            pts = self._place_on_grid(body, kin.fk(qs)[:, kin.link_index[body.link]], key)
        margin = sum(rates[j] * (kin.upper[j] - kin.lower[j]) / (per - 1) / 2 for j in joints)
        return pts, np.tile(body.radii, len(qs)) + padding, float(margin)

    def _grid(self, joints: np.ndarray, samples: int) -> tuple[np.ndarray, int]:
        """The configurations of `sweep`'s grid over `joints` (the others at mid-range) and
        how many values each joint takes."""
        kin = self.kin
        per = samples if len(joints) == 1 else int(np.sqrt(3 * samples))
        axes = [np.linspace(kin.lower[j], kin.upper[j], per) for j in joints]
        qs = np.tile(0.5 * (kin.lower + kin.upper), (per ** len(joints), 1))
        for j, values in zip(joints, np.meshgrid(*axes, indexing="ij"), strict=True):
            qs[:, j] = values.ravel()
        return qs, per

    def _place_on_grid(self, body: Body, poses: np.ndarray, key: tuple) -> np.ndarray:
        """`body`'s sphere centres placed by its link's `poses` on a grid, (N, 3); kept
        under `key` with their bounding box per grid configuration (not for a held
        object, which changes)."""
        each = _placed(poses, body.centres)
        pts = each.reshape(-1, 3)
        if body.name != OBJECT:
            self._memo[key] = pts
            self._memo[("bounds", *key[1:])] = (each.min(axis=1), each.max(axis=1))
        return pts

    def _sweep_ahead(self, links: Collection[str]) -> None:
        """The box-free part of the walls' sweeps of the bodies of `links`, each moved by
        one planning joint (a torso's lift carrying the other arm and the head): their
        covers (first, fine, inner) placed on the joint's grid, with their bounding boxes
        and levers. A request's new box then costs only the test against them, not
        forward kinematics and placement of every carried body (5-10 ms each under load)."""
        kin = self.kin
        by_joint: dict[int, list[Body]] = {}
        for b in self.bodies:
            if b.link not in links:
                continue
            lb = kin.link_index[b.link]
            (joint,) = set(kin.src[kin.ancestors[lb] & (kin.src >= 0)].tolist())
            covers = (b, self.fine_body(b.name), self.inner_body(b.name))
            by_joint.setdefault(int(joint), []).extend(c for c in covers if c is not None)
        for joint, bodies in by_joint.items():
            joints = np.array([joint])
            qs, _ = self._grid(joints, WALL_SAMPLES)
            poses = kin.fk(qs)
            for body in bodies:
                self._levers(body)
                key = ("sweep", body.name, WALL_SAMPLES, (joint,))
                self._place_on_grid(body, poses[:, kin.link_index[body.link]], key)

    def reach_into(
        self,
        body: Body,
        joints: np.ndarray,
        rates: np.ndarray,
        padding: float,
        samples: int,
        env: kernels.Shapes,
        shapes: list[tuple[bytes, np.ndarray, np.ndarray]],
        rows: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Where `body`, its `joints` swept (`sweep`), meets each shape of `env` (the
        kernels' arrays; `shapes`, their `_each_shape`): (shapes,) True where it never
        comes within what it moves between grid points of the shape, and (grid
        configurations, shapes) True where it is inside the shape by more than that.
        With `rows` ((grid configurations, shapes) bool), only those are asked: the
        others answer not inside, and "never" speaks of the asked ones alone.
        Kept per body and shape, the last SHAPES_KEPT answers (a world's shapes are the
        same in every request, and a request's boxes come back while its user moves the
        goal); the grid configurations whose spheres' bounding box is farther from a
        shape's than a sphere's radius (and what it moves) are answered without a look at
        each sphere."""
        pts, radii, margin = self.sweep(body, joints, rates, padding, samples)
        per = len(body.radii)
        grid = len(pts) // per
        bounds = self._memo.get(("bounds", body.name, samples, tuple(int(j) for j in joints)))
        if bounds is None or body.name == OBJECT:
            each = pts.reshape(grid, per, 3)
            bounds = (each.min(axis=1), each.max(axis=1))
        far = float(radii.max()) + margin
        asked = np.ones((grid, len(shapes)), dtype=bool) if rows is None else rows.copy()
        never = np.zeros(len(shapes), dtype=bool)
        inside = np.zeros((grid, len(shapes)), dtype=bool)
        todo = []
        for s, (key, lo, hi) in enumerate(shapes):
            memo = (body.name, float(padding), samples, rows is None, key)
            kept = self._shapes.get(memo) if body.name != OBJECT else None
            if kept is not None:
                self._shapes.move_to_end(memo)
                never[s], inside[:, s] = kept
                continue
            asked[:, s] &= _box_gap(bounds[0], bounds[1], lo, hi) <= far
            if asked[:, s].any():
                todo.append(s)
            else:
                never[s] = True
                self._keep(body, memo, (True, inside[:, s].copy()))
        if todo:
            # the grid configurations any shape asks, and only those
            at = np.flatnonzero(asked[:, todo].any(axis=1))
            depth = radii.reshape(grid, per)[at].reshape(-1, 1) - _shape_gaps(
                pts.reshape(grid, per, 3)[at].reshape(-1, 3), *_pick(env, todo)
            )
            never[todo] = depth.max(axis=0) < -margin
            deep = depth.reshape(len(at), per, -1).max(axis=1) > margin
            inside[at[:, None], todo] = deep & asked[at][:, todo]
            for s in todo:
                memo = (body.name, float(padding), samples, rows is None, shapes[s][0])
                self._keep(body, memo, (bool(never[s]), inside[:, s].copy()))
        return never, inside

    def _keep(self, body: Body, key: tuple, answer: tuple[bool, np.ndarray]) -> None:
        """Keep one answer of `reach_into` (not for a held object, which changes)."""
        if body.name == OBJECT:
            return
        self._shapes[key] = answer
        while len(self._shapes) > SHAPES_KEPT:
            self._shapes.popitem(last=False)


@dataclass
class Environment:
    """Obstacles as primitive arrays: boxes, cylinders (along their z) and spheres, each
    with a name for explanations. Meshes enter as their oriented bounding box."""

    names: list[str] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    poses: list[np.ndarray] = field(default_factory=list)
    dims: list[np.ndarray] = field(default_factory=list)

    def add(self, name: str, shape: Shape, pose: Pose | np.ndarray) -> None:
        m = pose.matrix() if isinstance(pose, Pose) else np.asarray(pose, dtype=float)
        if isinstance(shape, Box):
            size = np.asarray(shape.size, dtype=float)
            if np.any(size < 0):
                raise ValueError(f"obstacle {name!r}: box size {tuple(size)} has a negative edge")
            self._append(name, "box", m, size / 2)
        elif isinstance(shape, Cylinder):
            self._append(name, "cylinder", m, np.array([shape.radius, shape.length / 2, 0.0]))
        elif isinstance(shape, Sphere):
            self._append(name, "sphere", m, np.array([shape.radius, 0.0, 0.0]))
        elif isinstance(shape, Mesh):
            import trimesh

            if shape.data is not None:
                tm = trimesh.Trimesh(shape.data.vertices, shape.data.faces, process=False)
            else:
                tm = trimesh.load(shape.filename, force="mesh")
            tm.apply_scale(np.asarray(shape.scale))
            obb = tm.bounding_box_oriented
            self._append(
                name, "box", m @ obb.primitive.transform, np.asarray(obb.primitive.extents) / 2
            )
        else:
            raise TypeError(f"obstacle {name!r}: unsupported shape {shape!r}")

    def _append(self, name: str, kind: str, m: np.ndarray, dims: np.ndarray) -> None:
        self.names.append(name)
        self.kinds.append(kind)
        self.poses.append(m)
        self.dims.append(dims)

    def arrays(self, keep: Sequence[int] | None = None) -> kernels.Shapes:
        """The tuple the kernels take: box inverse poses and half extents, cylinder
        inverse poses, radii and half lengths, sphere centres and radii (of the shapes
        in `keep`, default all)."""
        chosen = set(range(len(self.kinds)) if keep is None else keep)

        def pick(kind: str) -> list[int]:
            return [i for i, k in enumerate(self.kinds) if k == kind and i in chosen]

        bi, ci, si = pick("box"), pick("cylinder"), pick("sphere")
        inv = [np.linalg.inv(m) for m in self.poses]
        return kernels.Shapes(
            np.array([inv[i] for i in bi]).reshape(-1, 4, 4),
            np.array([self.dims[i] for i in bi]).reshape(-1, 3),
            np.array([inv[i] for i in ci]).reshape(-1, 4, 4),
            np.array([self.dims[i][0] for i in ci], dtype=float),
            np.array([self.dims[i][1] for i in ci], dtype=float),
            np.array([self.poses[i][:3, 3] for i in si]).reshape(-1, 3),
            np.array([self.dims[i][0] for i in si], dtype=float),
        )

    def __len__(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class HeldObject:
    """An object carried by the hand: its shape and its pose in the attach link's frame."""

    shape: Shape
    pose_in_link: np.ndarray
    link: str


class CollisionChecker:
    """Batched, compiled validity checks for one robot in one environment.

    `valid(qs)` takes (N, d) planning configurations; `motion_valid(a, b)` checks the
    straight joint-space segment at the robot's resolution (times `resolution_scale`).
    `padding` (m) inflates the robot's spheres against the environment. `held` is an
    object carried by the hand; the links it touches at `held_touch_at` may touch it.
    With `fine` (default: when the robot's fine covers are made), each link's fine cover
    is asked where its first cover touches an obstacle or another link (every link's
    made first, unless `refine` is False: then those made); `finer()` gives that
    checker. The links of the robot's `fine_self` have theirs, once made, asked always.
    """

    def __init__(
        self,
        robot: RobotSpheres,
        env: Environment | None = None,
        padding: float = 0.0,
        held: HeldObject | None = None,
        held_touch_at: np.ndarray | None = None,
        resolution_scale: float = 1.0,
        fine: bool | None = None,
        refine: bool = True,
    ) -> None:
        self._settings = (robot, env, padding, held, held_touch_at, resolution_scale)
        self.fine = robot.refined if fine is None else bool(fine) and robot.has_fine
        if self.fine and refine:
            robot.refine()
        self._made = robot.fine_links()
        self._finer: CollisionChecker | None = self if self.fine and robot.refined else None
        self.robot = robot
        self.kin = robot.kin
        self.env = env if env is not None else Environment()
        self.padding = float(padding)
        self.resolution = robot.resolution * float(resolution_scale)
        bodies = list(robot.bodies)
        disabled = set(robot.disabled)
        if held is not None:
            centres, radii = shape_spheres(held.shape)
            m = held.pose_in_link
            bodies.append(Body(OBJECT, held.link, centres @ m[:3, :3].T + m[:3, 3], radii))
        self.bodies = bodies
        self._pack()
        self.touch_links: list[str] = []
        if held is not None:
            group = robot._rigid_group()
            hk = group[self.kin.link_index[held.link]]
            q0 = held_touch_at if held_touch_at is not None else np.zeros(self.kin.d)
            touching = self.contacts(q0, pairs=[(b.name, OBJECT) for b in robot.bodies])
            for b in robot.bodies:
                if group[self.kin.link_index[b.link]] == hk or (b.name, OBJECT) in touching:
                    disabled.add((b.name, OBJECT))
                    self.touch_links.append(b.name)
        self.disabled = disabled
        names = [b.name for b in bodies]
        self.pairs = np.array(
            [
                (i, j)
                for i in range(len(names))
                for j in range(i + 1, len(names))
                if (names[i], names[j]) not in disabled
            ],
            dtype=np.int64,
        ).reshape(-1, 2)
        self.env_bodies = np.array(
            [i for i, b in enumerate(bodies) if self.kin.moving[self.kin.link_index[b.link]]],
            dtype=np.int64,
        )
        self._travel = self._travel_bounds()
        env_arrays = self._reachable_env()
        self._walls: list[Wall] | None = None
        self.never_touching = self._never_touching(env_arrays)
        every, reachable = kernels.item_lists(self.never_touching, len(self.pairs))
        self._packed = kernels.pack(
            {
                **self._kin_args._asdict(),
                **self._bodies,
                "env_bodies": self.env_bodies,
                "pairs": self.pairs,
                "rate": kernels.rates(*self._travel),
                "resolution": self.resolution,
                "lower": self.kin.lower,
                "upper": self.kin.upper,
                "pad": np.array([self.padding]),
                **env_arrays._asdict(),
            },
            every,
            reachable,
        )

    def _reachable_env(self) -> kernels.Shapes:
        """The environment arrays without shapes no moving body can reach (table legs,
        a floor far below the arm): fewer tests for every check."""
        reach = self.robot.reach + self.padding + 1e-3
        for b in self.bodies:
            if b.name == OBJECT:
                reach += float(np.max(np.linalg.norm(b.centres, axis=1) + b.radii))
        keep = [
            i
            for i in range(len(self.env))
            if _distance(self.robot.origin, self.env.kinds[i], self.env.poses[i], self.env.dims[i])
            <= reach
        ]
        return self.env.arrays(keep)

    def _never_touching(self, env: kernels.Shapes, samples: int = 512) -> np.ndarray:
        """(env bodies, shapes) True where a body that only one or two planning joints
        move cannot reach the shape anywhere in those joints' ranges (a first link turning
        above the table it stands on). The joints are swept on a grid; between grid points
        a body moves at most its travel bound times half a step, which the gap must
        exceed. Clearances then ignore those pairs: they would otherwise set the pace of
        every motion check while never being in danger."""
        n_shapes = len(env.box_inv) + len(env.cyl_inv) + len(env.sph_c)
        out = np.zeros((len(self.env_bodies), n_shapes), dtype=bool)
        rates = self._travel[0]
        shapes = _each_shape(env)
        for e, bi in enumerate(self.env_bodies):
            joints = np.nonzero(rates[bi] > 0)[0]
            if self.bodies[bi].name == OBJECT or not 1 <= len(joints) <= 2 or n_shapes == 0:
                continue
            out[e] = self.robot.reach_into(
                self.bodies[bi], joints, rates[bi], self.padding, samples, env, shapes
            )[0]
        return out

    def walls(self) -> list[Wall]:
        """The joint ranges no path crosses (`Wall`), found once per checker: a body
        that only one planning joint moves (a hand the turning torso carries while its
        own arm is held) and that reaches into an obstacle over part of that joint's
        range splits the joint space in two."""
        if self._walls is not None:
            return self._walls
        env = self.env.arrays()
        names = [  # in the kernels' order
            self.env.names[i]
            for kind in ("box", "cylinder", "sphere")
            for i, k in enumerate(self.env.kinds)
            if k == kind
        ]
        rates = self._travel[0]
        shapes = _each_shape(env)
        self._walls = []
        for bi in self.env_bodies if names else []:
            body = self.bodies[bi]
            joints = np.nonzero(rates[bi])[0]
            if body.name == OBJECT or len(joints) != 1:
                continue
            # the first cover (its sweep kept from `_never_touching`) tells where to look
            # with the balls the fine one holds inside the link: only those grid values
            coarse = self._inside(body, joints, env, shapes)
            if not coarse.any():
                continue
            self.robot.refine({body.link})
            fine, inner = self.robot.fine_body(body.name), self.robot.inner_body(body.name)
            if fine is None or inner is None:
                continue
            inside = self._inside(fine, joints, env, shapes, rows=coarse)
            sure = self._inside(inner, joints, env, shapes, rows=inside)
            own = next(b for b in self.robot.bodies if b.name == body.name)
            bulge = float(np.max(own.fine_radii - own.fine_inner))
            values = np.linspace(self.kin.lower[joints[0]], self.kin.upper[joints[0]], WALL_SAMPLES)
            edges = np.flatnonzero(np.diff(np.r_[0, inside.any(axis=1).astype(int), 0]))
            for lo, hi in zip(edges[::2], edges[1::2] - 1, strict=True):
                s = int(np.argmax(inside[lo : hi + 1].sum(axis=0)))
                wall = Wall(int(joints[0]), values[lo], values[hi], body.name, names[s])
                self._walls.append(
                    replace(wall, sure=bool(sure[lo : hi + 1, s].any()), bulge=bulge)
                )
        key = ("pair walls", "", self.padding)
        if key not in self.robot._memo:
            self.robot._memo[key] = self._pair_walls()
        self._walls += self.robot._memo[key]
        return self._walls

    def _pair_walls(self) -> list[Wall]:
        """Walls of one joint made by links that two planning joints move (a held arm
        that a torso's yaw and pitch carry): the values of one of the two joints where
        such links are inside a link no planning joint moves (the pelvis) whatever the
        other joint does, on a grid of the two (the fine covers decide). The robot's
        own: the same in every scene."""
        rates = self._travel[0]
        groups: dict[tuple[int, int], list[int]] = {}
        for bi in self.env_bodies:
            joints = tuple(int(j) for j in np.nonzero(rates[bi])[0])
            if self.bodies[bi].name != OBJECT and len(joints) == 2:
                groups.setdefault(joints, []).append(int(bi))
        moving = set(self.env_bodies.tolist())
        enabled = {tuple(sorted(p)) for p in self.pairs.tolist()}
        per = int(np.sqrt(3 * WALL_SAMPLES))  # grid values of each joint (`sweep`)
        out: list[Wall] = []
        for (j, k), members in groups.items():
            # the first covers hold the links: where their cells leave a way round,
            # the fine ones do too (and need not be made)
            partners, first = {}, {}
            coarse = np.zeros(per * per, dtype=bool)
            for bi in members:
                partners[bi] = [
                    f
                    for f, b in enumerate(self.bodies)
                    if f not in moving and b.name != OBJECT and tuple(sorted((bi, f))) in enabled
                ]
                first[bi] = self._pair_inside(self.bodies[bi], (j, k), partners[bi], False)
                coarse |= first[bi].any(axis=1)
            coarse = coarse.reshape(per, per)
            rows, cols = coarse.all(axis=1), coarse.all(axis=0)
            if not (rows.any() or cols.any()):
                continue
            candidate = (rows[:, None] | cols[None, :]).ravel()
            hits: dict[tuple[str, str], np.ndarray] = {}
            for bi in members:
                body = self.bodies[bi]
                near = first[bi][candidate].any(axis=0)  # by partner
                if not near.any():
                    continue
                links = [self.bodies[f].link for f in partners[bi]]
                self.robot.refine(
                    {body.link} | {link for link, t in zip(links, near, strict=True) if t}
                )
                inside = self._pair_inside(body, (j, k), partners[bi], True)
                if inside is None:
                    continue
                for c, other in enumerate(self.bodies[f].name for f in partners[bi]):
                    if inside[:, c].any():
                        grid = inside[:, c].reshape(per, per)
                        key = (body.name, other)
                        hits[key] = hits[key] | grid if key in hits else grid
            if not hits:
                continue
            blocked = np.any(list(hits.values()), axis=0)
            for joint, rows, axis in ((j, blocked.all(axis=1), 1), (k, blocked.all(axis=0), 0)):
                values = np.linspace(self.kin.lower[joint], self.kin.upper[joint], per)
                edges = np.flatnonzero(np.diff(np.r_[0, rows.astype(int), 0]))
                for lo, hi in zip(edges[::2], edges[1::2] - 1, strict=True):
                    span = slice(lo, hi + 1)
                    counts = {
                        key: int((g[span] if axis == 1 else g[:, span]).sum())
                        for key, g in hits.items()
                    }
                    body_name, other = max(counts, key=lambda key: counts[key])
                    out.append(Wall(joint, values[lo], values[hi], body_name, other))
        return out

    def _pair_inside(
        self,
        body: Body,
        joints: tuple[int, int],
        partners: list[int],
        fine: bool,
    ) -> np.ndarray | None:
        """(grid configurations, partner links) True where `body` (its fine cover with
        `fine`), its two joints swept on a grid, is inside a partner link (a link no
        planning joint moves; its fine cover with `fine`) by more than it moves between
        grid points; None when its fine cover is not made."""
        if fine:
            fine_body = self.robot.fine_body(body.name)
            if fine_body is None:
                return None
            body = fine_body
        pair = np.array(joints)
        rates = self.robot.arms(body, self.padding) @ self._to_joint
        pts, radii, margin = self.robot.sweep(body, pair, rates, self.padding, WALL_SAMPLES)
        grid = len(pts) // len(body.radii)
        cols = [np.zeros((grid, 0), dtype=bool)]
        own_links = {b.name: b for b in self.robot.bodies}
        pose = self.kin.fk(0.5 * (self.kin.lower + self.kin.upper))
        for f in partners:
            other = own_links[self.bodies[f].name]
            centres, r = other.centres, other.radii
            if fine and other.fine_centres is not None:
                centres, r = other.fine_centres, other.fine_radii
            m = pose[self.kin.link_index[other.link]]
            c = centres @ m[:3, :3].T + m[:3, 3]
            # only points within reach of the link's box can be inside it by the margin
            reach = float(radii.max()) + margin
            lo, hi = (c - r[:, None]).min(axis=0) - reach, (c + r[:, None]).max(axis=0) + reach
            near = np.flatnonzero(np.all((pts >= lo) & (pts <= hi), axis=1))
            depth = np.full(len(pts), -np.inf)
            for s in range(0, len(near), 4096):
                at = near[s : s + 4096]
                gap = np.linalg.norm(pts[at, None] - c[None], axis=-1) - r[None]
                depth[at] = radii[at] - self.padding - gap.min(axis=1)
            cols.append((depth.reshape(grid, -1).max(axis=1) > margin)[:, None])
        return np.hstack(cols)

    def _inside(
        self,
        body: Body,
        joints: np.ndarray,
        env: kernels.Shapes,
        shapes: list,
        rows: np.ndarray | None = None,
    ) -> np.ndarray:
        """(grid values, obstacles) True where `body`, its one joint swept over its range,
        is inside an obstacle by more than it moves between grid values (of `rows` only,
        when given: `RobotSpheres.reach_into`)."""
        rates = self.robot.arms(body, self.padding) @ self._to_joint
        return self.robot.reach_into(
            body, joints, rates, self.padding, WALL_SAMPLES, env, shapes, rows
        )[1]

    def beyond_walls(self, a: np.ndarray, qs: np.ndarray) -> np.ndarray:
        """(N,) bool: which configurations of `qs` lie past a wall (`walls`) from `a`:
        no path reaches them from `a`."""
        qs = np.atleast_2d(qs)
        out = np.zeros(len(qs), dtype=bool)
        for w in self.walls():
            out |= w.crossed(a, qs)
        return out

    def _travel_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(bodies, d) and (pairs, d): metres per unit of each planning joint that a body
        may move in the world, and that two bodies may move toward each other (joints
        that move both carry them rigidly and do not count). The robot's own, kept by
        padding: every request's checker asks them alike (not with a held object)."""
        key = ("travel", "", self.padding)
        own = all(b.name != OBJECT for b in self.bodies)
        if own and key in self.robot._memo:
            self._to_joint, body_rate, pair_rate = self.robot._memo[key]
            return body_rate, pair_rate
        kin = self.kin
        arms = np.array([self.robot.arms(b, self.padding) for b in self.bodies])
        to_joint = np.zeros((len(kin.link_names), kin.d))
        for k in range(len(kin.link_names)):
            if kin.src[k] >= 0:
                to_joint[k, kin.src[k]] = 1.0
        self._to_joint = to_joint
        links = [kin.link_index[b.link] for b in self.bodies]
        pair = np.array(
            [
                np.where(kin.ancestors[links[i]] & kin.ancestors[links[j]], 0.0, arms[i] + arms[j])
                for i, j in self.pairs
            ]
        ).reshape(-1, arms.shape[1])
        body_rate = np.ascontiguousarray(arms @ to_joint)
        pair_rate = np.ascontiguousarray(pair @ to_joint)
        if own:
            self.robot._memo[key] = (to_joint, body_rate, pair_rate)
        return body_rate, pair_rate

    def _pack(self) -> None:
        """The kernels' arrays: spheres and bounds in the frames of the collapsed tree
        (only the links a planning joint moves; `Kinematics.collapsed`). The robot's
        own, kept by the fine covers made and asked: every request's checker packs them
        alike (not with a held object)."""
        key = ("pack", ",".join(sorted(self._made)), float(self.fine))
        own = all(b.name != OBJECT for b in self.bodies)
        if own and key in self.robot._memo:
            self._kin_args, self._bodies, fine_bodies = self.robot._memo[key]
            self.fine_bodies = set(fine_bodies)
        else:
            self._pack_bodies()
            if own:
                self.robot._memo[key] = (self._kin_args, self._bodies, set(self.fine_bodies))
        self._check_sizes(self._bodies["end"] - self._bodies["start"])

    def _pack_bodies(self) -> None:
        """`_pack`'s arrays, made."""
        self._kin_args, node, rel = self.kin.collapsed()
        link_index = self.kin.link_index
        starts, ends, local, radius, body_link, bound_local, bound_r = ([] for _ in range(7))
        n = 0
        for b in self.bodies:
            li = link_index[b.link]
            m = rel[li]
            starts.append(n)
            n += len(b.radii)
            ends.append(n)
            local.append(b.centres @ m[:3, :3].T + m[:3, 3])
            radius.append(b.radii)
            c = 0.5 * (b.centres.min(axis=0) + b.centres.max(axis=0))
            body_link.append(node[li])
            bound_local.append(m[:3, :3] @ c + m[:3, 3])
            bound_r.append(float(np.max(np.linalg.norm(b.centres - c, axis=1) + b.radii)))
        # the fine runs after all the coarse ones; empty unless asked; a body's bounding
        # sphere holds its fine spheres too
        fine_starts, fine_ends = [], []
        self.fine_bodies = set()
        for k, b in enumerate(self.bodies):
            m = rel[link_index[b.link]]
            fine_starts.append(n)
            asked = self.fine or b.name in self.robot.fine_self
            if asked and b.fine_centres is not None and b.fine_radii is not None:
                self.fine_bodies.add(b.name)
                n += len(b.fine_radii)
                local.append(b.fine_centres @ m[:3, :3].T + m[:3, 3])
                radius.append(b.fine_radii)
                c = 0.5 * (b.centres.min(axis=0) + b.centres.max(axis=0))
                far = np.linalg.norm(b.fine_centres - c, axis=1) + b.fine_radii
                bound_r[k] = max(bound_r[k], float(np.max(far)))
            fine_ends.append(n)
        self._bodies = {
            "node": np.array(body_link, dtype=np.int64),
            "bound_local": np.array(bound_local).reshape(-1, 3),
            "bound_r": np.array(bound_r),
            "start": np.array(starts, dtype=np.int64),
            "end": np.array(ends, dtype=np.int64),
            "fine_start": np.array(fine_starts, dtype=np.int64),
            "fine_end": np.array(fine_ends, dtype=np.int64),
            "sphere_local": np.ascontiguousarray(np.vstack(local).T),  # one row per axis
            "radius": np.concatenate(radius),
        }

    def _check_sizes(self, spheres: np.ndarray) -> None:
        """The compiled checks hold a robot's frames, bodies and a body's spheres in
        fixed room; say which is too large rather than overrun it."""
        nodes, d = len(self._kin_args.parent), self.kin.d
        name = self.kin.model.name
        if nodes > kernels.MAX_NODES or d > kernels.MAX_NODES:
            raise ValueError(
                f"robot {name!r}: {nodes - 1} moving frames and {d} planning joints; the "
                f"planner's collision checks take at most {kernels.MAX_NODES - 1} "
                "(plan a smaller joint group)"
            )
        if len(self.bodies) > kernels.MAX_BODIES:
            raise ValueError(
                f"robot {name!r}: {len(self.bodies)} links with collision shapes; the "
                f"planner's collision checks take at most {kernels.MAX_BODIES}"
            )
        big = int(np.argmax(spheres))
        if spheres[big] > kernels.BODY_SPHERES:
            raise ValueError(
                f"robot {name!r}: link {self.bodies[big].name!r} is covered by "
                f"{spheres[big]} spheres; the planner's collision checks take at most "
                f"{kernels.BODY_SPHERES} per link"
            )

    @property
    def d(self) -> int:
        return self.kin.d

    @property
    def lower(self) -> np.ndarray:
        return self.kin.lower

    @property
    def upper(self) -> np.ndarray:
        return self.kin.upper

    def valid(self, qs: np.ndarray) -> np.ndarray:
        """(N,) bool: which configurations of (N, d) are free."""
        q = np.ascontiguousarray(np.atleast_2d(np.asarray(qs, dtype=float)))
        out = np.empty(len(q), dtype=bool)
        kernels.valid_batch(q, out, *self._packed)
        return out

    def free(self, q: np.ndarray) -> bool:
        """Is the one configuration `q` (d,) free? (`valid` without a batch's arrays.)"""
        return kernels.config_free(*self._packed, np.ascontiguousarray(q, dtype=float))

    def kernel_args(self) -> kernels.Packed:
        """What the compiled checks take (`kernels.Packed`): compiled planners call
        `kernels.motion_free` and `kernels.config_free` with it."""
        return self._packed

    def motions_valid(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(N,) bool: which straight segments a[i] -> b[i] are free (a[i] assumed free).

        Proves each segment free stretch by stretch from the clearance of configurations
        along it, down to the robot's resolution, and stops at the first contact."""
        a = np.ascontiguousarray(np.atleast_2d(a), dtype=float)
        out = np.empty(len(a), dtype=bool)
        kernels.motions_valid(
            a, np.ascontiguousarray(np.atleast_2d(b), dtype=float), out, *self._packed
        )
        return out

    def motion_valid(self, a: np.ndarray, b: np.ndarray) -> bool:
        return bool(self.motions_valid(a, b)[0])

    def finer(self, q: np.ndarray | None = None) -> CollisionChecker | None:
        """This checker with the robot's fine covers asked too, or None when the robot has
        none. For the configurations the first cover calls touching although the links
        are 1-2 cm clear: a start or goal close to a shelf board or a table top. With
        `q`, only the links whose first cover touches something there get theirs made
        (the others keep their first cover, which holds them as well); else every link.
        Kept until more fine covers are made; with `q`, a kept one that finds `q` free
        is answered without looking for contacts."""
        if not self.robot.has_fine:
            return None
        if q is not None and self._finer is not None and self._finer.valid(q[None])[0]:
            return self._finer
        if q is None:
            self.robot.refine()
        else:
            touching = {name for pair in self.contacts(q, fine=False) for name in pair}
            self.robot.refine(touching & {b.link for b in self.robot.bodies})
        if self._finer is None or self._finer._made != self.robot.fine_links():
            self._finer = type(self)(*self._settings, fine=True, refine=False)
        return self._finer

    def contacts(
        self,
        q: np.ndarray,
        pairs: Iterable[tuple[str, str]] | None = None,
        fine: bool | None = None,
    ) -> set[tuple[str, str]]:
        """Which bodies touch which (robot link, other link or obstacle name) at `q`.

        With `pairs`, only those robot pairs are tested (and no obstacles); otherwise
        every enabled self pair and every obstacle. Used to explain a failure. Two
        links touch where their first covers do and, as the checks ask them, their
        fine covers too. Obstacles count as touched where the first cover reaches them
        and the fine cover too: as the checks ask it (`fine` None), for every link
        (True) or for none (False).
        """
        poses = self.kin.fk(np.asarray(q, dtype=float))
        world = {}
        for b in self.bodies:
            m = poses[self.kin.link_index[b.link]]
            world[b.name] = (b.centres @ m[:3, :3].T + m[:3, 3], b.radii, b.link)
        out: set[tuple[str, str]] = set()
        if pairs is None:
            names = [b.name for b in self.bodies]
            pair_list = [(names[i], names[j]) for i, j in self.pairs]
        else:
            pair_list = [p for p in pairs if p[0] in world and p[1] in world]
        bodies = {b.name: b for b in self.bodies}

        def cover(name: str) -> tuple[np.ndarray, np.ndarray]:
            body = bodies[name]
            if name not in self.fine_bodies:
                return world[name][:2]
            m = poses[self.kin.link_index[body.link]]
            return body.fine_centres @ m[:3, :3].T + m[:3, 3], body.fine_radii

        for a, b in pair_list:
            if _spheres_touch(*world[a][:2], *world[b][:2]) and (
                not {a, b} & self.fine_bodies or _spheres_touch(*cover(a), *cover(b))
            ):
                out.add((a, b))
        if pairs is not None:
            return out
        asked = self.fine_bodies if fine is None else set(bodies) if fine else set()
        if fine:
            self.robot.refine()
        own = {b.name: b for b in self.robot.bodies}
        for i in self.env_bodies:
            body = own.get(self.bodies[i].name, self.bodies[i])
            c, r, _ = world[body.name]
            refined = None
            if body.name in asked and body.fine_centres is not None:
                m = poses[self.kin.link_index[body.link]]
                refined = (body.fine_centres @ m[:3, :3].T + m[:3, 3], body.fine_radii)
            for k, kind in enumerate(self.env.kinds):
                pose, dims = self.env.poses[k], self.env.dims[k]
                if _touches(c, r + self.padding, kind, pose, dims) and (
                    refined is None
                    or _touches(refined[0], refined[1] + self.padding, kind, pose, dims)
                ):
                    out.add((body.name, self.env.names[k]))
        return out


def _arrays(group: list[CollisionSphere] | None) -> tuple[Any, Any]:
    """Centres (n, 3) and radii (n,) of a group of spheres, or (None, None)."""
    if not group:
        return None, None
    centres = np.array([s.center for s in group], dtype=float)
    return centres, np.array([s.radius for s in group], dtype=float)


def _placed(poses: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """(N, S, 3): points `centres` (S, 3) of a link placed by each of its `poses` (N, 4, 4);
    a stacked matrix product (an unoptimised einsum takes ten times as long)."""
    return centres @ poses[:, :3, :3].transpose(0, 2, 1) + poses[:, None, :3, 3]


def _by_link(spheres: Iterable[CollisionSphere]) -> dict[str, list[CollisionSphere]]:
    out: dict[str, list[CollisionSphere]] = {}
    for s in spheres:
        out.setdefault(s.link, []).append(s)
    return out


def _spheres_touch(ca: np.ndarray, ra: np.ndarray, cb: np.ndarray, rb: np.ndarray) -> bool:
    """Does a sphere of one set (centres, radii) overlap one of the other?"""
    dist = np.linalg.norm(ca[:, None] - cb[None], axis=-1)
    return bool(np.any(dist <= ra[:, None] + rb[None]))


def _local_gaps(local: np.ndarray, kind: str, dims: np.ndarray) -> np.ndarray:
    """(n,) distance from points given in a shape's frame to the shape (0 inside): a box
    of half extents dims, a cylinder along z (dims: radius, half length), a sphere."""
    if kind == "box":
        return np.linalg.norm(np.maximum(np.abs(local) - dims[:3], 0.0), axis=1)
    if kind == "cylinder":
        dr = np.maximum(np.linalg.norm(local[:, :2], axis=1) - dims[0], 0.0)
        return np.hypot(dr, np.maximum(np.abs(local[:, 2]) - dims[1], 0.0))
    return np.maximum(np.linalg.norm(local, axis=1) - dims[0], 0.0)


def _each_shape(env: kernels.Shapes) -> list[tuple[bytes, np.ndarray, np.ndarray]]:
    """Each shape of the kernels' arrays (boxes, cylinders, spheres in that order): a key
    naming its kind, pose and size, and its bounding box in the world (low, high)."""
    out = []
    for kind, invs, halves in (
        (b"box", env.box_inv, env.box_half),
        (b"cylinder", env.cyl_inv, np.stack([env.cyl_r, env.cyl_r, env.cyl_h], axis=-1)),
    ):
        for inv, half in zip(invs, halves.reshape(-1, 3), strict=True):
            rot = inv[:3, :3].T
            centre = -rot @ inv[:3, 3]
            extent = np.abs(rot) @ half
            out.append((kind + inv.tobytes() + half.tobytes(), centre - extent, centre + extent))
    for c, r in zip(env.sph_c, env.sph_r, strict=True):
        out.append((b"sphere" + c.tobytes() + np.float64(r).tobytes(), c - r, c + r))
    return out


def _pick(env: kernels.Shapes, which: Sequence[int]) -> kernels.Shapes:
    """The shapes `which` (indices in the kernels' order) of `env`."""
    n_box, n_cyl = len(env.box_inv), len(env.cyl_inv)
    box = [i for i in which if i < n_box]
    cyl = [i - n_box for i in which if n_box <= i < n_box + n_cyl]
    sph = [i - n_box - n_cyl for i in which if i >= n_box + n_cyl]
    return kernels.Shapes(
        env.box_inv[box],
        env.box_half[box],
        env.cyl_inv[cyl],
        env.cyl_r[cyl],
        env.cyl_h[cyl],
        env.sph_c[sph],
        env.sph_r[sph],
    )


def _box_gap(lo_a: np.ndarray, hi_a: np.ndarray, lo_b: np.ndarray, hi_b: np.ndarray) -> np.ndarray:
    """Distance between axis-aligned boxes given by their corners (0 where they meet), over
    the leading axes of the corners (..., 3)."""
    gap = np.maximum(np.maximum(lo_a - hi_b, lo_b - hi_a), 0.0)
    return np.sqrt(np.sum(gap * gap, axis=-1))


def _shape_gaps(pts, box_inv, box_half, cyl_inv, cyl_r, cyl_h, sph_c, sph_r) -> np.ndarray:
    """(points, shapes) distance from each point to each kernel shape (boxes, cylinders,
    spheres in the kernels' order; 0 inside)."""
    cols = [
        _local_gaps(pts @ inv[:3, :3].T + inv[:3, 3], "box", half)
        for inv, half in zip(box_inv, box_half, strict=True)
    ]
    cols += [
        _local_gaps(pts @ inv[:3, :3].T + inv[:3, 3], "cylinder", np.array([r, h]))
        for inv, r, h in zip(cyl_inv, cyl_r, cyl_h, strict=True)
    ]
    cols += [
        _local_gaps(pts - c, "sphere", np.array([r])) for c, r in zip(sph_c, sph_r, strict=True)
    ]
    return np.stack(cols, axis=1)


def _distance(p: np.ndarray, kind: str, pose: np.ndarray, dims: np.ndarray) -> float:
    """Distance from point p to an environment shape (0 inside)."""
    inv = np.linalg.inv(pose)
    return float(_local_gaps((inv[:3, :3] @ p + inv[:3, 3])[None], kind, dims)[0])


def _touches(c: np.ndarray, r: np.ndarray, kind: str, pose: np.ndarray, dims: np.ndarray) -> bool:
    inv = np.linalg.inv(pose)
    return bool(np.any(_local_gaps(c @ inv[:3, :3].T + inv[:3, 3], kind, dims) <= r))
