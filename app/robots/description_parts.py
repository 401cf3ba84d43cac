"""The pieces of a robot description (`app.robots.description`): the legs' joint and link
names, the board, where the joints are, the links' parts, servo mounts, calibration, joints and
contact; each validated on its own, m, kg, rad (docs/DESIGN.md §3, §7)."""

from __future__ import annotations

import math
from typing import Annotated, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, Strict, field_validator, model_validator

from hardware.servo import PULSE_CENTER_US, PULSE_MAX_US, PULSE_MIN_US, US_PER_DEG

LegJoint = Literal["hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"]
LEG_JOINTS: tuple[str, ...] = get_args(LegJoint)
#: the boards the firmware is built for (docs/BOARDS.md): ArtRo's ATmega128 with TDM-PWM, or an
#: Arduino Mega 2560 writing the pulses to a PCA9685 on I2C
Board = Literal["artro-atmega128", "mega2560-pca9685"]
LinkName = Literal["hip_yaw", "hip_roll", "thigh", "shank", "ankle", "foot"]  # `links`' keys
LINKS: tuple[Literal["trunk"], LinkName, LinkName, LinkName, LinkName, LinkName, LinkName] = (
    "trunk", "hip_yaw", "hip_roll", "thigh", "shank", "ankle", "foot"
)  # fmt: skip
#: a number written as one (not "0.09", not true), finite
Real = Annotated[float, Strict()]
#: a length of a small servo-driven biped's part: 0.1 mm to a metre
Length = Annotated[float, Strict(), Field(ge=1e-4, le=1.0)]
#: a position relative to a joint, each coordinate within a metre
Vec3 = tuple[
    Annotated[float, Strict(), Field(ge=-1.0, le=1.0)],
    Annotated[float, Strict(), Field(ge=-1.0, le=1.0)],
    Annotated[float, Strict(), Field(ge=-1.0, le=1.0)],
]
Size3 = tuple[Length, Length, Length]
Name = Annotated[str, Strict()]


class DescriptionModel(BaseModel):
    """What every piece of a description is: frozen, no unknown key, finite numbers."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Geometry(DescriptionModel):
    """Where the joints are. The hip roll and pitch axes cross, so do the ankle's (eqs 2–9)."""

    hip_spacing_m: Length = Field(description="between the two hip-yaw axes")
    hip_yaw_offset_m: Real = Field(
        ge=0, le=1.0, description="trunk origin (abdomen centre) down to the hip-yaw joint"
    )
    hip_roll_offset_m: Length = Field(
        description="hip-yaw joint down to the hip roll/pitch crossing"
    )
    # at least a centimetre: a servo-driven leg is longer than the servos' horns
    thigh_m: Length = Field(ge=0.01, description="L_UL: hip crossing to knee axis (eq 3)")
    shank_m: Length = Field(ge=0.01, description="L_LL: knee axis to ankle crossing (eq 3)")
    ankle_to_sole_m: Length = Field(description="ankle crossing down to the sole")
    foot_length_m: Length
    foot_width_m: Length
    foot_thickness_m: Length

    @model_validator(mode="after")
    def _fits(self) -> Geometry:
        if self.foot_thickness_m >= self.ankle_to_sole_m:
            raise ValueError(
                f"foot_thickness_m ({self.foot_thickness_m}) must be less than ankle_to_sole_m "
                f"({self.ankle_to_sole_m}): the plate hangs below the ankle"
            )
        leg_m = self.thigh_m + self.shank_m + self.ankle_to_sole_m
        if self.foot_length_m > leg_m:
            raise ValueError(
                f"foot_length_m ({self.foot_length_m}) must not exceed the leg's length, hip to "
                f"sole ({leg_m:.4g} m): a biped on longer feet stands like a table"
            )
        if self.foot_width_m > self.hip_spacing_m:
            raise ValueError(
                f"foot_width_m ({self.foot_width_m}) must not exceed hip_spacing_m "
                f"({self.hip_spacing_m}): standing, the feet would overlap"
            )
        return self

    @property
    def standing_height_m(self) -> float:
        """Trunk origin above the soles with straight legs."""
        return (
            self.hip_yaw_offset_m
            + self.hip_roll_offset_m
            + self.thigh_m
            + self.shank_m
            + self.ankle_to_sole_m
        )


