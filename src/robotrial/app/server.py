"""The web server (layer 5): the built page, the robot and world files, the catalog of
built-ins, and the place where the rosbridge WebSocket joins.

`create_app()` returns a FastAPI app; `robotrial serve` runs it with uvicorn. The page
is the Vite build of web/ in this package's `static/` folder. Every name in a URL is
checked against the built-in lists before anything is built; no part of a URL ever
becomes a file path except through StaticFiles, which stays inside its folder.
"""

from __future__ import annotations

import logging
import shutil
import tempfile
import threading
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import FormData
from starlette.datastructures import UploadFile as StarletteUpload
from starlette.exceptions import HTTPException
from starlette.formparsers import MultiPartException

from robotrial.app.catalog import Asset, Catalog, UnknownName, robot_kind
from robotrial.app.guard import AccessGuard
from robotrial.app.live import LivePlatform, runs_live
from robotrial.app.models import (
    Config,
    LiveInfo,
    MjcfBundle,
    Pair,
    RobotEntry,
    RobotList,
    SpawnPose,
    ToolChoice,
    UploadAnswer,
    VerdictJob,
    VerdictRequest,
    WorldEntry,
    WorldList,
)
from robotrial.app.uploads import (
    MAX_UPLOAD_BYTES,
    UploadRefused,
    UploadStore,
    stored_name,
    too_large_message,
)
from robotrial.app.verdict_jobs import VerdictJobs, VerdictRefused
from robotrial.geometry import Pose
from robotrial.model import library
from robotrial.model.robot import ModelError
from robotrial.model.world import load_world_text
from robotrial.ros.rosbridge.access import TOKEN_COOKIE, Access

MAX_WORLD_BYTES = 1024 * 1024
"""The largest world YAML POST /api/worlds (and /api/verdict) takes."""
JSON_SLACK = 256 * 1024
"""Room for the JSON around a world YAML and its escapes in POST /api/verdict."""

if TYPE_CHECKING:
    from robotrial.model.robot import RobotModel
    from robotrial.model.world import World
    from robotrial.planning.task import TaskPlanner
    from robotrial.ros.bus import Bus

STATIC_DIR = Path(__file__).parent / "static"
ROSBRIDGE_PATH = "/rosbridge"
GLB_MEDIA_TYPE = "model/gltf-binary"

log = logging.getLogger(__name__)

