"""The buyer's verdict behind the page's "Check my home" (layer 5): jobs that check a home
for one or two robots in the background while the server keeps answering.

POST /api/verdict hands `VerdictJobs.start` a world (a name or its YAML) and the robots;
the quick checks run at once (the YAML parses, the robots exist and drive, the world
names rooms) and refuse with `VerdictRefused`; the rest runs in a small thread pool: the
home must be closed (no way out to the edge of the map from the dock), then each robot
goes through `robot_verdict`. GET /api/verdict/{id} reads `VerdictJobs.get`.

`robot_verdict` is the one place that calls the verdict engine (robotrial.trials.verdict,
`check_home` without chores) and turns its answer into JSON: a summary, rows per room,
pictures as data URLs, the reach over the furniture, and whatever else the engine
reports.
"""

from __future__ import annotations

import base64
import logging
import math
import threading
import time
import uuid
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robotrial.app.catalog import Catalog, UnknownName, robot_kind
from robotrial.app.models import RobotVerdict, VerdictJob
from robotrial.model.anatomy import has_wheels
from robotrial.model.robot import ModelError, RobotModel
from robotrial.model.world import World, load_world_text

Progress = Callable[[float, str], None]
"""progress(fraction from 0 to 1, what is being done now)."""

RUNNING = 2
"""Verdicts computed at the same time (threads)."""
WAITING = 4
"""Jobs not yet finished (running or queued) beyond which new ones are refused."""
KEPT = 32
"""Finished jobs whose answers are kept for GET."""
ROUTE_POINTS = 80
"""At most this many points of each room's route go to the page."""

log = logging.getLogger(__name__)

_PLOT_LOCK = threading.Lock()  # matplotlib's pyplot keeps global state: one figure at a time


class VerdictRefused(Exception):
    """A request the server will not check: `status` (HTTP) and a message saying why."""

    def __init__(self, message: str, status: int = 422) -> None:
        super().__init__(message)
        self.status = status


def robot_verdict(
    world: World,
    robot: str,
    model: RobotModel,
    progress: Progress,
    chores: list[tuple[str, str]] | None = None,
    seeds: int = 1,
) -> dict[str, Any]:
    """The verdict for `robot` (its `model`) in `world` as a JSON-safe dict: `summary`,
    `rooms` (one dict per room: room, reachable, colour, ...; `route` as [x, y] points
    when known), `pictures` (title -> PNG data URL: the floor plan with the reach heat
    maps, and for an arm the reach maps and the heights), `reach` (each furniture top's
    share reached, without the heat maps' points), `chores` (each chore's figures, when
    `chores` (object, room) were asked for, over `seeds` runs) and the engine's other
    figures."""
    from robotrial.trials.verdict import check_home, pictures

    verdict = check_home(
        world,
        model,
        chores=chores or (),
        seeds=seeds,
        progress=lambda fraction, what: progress(0.9 * fraction, what),
    )
    progress(0.9, f"drawing the {robot}'s floor plan")
    with _PLOT_LOCK:
        drawn = pictures(verdict)
    out = verdict.base.to_dict()
    for row, room in zip(out["rooms"], verdict.base.rooms, strict=True):
        if room.route is not None:
            row["route"] = _thin(room.route, ROUTE_POINTS)
    out["summary"] = verdict.summary
    reach = verdict.reach.to_dict()
    for surface in reach["surfaces"]:
        surface.pop("heat_map")
    out["reach"] = reach
    if verdict.chores is not None:
        out["chores"] = [c.to_dict() for c in verdict.chores]
    titles = {"floor_plan": "floor plan", "reach": "reach maps", "heights": "heights"}
    out["pictures"] = {titles[k]: data_url(png) for k, png in drawn.items()}
    progress(1.0, f"{robot} done")
    return json_safe(out)


