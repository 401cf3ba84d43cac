"""The Sensors panel's routes: what the modelled IMU and force sensors read over the last seconds
and what the feedback laws made of it, and beside it a linked robot's own frames as `artro link`
forwards them (docs/DESIGN.md §15)."""

import math
from typing import TYPE_CHECKING, Annotated, Any, Literal

from annotated_types import Ge
from fastapi import APIRouter
from pydantic import BaseModel, ConfigDict, Field

from app.firmware import protocol as proto
from app.server.api.answers import ANSWER
from app.server.api.answers_data import FramesTaken, SensorChannels, Sensors
from app.server.api.deps import WHOLE_FLOAT, JsonIntFrom0, ServicesDep, StrictJsonRoute
from app.server.feeds.robot_sensors import WINDOW_FRAMES, RobotFrame
from app.server.http.errors import GATE_RESPONSES, responses
from app.server.recording.sensor_trace import COLUMNS
from app.sim.sensor_channels import channel_list

router = APIRouter(
    prefix="/api/sensors", tags=["sensors"], responses=GATE_RESPONSES, route_class=StrictJsonRoute
)

MAX_POSTED_FRAMES = 16  # within the 16 KiB body limit at any float; the link posts ~8 a time
GYRO_LIMIT_RAD_S = 4.37  # the MPU-6050's ±250 °/s range (32768 counts of 1/131 °/s)
ACCEL_LIMIT_M_S2 = 19.62  # its ±2 g range
FSR_LIMIT_N = 5120.0  # the divider's force at the ADC's top count (5 N · 1023 / 1)


def _values(n: int, what: str) -> Any:
    """The field of a list of `n` values (each within `_each`'s bounds)."""
    return Field(min_length=n, max_length=n, description=what)


def _each(limit: float, low: float | None = None) -> Any:
    """The field of one value, `low` (default -limit) to `limit`."""
    return Field(ge=-limit if low is None else low, le=limit)


Angles2 = Annotated[
    list[Annotated[float, _each(math.pi)]], _values(2, "pitch, roll (rad, within ±π)")
]
Rates3 = Annotated[
    list[Annotated[float, _each(GYRO_LIMIT_RAD_S)]],
    _values(3, "x, y, z rate (rad/s, within ±4.37)"),
]
Accelerations3 = Annotated[
    list[Annotated[float, _each(ACCEL_LIMIT_M_S2)]], _values(3, "x, y, z (m/s², within ±19.62)")
]
Forces4 = Annotated[
    list[Annotated[float, _each(FSR_LIMIT_N, low=0.0)]],
    _values(4, "fl, fr, bl, br (N, 0 to 5120)"),
]
if TYPE_CHECKING:  # Literals of names known only when it runs: to mypy, names
    StatusBit = str
    LawName = str
else:
    StatusBit = Literal[tuple(proto.STATUS_BITS)]
    LawName = Literal[tuple(proto.LAW_BITS)]


class RobotFrameBody(BaseModel):
    """One SENSORS frame of the robot as `artro link` decodes it (hardware/firmware/PROTOCOL.md;
    the counts in SI units as app/firmware/sensor_feed.py `decoded` makes them)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)
    frame: JsonIntFrom0 = Field(le=2**32 - 1, description="the robot's frame the laws corrected")
    status: list[StatusBit] = Field(
        max_length=len(proto.STATUS_BITS), description="the status bits set"
    )
    imu_failures: JsonIntFrom0 = Field(le=255, description="failed IMU reads since boot")
    laws: list[LawName] = Field(max_length=len(proto.LAW_BITS), description="the laws switched on")
    support: Annotated[int, Ge(-1), WHOLE_FLOAT] = Field(
        le=1, description="support foot: 0 left, 1 right, -1 neither"
    )
    attitude_rad: Angles2
    gyro_rad_s: Rates3
    accel_m_s2: Accelerations3
    fsr_n: Annotated[
        list[Forces4], Field(min_length=2, max_length=2, description="left sole, right sole")
    ]
    tilt_rad: Angles2
    a_y_delta: float = Field(ge=-1.0, le=1.0, description="the yaw-rate loop's change of a_y")
    cop_rad: Angles2

    def frame_record(self) -> RobotFrame:
        return RobotFrame(
            frame=self.frame,
            status=tuple(dict.fromkeys(self.status)),
            imu_failures=self.imu_failures,
            laws=tuple(dict.fromkeys(self.laws)),
            support=self.support,
            attitude_rad=_two(self.attitude_rad),
            gyro_rad_s=_three(self.gyro_rad_s),
            accel_m_s2=_three(self.accel_m_s2),
            fsr_n=(tuple(self.fsr_n[0]), tuple(self.fsr_n[1])),
            tilt_rad=_two(self.tilt_rad),
            a_y_delta=self.a_y_delta,
            cop_rad=_two(self.cop_rad),
        )


def _two(values: list[float]) -> tuple[float, float]:
    first, second = values  # of a field of two (min_length, max_length)
    return first, second


def _three(values: list[float]) -> tuple[float, float, float]:
    x, y, z = values  # of a field of three
    return x, y, z


class RobotFramesBody(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    frames: list[RobotFrameBody] = Field(
        min_length=1,
        max_length=MAX_POSTED_FRAMES,
        description=f"1 to {MAX_POSTED_FRAMES} frames, in the robot's order",
    )


@router.get("", response_model=Sensors, **ANSWER)
def sensors(services: ServicesDep) -> dict[str, Any]:
    """The last 5 s, one value per 20 ms frame in each column (oldest first; null where a sole
    carries nothing): the estimated attitude against the simulator's true one (for the eye
    only, no law reads it), the gyro, each law's output, each sole's centre of pressure (mm
    from its centre, x forward, y left) and load; with the sole outline and the force sensors'
    places. Empty columns before the first frame. `robot`: a linked robot's last 5 s in the
    same units (`t_s` its own clock: frame × 20 ms) with its last frame's status, or null when
    none arrived in the last 2 s."""
    robot = services.robot_sensors.view()
    view = services.sensor_view()
    if view is None:
        empty: dict[str, Any] = {
            "columns": {name: [] for name in COLUMNS},
            "sole_mm": None,
            "fsr_mm": [],
        }
        return empty | {"robot": robot}
    return view.to_dict() | {"robot": robot}


@router.get("/channels", response_model=SensorChannels, **ANSWER)
def channels() -> dict[str, Any]:
    """What the columns of GET /api/sensors are and how the Sensors panel draws them, declared
    once (app/sim/sensor_channels.py): its charts; each column's key, unit, label, chart (null:
    drawn by none, as the soles' CoP and loads), colour, dashed and scale; each law's group and
    name in the order of its switch bit; per chart, the series a linked robot's frames add to
    it (key: its column in `robot.columns`, label, colour). The same for the server's life: ask
    once."""
    return channel_list()


@router.post("/robot", response_model=FramesTaken, responses=responses(422), **ANSWER)
def post_robot_frames(services: ServicesDep, body: RobotFramesBody) -> dict[str, Any]:
    """A linked robot's SENSORS frames, decoded (what `artro link` forwards every 150 ms): kept
    for 5 s beside the simulation's sensors, each sole's centre of pressure placed on the
    dashboard robot's force sensors. A frame held already is skipped; 422 for a bad body, and
    none of it is kept."""
    frames = [frame.frame_record() for frame in body.frames]
    taken = services.robot_sensors.add(frames, services.robot.fsr_positions_m)
    return {"taken": taken, "window_frames": WINDOW_FRAMES}