MISSING_BUILD_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>robotrial: page not built</title></head>
<body style="font-family: system-ui, sans-serif; max-width: 40em; margin: 4em auto">
<h1>The robotrial page has not been built</h1>
<p>The server is running, but the web page is missing from <code>{static}</code>.</p>
<p>Build it with <code>make web</code> (or <code>cd web &amp;&amp; npm ci &amp;&amp;
npm run build</code>), then reload. The API works meanwhile: see <a href="/docs">/docs</a>.</p>
</body></html>
"""


NOT_FOUND: dict[int | str, dict[str, Any]] = {404: {"description": "no such built-in name"}}


class PageAssets(StaticFiles):
    """The page's scripts and styles; plain 404s (not errors) while the page is not built,
    and it is served as soon as it is, without a restart."""

    def __init__(self, directory: Path) -> None:
        super().__init__(directory=directory, check_dir=False)

    async def check_config(self) -> None:
        if self.directory is not None and Path(self.directory).is_dir():
            await super().check_config()


def mount_rosbridge(app: FastAPI, bus: Bus, access: Access) -> None:
    """Add the rosbridge v2 WebSocket route at ROSBRIDGE_PATH, serving `bus`.

    This is where the rosbridge server joins the web app; it lives in layer 4
    (`robotrial.ros.rosbridge`), the app only mounts it.
    """
    from robotrial.ros.rosbridge import add_rosbridge_route

    add_rosbridge_route(app, bus, path=ROSBRIDGE_PATH, access=access)


def create_app(
    robot: str = library.DEFAULT_ROBOT,
    world: str = library.DEFAULT_WORLD,
    *,
    bus: Bus | None = None,
    static_dir: Path = STATIC_DIR,
    warm: bool = True,
    uploads_dir: Path | None = None,
    max_upload_bytes: int = MAX_UPLOAD_BYTES,
    live: bool = False,
    planner: bool = False,
    access: Access | None = None,
    foxglove_port: int | None = None,
) -> FastAPI:
    """The web app, opening on `robot` in `world`.

    `bus`: the in-process topic/service bus to serve over rosbridge at `/rosbridge`
    (none: no rosbridge route). `warm`: build the default robot's and world's files in
    the background at start-up, so the first page load does not wait for them.
    `uploads_dir`: where uploaded robots are kept (default: a temporary folder removed
    when the server stops); `max_upload_bytes`: the largest upload taken. `live`: with a
    `bus`, a mobile robot in a room runs as a live platform (simulator and SLAM on the
    bus, real time; robotrial.app.live) while the server runs. `planner`: with a `bus`
    and an arm as `robot`, the planning node (robotrial.ros.planning_node) answers
    `/robotrial/plan_task` for it in `world`, the page's Move Robot!. `access`: which
    origins may connect to rosbridge and upload, and the token (robotrial.ros.rosbridge.
    access; default: the page's own origin and clients without one, no token).
    `foxglove_port`: with a `bus`, also serve it over the Foxglove WebSocket protocol on
    that port (robotrial.ros.foxglove_bridge; 0: any free port; None: not at all), on the
    address `access` listens on; `app.state.foxglove` is the bridge once started (None if
    the port could not be opened; the reason is logged).
    `robot` and `world` may be files (a robot description, a world YAML): they join the
    lists under their own names. Raises ModelError if `robot` or `world` is neither a
    built-in name nor a file that loads.
    """
    try:
        catalog = Catalog(robot, world)
    except UnknownName as exc:
        raise ModelError(str(exc)) from None

    scratch = None
    if uploads_dir is None:
        scratch = tempfile.TemporaryDirectory(prefix="robotrial-uploads-")
        uploads_dir = Path(scratch.name)
    uploads = UploadStore(uploads_dir, max_bytes=max_upload_bytes)
    access = access or Access()
    platform: LivePlatform | None = None
    if live and bus is not None:
        robot_model = catalog.robot(catalog.default_robot)
        world_model = catalog.world(catalog.default_world)
        if runs_live(robot_model, world_model):
            spawn = next(w for w in catalog.worlds() if w["name"] == catalog.default_world)
            platform = LivePlatform(
                bus, robot_model, world_model, Pose(spawn["spawn"]["xyz"], spawn["spawn"]["quat"])
            )

    planning = None
    if planner and bus is not None:
        from robotrial.ros.planning_node import PlanningNode

        default = catalog.robot(catalog.default_robot)
        planning = PlanningNode(
            bus,
            default if robot_kind(default) == "arm" else None,
            catalog.world(catalog.default_world),
            robots=lambda n: _arm(catalog, n),
        )
        for entry in catalog.robots():
            if entry["kind"] == "arm":
                planning.add_robot(entry["name"])
    planner_state = {"status": None if planning is None else "compiling"}
    verdicts = VerdictJobs(catalog)

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        if warm:
            task = planning.planner if planning is not None else None  # None: not an arm
            threading.Thread(target=_warm, args=(catalog, task, planner_state), daemon=True).start()
        elif planning is not None:
            planner_state["status"] = "ready"
        if platform is not None:
            platform.start()
        if foxglove_port is not None and bus is not None:
            app.state.foxglove = _start_foxglove(bus, access, foxglove_port, catalog)
        try:
            yield
        finally:
            verdicts.close()
            if app.state.foxglove is not None:
                app.state.foxglove.destroy()
            if platform is not None:
                platform.stop()
            if planning is not None:
                planning.destroy()
            if scratch is not None:
                scratch.cleanup()

    app = FastAPI(
        title="robotrial",
        summary="Try a robot in simulation: the page, robot and world files, rosbridge.",
        version="0.1.0",
        lifespan=lifespan,
    )
    app.state.catalog = catalog
    app.state.uploads = uploads
    app.state.foxglove = None
    app.add_middleware(
        AccessGuard, access=access, rosbridge_path=ROSBRIDGE_PATH if bus is not None else None
    )

    @app.exception_handler(UnknownName)
    async def unknown_name(_: Request, exc: UnknownName) -> JSONResponse:
        return JSONResponse({"detail": str(exc.args[0])}, status_code=404)

    @app.exception_handler(ModelError)
    async def broken_model(_: Request, exc: ModelError) -> JSONResponse:
        return JSONResponse({"detail": f"could not build the file: {exc}"}, status_code=500)

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def page(request: Request) -> Response:
        """The page shell; opened with the server's `?token=`, it also gets the token
        as a cookie, so the page's own requests carry it."""
        index = static_dir / "index.html"
        if not index.is_file():
            return HTMLResponse(MISSING_BUILD_PAGE.format(static=static_dir), status_code=503)
        answer = FileResponse(index, media_type="text/html", headers={"Cache-Control": "no-cache"})
        given = request.query_params.get("token")
        if access.token is not None and given is not None and access.token_ok(given):
            answer.set_cookie(TOKEN_COOKIE, given, httponly=True, samesite="strict")
        return answer

    @app.get("/api/config", response_model=Config, tags=["page"])
    def config() -> Config:
        """The robot and world the page opens on, and where rosbridge listens."""
        return Config(
            robot=catalog.default_robot,
            world=catalog.default_world,
            rosbridge=ROSBRIDGE_PATH,
            rosbridge_enabled=bus is not None,
            live=None
            if platform is None
            else LiveInfo(
                robot=catalog.default_robot,
                world=catalog.default_world,
                origin=SpawnPose(xyz=list(platform.spawn.xyz), quat=list(platform.spawn.quat)),
                error=platform.error,
            ),
            planner=planner_state["status"],
            plan_services={} if planning is None else planning.services(),
        )

    @app.get("/api/robots", response_model=RobotList, tags=["robots"])
    def robots() -> RobotList:
        """The built-in robots: name, kind (arm or mobile), joint count, the world each
        opens in, and the server's default robot and world."""
        return RobotList(default=Pair(**catalog.default_pair()), robots=catalog.robots())

    @app.get("/api/worlds", response_model=WorldList, tags=["worlds"])
    def worlds() -> WorldList:
        """The built-in worlds: name, kind (arm: a tabletop scene; mobile: a room),
        description and the robot's spawn pose, and the default robot and world."""
        return WorldList(default=Pair(**catalog.default_pair()), worlds=catalog.worlds())

    @app.post(
        "/api/robots/upload",
        response_model=UploadAnswer,
        status_code=201,
        tags=["robots"],
        responses={
            400: {"description": "not a robot file, or a zip that is unsafe to unpack"},
            401: {"description": "the server needs a token (Authorization: Bearer TOKEN)"},
            403: {"description": "sent from a web page of another site"},
            413: {"description": "larger than the server takes"},
            422: {"description": "the robot description is broken; detail says where"},
        },
    )
    async def upload_robot(request: Request) -> Response:
        """Add a robot from a multipart upload (field `file`): a .zip holding a URDF or
        xacro with its meshes, a .urdf, a .xacro, or an RDTF .glb. It joins the robot
        list under the name returned; its RDTF route works at once."""
        refused = _refusal(access, request)
        if refused is not None:
            return refused
        try:
            form = await _bounded_form(request, uploads.max_bytes)
            sent = form.get("file")
            if not isinstance(sent, StarletteUpload) or not sent.filename:
                raise UploadRefused("no file: send the robot in the multipart field 'file'")
            filename = stored_name(sent.filename)
            folder = uploads.new_folder(filename)
            with open(folder / filename, "wb") as out:
                shutil.copyfileobj(sent.file, out)
            robot = await run_in_threadpool(
                uploads.load, filename, folder / filename, set(catalog.robot_names())
            )
            catalog.add_robot(robot.name, robot.model, robot.rdtf)
            if planning is not None and robot_kind(robot.model) == "arm":
                planning.add_robot(robot.name)
        except UploadRefused as exc:
            return JSONResponse({"detail": str(exc)}, status_code=exc.status)
        except ModelError as exc:
            return JSONResponse({"detail": str(exc)}, status_code=422)
        entry = next(r for r in catalog.robots() if r["name"] == robot.name)
        answer = UploadAnswer(robot=RobotEntry(**entry), repairs=list(robot.model.repairs))
        return JSONResponse(answer.model_dump(), status_code=201)

    @app.post(
        "/api/robots/{name}/tool",
        response_model=RobotEntry,
        tags=["robots"],
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {"application/json": {"schema": ToolChoice.model_json_schema()}},
            }
        },
        responses={
            401: {"description": "the server needs a token (Authorization: Bearer TOKEN)"},
            403: {"description": "sent from a web page of another site"},
            404: {"description": "no uploaded robot of that name"},
            422: {"description": "the link cannot be the tool; detail names those that can"},
        },
    )
    async def choose_tool(name: str, request: Request) -> Response:
        """Make another link the tool of an uploaded arm (one of its entry's `tools`):
        the hand read-out and Move Robot!'s goal then refer to it, and the arm is the
        chain of joints that moves it. Answers the robot's new entry."""
        refused = _refusal(access, request)
        if refused is not None:
            return refused
        body = await _bounded_body(request, 4096)
        try:
            link = ToolChoice.model_validate_json(bytes(body or b"")).link
        except ValidationError as exc:
            return JSONResponse({"detail": _invalid(exc)}, status_code=422)
        try:
            model = await run_in_threadpool(catalog.set_tool, name, link)
        except ModelError as exc:
            return JSONResponse({"detail": str(exc)}, status_code=422)
        if planning is not None and robot_kind(model) == "arm":
            default = name == catalog.default_robot
            await run_in_threadpool(planning.forget, name, default)
        entry = next(r for r in catalog.robots() if r["name"] == name)
        return JSONResponse(RobotEntry(**entry).model_dump())

    @app.post(
        "/api/worlds",
        response_model=WorldEntry,
        status_code=201,
        tags=["worlds"],
        responses={
            401: {"description": "the server needs a token (Authorization: Bearer TOKEN)"},
            403: {"description": "sent from a web page of another site"},
            413: {"description": "larger than the server takes"},
            422: {"description": "the world YAML is broken; detail names the entry"},
        },
    )
    async def add_world(request: Request) -> Response:
        """Add a world from its YAML (the request body, docs/worlds.md), such as a home
        drawn in the page. Files are not taken (no meshes). It joins the world list."""
        refused = _refusal(access, request)
        if refused is not None:
            return refused
        body = await _bounded_body(request, MAX_WORLD_BYTES)
        if body is None:
            return _world_too_large()
        try:
            text = body.decode("utf-8", errors="replace")
            world = await run_in_threadpool(load_world_text, text, "world.yaml")
        except ModelError as exc:
            return JSONResponse({"detail": str(exc)}, status_code=422)
        name = catalog.add_world(world)
        entry = next(w for w in catalog.worlds() if w["name"] == name)
        return JSONResponse(WorldEntry(**entry).model_dump(), status_code=201)

    @app.post(
        "/api/verdict",
        response_model=VerdictJob,
        status_code=202,
        tags=["verdict"],
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {"application/json": {"schema": VerdictRequest.model_json_schema()}},
            }
        },
        responses={
            401: {"description": "the server needs a token (Authorization: Bearer TOKEN)"},
            403: {"description": "sent from a web page of another site"},
            413: {"description": "larger than the server takes"},
            422: {"description": "unknown robot, a robot without a base, broken world YAML"},
            429: {"description": "too many checks already waiting"},
        },
    )
    async def start_verdict(request: Request) -> Response:
        """Check a home for one or two robots (docs/verdict.md). The check runs in the
        background: poll GET /api/verdict/{id} with the id answered here."""
        refused = _refusal(access, request)
        if refused is not None:
            return refused
        body = await _bounded_body(request, MAX_WORLD_BYTES + JSON_SLACK)
        if body is None:
            return _world_too_large()
        try:
            asked = VerdictRequest.model_validate_json(bytes(body))
        except ValidationError as exc:
            return JSONResponse({"detail": _invalid(exc)}, status_code=422)
        if len(asked.world.encode("utf-8")) > MAX_WORLD_BYTES:
            return _world_too_large()
        try:
            chores = [(c.object, c.to) for c in asked.chores]
            job = await run_in_threadpool(
                verdicts.start, asked.world, asked.robots, chores, asked.seeds
            )
        except VerdictRefused as exc:
            return JSONResponse({"detail": str(exc)}, status_code=exc.status)
        return JSONResponse(job.model_dump(), status_code=202)

    @app.get(
        "/api/verdict/{job_id}",
        response_model=VerdictJob,
        tags=["verdict"],
        responses={404: {"description": "no such job (finished ones are kept a while)"}},
    )
    def verdict_job(job_id: str) -> Response:
        """A check's progress (fraction, what) and, once done, each robot's verdict; or
        the error that stopped it."""
        job = verdicts.get(job_id)
        if job is None:
            return JSONResponse(
                {"detail": f"no verdict job {job_id!r} on this server (it may have restarted)"},
                status_code=404,
            )
        return JSONResponse(job.model_dump())

    @app.get(
        "/api/robots/{name}.glb",
        tags=["robots"],
        responses={200: {"content": {GLB_MEDIA_TYPE: {}}}, **NOT_FOUND},
        response_class=Response,
    )
    def robot_file(name: str, request: Request) -> Response:
        """The robot as RDTF: glTF binary with the RDTF_robot extension (docs/rdtf.md)."""
        return _glb(catalog.robot_glb(name), request)

    @app.get(
        "/api/worlds/{name}.glb",
        tags=["worlds"],
        responses={200: {"content": {GLB_MEDIA_TYPE: {}}}, **NOT_FOUND},
        response_class=Response,
    )
    def world_file(name: str, request: Request) -> Response:
        """The world as a glTF binary scene (floor, walls, obstacles, objects, lights)."""
        return _glb(catalog.world_glb(name), request)

    @app.get(
        "/api/robots/{name}/mjcf.json",
        tags=["robots"],
        response_model=MjcfBundle,
        responses=NOT_FOUND,
    )
    def robot_mjcf(name: str, request: Request, world: str | None = None) -> Response:
        """The robot standing in `world` (default: the world it opens in) as MJCF for
        the browser's physics (mujoco-js): the XML, its mesh files in base64, and what the
        writer had to change. Every actuated joint has a position servo."""
        if world is None:
            world = catalog.world_for(robot_kind(catalog.robot(name)))
        asset = catalog.mjcf_bundle(name, world)
        headers = {"ETag": asset.etag, "Cache-Control": "no-cache"}
        if request.headers.get("if-none-match") == asset.etag:
            return Response(status_code=304, headers=headers)
        return Response(asset.data, media_type="application/json", headers=headers)

    app.mount("/assets", PageAssets(directory=static_dir / "assets"), name="assets")
    if bus is not None:
        mount_rosbridge(app, bus, access)
    return app


