"""The exact collision check: MuJoCo on the real collision shapes (layer 2).

Spheres are fast and conservative; this is the referee. It compiles the robot (with the
held object as one more link), the world and the request's obstacles to MJCF, sets the
joints, runs MuJoCo's collision detection and keeps the contacts the sphere model would
also count: robot pairs it has enabled, and moving links (or the held object) against
anything static. `path_valid` checks a path densely.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterable, Sequence

import numba as nb
import numpy as np

from robotrial.collision.contacts import qpos_map
from robotrial.collision.sphere_model import OBJECT, CollisionChecker
from robotrial.geometry import Pose, Shape
from robotrial.model.mjcf import to_mjcf
from robotrial.model.robot import Collision, Joint, Link
from robotrial.model.world import Obstacle, World

HELD_LINK = "held_object"


_EXCLUDED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""Per robot (its sphere model), the link pairs its MJCF keeps from colliding: found once,
they spare every later check a second build of the model."""


class ExactChecker:
    """MuJoCo collision queries that mirror a `CollisionChecker`'s rules.

    `obstacles` are (name, shape, pose) added to `world` for this check only.
    `robot_pairs`: the pairs of robot bodies whose contacts count (default: the pairs
    the checker enables), for a stricter check than the planner's own.
    """

    def __init__(
        self,
        checker: CollisionChecker,
        world: World | None = None,
        obstacles: Sequence[tuple[str, Shape, Pose]] = (),
        held: tuple[Shape, Pose, str] | None = None,
        tolerance: float = 1e-6,
        robot_pairs: Iterable[tuple[str, str]] | None = None,
    ) -> None:
        self.checker = checker
        self.tolerance = tolerance
        self._world = world
        self._obstacles = tuple(obstacles)
        self._held = held
        self._robot_pairs = None if robot_pairs is None else tuple(robot_pairs)
        self._built = False
        self._half_step = np.ascontiguousarray(checker.resolution / 2, dtype=float)

    def _build(self) -> None:
        """The MJCF and MuJoCo model of the scene, made on the first query: most answers
        never ask MuJoCo (the screen clears every sample), so they skip loading it."""
        if self._built:
            return
        import mujoco

        checker, held, world = self.checker, self._held, self._world
        kin = checker.kin
        robot = kin.model
        if held is not None:
            shape, pose_in_link, link = held
            robot = robot.with_changes(
                links=(*robot.links, Link(HELD_LINK, collisions=(Collision(shape),))),
                joints=(
                    *robot.joints,
                    Joint(f"{HELD_LINK}_mount", "fixed", link, HELD_LINK, pose_in_link),
                ),
            )
        extra = tuple(Obstacle(name, shape, pose) for name, shape, pose in self._obstacles)
        if world is None:
            world = World(name="planning", obstacles=extra)
        else:
            world = World(
                name=world.name,
                floor=world.floor,
                walls=world.walls,
                obstacles=world.obstacles + extra,
                spawns={"default": Pose()},
            )
        known = _EXCLUDED.get(checker.robot) if held is None else None
        self.doc = to_mjcf(
            robot,
            world,
            spawn=Pose(),
            actuators="none",
            self_collision=True,
            visuals=False,
            excludes=known,
        )
        if held is None:
            _EXCLUDED[checker.robot] = self.doc.excluded
        self.model = self.doc.compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        body_names = [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) or "" for i in range(m.nbody)
        ]
        links = {lk.name for lk in kin.model.links}
        # what each MuJoCo body is to the sphere model: a robot body name, or "" (static)
        self._role = [OBJECT if n == HELD_LINK else (n if n in links else "") for n in body_names]
        moving = {n for n, k in kin.link_index.items() if kin.moving[k]}
        self._moving = [r == OBJECT or r in moving for r in self._role]
        names = [b.name for b in checker.bodies]
        self._enabled = (
            {(names[i], names[j]) for i, j in checker.pairs}
            if self._robot_pairs is None
            else set(self._robot_pairs)
        )
        self._enabled |= {(b, a) for a, b in self._enabled}
        # counts[b1, b2]: a contact between these MuJoCo bodies is a collision
        nb = m.nbody
        self._counts = np.zeros((nb, nb), dtype=bool)
        for i in range(nb):
            for j in range(nb):
                ri, rj = self._role[i], self._role[j]
                if ri and rj:
                    self._counts[i, j] = (ri, rj) in self._enabled
                else:
                    self._counts[i, j] = self._moving[i] or self._moving[j]
        self._qpos0, self._adr, self._src, self._mult, self._off = qpos_map(kin, m)
        self._geom_body = np.asarray(m.geom_bodyid)
        self._built = True

    def _set(self, q: np.ndarray) -> None:
        import mujoco

        self._build()
        qpos = self._qpos0.copy()
        qpos[self._adr] = self._mult * q[self._src] + self._off
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_collision(self.model, self.data)

    def _hits(self) -> np.ndarray:
        n = self.data.ncon
        if n == 0:
            return np.zeros((0, 2), dtype=np.int64)
        dist = self.data.contact.dist[:n]
        geoms = self.data.contact.geom[:n]
        b = self._geom_body[geoms]
        keep = (dist < -self.tolerance) & self._counts[b[:, 0], b[:, 1]]
        return geoms[keep]

    def contacts(self, q: np.ndarray) -> list[tuple[str, str]]:
        """Contacts that count at `q`: (robot body, other body or geom name)."""
        import mujoco

        self._set(np.asarray(q, dtype=float))
        out = []
        for g1, g2 in self._hits():
            r1, r2 = self._role[self._geom_body[g1]], self._role[self._geom_body[g2]]
            if not r1:
                r1, r2, g2 = r2, r1, g1
            other = r2 or (mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, g2) or "world")
            out.append((r1, other))
        return out

    def valid(self, q: np.ndarray) -> bool:
        self._set(np.asarray(q, dtype=float))
        return len(self._hits()) == 0

    def path_valid(
        self,
        path: np.ndarray,
        step: float | None = None,
        screen: CollisionChecker | None = None,
    ) -> tuple[bool, int]:
        """Check a path densely (every `step` rad; default: the sphere model's resolution
        halved). Returns (valid, index of the first colliding sample or -1).

        With `screen` (a sphere checker of the same scene: its covers hold the real
        shapes and its contacts count from 10 um, so a sample it calls free is free for
        MuJoCo too), only the samples it does not clear go to MuJoCo: those near a
        contact."""
        path = np.ascontiguousarray(np.atleast_2d(path), dtype=float)
        if not len(path):
            return True, -1
        res = self._half_step if step is None else np.full(path.shape[1], float(step))
        qs = _samples(path, res)
        near = np.arange(len(qs)) if screen is None else np.nonzero(~screen.valid(qs))[0]
        if not len(near):
            return True, -1
        import mujoco

        self._build()
        qpos = np.tile(self._qpos0, (len(near), 1))
        qpos[:, self._adr] = self._mult * qs[near][:, self._src] + self._off
        model, data = self.model, self.data
        for k, row in zip(near, qpos, strict=True):
            data.qpos[:] = row
            mujoco.mj_kinematics(model, data)
            mujoco.mj_collision(model, data)
            if data.ncon and len(self._hits()):
                return False, int(k)
        return True, -1


@nb.njit(cache=True, nogil=True)
def _samples(path, res):
    """The points of the polyline `path` (n, d) at most `res` (d,) apart in every joint:
    each segment cut into equal steps, the last point included."""
    n, d = path.shape
    counts = np.empty(max(n - 1, 0), dtype=np.int64)
    total = 1
    for i in range(n - 1):
        k = 0.0
        for j in range(d):
            k = max(k, np.ceil(abs(path[i + 1, j] - path[i, j]) / res[j]))
        counts[i] = max(int(k), 1)
        total += counts[i]
    out = np.empty((total, d))
    m = 0
    for i in range(n - 1):
        for k in range(counts[i]):
            f = k / counts[i]
            for j in range(d):
                out[m, j] = path[i, j] + f * (path[i + 1, j] - path[i, j])
            m += 1
    out[m] = path[n - 1]
    return out
