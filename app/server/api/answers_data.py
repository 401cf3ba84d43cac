"""What the data routes answer (recording, scope, sensors, robots), one pydantic model each, as
in `answers.py`: fields the page reads named, any other still sent, keys left out still out."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from app.server.api.answers import Answer, Params, ReplayStatus


class RecordingSummary(Answer):
    frames: int
    capacity: int
    first_t_s: float | None
    last_t_s: float | None
    events: list[dict[str, Any]] = Field(description="the newest events: kind, t_s and more")
    replay: ReplayStatus


class ScopeFrame(Answer):
    """One TDM-PWM frame as the scope draws it (app/server/feeds/scope_frames.py)."""

    frame: int
    t_s: float
    phase_rad: float
    params_version: int
    source: str
    tick_us: float
    frame_ticks: int
    slot_ticks: int
    select_change_ticks: int
    channels: list[dict[str, Any]] = Field(description="per channel its slots")
    lines: list[dict[str, Any]] = Field(description="each wire's initial level and edges")
    flags: dict[str, Any]


class ScopeFrames(Answer):
    frames: list[ScopeFrame]


class RecordedFrame(ScopeFrame):
    """A recorded frame as the scope draws it, and where it lies in the recording."""

    index: int
    recorded: bool
    session_t_s: float


class LinkedRobotSensors(Answer):
    """A linked robot's last 5 s (`artro link`) and its last frame's status."""

    columns: dict[str, list[Any]]
    received_s_ago: float
    frames_received: int
    frame: int
    status: list[Any]
    imu_failures: int
    laws: list[Any]
    support: Any


class Sensors(Answer):
    columns: dict[str, list[float | None]] = Field(
        description="one value per 20 ms frame, oldest first; null where a sole carries nothing"
    )
    sole_mm: list[float] | None = Field(description="the sole's outline")
    fsr_mm: list[list[float]] = Field(description="the force sensors' places")
    robot: LinkedRobotSensors | None


class LinkedRobotSeries(Answer):
    """A series a linked robot's frames add to a chart (app/sim/sensor_channels.py)."""

    key: str = Field(description="its column in GET /api/sensors `robot.columns`")
    label: str = Field(description='the legend says "robot: " and this')
    colour: str = Field(description="drawn in this colour (CSS), thicker than the simulation's")


class SensorChart(Answer):
    key: str = Field(description="the chart's name, as a column's `chart` gives it")
    label: str = Field(description="its axis label")


class SensorChannel(Answer):
    """A column of GET /api/sensors (app/sim/sensor_channels.py `Channel`)."""

    key: str = Field(description="its name among GET /api/sensors `columns`")
    unit: str
    label: str
    chart: str | None = Field(description="the chart that draws it; null: none (the soles')")
    colour: str = Field(description="drawn in this colour (CSS)")
    dashed: bool
    scale: float = Field(description="drawn times this")


class SensorLaw(Answer):
    group: str = Field(description="the law's group of the gait schema")
    label: str = Field(description="its name on the panel")


class SensorChannels(Answer):
    """The Sensors panel's charts, the trace's columns, the laws and a linked robot's series,
    as declared once (app/sim/sensor_channels.py, gait/feedback_params.py `LAWS`)."""

    charts: list[SensorChart] = Field(description="each chart's key and axis label")
    channels: list[SensorChannel] = Field(description="each column of GET /api/sensors, in order")
    laws: list[SensorLaw] = Field(description="each law's group and name, in bit order")
    robot: dict[str, list[LinkedRobotSeries]] = Field(
        default={},
        description="each chart's key: the series a linked robot's frames add to it, in order "
        "(drawn while GET /api/sensors has a `robot`)",
    )


class FramesTaken(Answer):
    taken: int = Field(description="the frames new to the ring")
    window_frames: int


class RobotOffer(Answer):
    name: str
    title: str
    default_preset: str
    leg_m: float
    total_mass_kg: float


class RobotList(Answer):
    loaded: str = Field(description="the robot in use")
    robots: list[RobotOffer]


class RobotSummary(Answer):
    """The description and the figures that follow from it (`artro robot show`)."""

    name: str
    title: str
    default_preset: str
    description: dict[str, Any]
    geometry: dict[str, Any]
    total_mass_kg: float
    mapping: dict[str, Any]
    derived: dict[str, Any]


class RobotSwitched(Answer):
    robot: str
    changed: bool
    params: Params


class RobotImported(Answer):
    robot: str
    title: str
    file: str = Field(description="the robot file within the upload")
    written: str = Field(description="the description written")
    total_mass_kg: float
    leg_m: float
    geometry: dict[str, Any]
    forward_from: Any
    mapping: list[dict[str, Any]]
    held: list[Any]
    notes: list[str]


class Cancelled(Answer):
    cancelled: bool


class RecordingFile(Answer):
    """A recording as one JSON document (`GET /api/recording/export`, the import's body)."""

    format: str
    format_version: int
    model: str = Field(description="the robot's model it was recorded on")
    frame_s: float
    frames: int
    columns: dict[str, list[Any]] = Field(description="one array per column, frame by frame")
    events: list[dict[str, Any]]
    params: dict[str, Any] = Field(description="the parameter document of each version in it")
