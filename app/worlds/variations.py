"""Model variations: one typed departure from the nominal robot (friction, masses, servo,
latency, play, floor tilt, calibration), its `key=value` text, and `vary_model`, which applies it
to a copy of the compiled model (docs/DESIGN.md §8). Ranges and seeded samples are
`app.worlds.sampling`; the set-point part (latency, calibration, play) `app.worlds.servo_path`."""

from __future__ import annotations

import copy
import dataclasses
import math
import numbers
import zlib
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from app.robots.model import RobotModel
from gait import JOINT_NAMES

#: geoms whose sliding friction `Variation.friction` sets: the floor and both sole plates
FRICTION_GEOMS = ("floor", "l_foot_plate", "r_foot_plate")
#: MG996R supply range 4.8-7.2 V around the model's 6 V; stall torque is proportional to it
TORQUE_SCALE_MAX = 1.2
SCALES = (
    "trunk_mass_scale",
    "link_mass_scale",
    "kp_scale",
    "torque_scale",
    "damping_scale",
    "frictionloss_scale",
)
NON_NEGATIVE = ("latency_ms", "deadband_deg", "backlash_deg")
#: the smallest scale that still describes a robot of this build (a tenth of its masses, its
#: servos' stiffness, torque, damping or gear friction); friction's floor: wet ice is ~0.02, no
#: floor a robot walks on is under 0.01, and by 1e-6 the physics blows up at every start;
#: a slope past 45° holds no foot with friction ≤ 1 (tan 45° = 1)
SCALE_MIN = 0.1
FRICTION_MIN = 0.01
TILT_MAX_DEG = 45.0
#: the largest value of each scale and servo error that still describes a hobby biped
#: (docs/DESIGN.md §8): a value past it is no plausible robot, and some (a latency of 1e10 ms,
#: a stiffness of 1e308) cannot even be simulated
UPPER_LIMITS = {
    "trunk_mass_scale": 5.0,  # a payload four times the trunk
    "link_mass_scale": 3.0,  # metal brackets and heavier servos on every link
    "kp_scale": 5.0,  # a digital servo's holding stiffness, several times an analogue one's
    "damping_scale": 10.0,
    "frictionloss_scale": 10.0,  # a worn gear train
    "latency_ms": 200.0,  # ten frames: a bus servo behind a slow serial link
    "deadband_deg": 10.0,  # 20 times the MG996R's 5 µs dead band (0.5°)
    "backlash_deg": 10.0,  # a worn plastic gear train: a few degrees
}
#: a servo horn set on its spline more than this off its zero is a robot not yet assembled
CALIBRATION_LIMIT_DEG = 45.0
CAL_PREFIX = "cal."
#: the sensors' errors and a push (docs/DESIGN.md §8): they act on what the sensors read and on
#: the trunk, not on the compiled model; (low, high, low_open, high_open) of each
SENSOR_LIMITS = {
    "imu_tilt_bias_deg": (0.0, 10.0, False, False),
    "imu_tilt_direction_deg": (0.0, 360.0, False, True),
    "gyro_bias_deg_s": (-250.0, 250.0, False, False),  # the MPU-6050's range at ±250 °/s
    "gyro_noise_deg_s": (0.0, 25.0, False, False),
    "imu_delay_ms": (0.0, 40.0, False, False),  # two frames of readings are kept
    "fsr_gain": (0.0, 5.0, True, False),
    "push_n_s": (0.0, 5.0, False, False),
    "push_time_s": (0.0, 3600.0, False, False),
    "push_direction_deg": (0.0, 360.0, False, True),
}
SENSOR_FIELDS = tuple(SENSOR_LIMITS)


def _limits(name: str) -> tuple[str, float, float, bool, bool]:
    """(text, low, high, low_open, high_open) of a scalar field's allowed values."""
    if name == "friction":
        return f"≥ {FRICTION_MIN:g} and ≤ 1", FRICTION_MIN, 1.0, False, False
    if name == "torque_scale":
        high = TORQUE_SCALE_MAX
        return f"≥ {SCALE_MIN:g} and ≤ {high}", SCALE_MIN, high, False, False
    if name in SCALES:
        high = UPPER_LIMITS[name]
        return f"≥ {SCALE_MIN:g} and ≤ {high:g}", SCALE_MIN, high, False, False
    if name in NON_NEGATIVE:
        high = UPPER_LIMITS[name]
        return f"≥ 0 and ≤ {high:g}", 0.0, high, False, False
    if name == "tilt_deg":
        return f"≥ 0 and ≤ {TILT_MAX_DEG:g}", 0.0, TILT_MAX_DEG, False, False
    if name == "tilt_direction_deg":
        return "≥ 0 and < 360", 0.0, 360.0, False, True
    if name == "calibration_deg":
        limit = CALIBRATION_LIMIT_DEG
        return f"≥ {-limit:g} and ≤ {limit:g}", -limit, limit, False, False
    if name in SENSOR_LIMITS:
        low, high, low_open, high_open = SENSOR_LIMITS[name]
        text = f"{'>' if low_open else '≥'} {low:g} and {'<' if high_open else '≤'} {high:g}"
        return text, low, high, low_open, high_open
    raise ValueError(f"unknown variation field {name!r}; known: {', '.join(FIELDS)}")


