"""A robot description: one validated document that says what a biped of ArtRo's structure is;
the model, leg geometry, servo settings, calibration, TDM map and firmware header follow from it.
The left leg is described, the right one mirrors it; m, kg, rad (docs/DESIGN.md §3, §7). What
needs the model or the gait's poses (eq (1)) is `app.robots.checks`. A file may define its own
servos (`servos:`, validated as the table's); the total mass is optional (`mass_tolerance_kg`)."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from app.assets import builtin_presets_dir
from app.robots.cad_source import CadSource
from app.robots.description_parts import (
    LEG_JOINTS,
    LINKS,
    Board,
    Contact,
    DescriptionModel,
    Geometry,
    Joint,
    LegJoint,
    LinkName,
    Name,
    Part,
    Real,
    ServoMount,
)
from app.robots.fitted import Fitted
from app.robots.gait_reach import check_knee_reach, check_reach, preset_gait
from app.robots.servos import ServoName, ServoSpec, rating_at, servo_table
from gait import JOINT_NAMES, GaitParams
from hardware import CHANNELS
from hardware.timer import SLOTS_USED

#: a stated total_mass_kg is a kitchen scale's reading; the parts are datasheet and estimated
#: masses: they agree within 2 % of the parts or 5 g, whichever is larger (docs/DESIGN.md §7)
MASS_TOLERANCE_FRACTION = 0.02
MASS_TOLERANCE_MIN_KG = 0.005
MAX_MASS_KG = 20.0  # stated or the parts' sum: a small servo-driven biped


class RobotDescription(DescriptionModel):
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
        gaits = self.walked_gaits()
        check_knee_reach(self.joints, self.geometry, min(gait.leg.eta_min for _, gait in gaits))
        check_reach(self.joints, self.geometry, gaits)
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
