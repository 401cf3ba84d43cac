"""What the JSON routes answer, one pydantic model each (their `response_model`): `/openapi.json`
and `/docs` describe every success body and schemathesis checks them. Each names the fields the
page reads; a field a model does not name still goes out (extra allowed) and a key a route
leaves out stays out (answered with `exclude_unset`): the JSON the page reads never changes."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from app.params.presets import PresetInfo, PresetProblem
from app.params.schema import GaitModel, MotionModel
from app.server.sim.emulated_controller import FirmwareStatus
from app.server.sim.published import LatencySummary, PushMark, TrunkPose

#: the keyword arguments of a route with an answer model: keys left out stay out
ANSWER: dict[str, Any] = {"response_model_exclude_unset": True}


class Answer(BaseModel):
    """A route's answer; fields it does not name go out too."""

    model_config = ConfigDict(extra="allow")


# --- the simulation (api/sim.py) -------------------------------------------------------------


class Health(Answer):
    status: str = Field(description='"ok", or "simulation stopped"')
    version: str = Field(description="the project's version")
    viser_port: int | None = Field(description="the 3D view's port; null without the view")


class Accepted(Answer):
    accepted: str = Field(description="what was accepted (a command, a setting)")


class SpeedAccepted(Accepted):
    speed: float = Field(description="x real time")


class DriveAccepted(Accepted):
    drive: str = Field(description='"model" or "firmware"')


class PushAccepted(Accepted):
    impulse_n_s: float
    direction_deg: float


class ReplayStatus(Answer):
    """A replay shown, or `{"active": false}` for live."""

    active: bool
    origin: str | None = Field(None, description="the session or an imported file")
    index: int | None = Field(None, description="the frame shown, 0-based")
    frames: int | None = None
    session_t_s: float | None = None
    t_s: float | None = Field(None, description="the simulated time of the frame shown")
    frame: int | None = Field(None, description="the frame's number in its session")


class ScopeClients(Answer):
    clients: int
    dropped: int


class JobRef(Answer):
    """A background job's id and status (GET /api/jobs/{id} has the rest)."""

    id: str
    status: str


class State(Answer):
    """The simulation thread's published status (`SimStatus`) and what the page asks besides."""

    sim_time_s: float
    frame: int
    rtf: float | None = Field(description="the real-time factor over the last 2 s")
    speed: float
    paused: bool
    fell: bool
    behind: bool
    frames_dropped: int
    trunk: TrunkPose
    params_version_applied: int
    param_latency_frames: LatencySummary
    resets: int
    errors: list[str]
    drive: str
    firmware: FirmwareStatus | None
    gait_ramp: float | None = Field(description="how far a change of gait constants has come")
    world: str
    robot: str
    push: PushMark | None
    params_version: int
    scope: ScopeClients
    running: bool
    replay: ReplayStatus
    tune: JobRef | None
    fit: JobRef | None = Field(description="the latest fit to a recording (null: none ran)")
    robustness_report: bool
    servo_bus: bool = Field(description="the server runs a servo bus (GET /api/bus)")


# --- the world (api/world.py) ----------------------------------------------------------------


class WorldName(Answer):
    variation: str = Field(description="the variation's name; nominal for none")


class World(WorldName):
    values: dict[str, Any] = Field(description="each field of the variation, its value")
    fitted: str | None = Field(
        None,
        description="whose fit the variation is: a fit job's id, or the fitted robot's "
        "recording (docs/FIT.md); null: no fit is in force",
    )
    ranges: dict[str, list[float]] = Field(description="`artro bench robust`'s default ranges")


class RobustnessReport(Answer):
    """`artro bench robust`'s report of the gait in use, as the job made it."""

    finished_at: float | None = Field(None, description="Unix s")
    params_version: int | None = None


# --- the paths (api/paths.py) ----------------------------------------------------------------


class Anchor(Answer):
    t_s: float
    x_m: float
    y_m: float
    yaw_rad: float


class Axle(Answer):
    axle_m: float | None = Field(description="set by hand; null: the distance between the feet")
    axle_source: str = Field(description="feet or manual")


class PathView(Answer):
    axle_m: float = Field(description="the axle b the prediction uses")
    axle_source: str = Field(description="feet, fitted or manual")
    actual: list[list[float]] = Field(description="rows of (t_s, x_m, y_m, yaw_rad)")
    predicted: list[list[float]]
    anchor: Anchor | None
    speed_m_s: float
    speed_source: str
    feet_m: float
    ca: float
    turn_radius_m: float | None = Field(description="null: straight")
    predicted_turn_deg_s: float
    actual_turn_deg_s: float
    actual_forward_m_s: float
    actual_lateral_m_s: float
    axle_stale: bool = Field(description="a fitted axle of another gait than the one in use")


# --- the parameters and presets (api/params.py, api/presets.py) ------------------------------


class Reverted(Answer):
    version: int
    source: str


class Params(Answer):
    """The parameters in use (a store version)."""

    version: int
    name: str
    robot: str
    motion: MotionModel
    gait: GaitModel
    warnings: list[str] | None = Field(None, description="a set tuned for another robot")
    reverted: Reverted | None = Field(None, description="undo/redo: whose change was replaced")


class SchemaField(Answer):
    name: str
    default: Any
    min: Any = None
    max: Any = None
    step: Any = None
    unit: str
    doc: str
    eq: str | None = Field(description="the equation it enters")


class SchemaGroup(Answer):
    group: str
    title: str
    engines: list[str] = Field(description="the gait engines that read it")
    fields: list[SchemaField]


class PresetList(Answer):
    presets: list[PresetInfo]
    problems: list[PresetProblem] = Field(description="files in the presets folder skipped")


class Difference(Answer):
    field: str
    a: Any
    b: Any


class PresetDiff(Answer):
    a: str
    b: str
    differences: list[Difference]


class ParameterDocument(Answer):
    """A parameter set as a file holds it."""

    name: str
    robot: str | None = None
    created: str | None = None
    motion: MotionModel
    gait: GaitModel


class Deleted(Answer):
    deleted: str


# --- the ghost (api/ghost.py) ----------------------------------------------------------------


class VersionRef(Answer):
    version: int
    name: str
    source: str


class GhostDiff(Answer):
    field: str
    live: Any
    ghost: Any


class GhostMetrics(Answer):
    live: dict[str, Any] | None
    ghost: dict[str, Any] | None
    delta: dict[str, Any] | None


class GhostState(Answer):
    """Off: `enabled` false and the versions; on: the comparison too."""

    enabled: bool
    versions: list[VersionRef]
    source: str | None = None
    phase_locked: bool | None = None
    note: str | None = None
    fell: bool | None = None
    window_s: float | None = None
    diff: list[GhostDiff] | None = None
    metrics: GhostMetrics | None = None


class GhostAccepted(Accepted):
    source: str | None = Field(description="what the ghost walks; null when removed")
    warnings: list[str] | None = None
