"""The box variations are drawn from (`VariationRanges`: default ranges, their sources in
docs/DESIGN.md §8, `--range NAME=LOW:HIGH`) and `sample`: n variations for a seed, the same list
to the bit on any machine."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from app.worlds.variations import (
    CAL_PREFIX,
    FIELDS,
    PHYSICS_FIELDS,
    SCALES,
    SENSOR_FIELDS,
    Variation,
    as_number,
    check_value,
)
from gait import JOINT_NAMES


@dataclass(frozen=True)
class VariationRanges:
    """The box `sample` draws from: (low, high) per field, both allowed values of the field
    (`calibration_deg` holds for each joint; a direction may reach 360, drawn modulo 360).
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
    imu_tilt_bias_deg: tuple[float, float] = (0.0, 1.0)
    imu_tilt_direction_deg: tuple[float, float] = (0.0, 360.0)
    gyro_bias_deg_s: tuple[float, float] = (-0.5, 0.5)
    gyro_noise_deg_s: tuple[float, float] = (0.0, 0.1)
    imu_delay_ms: tuple[float, float] = (2.0, 25.0)
    fsr_gain: tuple[float, float] = (0.8, 1.2)
    push_n_s: tuple[float, float] = (0.0, 0.0)  # no push unless asked (`--range push_n_s=...`)
    push_time_s: tuple[float, float] = (6.0, 12.0)
    push_direction_deg: tuple[float, float] = (0.0, 360.0)
    calibration_deg: tuple[float, float] = (-1.5, 1.5)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            bounds = getattr(self, f.name)
            if isinstance(bounds, (str, bytes)) or len(bounds) != 2:
                raise ValueError(f"range of {f.name} must be (low, high), got {bounds!r}")
            low, high = (as_number(f.name, b) for b in bounds)
            for b in (low, high):
                if f.name in DIRECTIONS and b == 360.0:
                    continue
                try:
                    check_value(f.name, b)
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
    **dict.fromkeys(("friction", *SCALES, "fsr_gain"), 3),
    **dict.fromkeys(("latency_ms", "imu_delay_ms"), 0),
    **dict.fromkeys(("deadband_deg", "backlash_deg", "tilt_deg", "calibration_deg"), 2),
    **dict.fromkeys(("imu_tilt_bias_deg", "gyro_bias_deg_s", "gyro_noise_deg_s", "push_n_s"), 3),
    **dict.fromkeys(("tilt_direction_deg", "imu_tilt_direction_deg", "push_direction_deg"), 1),
    "push_time_s": 2,
}
DIRECTIONS = ("tilt_direction_deg", "imu_tilt_direction_deg", "push_direction_deg")
#: the physics table's columns: the scalar fields, then each joint's calibration
SAMPLE_COLUMNS = (*PHYSICS_FIELDS[:-1], *(CAL_PREFIX + j for j in JOINT_NAMES))


def _draw(u: list[float], names: tuple[str, ...], ranges: VariationRanges) -> list[float]:
    """One row of uniform draws scaled into the ranges of `names` and rounded."""
    out = []
    for x, name in zip(u, names, strict=True):
        field = "calibration_deg" if name.startswith(CAL_PREFIX) else name
        low, high = getattr(ranges, field)
        value = min(max(round(low + (high - low) * x, SAMPLE_DECIMALS[field]), low), high)
        out.append(value % 360.0 if field in DIRECTIONS else value)
    return out


def sample(ranges: VariationRanges, n: int, seed: int) -> list[Variation]:
    """n variations drawn from `ranges`, the same list to the bit for a seed on any machine.

    Every field (and each joint's calibration) is drawn independently and uniformly from its
    range: the physics from one `Generator(PCG64(seed)).random((n, 24))` table, a row per
    variation and a column per value in `SAMPLE_COLUMNS` order, the sensors' errors and the push
    from a second table of the stream `PCG64([seed, 1])` (columns in `SENSOR_FIELDS` order),
    scaled as low + (high - low)·u, rounded to `SAMPLE_DECIMALS` and kept inside the range
    (directions modulo 360). So the first m of n samples are `sample(ranges, m, seed)`,
    narrowing one range leaves the others' draws, and the physics drawn for a seed do not
    depend on the sensors' ranges. Without a push, its time and direction are left at 0.
    """
    if n < 0 or seed < 0:
        raise ValueError(f"sample needs n ≥ 0 and seed ≥ 0, got n={n}, seed={seed}")
    physics = np.random.Generator(np.random.PCG64(seed)).random((n, len(SAMPLE_COLUMNS)))
    sensors = np.random.Generator(np.random.PCG64([seed, 1])).random((n, len(SENSOR_FIELDS)))
    n_scalar = len(PHYSICS_FIELDS) - 1
    out = []
    for row, sensor_row in zip(physics.tolist(), sensors.tolist(), strict=True):
        values = _draw(row, SAMPLE_COLUMNS, ranges)
        scalars = dict(zip(SAMPLE_COLUMNS[:n_scalar], values[:n_scalar], strict=True))
        errors = dict(zip(SENSOR_FIELDS, _draw(sensor_row, SENSOR_FIELDS, ranges), strict=True))
        if errors["push_n_s"] == 0.0:
            errors |= {"push_time_s": 0.0, "push_direction_deg": 0.0}
        out.append(Variation(**scalars, **errors, calibration_deg=tuple(values[n_scalar:])))
    return out
