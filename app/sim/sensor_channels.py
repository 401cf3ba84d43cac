"""The sensor channels declared once (docs/DESIGN.md §15): each column the Sensors trace keeps per
frame -- its key, unit, label, the panel's chart it is drawn in and how it is taken from a frame's
reading and law outputs -- the sensors' here, each law's from `gait.feedback_params.LAWS`. The
trace's rows, `GET /api/sensors/channels` and the page's charts follow from `CHANNELS`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from app.sim.sensors import SensorReading
from gait import feedback
from gait.feedback_params import LAWS, LawOutput


@dataclass(frozen=True)
class FrameSample:
    """What a channel is taken from, for one frame: the reading, what the laws made of it, and
    what the trace works out once for several channels (each sole's CoP, the true tilt)."""

    time_s: float  # when it was read: after the frame
    reading: SensorReading
    out: feedback.Output
    true_tilt_deg: tuple[float, float]  # (pitch, roll) as the simulator has them: for the eye
    cop_mm: NDArray[np.float64]  # (2, 2) each sole's (x, y) from its centre; NaN: no load


@dataclass(frozen=True)
class Channel:
    """One column of the trace. `chart`: the Sensors panel's chart that draws it (`CHARTS`), or
    None (kept, drawn otherwise: the soles' outline reads the CoP and loads); drawn `scale` times
    itself in `colour`, `dashed` or not."""

    key: str  # the column's name in GET /api/sensors
    unit: str
    label: str
    chart: str | None
    take: Callable[[FrameSample], float]
    colour: str = "#adb5bd"
    dashed: bool = False
    scale: float = 1.0


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


def law_channel(output: LawOutput) -> Channel:
    """A law's output as a channel of the laws' chart (or of none, if it is not drawn)."""
    chart = "laws" if output.drawn else None
    take = _law_output(output)
    return Channel(
        output.key, output.unit, output.label, chart, take, output.colour, output.dashed,
        output.scale,
    )  # fmt: skip


#: what the sensors read and what the estimate makes of it, before the laws' outputs
SENSOR_CHANNELS: tuple[Channel, ...] = (
    Channel("t_s", "s", "simulated time", None, lambda f: f.time_s),
    Channel("pitch_est_deg", "°", "pitch, estimated", "attitude", _attitude_deg(0), "#4dabf7"),
    Channel("roll_est_deg", "°", "roll, estimated", "attitude", _attitude_deg(1), "#ff922b"),
    Channel("pitch_true_deg", "°", "pitch, true", "attitude", lambda f: f.true_tilt_deg[0],
            "#4dabf7", dashed=True),
    Channel("roll_true_deg", "°", "roll, true", "attitude", lambda f: f.true_tilt_deg[1],
            "#ff922b", dashed=True),
    Channel("gyro_x_deg_s", "°/s", "roll rate x", "gyro", _gyro_deg_s(0), "#ff922b"),
    Channel("gyro_y_deg_s", "°/s", "pitch rate y", "gyro", _gyro_deg_s(1), "#4dabf7"),
    Channel("gyro_z_deg_s", "°/s", "yaw rate z", "gyro", _gyro_deg_s(2), "#51cf66"),
)  # fmt: skip
#: each sole's centre of pressure and load, which the panel draws in the soles' outline
SOLE_CHANNELS: tuple[Channel, ...] = (
    Channel("cop_l_x_mm", "mm", "left sole: CoP x", None, _cop_mm(0, 0)),
    Channel("cop_l_y_mm", "mm", "left sole: CoP y", None, _cop_mm(0, 1)),
    Channel("cop_r_x_mm", "mm", "right sole: CoP x", None, _cop_mm(1, 0)),
    Channel("cop_r_y_mm", "mm", "right sole: CoP y", None, _cop_mm(1, 1)),
    Channel("load_l_n", "N", "left sole: load", None, _load_n(0)),
    Channel("load_r_n", "N", "right sole: load", None, _load_n(1)),
)
#: every column of the trace, in order: the sensors', each law's outputs in LAWS' order, the soles'
CHANNELS: tuple[Channel, ...] = (
    *SENSOR_CHANNELS,
    *(law_channel(output) for law in LAWS for output in law.outputs),
    *SOLE_CHANNELS,
)
COLUMNS: tuple[str, ...] = tuple(channel.key for channel in CHANNELS)


def channel_list() -> dict[str, list[dict[str, object]]]:
    """The charts, their channels and the laws as the page draws and names them (`GET
    /api/sensors/channels`): {"charts": [{key, label}], "channels": [{key, unit, label, chart,
    colour, dashed, scale}], "laws": [{group, label}]}."""
    fields = ("key", "unit", "label", "chart", "colour", "dashed", "scale")
    return {
        "charts": [{"key": key, "label": label} for key, label in CHARTS.items()],
        "channels": [{name: getattr(c, name) for name in fields} for c in CHANNELS],
        "laws": [{"group": law.group, "label": law.label} for law in LAWS],
    }
