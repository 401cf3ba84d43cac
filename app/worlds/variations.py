"""Model variations: one typed departure from the nominal ArtRo model (friction, masses, servo,
latency, play, floor tilt, calibration), its `key=value` text, default ranges and seeded samples,
and `vary_model`, which applies it to a copy of the compiled model (docs/DESIGN.md §8). The
set-point part (latency, calibration, dead band, backlash) is `app.worlds.servo_path.ServoPath`.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import numbers
from dataclasses import dataclass

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
CAL_PREFIX = "cal."


def _limits(name: str) -> tuple[str, float, float, bool, bool]:
    """(text, low, high, low_open, high_open) of a scalar field's allowed values."""
    if name == "friction":
        return "> 0 and ≤ 1", 0.0, 1.0, True, False
    if name == "torque_scale":
        return f"> 0 and ≤ {TORQUE_SCALE_MAX}", 0.0, TORQUE_SCALE_MAX, True, False
    if name in SCALES:
        return "> 0 and finite", 0.0, math.inf, True, True
    if name in NON_NEGATIVE:
        return "≥ 0 and finite", 0.0, math.inf, False, True
    if name == "tilt_deg":
        return "≥ 0 and < 90", 0.0, 90.0, False, True
    if name == "tilt_direction_deg":
        return "≥ 0 and < 360", 0.0, 360.0, False, True
    if name == "calibration_deg":
        return "finite", -math.inf, math.inf, True, True
    raise ValueError(f"unknown variation field {name!r}; known: {', '.join(FIELDS)}")


def _number(name: str, value: object) -> float:
    """`value` as a float, with -0.0 made 0.0 (so the text round trip keeps every bit)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"variation field {name} must be a number, got {value!r}")
    return float(value) + 0.0


def _calibration(value: object) -> tuple[float, ...]:
    n = len(JOINT_NAMES)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise TypeError(f"variation field calibration_deg must be {n} numbers, got {value!r}")
    if len(value) != n:
        raise ValueError(
            f"variation field calibration_deg needs {n} values ({', '.join(JOINT_NAMES)}), "
            f"got {len(value)}"
        )
    cal = tuple(_number(CAL_PREFIX + j, v) for j, v in zip(JOINT_NAMES, value, strict=True))
    for j, v in zip(JOINT_NAMES, cal, strict=True):
        if not math.isfinite(v):
            raise ValueError(f"variation field {CAL_PREFIX}{j} must be finite, got {v!r}")
    return cal


def _check(name: str, value: float) -> None:
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
            frictionloss_scale: joint friction loss [0.02 N·m]. All > 0.
        latency_ms: set-point delay, ms ≥ 0, rounded to whole physics steps.
        deadband_deg, backlash_deg: servo dead band and gear play, degrees ≥ 0 (full widths).
        tilt_deg: floor tilt in [0, 90); tilt_direction_deg: the downhill direction, degrees
            counter-clockwise from the world x axis, in [0, 360).
        calibration_deg: 12 per-joint zero offsets in `gait.JOINT_NAMES` order (a servo drives
            to set-point + offset).

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
    calibration_deg: tuple[float, ...] = (0.0,) * len(JOINT_NAMES)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "calibration_deg":
                object.__setattr__(self, f.name, _calibration(value))
            elif value is not None or f.name != "friction":
                number = _number(f.name, value)
                _check(f.name, number)
                object.__setattr__(self, f.name, number)

    @property
    def is_nominal(self) -> bool:
        """True when nothing departs from the model."""
        return self == NOMINAL

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
            known = [*FIELDS[:-1], CAL_PREFIX + "<joint>"]
            raise ValueError(f"unknown variation field {key!r}; known: {', '.join(known)}")
    return Variation(**scalars, calibration_deg=tuple(cal.values()))


@dataclass(frozen=True)
class VariationRanges:
    """The box `sample` draws from: (low, high) per field, both allowed values of the field
    (`calibration_deg` holds for each joint; the direction may reach 360, drawn modulo 360).
    Defaults and their sources: docs/DESIGN.md §8. ValueError naming the field if a bound is
    outside the field's range or low > high."""

    friction: tuple[float, float] = (0.4, 1.0)
    trunk_mass_scale: tuple[float, float] = (0.85, 1.15)
    link_mass_scale: tuple[float, float] = (0.9, 1.1)
    kp_scale: tuple[float, float] = (0.8, 1.2)
    torque_scale: tuple[float, float] = (0.8, 1.0)
    damping_scale: tuple[float, float] = (0.8, 1.2)
    frictionloss_scale: tuple[float, float] = (0.5, 1.5)
    latency_ms: tuple[float, float] = (0.0, 60.0)
    deadband_deg: tuple[float, float] = (0.0, 0.5)
    backlash_deg: tuple[float, float] = (0.0, 1.0)
    tilt_deg: tuple[float, float] = (0.0, 3.0)
    tilt_direction_deg: tuple[float, float] = (0.0, 360.0)
    calibration_deg: tuple[float, float] = (-1.5, 1.5)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            bounds = getattr(self, f.name)
            if isinstance(bounds, (str, bytes)) or len(bounds) != 2:
                raise ValueError(f"range of {f.name} must be (low, high), got {bounds!r}")
            low, high = (_number(f.name, b) for b in bounds)
            for b in (low, high):
                if f.name == "tilt_direction_deg" and b == 360.0:
                    continue
                try:
                    _check(f.name, b)
                except ValueError as e:
                    raise ValueError(f"range of {e}") from None
            if low > high:
                raise ValueError(f"range of {f.name}: low {low!r} > high {high!r}")
            object.__setattr__(self, f.name, (low, high))

    def with_range(self, name: str, low: float, high: float) -> VariationRanges:
        """A copy with `name`'s range set to [low, high] (`--range friction=0.3:0.6`)."""
        if name not in FIELDS:
            raise ValueError(f"unknown variation field {name!r}; known: {', '.join(FIELDS)}")
        return dataclasses.replace(self, **{name: (low, high)})


