"""A robot description: one validated document that says what a biped of ArtRo's structure is;
the model, leg geometry, servo settings, calibration, TDM map and firmware header follow from it.
The left leg is described, the right one mirrors it; m, kg, rad (docs/DESIGN.md §3, §7). What
needs the model or the gait's poses (eq (1)) is `app.robots.checks`. A file may define its own
servos (`servos:`, validated as the table's); the total mass is optional (`mass_tolerance_kg`)."""

from __future__ import annotations

import functools
import json
import math
from typing import Annotated, Literal, get_args

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, Strict, field_validator, model_validator

from app.assets import builtin_presets_dir
from app.robots.cad_source import CadSource
from app.robots.fitted import Fitted
from app.robots.servos import ServoName, ServoSpec, rating_at, servo_table
from gait import JOINT_NAMES, GaitParams, LegGeometry, Motion, joint_angles_with_flags
from gait.leg_interface import knee_triangle
from hardware import CHANNELS
from hardware.servo import PULSE_CENTER_US, PULSE_MAX_US, PULSE_MIN_US, US_PER_DEG
from hardware.timer import SLOTS_USED

LegJoint = Literal["hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"]
LEG_JOINTS: tuple[str, ...] = get_args(LegJoint)
#: the boards the firmware is built for (docs/BOARDS.md): ArtRo's ATmega128 with TDM-PWM, or an
#: Arduino Mega 2560 writing the pulses to a PCA9685 on I2C
Board = Literal["artro-atmega128", "mega2560-pca9685"]
LinkName = Literal["hip_yaw", "hip_roll", "thigh", "shank", "ankle", "foot"]  # `links`' keys
LINKS: tuple[Literal["trunk"], LinkName, LinkName, LinkName, LinkName, LinkName, LinkName] = (
    "trunk", "hip_yaw", "hip_roll", "thigh", "shank", "ankle", "foot"
)  # fmt: skip
#: a stated total_mass_kg is a kitchen scale's reading; the parts are datasheet and estimated
#: masses: they agree within 2 % of the parts or 5 g, whichever is larger (docs/DESIGN.md §7)
MASS_TOLERANCE_FRACTION = 0.02
MASS_TOLERANCE_MIN_KG = 0.005
MAX_MASS_KG = 20.0  # stated or the parts' sum: a small servo-driven biped
#: the motions whose poses every joint's range must hold: seed 000's table, both ways
REACH_CASES = (
    Motion(),
    *(Motion(**{axis: sign * value}) for axis, value in (("a_p", 0.07), ("a_r", 0.1), ("a_y", 0.2))
      for sign in (1.0, -1.0)),
)  # fmt: skip
REACH_PHASES = 64


@functools.cache
def preset_gait(name: str) -> GaitParams:
    """The gait constants of the built-in preset `name` (models/presets/NAME.json), read here:
    the robots' checks need no parameter-set documents (`app.params`)."""
    doc = json.loads((builtin_presets_dir() / f"{name}.json").read_text(encoding="utf-8"))
    return GaitParams.from_dict(doc["gait"])


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


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Geometry(_Strict):
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


class Part(_Strict):
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


class ServoMount(_Strict):
    """Where a joint's servo case sits: in the link above the joint, relative to the joint."""

    pos_m: Vec3 = (0.0, 0.0, 0.0)
    euler_rad: tuple[Real, Real, Real] = (0.0, 0.0, 0.0)
    box_m: Size3 | None = Field(None, description="the case as drawn, if not the datasheet's")


class Calibration(_Strict):
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


class Joint(_Strict):
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


class Contact(_Strict):
    """Floor and sole contact. Physics stays honest: sliding friction at most 1."""

    friction: Real = Field(default=0.7, gt=0, le=1.0, description="sliding, soles and floor")
    torsional_friction: Real = Field(default=0.005, ge=0, le=0.1)
    rolling_friction: Real = Field(default=0.0001, ge=0, le=0.01)
    condim: Literal[3, 4, 6] = 3