def _start_foxglove(bus: Bus, access: Access, port: int, catalog: Catalog) -> Any:
    """The Foxglove bridge on `port`, serving the default robot's meshes; None (logged)
    when the port cannot be opened, so the page keeps working."""
    from robotrial.ros.foxglove_bridge import FoxgloveBridge

    try:
        robot = catalog.robot(catalog.default_robot)
        return FoxgloveBridge(bus, host=access.listen_host, port=port, robot=robot, access=access)
    except OSError as exc:
        log.error("Foxglove: %s", exc)
        return None


async def _bounded_body(request: Request, limit: int) -> bytearray | None:
    """The request's body, or None as soon as it passes `limit` bytes."""
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > limit:
            return None
    return body


def _world_too_large() -> JSONResponse:
    return JSONResponse(
        {"detail": f"a world YAML is at most {MAX_WORLD_BYTES // 1024} kB"}, status_code=413
    )


def _invalid(exc: ValidationError) -> str:
    """A request body's mistakes in one line, each with the field it is in."""
    return "; ".join(
        f"{'.'.join(str(p) for p in e['loc']) or 'body'}: {e['msg']}" for e in exc.errors()
    )


async def _bounded_form(request: Request, limit: int) -> FormData:
    """The request's multipart form, refused with 413 as soon as the body passes
    `limit` bytes (plus room for the multipart framing), before it is all read."""
    message = too_large_message(limit)
    slack = 64 * 1024
    length = request.headers.get("content-length", "")
    if length.isdigit() and int(length) > limit + slack:
        raise UploadRefused(message, status=413)
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > limit + slack:
            raise UploadRefused(message, status=413)
    replayed = False

    async def receive() -> dict[str, Any]:
        nonlocal replayed
        if replayed:
            return {"type": "http.disconnect"}
        replayed = True
        return {"type": "http.request", "body": bytes(body), "more_body": False}

    try:
        return await Request(request.scope, receive).form(max_files=1, max_fields=10)
    except (HTTPException, MultiPartException) as exc:
        detail = getattr(exc, "detail", None) or getattr(exc, "message", str(exc))
        raise UploadRefused(f"not a readable upload: {detail}") from None


