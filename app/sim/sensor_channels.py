"""The sensor channels declared once (docs/DESIGN.md §15): each column the Sensors trace keeps per
frame -- its key, unit, label, the panel's chart it is drawn in and how it is taken from a frame's
reading and law outputs -- the sensors' here, each law's from `gait.feedback_params.LAWS`; which of
them a linked robot's frames carry and how its series are drawn. The trace's rows, the robot's
view, `GET /api/sensors/channels` and the page's charts follow (`CHANNELS`, `ROBOT_SERIES`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.sim.sensors import SensorReading
from gait import feedback
from gait.feedback_params import LAWS, LawOutput
from hardware.firmware.wire import SENSORS


@dataclass(frozen=True)
class FrameSample:
    """What a channel is taken from, for one frame: the reading, what the laws made of it, and
    what the trace works out once for several channels (each sole's CoP, the true tilt). A
    linked robot's frame makes one too (`robot_sample`), its values float64 as posted."""

    time_s: float  # when it was read: after the frame
    reading: SensorReading
    out: feedback.Output
    true_tilt_deg: tuple[float, float]  # (pitch, roll) as the simulator has them: for the eye
    cop_mm: NDArray[np.float64]  # (2, 2) each sole's (x, y) from its centre; NaN: no load


@dataclass(frozen=True)
class Channel:
    """One column of the trace. `chart`: the Sensors panel's chart that draws it (`CHARTS`), or
    None (kept, drawn otherwise: the soles' outline reads the CoP and loads); drawn `scale` times
    itself in `colour`, `dashed` or not. `robot`: a linked robot's frames carry it too (a column
    of its view, app/server/feeds/robot_sensors.py, taken from `robot_sample` the same way)."""

    key: str  # the column's name in GET /api/sensors
    unit: str
    label: str
    chart: str | None
    take: Callable[[FrameSample], float]
    colour: str = "#adb5bd"
    dashed: bool = False
    scale: float = 1.0
    robot: bool = False


#: the panel's charts: key -> axis label
CHARTS = {
    "attitude": "trunk tilt (°)",
    "gyro": "gyro (°/s)",
    "laws": "law outputs (°; a_y ×100)",
}


def _gyro_deg_s(axis: int) -> Callable[[FrameSample], float]:
    return lambda f: float(np.degrees(f.reading.gyro_rad_s)[axis])


def _attitude_deg(axis: int) -> Callable[[FrameSample], float]:
    return lambda f: float(np.degrees(f.out.attitude_rad)[axis])


def _cop_mm(foot: int, axis: int) -> Callable[[FrameSample], float]:
    return lambda f: float(f.cop_mm[foot, axis])


def _load_n(foot: int) -> Callable[[FrameSample], float]:
    return lambda f: float(f.reading.fsr_n[foot].sum())


def _law_output(output: LawOutput) -> Callable[[FrameSample], float]:
    """The output's value: its field of `feedback.Output` (the index-th), in degrees for "°"."""

    def take(f: FrameSample) -> float:
        value = getattr(f.out, output.field)
        value = np.degrees(value) if output.unit == "°" else value  # float32 in, float32 out
        return float(value if output.index is None else value[output.index])

    return take


#: the fields of `feedback.Output` a linked robot's SENSORS frame carries: those that
#: hardware/firmware/wire.py forwards to the dashboard as float32, by the same name
ROBOT_OUTPUT_FIELDS: tuple[str, ...] = tuple(
    f.name
    for f in SENSORS.fields
    if f.dashboard == "float32" and f.name in {o.name for o in fields(feedback.Output)}
)


def law_channel(output: LawOutput) -> Channel:
    """A law's output as a channel of the laws' chart (or of none, if it is not drawn); the
    robot's too when its SENSORS frames carry the output's field."""
    chart = "laws" if output.drawn else None
    take = _law_output(output)
    return Channel(
        output.key, output.unit, output.label, chart, take, output.colour, output.dashed,
        output.scale, robot=output.field in ROBOT_OUTPUT_FIELDS,
    )  # fmt: skip


#: what the sensors read and what the estimate makes of it, before the laws' outputs
SENSOR_CHANNELS: tuple[Channel, ...] = (
    Channel("t_s", "s", "simulated time", None, lambda f: f.time_s, robot=True),
    Channel("pitch_est_deg", "°", "pitch, estimated", "attitude", _attitude_deg(0), "#4dabf7",
            robot=True),
    Channel("roll_est_deg", "°", "roll, estimated", "attitude", _attitude_deg(1), "#ff922b",
            robot=True),
    Channel("pitch_true_deg", "°", "pitch, true", "attitude", lambda f: f.true_tilt_deg[0],
            "#4dabf7", dashed=True),
    Channel("roll_true_deg", "°", "roll, true", "attitude", lambda f: f.true_tilt_deg[1],
            "#ff922b", dashed=True),
    Channel("gyro_x_deg_s", "°/s", "roll rate x", "gyro", _gyro_deg_s(0), "#ff922b", robot=True),
    Channel("gyro_y_deg_s", "°/s", "pitch rate y", "gyro", _gyro_deg_s(1), "#4dabf7", robot=True),
    Channel("gyro_z_deg_s", "°/s", "yaw rate z", "gyro", _gyro_deg_s(2), "#51cf66", robot=True),
)  # fmt: skip
#: each sole's centre of pressure and load, which the panel draws in the soles' outline
SOLE_CHANNELS: tuple[Channel, ...] = (
    Channel("cop_l_x_mm", "mm", "left sole: CoP x", None, _cop_mm(0, 0), robot=True),
    Channel("cop_l_y_mm", "mm", "left sole: CoP y", None, _cop_mm(0, 1), robot=True),
    Channel("cop_r_x_mm", "mm", "right sole: CoP x", None, _cop_mm(1, 0), robot=True),
    Channel("cop_r_y_mm", "mm", "right sole: CoP y", None, _cop_mm(1, 1), robot=True),
    Channel("load_l_n", "N", "left sole: load", None, _load_n(0), robot=True),
    Channel("load_r_n", "N", "right sole: load", None, _load_n(1), robot=True),
)
#: every column of the trace, in order: the sensors', each law's outputs in LAWS' order, the soles'
CHANNELS: tuple[Channel, ...] = (
    *SENSOR_CHANNELS,
    *(law_channel(output) for law in LAWS for output in law.outputs),
    *SOLE_CHANNELS,
)
COLUMNS: tuple[str, ...] = tuple(channel.key for channel in CHANNELS)
#: the channels a linked robot's frames carry, in the trace's order (the time first)
ROBOT_CHANNELS: tuple[Channel, ...] = tuple(channel for channel in CHANNELS if channel.robot)


@dataclass(frozen=True)
class RobotSeries:
    """A series a linked robot's frames add to the panel: its column `key`, drawn in the chart
    of the channel of that key, as "robot: `label`" in `colour` (a lighter tint, drawn thicker)."""

    key: str
    label: str
    colour: str


#: the robot's series, in each chart's legend order after the simulation's
ROBOT_SERIES: tuple[RobotSeries, ...] = (
    RobotSeries("pitch_est_deg", "pitch", "#a5d8ff"),
    RobotSeries("roll_est_deg", "roll", "#ffd8a8"),
    RobotSeries("gyro_x_deg_s", "roll rate x", "#ffd8a8"),
    RobotSeries("gyro_y_deg_s", "pitch rate y", "#a5d8ff"),
    RobotSeries("gyro_z_deg_s", "yaw rate z", "#b2f2bb"),
    RobotSeries("tilt_pitch_deg", "tilt trim pitch", "#a5d8ff"),
    RobotSeries("tilt_roll_deg", "tilt trim roll", "#ffd8a8"),
)
_DRAWN_ON_ROBOT = {c.key: c.chart for c in ROBOT_CHANNELS if c.chart is not None}
if bad := [s.key for s in ROBOT_SERIES if s.key not in _DRAWN_ON_ROBOT]:
    raise ValueError(f"robot series {bad}: each must be a drawn channel with robot=True")


def robot_sample(
    time_s: float, reading: SensorReading, sent: dict[str, object], cop_mm: NDArray[np.float64]
) -> FrameSample:
    """A linked robot's frame as the channels take it: `sent` holds the law outputs it carries
    ({field: value} of ROBOT_OUTPUT_FIELDS); what it does not carry is NaN (no robot channel
    reads it), the true tilt too."""
    if set(sent) != set(ROBOT_OUTPUT_FIELDS):
        raise ValueError(f"a robot frame's law outputs are {ROBOT_OUTPUT_FIELDS}, not {[*sent]}")
    nan2, nan12 = np.full(2, np.nan), np.full(12, np.nan)
    unsent = feedback.Output(nan12, np.float32(np.nan), nan2, nan12, nan2, -1, nan2)
    carried: dict[str, Any] = {name: np.asarray(value) for name, value in sent.items()}
    out = replace(unsent, **carried)
    return FrameSample(time_s, reading, out, (np.nan, np.nan), cop_mm)


def channel_list() -> dict[str, object]:
    """The charts, their channels and the laws as the page draws and names them (`GET
    /api/sensors/channels`): {"charts": [{key, label}], "channels": [{key, unit, label, chart,
    colour, dashed, scale}], "laws": [{group, label}], "robot": {chart: [{key, label,
    colour}]}}, the last a linked robot's series of each chart."""
    keys = ("key", "unit", "label", "chart", "colour", "dashed", "scale")
    robot: dict[str, list[dict[str, str]]] = {chart: [] for chart in CHARTS}
    for s in ROBOT_SERIES:
        robot[_DRAWN_ON_ROBOT[s.key]].append({"key": s.key, "label": s.label, "colour": s.colour})
    return {
        "charts": [{"key": key, "label": label} for key, label in CHARTS.items()],
        "channels": [{name: getattr(c, name) for name in keys} for c in CHANNELS],
        "laws": [{"group": law.group, "label": law.label} for law in LAWS],
        "robot": robot,
    }
