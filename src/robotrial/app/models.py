"""The JSON the web server answers with (layer 5): one pydantic model per shape.

The routes in robotrial.app.server validate their answers with these models and
describe them in the OpenAPI schema; robotrial.app.typescript writes the web client's
types from them (web/src/generated/api.ts). A field's docstring is its description in
both. Every field is in every answer, defaults included, and the serialization schema
says so (`json_schema_serialization_defaults_required`).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from robotrial.app.catalog import Kind


class ApiModel(BaseModel):
    """The base of the answers: field docstrings describe the fields, and a field with a
    default is still required in the serialization schema (it is always sent)."""

    model_config = ConfigDict(
        use_attribute_docstrings=True, json_schema_serialization_defaults_required=True
    )


class Pair(ApiModel):
    """A robot and a world, by name."""

    robot: str
    world: str


class SpawnPose(ApiModel):
    """Where a robot's base stands in a world."""

    xyz: tuple[float, float, float]
    """Position (m)."""
    quat: tuple[float, float, float, float]
    """Orientation as a unit quaternion: x, y, z, w."""


class LiveInfo(ApiModel):
    """The simulated platform streaming on rosbridge: which robot in which world, and
    where its odom and map frames start in the world (the spawn pose)."""

    robot: str
    world: str
    origin: SpawnPose
    error: str | None = None
    """Why it could not start, or null."""


class Config(ApiModel):
    """What the page needs to start."""

    robot: str
    """The robot the page opens on: the server's default."""
    world: str
    """The world the page opens on: the server's default."""
    rosbridge: str
    """Path of the rosbridge WebSocket on this server, e.g. "/rosbridge"."""
    rosbridge_enabled: bool
    """Whether this server offers rosbridge there."""
    live: LiveInfo | None = None
    """The platform the server simulates live (a mobile robot in a room), or null."""
    planner: str | None = None
    """The planning service: "compiling" while its kernels compile at start (a first
    Move Robot! would wait for them), "ready", or null when the server has none."""
    plan_services: dict[str, str] = {}
    """Robot name -> its PlanTask service (robotrial.ros.planning_node.robot_service)."""


class RobotEntry(ApiModel):
    """A robot the server offers."""

    name: str
    """Its name in the list and in URLs (lower case letters, digits, underscores)."""
    title: str = ""
    """Its name as its description writes it (the URDF's robot name), to show."""
    kind: Kind
    joints: int
    """How many joints it drives."""
    world: str
    """The world this robot opens in when picked."""
    uploaded: bool = False
    """True for a robot a user uploaded to this server (or gave it as a file)."""
    tool: str = ""
    """The tool link: what the hand read-out shows and Move Robot!'s goal moves."""
    tools: list[str] = []
    """Links an arm's tool may be (POST /api/robots/{name}/tool); the tool first."""
    stand: SpawnPose = SpawnPose(xyz=(0.0, 0.0, 0.0), quat=(0.0, 0.0, 0.0, 1.0))
    """Where its base stands relative to the spawn of `world`: lifted onto the floor and
    moved back from the furniture when its legs reach below the floor, else no change."""


class ToolChoice(ApiModel):
    """The link to make an uploaded robot's tool."""

    link: str


class UploadAnswer(ApiModel):
    """A robot accepted from an upload: its catalog entry and what the loader repaired."""

    robot: RobotEntry
    repairs: list[str]
    """What the loader repaired (missing inertials and the like)."""


class RobotList(ApiModel):
    """The robots the server offers, and its default robot and world."""

    default: Pair
    robots: list[RobotEntry]


class WorldEntry(ApiModel):
    """A world the server offers."""

    name: str
    kind: Kind
    """arm: a tabletop scene; mobile: a room."""
    description: str
    spawn: SpawnPose
    """Where a robot stands in it."""


class WorldList(ApiModel):
    """The worlds the server offers, and its default robot and world."""

    default: Pair
    worlds: list[WorldEntry]


class MjcfBundle(ApiModel):
    """A MuJoCo model for the browser: MJCF text and the files it names."""

    name: str
    xml: str
    assets: dict[str, str]
    """The files the XML names (meshes), base64, by file name."""
    notes: list[str]
    """What the MJCF writer had to change."""


class ChoreRequest(ApiModel):
    """A chore to try in a home: carry the movable `object` to the room `to`."""

    object: str
    to: str


class VerdictRequest(ApiModel):
    """A home to check (POST /api/verdict): the world, one or two robots, and the chores
    to run as carry trials (docs/verdict.md, Chores)."""

    world: str
    """A world's name on this server, or a World YAML (docs/worlds.md), such as the home
    drawn in the page."""
    robots: list[str] = Field(min_length=1, max_length=2)
    """One robot, or two to compare side by side."""
    chores: list[ChoreRequest] = Field(default=[], max_length=5)
    """Chores, each run `seeds` times for each robot (about a minute of server time a run)."""
    seeds: int = Field(default=1, ge=1, le=5)
    """Runs (seeds 0 .. seeds - 1) of each chore."""


class RobotVerdict(ApiModel):
    """One robot's verdict on a home (docs/verdict.md)."""

    robot: str
    summary: str
    """One line: how many rooms it reaches, which not, which are tight."""
    pictures: dict[str, str]
    """Title -> a PNG as a data: URL (the floor plan with the routes in their colours)."""
    rooms: list[dict[str, Any]]
    """One row per room: `room`, `reachable`, `colour` (green, amber, red) and the
    engine's figures for it; `route`, when given, is the way there as [x, y] points (m)."""
    footprint: tuple[float, float] | None = None
    """The base's length and width (m), when the engine reports them."""
    turning_diameter: float | None = None
    """The circle the base needs to turn on the spot (m), when the engine reports it."""
    chores: list[dict[str, Any]] = []
    """One per chore asked for: `chore`, `object`, `room`, `runs`, `successes`, `done`,
    `mean_time` (s, simulated, of the successful runs), `failed_phases`, `outcomes`
    (per run: `seed`, `success`, `failed_phase`, `cause`, `reason`, `sim_time`), `refused` (why the
    trial would not run it, or "") and `wall_time` (s)."""
    details: dict[str, Any] = {}
    """Whatever else the engine reports, by name."""


class VerdictJob(ApiModel):
    """A check of a home running on the server (GET /api/verdict/{id})."""

    id: str
    state: Literal["queued", "running", "done", "failed"]
    fraction: float
    """How much is done, from 0 to 1."""
    what: str
    """What the server is doing now, in words."""
    world: str
    """The name of the world checked."""
    robots: list[str]
    results: list[RobotVerdict]
    """One per robot, in the order asked for, as each is finished."""
    error: str | None = None
    """Why the check failed (state "failed"), naming what and where; else null."""
    seconds: float
    """Time since the job was taken (s), until it finished."""


API_MODELS: tuple[type[ApiModel], ...] = (
    Config,
    RobotList,
    WorldList,
    UploadAnswer,
    ToolChoice,
    MjcfBundle,
    VerdictRequest,
    VerdictJob,
)
"""What the routes answer with; the models they hold come with them."""