def data_url(png: bytes) -> str:
    """PNG bytes as a data: URL the page can show in an <img>."""
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def json_safe(value: Any) -> Any:
    """`value` with numpy numbers and arrays as plain ones, tuples as lists, floats
    rounded to 4 decimals and NaN or infinity as None."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, np.generic):
        return json_safe(value.item())
    if isinstance(value, float):
        return round(value, 4) if math.isfinite(value) else None
    return value


def _thin(route: np.ndarray, most: int) -> list[list[float]]:
    """At most `most` points of a polyline, the first and last kept."""
    pts = np.asarray(route, dtype=float)
    if len(pts) > most:
        pts = pts[np.unique(np.linspace(0, len(pts) - 1, most).round().astype(int))]
    return np.round(pts, 3).tolist()


def check_closed(world: World) -> None:
    """Raise VerdictRefused when the floor around the dock reaches the edge of the map:
    the message names the room and the point where the walls leave a gap."""
    from robotrial.model.gridmap import world_map
    from robotrial.nav.enclosure import way_out

    grid = world_map(world)
    dock = world.spawn("default").xyz
    origin, res = np.asarray(grid.origin, dtype=float), grid.resolution
    col, row = (int(v) for v in np.floor((np.asarray(dock[:2]) - origin) / res))
    path = way_out(grid.occupied, (row, col))
    if path is None:
        return
    points = origin + (path[:, ::-1] + 0.5) * res
    inside = [i for i, (x, y) in enumerate(points) if any(r.contains(x, y) for r in world.rooms)]
    if not inside:
        raise VerdictRefused(
            f"the home is not closed: the robot's start ({dock[0]:.2f}, {dock[1]:.2f}) m "
            "lies in no room and the floor around it is open to the outside"
        )
    x, y = points[min(inside[-1] + 1, len(points) - 1)]
    room = next(r.name for r in world.rooms if r.contains(*points[inside[-1]]))
    raise VerdictRefused(
        f"the home is not closed: the walls of {room} have a gap near ({x:.2f}, {y:.2f}) m "
        "that leads outside (a doorway to the outside or a missing wall). Close it for the "
        "check: the verdict only counts ways inside the home."
    )


def check_chores(world: World, chores: list[tuple[str, str]]) -> None:
    """Raise VerdictRefused unless every chore names a movable object and a room of
    `world`; the message names the one that does not and lists what the home has."""
    objects = [b.name for b in world.objects]
    rooms = [r.name for r in world.rooms]
    for obj, room in chores:
        if obj not in objects:
            raise VerdictRefused(
                f"chore {obj}:{room}: the home has no movable object {obj!r}; its objects: "
                f"{', '.join(objects) or 'none (add one in the editor)'}"
            )
        if room not in rooms:
            raise VerdictRefused(
                f"chore {obj}:{room}: the home has no room {room!r}; its rooms: {', '.join(rooms)}"
            )


def _mobile(catalog: Catalog, name: str) -> RobotModel:
    """The robot `name`, refused unless it exists and has a wheeled base."""
    try:
        model = catalog.robot(name)
    except UnknownName as exc:
        raise VerdictRefused(str(exc.args[0])) from None
    if robot_kind(model) != "mobile" and not has_wheels(model):
        mobile = [r["name"] for r in catalog.robots() if r["kind"] == "mobile"]
        raise VerdictRefused(
            f"robot {name!r} has no mobile base (it is an arm that stays where it is "
            f"mounted), so it cannot go around a home; robots that drive: {', '.join(mobile)}"
        )
    return model


def _world(catalog: Catalog, text: str) -> World:
    """A world by catalog name, or from its YAML; refused with the reason."""
    if text in catalog.world_names():
        world = catalog.world(text)
    elif "\n" not in text and ":" not in text:
        raise VerdictRefused(
            f"unknown world {text!r}: send a world name ({', '.join(catalog.world_names())}) "
            "or the world's YAML"
        )
    else:
        try:
            world = load_world_text(text, "world YAML")
        except ModelError as exc:
            raise VerdictRefused(str(exc)) from None
    if not world.rooms:
        raise VerdictRefused(
            f"world {world.name!r} names no rooms, so there is nothing to check: give `rooms` "
            "in its YAML (a home drawn in the page has them)"
        )
    return world


@dataclass
class _Job:
    id: str
    world: World
    robots: list[tuple[str, RobotModel]]
    chores: list[tuple[str, str]] = field(default_factory=list)
    seeds: int = 1
    state: str = "queued"
    fraction: float = 0.0
    what: str = "waiting for a free worker"
    results: list[RobotVerdict] = field(default_factory=list)
    error: str | None = None
    started: float = field(default_factory=time.monotonic)
    finished: float | None = None

    def answer(self) -> VerdictJob:
        end = self.finished if self.finished is not None else time.monotonic()
        return VerdictJob(
            id=self.id,
            state=self.state,
            fraction=round(self.fraction, 3),
            what=self.what,
            world=self.world.name,
            robots=[name for name, _ in self.robots],
            results=list(self.results),
            error=self.error,
            seconds=round(end - self.started, 2),
        )


class VerdictJobs:
    """The verdict jobs of one server: at most RUNNING at a time, WAITING unfinished,
    the last KEPT finished ones kept for their answers."""

    def __init__(self, catalog: Catalog) -> None:
        self.catalog = catalog
        self._pool = ThreadPoolExecutor(max_workers=RUNNING, thread_name_prefix="verdict")
        self._lock = threading.Lock()
        self._jobs: OrderedDict[str, _Job] = OrderedDict()

    def start(
        self,
        world: str,
        robots: list[str],
        chores: list[tuple[str, str]] | None = None,
        seeds: int = 1,
    ) -> VerdictJob:
        """Check the request and queue the job; raises VerdictRefused (422 for a bad
        request, 429 when too many jobs wait). `chores` (object, room) run `seeds` times
        for each robot."""
        if len(set(robots)) != len(robots):
            raise VerdictRefused(f"the same robot twice ({', '.join(robots)}): pick two robots")
        if not 1 <= seeds <= 5:
            raise VerdictRefused(f"seeds: give 1 to 5 runs of each chore, not {seeds}")
        models = [(name, _mobile(self.catalog, name)) for name in robots]
        home = _world(self.catalog, world)
        check_chores(home, list(chores or []))
        job = _Job(uuid.uuid4().hex, home, models, list(chores or []), seeds)
        with self._lock:
            waiting = sum(j.finished is None for j in self._jobs.values())
            if waiting >= WAITING:
                raise VerdictRefused(
                    f"the server is already checking {waiting} homes; try again in a moment",
                    status=429,
                )
            self._jobs[job.id] = job
            self._forget()
        self._pool.submit(self._run, job)
        return job.answer()

    def get(self, job_id: str) -> VerdictJob | None:
        """The job's progress or answer; None for an id this server does not know."""
        with self._lock:
            job = self._jobs.get(job_id)
            return None if job is None else job.answer()

    def close(self) -> None:
        """Stop taking jobs; queued ones are dropped, running ones finish on their own."""
        self._pool.shutdown(wait=False, cancel_futures=True)

    def _forget(self) -> None:
        finished = [k for k, j in self._jobs.items() if j.finished is not None]
        for key in finished[: max(0, len(finished) - KEPT)]:
            del self._jobs[key]

    def _run(self, job: _Job) -> None:
        n = len(job.robots)

        def report(i: int) -> Progress:
            def progress(fraction: float, what: str) -> None:
                with self._lock:
                    job.fraction = 0.05 + 0.95 * (i + min(max(fraction, 0.0), 1.0)) / n
                    job.what = what

            return progress

        try:
            with self._lock:
                job.state, job.what = "running", "checking that the home is closed"
            check_closed(job.world)
            for i, (name, model) in enumerate(job.robots):
                found = robot_verdict(job.world, name, model, report(i), job.chores, job.seeds)
                with self._lock:
                    job.results.append(_as_answer(name, found))
            with self._lock:
                job.state, job.fraction, job.what = "done", 1.0, "done"
                job.finished = time.monotonic()
        except VerdictRefused as exc:
            self._fail(job, str(exc))
        except (ModelError, ValueError, KeyError) as exc:
            self._fail(job, f"could not check {job.world.name!r}: {exc}")
        except Exception as exc:  # the job reports it; the server keeps running
            log.exception("verdict job %s failed", job.id)
            self._fail(job, f"the check failed: {type(exc).__name__}: {exc}")

    def _fail(self, job: _Job, message: str) -> None:
        with self._lock:
            job.state, job.error, job.what = "failed", message, "failed"
            job.finished = time.monotonic()


def _as_answer(robot: str, found: dict[str, Any]) -> RobotVerdict:
    """The engine's dict as the route's model: the known parts by name, the rest in
    `details`."""
    rest = dict(found)
    return RobotVerdict(
        robot=robot,
        summary=str(rest.pop("summary", "")),
        pictures=rest.pop("pictures", {}),
        rooms=rest.pop("rooms", []),
        footprint=rest.pop("footprint", None),
        chores=rest.pop("chores", []),
        turning_diameter=rest.pop("turning_diameter", None),
        details={k: v for k, v in rest.items() if k != "robot"},
    )