def as_number(name: str, value: object) -> float:
    """`value` as a float, with -0.0 made 0.0 (so the text round trip keeps every bit)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"variation field {name} must be a number, got {value!r}")
    return float(value) + 0.0


def _calibration(value: Any) -> tuple[float, ...]:
    n = len(JOINT_NAMES)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise TypeError(f"variation field calibration_deg must be {n} numbers, got {value!r}")
    if len(value) != n:
        raise ValueError(
            f"variation field calibration_deg needs {n} values ({', '.join(JOINT_NAMES)}), "
            f"got {len(value)}"
        )
    cal = tuple(as_number(CAL_PREFIX + j, v) for j, v in zip(JOINT_NAMES, value, strict=True))
    limit = CALIBRATION_LIMIT_DEG
    for j, v in zip(JOINT_NAMES, cal, strict=True):
        if not (math.isfinite(v) and -limit <= v <= limit):
            raise ValueError(
                f"variation field {CAL_PREFIX}{j} must be ≥ {-limit:g} and ≤ {limit:g} degrees, "
                f"got {v!r}"
            )
    return cal


def check_value(name: str, value: float) -> None:
    text, low, high, low_open, high_open = _limits(name)
    ok = math.isfinite(value)
    ok = ok and (value > low if low_open else value >= low)
    ok = ok and (value < high if high_open else value <= high)
    if not ok:
        raise ValueError(f"variation field {name} must be {text}, got {value!r}")


@dataclass(frozen=True)
class Variation:
    """Departures from the nominal model; every default means "no change".

    Fields (the model's values in brackets, docs/DESIGN.md §8 for what each changes and why):
        friction: absolute sliding friction of the floor and both soles, > 0 and ≤ 1
            (None: the model's 0.7).
        trunk_mass_scale: trunk body mass and inertia (payload); link_mass_scale: every other
            body's; kp_scale: servo stiffness kp [4.5 N·m/rad]; torque_scale: servo force range
            [±1.08 N·m] (battery sag), ≤ 1.2; damping_scale: joint damping [0.144 N·m·s/rad];
            frictionloss_scale: joint friction loss [0.02 N·m]. All > 0, each at most its
            `UPPER_LIMITS` value.
        latency_ms: set-point delay, ms in [0, 200], rounded to whole physics steps.
        deadband_deg, backlash_deg: servo dead band and gear play, degrees in [0, 10] (full
            widths).
        tilt_deg: floor tilt in [0, 45]; tilt_direction_deg: the downhill direction, degrees
            counter-clockwise from the world x axis, in [0, 360).
        imu_tilt_bias_deg, imu_tilt_direction_deg: the IMU's frame tilted against the trunk's
            (mounting, accelerometer offset after calibration) by this angle, about the
            horizontal axis that lifts the direction's side (degrees counter-clockwise from the
            trunk's x axis).
        gyro_bias_deg_s: the gyro's residual bias on each axis after calibration at rest;
            gyro_noise_deg_s: its white noise, rms per reading (seeded by the variation: the
            same variation reads the same noise, `noise_seed`).
        imu_delay_ms: the IMU reading the laws get is this old (filter delay, read timing).
        fsr_gain: scale of every foot force sensor's reading.
        push_n_s: an impulse on the trunk, horizontal, toward push_direction_deg (counter-
            clockwise from the world x axis), in the physics step that starts at push_time_s.
        calibration_deg: 12 per-joint zero offsets in `gait.JOINT_NAMES` order, each within
            ±45° (a servo drives to set-point + offset).

    Raises TypeError for a non-number and ValueError naming the field and its allowed range.
    `dataclasses.replace` validates too.
    """

    friction: float | None = None
    trunk_mass_scale: float = 1.0
    link_mass_scale: float = 1.0
    kp_scale: float = 1.0
    torque_scale: float = 1.0
    damping_scale: float = 1.0
    frictionloss_scale: float = 1.0
    latency_ms: float = 0.0
    deadband_deg: float = 0.0
    backlash_deg: float = 0.0
    tilt_deg: float = 0.0
    tilt_direction_deg: float = 0.0
    imu_tilt_bias_deg: float = 0.0
    imu_tilt_direction_deg: float = 0.0
    gyro_bias_deg_s: float = 0.0
    gyro_noise_deg_s: float = 0.0
    imu_delay_ms: float = 0.0
    fsr_gain: float = 1.0
    push_n_s: float = 0.0
    push_time_s: float = 0.0
    push_direction_deg: float = 0.0
    calibration_deg: tuple[float, ...] = (0.0,) * len(JOINT_NAMES)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "calibration_deg":
                object.__setattr__(self, f.name, _calibration(value))
            elif value is not None or f.name != "friction":
                number = as_number(f.name, value)
                check_value(f.name, number)
                object.__setattr__(self, f.name, number)

    @property
    def is_nominal(self) -> bool:
        """True when nothing departs from the model."""
        return self == NOMINAL

    @property
    def physics(self) -> Variation:
        """This variation without the sensors' errors and the push: what the compiled model
        and the servos' set-points depart by (the same varied model serves both)."""
        return dataclasses.replace(self, **{f: _DEFAULTS[f] for f in SENSOR_FIELDS})

    def push(self, timestep_s: float) -> tuple[int, tuple[float, float, float]]:
        """The push as a simulation applies it: the physics step it acts in (the first that
        starts at or after push_time_s; -1 without a push) and the force on the trunk in that
        step, N (impulse / timestep, horizontal, toward push_direction_deg)."""
        if self.push_n_s <= 0.0:
            return -1, (0.0, 0.0, 0.0)
        step = math.ceil(self.push_time_s / timestep_s - 1e-9)
        force, direction = self.push_n_s / timestep_s, math.radians(self.push_direction_deg)
        return step, (force * math.cos(direction), force * math.sin(direction), 0.0)

    @property
    def noise_seed(self) -> int:
        """The seed of this variation's sensor noise: its text's CRC-32, the same in every
        process and on every machine."""
        return zlib.crc32(self.to_text().encode("ascii"))

    def departures(self) -> dict[str, float]:
        """The non-nominal values as text keys (`cal.<joint>` per joint), in field order."""
        out: dict[str, float] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "calibration_deg":
                out |= {CAL_PREFIX + j: v for j, v in zip(JOINT_NAMES, value, strict=True) if v}
            elif value != f.default:
                out[f.name] = value
        return out

    def to_text(self) -> str:
        """`key=value,...` of the non-nominal fields, floats repr-exact ("" when nominal);
        `parse_variation` reads it back to the bit."""
        return ",".join(f"{k}={_format(v)}" for k, v in self.departures().items())

    @property
    def name(self) -> str:
        """`to_text()`, or "nominal"."""
        return self.to_text() or "nominal"


NOMINAL = Variation()
FIELDS = tuple(f.name for f in dataclasses.fields(Variation))
_DEFAULTS: dict[str, Any] = {f.name: f.default for f in dataclasses.fields(Variation)}
#: the fields that depart from the compiled model or the set-points, calibration last
PHYSICS_FIELDS = tuple(f for f in FIELDS if f not in SENSOR_FIELDS)


def _format(value: float) -> str:
    text = repr(value)
    return text[:-2] if text.endswith(".0") else text


def parse_variation(text: str) -> Variation:
    """The `Variation` that `text` names: `key=value` items separated by commas (whitespace
    ignored), keys as the fields of `Variation` except calibration, given per joint as
    `cal.<joint>` (e.g. `cal.l_knee=1.2`); "" or "nominal" is the nominal model.

    Raises ValueError naming the item for an unknown or repeated key, a value that is no number,
    or a value outside its field's range.
    """
    text = text.strip()
    if text in ("", "nominal"):
        return NOMINAL
    scalars: dict[str, float] = {}
    cal = dict.fromkeys(JOINT_NAMES, 0.0)
    seen: set[str] = set()
    for item in text.split(","):
        key, sep, raw = (part.strip() for part in item.partition("="))
        if not sep:
            raise ValueError(f"variation item {item.strip()!r} is not key=value")
        if key in seen:
            raise ValueError(f"variation field {key} is given twice")
        seen.add(key)
        try:
            # float() would read other scripts' digits ("١" is 1.0) and digit groups ("0_5"
            # is 5: a typo of 0.5 read as ten times it)
            if not raw.isascii() or "_" in raw:
                raise ValueError
            value = float(raw)
        except ValueError:
            raise ValueError(f"variation field {key}: {raw!r} is not a number") from None
        if key.startswith(CAL_PREFIX):
            joint = key[len(CAL_PREFIX) :]
            if joint not in cal:
                raise ValueError(f"unknown joint in {key!r}; joints: {', '.join(JOINT_NAMES)}")
            cal[joint] = value
        elif key in FIELDS and key != "calibration_deg":
            scalars[key] = value
        else:
            known = [f for f in FIELDS if f != "calibration_deg"] + [CAL_PREFIX + "<joint>"]
            raise ValueError(f"unknown variation field {key!r}; known: {', '.join(known)}")
    return Variation(**scalars, calibration_deg=tuple(cal.values()))


def vary_model(robot: RobotModel, variation: Variation) -> mujoco.MjModel:
    """A copy of `robot.model` with `variation` applied in place (nothing recompiled); the
    robot's own model is never changed, and the nominal variation gives a copy equal to it in
    every array.

    friction: `geom_friction[:, 0]` of `FRICTION_GEOMS`. Masses: `body_mass` and `body_inertia`
    scaled together (same centre of mass and principal axes), then `mj_setConst` (subtree
    masses, invweights, `dof_M0`, `actuator_acc0`). kp: `actuator_gainprm[:, 0]` and
    `actuator_biasprm[:, 1]` (= -kp); torque: `actuator_forcerange`; damping and friction loss:
    `dof_damping`, `dof_frictionloss` of the 12 leg joints. Tilt: `opt.gravity` rotated by
    tilt_deg about the horizontal axis that makes its horizontal part point at
    tilt_direction_deg (the floor descends that way). Latency, dead band, backlash and
    calibration act on the set-points (`ServoPath`), not here.
    """
    model = copy.copy(robot.model)
    v = variation
    if v.friction is not None:
        for geom in FRICTION_GEOMS:
            model.geom_friction[model.geom(geom).id, 0] = v.friction
    links = [b for b in range(1, model.nbody) if b != robot.trunk_id]
    for bodies, scale in (([robot.trunk_id], v.trunk_mass_scale), (links, v.link_mass_scale)):
        if scale != 1.0:
            model.body_mass[bodies] *= scale
            model.body_inertia[bodies] *= scale
    if v.trunk_mass_scale != 1.0 or v.link_mass_scale != 1.0:
        mujoco.mj_setConst(model, mujoco.MjData(model))
    act, dof = robot.actuator_ids, robot.dof_adr
    if v.kp_scale != 1.0:
        model.actuator_gainprm[act, 0] *= v.kp_scale
        model.actuator_biasprm[act, 1] *= v.kp_scale
    if v.torque_scale != 1.0:
        model.actuator_forcerange[act] *= v.torque_scale
    if v.damping_scale != 1.0:
        model.dof_damping[dof] *= v.damping_scale
    if v.frictionloss_scale != 1.0:
        model.dof_frictionloss[dof] *= v.frictionloss_scale
    if v.tilt_deg != 0.0:
        model.opt.gravity[:] = tilted(model.opt.gravity, v.tilt_deg, v.tilt_direction_deg)
    return model


def varied_robot(robot: RobotModel, variation: Variation) -> RobotModel:
    """`robot` with `vary_model`'s model and the same joint, actuator and sensor addresses."""
    return dataclasses.replace(robot, model=vary_model(robot, variation))


def tilted(gravity: np.ndarray, tilt_deg: float, direction_deg: float) -> np.ndarray:
    """`gravity` (3,) rotated by tilt_deg (Rodrigues) about the horizontal axis at
    direction_deg - 90°, so a vertical gravity gains a horizontal part pointing at
    direction_deg (counter-clockwise from x); its length is kept."""
    t, d = math.radians(tilt_deg), math.radians(direction_deg)
    axis = np.array([math.sin(d), -math.cos(d), 0.0])
    g = np.asarray(gravity, dtype=np.float64)
    return (
        g * math.cos(t)
        + np.cross(axis, g) * math.sin(t)
        + axis * float(axis @ g) * (1.0 - math.cos(t))
    )