class Part(DescriptionModel):
    """A piece of a link: its mass and, for the inertia, a box or a capsule along the link."""

    name: Name = Field(min_length=1, max_length=80)
    mass_kg: Real = Field(ge=0, le=10.0)
    box_m: Size3 | None = Field(None, description="full box size x, y, z (default: no volume)")
    capsule_radius_m: Real | None = Field(
        None, gt=0, le=0.1, description="a capsule along the link from its joint to the next one"
    )
    capsule_inset_m: Real = Field(
        0.01, ge=0, le=0.5, description="capsule ends this far from joints"
    )
    pos_m: Vec3 = (0.0, 0.0, 0.0)
    collides: bool = False
    material: Literal["aluminium", "dummy", "board", "plastic"] = "aluminium"

    @model_validator(mode="after")
    def _one_shape(self) -> Part:
        if self.box_m is not None and self.capsule_radius_m is not None:
            raise ValueError(f"{self.name}: give box_m or capsule_radius_m, not both")
        if self.box_m is not None and min(self.box_m) <= 0:
            raise ValueError(f"{self.name}: box_m sizes must be > 0 m, got {list(self.box_m)}")
        return self


class ServoMount(DescriptionModel):
    """Where a joint's servo case sits: in the link above the joint, relative to the joint."""

    pos_m: Vec3 = (0.0, 0.0, 0.0)
    euler_rad: tuple[Real, Real, Real] = (0.0, 0.0, 0.0)
    box_m: Size3 | None = Field(None, description="the case as drawn, if not the datasheet's")


class Calibration(DescriptionModel):
    """How a joint angle becomes a pulse: direction, trim and the pulse limits (seed 000 §3.B)."""

    direction: Literal[1, -1] = 1
    trim_us: Real = Field(default=0.0, ge=-200.0, le=200.0)
    pulse_min_us: Real = PULSE_MIN_US
    pulse_max_us: Real = PULSE_MAX_US

    @model_validator(mode="after")
    def _range(self) -> Calibration:
        if not PULSE_MIN_US <= self.pulse_min_us < self.pulse_max_us <= PULSE_MAX_US:
            raise ValueError(
                f"pulse limits must satisfy {PULSE_MIN_US:g} <= pulse_min_us < pulse_max_us <= "
                f"{PULSE_MAX_US:g} µs (the TDM-PWM drive's range), got {self.pulse_min_us:g}.."
                f"{self.pulse_max_us:g}"
            )
        return self

    def angle_limits_rad(self) -> tuple[float, float]:
        """The joint angles whose pulse lies inside the limits (after trim and direction)."""
        ends = [
            math.radians((p - PULSE_CENTER_US - self.trim_us) / US_PER_DEG) * self.direction
            for p in (self.pulse_min_us, self.pulse_max_us)
        ]
        return max(min(ends), -math.pi / 2), min(max(ends), math.pi / 2)


class Joint(DescriptionModel):
    """One of the 12 joints: its servo, range of motion and calibration."""

    servo: Name | None = Field(None, description="a name of the servo table; default: `servo`")
    range_rad: tuple[Real, Real] = (-math.pi / 2, math.pi / 2)
    calibration: Calibration = Calibration()
    bus_id: int | None = Field(
        None,
        ge=0,
        le=252,
        description="its servo's ID on a serial bus (`artro bus`, docs/BUS.md); default: 1-12 "
        "in the gait's joint order",
    )

    @field_validator("range_rad")
    @classmethod
    def _ordered(cls, value: tuple[float, float]) -> tuple[float, float]:
        if not value[0] < value[1]:
            raise ValueError(f"range_rad must be (lower, upper) with lower < upper, got {value}")
        return value


class Contact(DescriptionModel):
    """Floor and sole contact. Physics stays honest: sliding friction at most 1."""

    friction: Real = Field(default=0.7, gt=0, le=1.0, description="sliding, soles and floor")
    torsional_friction: Real = Field(default=0.005, ge=0, le=0.1)
    rolling_friction: Real = Field(default=0.0001, ge=0, le=0.01)
    condim: Literal[3, 4, 6] = 3