def _glb(asset: Asset, request: Request) -> Response:
    """A built file; 304 when the browser already holds these bytes."""
    headers = {"ETag": asset.etag, "Cache-Control": "no-cache"}
    if request.headers.get("if-none-match") == asset.etag:
        return Response(status_code=304, headers=headers)
    return Response(asset.data, media_type=GLB_MEDIA_TYPE, headers=headers)


def _arm(catalog: Catalog, name: str) -> tuple[RobotModel, World]:
    """A robot of the list and the world it opens in, for its planner."""
    robot = catalog.robot(name)
    return robot, catalog.world(catalog.world_for(robot_kind(robot)))


def _refusal(access: Access, request: Request) -> JSONResponse | None:
    """The answer to a write from a page of another site (403); None when the request
    may go on (the token of every request is checked by AccessGuard)."""
    if not access.origin_allowed(request.headers):
        return JSONResponse({"detail": access.refusal(request.headers)}, status_code=403)
    return None


def _warm(catalog: Catalog, task: TaskPlanner | None, planner: dict[str, str | None]) -> None:
    """Build the default robot's and world's files, then plan once so that the planner's
    compiled kernels are ready before the first Move Robot! (`planner["status"]` says
    "compiling" until then)."""
    try:
        catalog.warm()
    except Exception as exc:  # the request that needs the file reports the error
        log.warning("could not prepare the default robot and world: %s", exc)
    if task is not None:
        try:
            task.warm()
        except Exception as exc:  # the first request compiles then, and reports errors
            log.warning("could not warm the planner: %s", exc)
    planner["status"] = "ready"
