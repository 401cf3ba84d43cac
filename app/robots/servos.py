"""The servo table (`models/servos.yaml`: datasheet figures at stated voltages, with sources; a
robot file's own `servos:` are validated by the same `ServoSpec`) and `servo_settings`, the one rule
from a datasheet to MuJoCo: force range = stall torque, damping = stall torque / no-load speed,
kp = stall torque / saturation error, armature and friction loss as assumed; linear between stated
voltages, refused outside (docs/DESIGN.md §7)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Annotated, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, Strict, field_validator, model_validator

from app.assets import servo_table_path

KGF_CM_TO_NM = 0.0980665  # 1 kgf·cm in N·m

#: a number written as one (not "9.4", not true); finite by the models' allow_inf_nan=False
Real = Annotated[float, Strict()]
#: a servo's name as a joint gives it: "MG996R", "AX-12A", "XL430-W250"
ServoName = Annotated[str, Strict(), Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,39}$")]
#: a case's size, mm: 1 to 200 mm (a hobby servo is 20-60 mm)
CaseMm = Annotated[float, Strict(), Field(ge=1.0, le=200.0)]


class _Figures(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Rating(_Figures):
    """One datasheet line: stall torque and no-load speed at a voltage."""

    voltage_v: Real = Field(gt=0, le=24.0)
    # the smallest hobby servos give ~0.2 kgf·cm and the fastest ~0.04 s/60°; below these bounds
    # the MuJoCo settings that follow (damping = torque / speed) are not a servo's any more
    stall_torque_kgf_cm: Real = Field(ge=0.05, le=1000.0)
    speed_s_per_60deg: Real = Field(ge=0.01, le=10.0)


class Assumed(_Figures):
    """What no datasheet gives, with the reason for each value (extra keys: the reasons)."""

    model_config = ConfigDict(extra="allow")
    # kp = stall torque / this: below 0.01 rad (0.6°) the gain is a rigid joint's, not a servo's
    saturation_error_rad: Real = Field(ge=0.01, le=1.0)
    armature_kg_m2: Real = Field(ge=0, le=1.0)
    frictionloss_nm: Real = Field(ge=0, le=10.0)


class ServoSpec(_Figures):
    """A servo of the table or of a robot file: figures at stated voltages and where they are
    from (`source`: a datasheet or maker's page named in words, or "measured" and how)."""

    maker: Annotated[str, Strict()] = Field(min_length=1, max_length=80)
    signal: Literal["pwm", "bus"]
    source: Annotated[str, Strict()] = Field(min_length=1, max_length=1000)
    ratings: tuple[Rating, ...] = Field(min_length=1, max_length=8)
    mass_kg: Real = Field(ge=0.001, le=1.0)
    case_mm: tuple[CaseMm, CaseMm, CaseMm]
    pulse_min_us: Real | None = Field(None, ge=0, le=3000.0)
    pulse_max_us: Real | None = Field(None, ge=0, le=3000.0)
    travel_deg: Real = Field(gt=0, le=360)
    assumed: Assumed

    @field_validator("ratings")
    @classmethod
    def _ascending(cls, ratings: tuple[Rating, ...]) -> tuple[Rating, ...]:
        volts = [r.voltage_v for r in ratings]
        if volts != sorted(set(volts)):
            raise ValueError(f"ratings must be in ascending, distinct voltages, got {volts}")
        return ratings

    @model_validator(mode="after")
    def _pulses(self) -> ServoSpec:
        pulses = (self.pulse_min_us, self.pulse_max_us)
        if self.signal == "pwm" and None in pulses:
            raise ValueError(
                "a pwm servo states its pulse range: pulse_min_us and pulse_max_us (µs); a "
                "guess goes with its reason under `assumed`"
            )
        low, high = pulses
        if low is not None and high is not None and not low < high:
            raise ValueError(f"pulse_min_us must be less than pulse_max_us, got {pulses}")
        return self

    @property
    def voltages_v(self) -> tuple[float, ...]:
        return tuple(r.voltage_v for r in self.ratings)


class ServoTable(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    schema_version: Literal[1]
    servos: dict[ServoName, ServoSpec]


@cache
def servo_table() -> dict[str, ServoSpec]:
    """The servos a robot description may name, by name."""
    raw = yaml.safe_load(servo_table_path().read_text(encoding="utf-8"))
    return ServoTable.model_validate(raw).servos


@dataclass(frozen=True)
class ServoSettings:
    """A servo's figures at one supply voltage and the MuJoCo settings that follow from them."""

    name: str
    voltage_v: float
    stall_torque_nm: float  # actuator force range
    no_load_speed_rad_s: float
    damping_nm_s_rad: float  # joint damping
    kp_nm_rad: float  # position actuator gain
    armature_kg_m2: float
    frictionloss_nm: float
    interpolated: bool  # the voltage lies between two datasheet lines

    def to_dict(self) -> dict[str, float | str | bool]:
        return dict(self.__dict__)


def rating_at(spec: ServoSpec, voltage_v: float, name: str = "servo") -> tuple[float, float, bool]:
    """(stall torque N·m, no-load speed rad/s, interpolated) at `voltage_v`; ValueError outside
    the voltages the datasheet states."""
    volts = spec.voltages_v
    if not volts[0] - 1e-9 <= voltage_v <= volts[-1] + 1e-9:
        stated = " and ".join(f"{v:g} V" for v in volts)
        span = f"{volts[0]:g} V" if len(volts) == 1 else f"{volts[0]:g}–{volts[-1]:g} V"
        raise ValueError(
            f"{name}: the datasheet states figures at {stated} only; a supply of {voltage_v:g} V "
            f"is outside {span}"
        )
    for lo, hi in zip(spec.ratings, spec.ratings[1:], strict=False):
        if lo.voltage_v <= voltage_v <= hi.voltage_v:
            w = (voltage_v - lo.voltage_v) / (hi.voltage_v - lo.voltage_v)
            torque = lo.stall_torque_kgf_cm + w * (hi.stall_torque_kgf_cm - lo.stall_torque_kgf_cm)
            speed = lo.speed_s_per_60deg + w * (hi.speed_s_per_60deg - lo.speed_s_per_60deg)
            exact = w in (0.0, 1.0)
            return torque * KGF_CM_TO_NM, (math.pi / 3) / speed, not exact
    only = spec.ratings[0] if voltage_v <= volts[0] + 1e-9 else spec.ratings[-1]
    return only.stall_torque_kgf_cm * KGF_CM_TO_NM, (math.pi / 3) / only.speed_s_per_60deg, False


def servo_settings(
    name: str, voltage_v: float, servos: Mapping[str, ServoSpec] | None = None
) -> ServoSettings:
    """The MuJoCo settings of servo `name` at `voltage_v` (see the module docstring), looked up
    in `servos` (default: the table; a robot's `servo_catalogue()` adds its own); ValueError for
    an unknown servo or a voltage the datasheet does not cover."""
    table = servo_table() if servos is None else servos
    if name not in table:
        raise ValueError(f"unknown servo {name!r}; known: {', '.join(sorted(table))}")
    spec = table[name]
    stall_nm, speed_rad_s, interpolated = rating_at(spec, voltage_v, name)
    return ServoSettings(
        name=name,
        voltage_v=voltage_v,
        stall_torque_nm=stall_nm,
        no_load_speed_rad_s=speed_rad_s,
        damping_nm_s_rad=stall_nm / speed_rad_s,
        kp_nm_rad=stall_nm / spec.assumed.saturation_error_rad,
        armature_kg_m2=spec.assumed.armature_kg_m2,
        frictionloss_nm=spec.assumed.frictionloss_nm,
        interpolated=interpolated,
    )