class RobotDescription(_Strict):
    """A biped of ArtRo's structure (docs/DESIGN.md §3, §7)."""

    schema_version: Literal[1] = 1
    name: Name = Field(pattern=r"^[a-z][a-z0-9_-]{0,39}$")
    title: Name = Field("", max_length=200)
    default_preset: Name = Field("paper", description="the parameter set it starts with")
    supply_voltage_v: Real = Field(gt=0, le=24)
    total_mass_kg: Real | None = Field(
        None,
        gt=0,
        le=MAX_MASS_KG,
        description="the robot on a scale (optional): checked against the sum of all parts "
        "within 2 % or 5 g, whichever is larger; the model carries the parts' sum",
    )
    servo: Name = Field(description="every joint's servo unless a joint names another")
    servos: dict[ServoName, ServoSpec] = Field(
        default_factory=dict,
        description="the robot's own servos, with the fields of models/servos.yaml (`source` "
        "may say measured); joints name them as they name the table's; no table name",
    )
    geometry: Geometry
    trunk: tuple[Part, ...] = Field(min_length=1)
    links: dict[LinkName, tuple[Part, ...]]
    servo_mounts: dict[LegJoint, ServoMount]
    joints: dict[str, Joint]
    tdm_channels: dict[str, tuple[str, ...]] = Field(
        description="TDM-PWM line -> the servos on its demultiplexer outputs, slot 0 first"
    )
    contact: Contact = Contact()
    board: Board = Field(
        "artro-atmega128",
        description="the controller the firmware is built for (`artro firmware`, docs/BOARDS.md): "
        "artro-atmega128 (TDM-PWM) or mega2560-pca9685 (an Arduino Mega 2560 and a PCA9685)",
    )
    cad: CadSource | None = Field(
        None,
        description="imported from a URDF or MJCF file (`artro robot import`): the model "
        "is the file's, mapped onto the gait; its links' masses are the file's",
    )
    fitted: Fitted | None = Field(
        None, description="the variation a fit to its recording found (`artro fit`)"
    )

    @model_validator(mode="after")
    def _consistent(self) -> RobotDescription:
        clash = sorted(set(self.servos) & set(servo_table()))
        if clash:
            raise ValueError(
                f"servos.{clash[0]}: {clash[0]} is a servo of the table (models/servos.yaml); "
                f"a robot's own servo takes a name of its own (e.g. {clash[0]}-mine), the "
                f"table's {clash[0]} is named as it is"
            )
        table = self.servo_catalogue()
        if self.servo not in table:
            raise ValueError(f"servo: unknown servo {self.servo!r}; known: {sorted(table)}")
        unknown = sorted(set(self.joints) - set(JOINT_NAMES))
        missing = [j for j in JOINT_NAMES if j not in self.joints]
        if unknown or missing:
            raise ValueError(
                f"joints must name each of {list(JOINT_NAMES)} once; unknown {unknown}, "
                f"missing {missing}"
            )
        for name, joint in self.joints.items():
            servo = joint.servo or self.servo
            if servo not in table:
                raise ValueError(
                    f"joints.{name}.servo: unknown servo {servo!r}; known: {sorted(table)}"
                )
            spec = table[servo]
            if spec.signal != "pwm" and self.cad is None:  # an imported robot: docs/DESIGN.md §16
                raise ValueError(
                    f"joints.{name}.servo: {servo} is a {spec.signal} servo; the TDM-PWM output "
                    f"of this robot (seed 000 §3) sends pulses, which {servo} does not take: "
                    f"the simulation and the firmware drive servos by those pulses, so a bus "
                    f"servo can be neither simulated nor driven here (choose a pwm servo)"
                )
            try:
                rating_at(spec, self.supply_voltage_v, servo)
            except ValueError as err:
                raise ValueError(f"supply_voltage_v: {err}") from None
            cal = joint.calibration
            if spec.pulse_min_us is not None and spec.pulse_max_us is not None:
                if cal.pulse_min_us < spec.pulse_min_us or cal.pulse_max_us > spec.pulse_max_us:
                    raise ValueError(
                        f"joints.{name}.calibration: pulses {cal.pulse_min_us:g}.."
                        f"{cal.pulse_max_us:g} µs are outside the {servo}'s "
                        f"{spec.pulse_min_us:g}..{spec.pulse_max_us:g} µs"
                    )
            lo, hi = joint.range_rad
            half_travel = math.radians(spec.travel_deg) / 2
            if lo < -half_travel - 1e-4 or hi > half_travel + 1e-4:
                raise ValueError(
                    f"joints.{name}.range_rad: {lo:.4f}..{hi:.4f} rad is beyond the {servo}'s "
                    f"travel of ±{half_travel:.4f} rad"
                )
        ids = self.bus_ids()
        twice = sorted({i for i in ids if ids.count(i) > 1})
        if twice:
            named = [j for j, i in zip(JOINT_NAMES, ids, strict=True) if i == twice[0]]
            given = [j for j in named if self.joints[j].bus_id is not None][-1]
            other = next(j for j in named if j != given)
            raise ValueError(
                f"joints.{given}.bus_id: {twice[0]} is {other}'s ID on the bus too "
                f"(unset, a joint's ID is its place in the gait's joint order, 1-12); each "
                f"servo on a bus has an ID of its own"
            )
        missing_mounts = [j for j in LEG_JOINTS if j not in self.servo_mounts]
        if missing_mounts and self.cad is None:  # an imported robot's servos are in its file
            raise ValueError(
                f"servo_mounts: no mount for {missing_mounts}; give each of {list(LEG_JOINTS)} "
                "(an empty {} puts the case at its joint)"
            )
        presets = sorted(p.stem for p in builtin_presets_dir().glob("*.json"))
        if self.default_preset not in presets:
            raise ValueError(
                f"default_preset: {self.default_preset!r} is not a built-in preset; built in: "
                f"{', '.join(presets)}"
            )
        for i, part in enumerate(self.links.get("foot", ())):
            if part.box_m or part.capsule_radius_m or part.collides or any(part.pos_m):
                raise ValueError(
                    f"links.foot.{i}: the foot's parts weigh its plate (geometry.foot_length_m, "
                    "foot_width_m, foot_thickness_m), which is its shape: give name and mass_kg "
                    "only"
                )
        if sum(p.mass_kg for p in self.links.get("foot", ())) <= 0:
            raise ValueError(
                "links.foot: the foot plate must weigh something (MuJoCo moves no massless "
                "body): give it a part with mass_kg > 0"
            )
        self._check_tdm()
        self._check_mass()
        self._check_capsules()
        self._check_knee_reach(min(gait.leg.eta_min for _, gait in self.walked_gaits()))
        self._check_reach()
        return self

    def walked_gaits(self) -> list[tuple[str, GaitParams]]:
        """The gaits the robot is checked for, named: the paper's constants and those of its
        default preset (what `artro serve` and `artro run` walk it with)."""
        own = preset_gait(self.default_preset)
        return [
            ("the paper's constants", GaitParams()),
            (f"default_preset {self.default_preset!r}", own),
        ]

    def link_length_m(self, link: str) -> float:
        """How far a link reaches from its joint to the next (0 where two axes cross)."""
        g = self.geometry
        lengths = {"hip_yaw": g.hip_roll_offset_m, "thigh": g.thigh_m, "shank": g.shank_m,
                   "foot": g.ankle_to_sole_m}  # fmt: skip
        return lengths.get(link, 0.0)

    def _check_capsules(self) -> None:
        """A capsule runs along its link between the two insets: there must be room for it."""
        for link, parts in (("trunk", self.trunk), *self.links.items()):
            length = self.link_length_m(link)
            for i, part in enumerate(parts):
                if part.capsule_radius_m is not None and 2 * part.capsule_inset_m >= length:
                    where = "trunk" if link == "trunk" else f"links.{link}"
                    raise ValueError(
                        f"{where}.{i}.capsule_inset_m: {part.capsule_inset_m:g} m from each "
                        f"end leaves no capsule on the {length:g} m {link}; allowed: less than "
                        f"{length / 2:g} m (or a box_m)"
                    )

    def _check_reach(self) -> None:
        """Every joint's range holds the poses of the table motions in each gait it is checked
        for (`walked_gaits`, this robot's legs): a narrower range stops the walk at its limit."""
        geometry = LegGeometry(upper_m=self.geometry.thigh_m, lower_m=self.geometry.shank_m)
        phases = np.linspace(-np.pi, np.pi, REACH_PHASES, endpoint=False)
        for gait_name, gait in self.walked_gaits():
            poses = np.concatenate(
                [joint_angles_with_flags(gait, m, phases, geometry).values for m in REACH_CASES]
            )
            for i, name in enumerate(JOINT_NAMES):
                lo, hi = self.joints[name].range_rad
                need_lo, need_hi = float(poses[:, i].min()), float(poses[:, i].max())
                if need_lo < lo - 1e-6 or need_hi > hi + 1e-6:
                    raise ValueError(
                        f"joints.{name}.range_rad: {lo:.4f}..{hi:.4f} rad does not hold the "
                        f"gait's reach of {need_lo:.4f}..{need_hi:.4f} rad ({gait_name} walking "
                        f"forward, backward, sideways and turning at seed 000's table speeds)"
                    )

    def _check_knee_reach(self, eta_min: float) -> None:
        """The knees bend to the gait's shortest leg, knee = α1 − π at η_min (eqs 3–7), and
        straighten (η = 1, knee 0)."""
        geometry = LegGeometry(upper_m=self.geometry.thigh_m, lower_m=self.geometry.shank_m)
        alpha1, _, _ = knee_triangle(eta_min, geometry)
        knee_rad = float(alpha1) - math.pi
        for side in ("l", "r"):
            lo, hi = self.joints[f"{side}_knee"].range_rad
            if knee_rad < lo - 1e-9 or hi < 0.0:
                raise ValueError(
                    f"joints.{side}_knee.range_rad: {lo:.4f}..{hi:.4f} rad must reach from "
                    f"{knee_rad:.4f} rad (the gait's shortest leg, eta_min = {eta_min:g}) to 0 "
                    f"(a straight leg)"
                )

    def bus_ids(self) -> list[int]:
        """Each joint's servo ID on a serial bus, in the gait's joint order: its `bus_id`, else
        its place in that order (1-12)."""
        return [
            i if (i := self.joints[name].bus_id) is not None else k
            for k, name in enumerate(JOINT_NAMES, 1)
        ]

    def _check_tdm(self) -> None:
        seen: dict[str, str] = {}
        for channel, servos in self.tdm_channels.items():
            if channel not in CHANNELS:
                raise ValueError(f"tdm_channels: unknown line {channel!r}; lines: {list(CHANNELS)}")
            if len(servos) > SLOTS_USED:
                raise ValueError(
                    f"tdm_channels.{channel}: {len(servos)} servos, but a 20 ms frame of eight "
                    f"2.5 ms slots carries at most {SLOTS_USED} pulses per line (the other "
                    f"three slots are the firmware's planning time)"
                )
            for servo in servos:
                if servo not in JOINT_NAMES:
                    raise ValueError(
                        f"tdm_channels.{channel}: unknown servo {servo!r}; servos: "
                        f"{list(JOINT_NAMES)}"
                    )
                if servo in seen:
                    raise ValueError(
                        f"tdm_channels: {servo} is on both {seen[servo]} and {channel}; each "
                        f"servo has one output"
                    )
                seen[servo] = channel
        missing = [s for s in JOINT_NAMES if s not in seen]
        if missing:
            raise ValueError(f"tdm_channels: no output for {missing}")

    def _check_mass(self) -> None:
        total = self.parts_mass_kg()
        if total > MAX_MASS_KG:
            raise ValueError(
                f"the parts add up to {total:.3f} kg (links and 12 servos); a small servo-driven "
                f"biped weighs at most {MAX_MASS_KG:g} kg"
            )
        if self.total_mass_kg is None:
            return
        tolerance = mass_tolerance_kg(total)
        if abs(total - self.total_mass_kg) > tolerance:
            raise ValueError(
                f"total_mass_kg: the parts add up to {total:.4f} kg (links and 12 servos), "
                f"{1000 * abs(total - self.total_mass_kg):.0f} g from the stated "
                f"{self.total_mass_kg:.4f} kg; allowed: ±{1000 * tolerance:.0f} g (2 % of the "
                f"parts or 5 g, whichever is larger): weigh again, add the missing parts (wires, "
                f"screws) or leave total_mass_kg out to use the parts' sum"
            )

    # --- what follows from it ------------------------------------------------------------------

    def joint_servo(self, joint: str) -> str:
        return self.joints[joint].servo or self.servo

    def servo_catalogue(self) -> dict[str, ServoSpec]:
        """The servos this robot may name: the table's and its own."""
        return servo_table() | self.servos

    def joint_servo_spec(self, joint: str) -> ServoSpec:
        return self.servo_catalogue()[self.joint_servo(joint)]

    def link_masses_kg(self) -> dict[str, float]:
        """Mass of each body, parts and the servo cases it carries (one leg; trunk with both
        hip-yaw servos)."""
        table = self.servo_catalogue()
        carrier = dict(zip(LEG_JOINTS, LINKS[:-1], strict=True))  # joint -> link carrying its servo
        masses = {"trunk": sum(p.mass_kg for p in self.trunk)}
        masses |= {link: sum(p.mass_kg for p in self.links.get(link, ())) for link in LINKS[1:]}
        if self.cad is not None:  # the file's masses carry its servos
            return masses
        for side in ("l", "r"):
            for joint in LEG_JOINTS:
                servo = table[self.joint_servo(f"{side}_{joint}")]
                link = carrier[joint]
                share = servo.mass_kg if link == "trunk" else servo.mass_kg / 2
                masses[link] += share  # a leg link's entry is the mean of the two legs
        return masses

    def parts_mass_kg(self) -> float:
        masses = self.link_masses_kg()
        return masses["trunk"] + 2 * sum(masses[link] for link in LINKS[1:])

    def channel_assignments(self) -> tuple[tuple[int, int], ...]:
        """(channel index, slot) per servo in JOINT_NAMES order, for `hardware.ChannelMap`."""
        where = {
            servo: (CHANNELS.index(channel), slot)
            for channel, servos in self.tdm_channels.items()
            for slot, servo in enumerate(servos)
        }
        return tuple(where[name] for name in JOINT_NAMES)


def mass_tolerance_kg(parts_kg: float) -> float:
    """How far a stated total may lie from the parts' sum: 2 % of it or 5 g, whichever is larger.
    A 1 g kitchen scale reads the robot to a gram or two; the parts' masses come from datasheets
    (servo masses vary by a few grams from unit to unit) and estimates of brackets, screws and
    wires, which a builder cannot meet to the gram; 2 % of ArtRo's 1.65 kg is 33 g, of micro's
    0.41 kg 8 g, and 5 g is the floor under which wires alone differ."""
    return max(MASS_TOLERANCE_FRACTION * parts_kg, MASS_TOLERANCE_MIN_KG)
