"""Parameters of the balance feedback on top of the open-loop gait (docs/DESIGN.md §4, §15): the
attitude estimate and each law -- tilt trim, yaw-rate loop, gyro damping, centre-of-pressure loop,
step timing -- with its switch (all off: the open-loop gait to the bit) and gains; and `LAWS`,
each law declared once: its group, titles and the outputs the trace keeps and the page draws."""

from __future__ import annotations

from dataclasses import dataclass

from gait.schema_fields import check_ranges as _check_ranges
from gait.schema_fields import switch as _switch
from gait.schema_fields import tunable as _param


@dataclass(frozen=True)
class AttitudeParams:
    """The complementary filter that estimates trunk pitch and roll from the IMU."""

    tau_s: float = _param(
        0.5, 0.05, 5.0, step=0.05, unit="s", eq="",
        doc="time constant: the accelerometer corrects the integrated gyro this slowly",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class TiltParams:
    """Tilt trim: the estimated pitch and roll against the tilt the motion is expected to have,
    filtered, past a dead band, integrated and clamped, on the balance offsets of eqs (38)–(39)
    (foot pitch; leg roll with the foot kept level), the roll's scaled by `roll_share`."""

    enabled: bool = _switch("trim the balance offsets from the trunk's tilt", default=False)
    pitch_offset_rad: float = _param(
        0.0, -0.2, 0.2, step=0.002, unit="rad", eq="",
        doc="expected trunk pitch on the spot (forward > 0): the stance's own lean",
    )  # fmt: skip
    pitch_per_a_p: float = _param(
        0.0, -2.0, 2.0, step=0.01, unit="1", eq="",
        doc="expected trunk pitch per unit a_p (leaning into the walk)",
    )  # fmt: skip
    roll_per_a_r: float = _param(
        0.0, -2.0, 2.0, step=0.01, unit="1", eq="",
        doc="expected trunk roll per unit a_r (stepping sideways)",
    )  # fmt: skip
    filter_s: float = _param(
        0.5, 0.02, 5.0, step=0.02, unit="s", eq="",
        doc="low-pass time constant of the tilt error (a gait cycle averages the sway out)",
    )  # fmt: skip
    deadband_rad: float = _param(
        0.005, 0.0, 0.1, step=0.001, unit="rad", eq="", doc="errors within this are left alone"
    )
    ki_per_s: float = _param(
        0.5, 0.0, 10.0, step=0.05, unit="1/s", eq="",
        doc="integral gain: the trim grows by this times the error per second",
    )  # fmt: skip
    kp: float = _param(0.0, 0.0, 2.0, step=0.01, unit="1", eq="", doc="proportional gain")
    clamp_rad: float = _param(
        0.1, 0.0, 0.3, step=0.005, unit="rad", eq="", doc="largest trim, each of pitch and roll"
    )
    roll_share: float = _param(
        1.0, 0.0, 1.0, step=0.05, unit="1", eq="",
        doc="the roll trim the hips get, a share of the law's (1: as pitch; 0: pitch only)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class YawRateParams:
    """Yaw-rate loop: a_y and CA become turn-rate commands (CA's by eq (13) of seed 004), the
    gyro closes the loop on a_y (PI)."""

    enabled: bool = _switch("close the turn rate on a_y through the gyro", default=False)
    turn_per_a_y: float = _param(
        -1.0, -5.0, 0.0, step=0.01, unit="rad/s", eq="",
        doc="turn rate commanded per unit a_y (a_y > 0 turns clockwise: < 0)",
    )  # fmt: skip
    speed_per_a_p: float = _param(
        0.5, 0.0, 2.0, step=0.01, unit="m/s", eq="seed 004 (13)",
        doc="walking speed V per unit a_p, for eq (13)'s rate -2 CA V / b",
    )  # fmt: skip
    axle_m: float = _param(
        0.1, 0.02, 0.5, step=0.005, unit="m", eq="seed 004 (13)", doc="axle b of eq (13)"
    )
    filter_s: float = _param(
        0.5, 0.02, 5.0, step=0.02, unit="s", eq="", doc="low-pass time constant of the rate error"
    )
    kp: float = _param(0.1, 0.0, 2.0, step=0.01, unit="s", eq="", doc="a_y per rad/s of error")
    ki_per_s: float = _param(
        0.2, 0.0, 10.0, step=0.01, unit="1", eq="", doc="integral gain: a_y per rad of error"
    )
    clamp: float = _param(
        0.15, 0.0, 0.5, step=0.005, unit="rad", eq="", doc="largest change of a_y"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class DampingParams:
    """Gyro damping: each ankle and hip joint moves against the trunk's rate (ROBOTIS OP3:
    0.015–0.045 rad per rad/s; rUNSWift: ankle pitch += rate / 25)."""

    enabled: bool = _switch("damp the trunk's rates at the ankles and hips", default=False)
    ankle_pitch: float = _param(
        0.02, 0.0, 0.2, step=0.001, unit="s", eq="", doc="ankle pitch per rad/s of pitch rate"
    )
    ankle_roll: float = _param(
        0.02, 0.0, 0.2, step=0.001, unit="s", eq="", doc="ankle roll per rad/s of roll rate"
    )
    hip_pitch: float = _param(
        0.0, 0.0, 0.2, step=0.001, unit="s", eq="", doc="hip pitch per rad/s of pitch rate"
    )
    hip_roll: float = _param(
        0.0, 0.0, 0.2, step=0.001, unit="s", eq="", doc="hip roll per rad/s of roll rate"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class CopParams:
    """Centre-of-pressure loop (seed 000 §6.B): the support foot's centre of pressure from its
    four force sensors, PID toward the plate's centre on that foot's pitch and roll."""

    enabled: bool = _switch("hold the support foot's centre of pressure at its centre", False)
    kp: float = _param(0.5, 0.0, 10.0, step=0.05, unit="rad/m", eq="", doc="proportional gain")
    ki_per_s: float = _param(0.0, 0.0, 50.0, step=0.1, unit="rad/m/s", eq="", doc="integral gain")
    kd_s: float = _param(0.0, 0.0, 1.0, step=0.005, unit="rad·s/m", eq="", doc="derivative gain")
    clamp_rad: float = _param(
        0.05, 0.0, 0.2, step=0.005, unit="rad", eq="", doc="largest correction, pitch and roll"
    )
    min_load_n: float = _param(
        1.0, 0.0, 20.0, step=0.1, unit="N", eq="", doc="a foot carries less: no centre of pressure"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class TimingParams:
    """Step-timing feedback (NimbRo's lateral stabiliser, Allgeuer and Behnke 2016;
    docs/SENSORS.md): the gait's frequency changed by the filtered trunk roll's deviation from
    the expected roll swing of the gait, faster when the trunk falls toward the swing foot,
    slower when it leans out over the support foot. The expected swing is measured on the
    nominal walk (`bench/timing_reference.py`), as the tilt trim's expected tilt is."""

    enabled: bool = _switch("time the steps by the trunk's roll", default=False)
    swing_rad: float = _param(
        0.0, -0.3, 0.3, step=0.001, unit="rad", eq="",
        doc="expected roll swing on the spot: roll = ... + swing cos(phi_Trunk + phase)",
    )  # fmt: skip
    swing_per_a_r: float = _param(
        0.0, -2.0, 2.0, step=0.01, unit="1", eq="",
        doc="expected roll swing's growth per unit |a_r| (side steps sway wider)",
    )  # fmt: skip
    swing_phase_rad: float = _param(
        0.0, -3.14, 3.14, step=0.01, unit="rad", eq="",
        doc="expected roll swing: its phase against phi_Trunk",
    )  # fmt: skip
    roll_offset_rad: float = _param(
        0.0, -0.2, 0.2, step=0.001, unit="rad", eq="", doc="expected roll on the spot (right > 0)"
    )
    roll_per_a_r: float = _param(
        0.0, -2.0, 2.0, step=0.01, unit="1", eq="", doc="expected roll per unit a_r"
    )
    filter_s: float = _param(
        0.05, 0.02, 1.0, step=0.01, unit="s", eq="",
        doc="low-pass time constant of the roll deviation (short: a step lasts ~0.7 s)",
    )  # fmt: skip
    deadband_rad: float = _param(
        0.02, 0.0, 0.2, step=0.001, unit="rad", eq="", doc="deviations within this are left alone"
    )
    speed_up_hz_per_rad: float = _param(
        5.0, 0.0, 50.0, step=0.1, unit="Hz/rad", eq="",
        doc="faster by this per rad the trunk falls toward the swing foot",
    )  # fmt: skip
    slow_down_hz_per_rad: float = _param(
        10.0, 0.0, 50.0, step=0.1, unit="Hz/rad", eq="",
        doc="slower by this per rad the trunk leans out over the support foot",
    )  # fmt: skip
    clamp_share: float = _param(
        0.3, 0.0, 0.5, step=0.01, unit="1", eq="",
        doc="largest change, a share of clock.freq_hz (the clock never stops or runs back)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class LawOutput:
    """One output of a law as the Sensors trace keeps it and the page draws it: the value of
    `gait.feedback.Output.<field>` (its `index`-th, for an array), in degrees where `unit` is
    "°" (the law's own are in rad), drawn `scale` times itself in the laws' chart unless not
    `drawn` (`app/sim/sensor_channels.py` makes a channel of it)."""

    key: str  # the trace's column and GET /api/sensors's key
    label: str  # the chart's legend
    unit: str
    field: str
    index: int | None = None
    colour: str = "#adb5bd"
    dashed: bool = False
    scale: float = 1.0
    drawn: bool = True


@dataclass(frozen=True)
class Law:
    """A feedback law declared once: its parameter group (a field of `GaitParams` by this name),
    the parameter panel's title, the page's short name, and its outputs."""

    group: str
    params: type
    title: str  # the parameter panel's folder (app/params/schema.py GROUP_TITLES)
    label: str  # the Sensors panel's "laws on: ..." and the linked robot's line
    outputs: tuple[LawOutput, ...]


#: The laws in the firmware's order: a law's id and switch bit (`LAW_*` in laws.h, the SENSORS
#: laws byte) is its place here, and its group's place among the laws in `GaitParams`; a new law
#: goes last. Joint indices are `gait.JOINT_NAMES`' (2: l_hip_pitch, 4: l_ankle_pitch).
LAWS: tuple[Law, ...] = (
    Law("tilt", TiltParams, "Feedback: tilt trim", "tilt trim", (
        LawOutput("tilt_pitch_deg", "tilt trim pitch", "°", "tilt_rad", 0, "#4dabf7"),
        LawOutput("tilt_roll_deg", "tilt trim roll", "°", "tilt_rad", 1, "#ff922b"),
    )),
    Law("yaw_rate", YawRateParams, "Feedback: yaw rate", "yaw rate", (
        LawOutput("a_y_delta", "yaw rate: a_y ×100", "1", "a_y_delta", None, "#51cf66", scale=100),
    )),
    Law("damping", DampingParams, "Feedback: gyro damping", "gyro damping", (
        LawOutput("damping_ankle_deg", "damping, left ankle pitch", "°", "damping_rad", 4,
                  "#e64dff"),
        LawOutput("damping_hip_deg", "damping, left hip pitch", "°", "damping_rad", 2,
                  drawn=False),
    )),
    Law("cop", CopParams, "Feedback: centre of pressure", "CoP", (
        LawOutput("cop_pitch_deg", "CoP pitch", "°", "cop_rad", 0, "#fcc419"),
        LawOutput("cop_roll_deg", "CoP roll", "°", "cop_rad", 1, "#fcc419", dashed=True),
    )),
    Law("timing", TimingParams, "Feedback: step timing", "step timing", (
        LawOutput("timing_freq_hz", "step timing: Hz ×10", "Hz", "freq_delta_hz", None,
                  "#ff6b6b", scale=10),
    )),
)  # fmt: skip