def parse_range(text: str) -> tuple[str, float, float]:
    """`name=low:high` (the CLI's `--range`) as (name, low, high) for `with_range`."""
    name, sep, bounds = text.partition("=")
    low, colon, high = bounds.partition(":")
    try:
        if not (sep and colon):
            raise ValueError
        return name.strip(), float(low), float(high)
    except ValueError:
        raise ValueError(f"range {text!r} must be name=low:high, e.g. friction=0.3:0.6") from None


#: decimals a sampled value is rounded to, so names stay short (latency: whole ms = steps)
SAMPLE_DECIMALS = {
    **dict.fromkeys(("friction", *SCALES), 3),
    "latency_ms": 0,
    **dict.fromkeys(("deadband_deg", "backlash_deg", "tilt_deg", "calibration_deg"), 2),
    "tilt_direction_deg": 1,
}
SAMPLE_COLUMNS = (*FIELDS[:-1], *(CAL_PREFIX + j for j in JOINT_NAMES))


def sample(ranges: VariationRanges, n: int, seed: int) -> list[Variation]:
    """n variations drawn from `ranges`, the same list to the bit for a seed on any machine.

    Every field (and each joint's calibration) is drawn independently and uniformly from its
    range: one `Generator(PCG64(seed)).random((n, 24))` table, a row per variation and a column
    per value in `SAMPLE_COLUMNS` order, scaled as low + (high - low)·u, rounded to
    `SAMPLE_DECIMALS` and kept inside the range (the direction modulo 360). So the first m of
    n samples are `sample(ranges, m, seed)`, and narrowing one range leaves the others' draws.
    """
    if n < 0 or seed < 0:
        raise ValueError(f"sample needs n ≥ 0 and seed ≥ 0, got n={n}, seed={seed}")
    u = np.random.Generator(np.random.PCG64(seed)).random((n, len(SAMPLE_COLUMNS)))
    bounds = [getattr(ranges, f) for f in FIELDS[:-1]]
    bounds += [ranges.calibration_deg] * len(JOINT_NAMES)
    decimals = [SAMPLE_DECIMALS[f] for f in FIELDS[:-1]]
    decimals += [SAMPLE_DECIMALS["calibration_deg"]] * len(JOINT_NAMES)
    out = []
    for row in u.tolist():
        values = []
        for x, (low, high), d in zip(row, bounds, decimals, strict=True):
            values.append(min(max(round(low + (high - low) * x, d), low), high))
        n_scalar = len(FIELDS) - 1
        scalars = dict(zip(FIELDS[:-1], values[:n_scalar], strict=True))
        scalars["tilt_direction_deg"] %= 360.0
        cal = tuple(values[n_scalar:])
        out.append(Variation(**scalars, calibration_deg=cal))
    return out


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
