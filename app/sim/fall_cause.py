"""What felled a run on a varied world (`artro run --vary`, docs/DESIGN.md §7, §8): the same run
again without each part of the variation -- the push, the sensors' errors (read only with a law
on), the servos' departures, the body's masses, the floor -- and the parts without which it
walks the whole run. What the run shows, not what the servos are blamed for."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from app.robots.model import RobotModel
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams, Motion, feedback

#: the variation's parts, each of its fields
PARTS = {
    "push": ("push_n_s", "push_time_s", "push_direction_deg"),
    "sensor error": (
        "imu_tilt_bias_deg", "imu_tilt_direction_deg", "gyro_bias_deg_s", "gyro_noise_deg_s",
        "imu_delay_ms", "fsr_gain",
    ),
    "servos": (
        "kp_scale", "damping_scale", "torque_scale", "frictionloss_scale", "latency_ms",
        "deadband_deg", "backlash_deg", "calibration_deg",
    ),
    "masses": ("trunk_mass_scale", "link_mass_scale"),
    "floor": ("friction", "tilt_deg", "tilt_direction_deg"),
}  # fmt: skip


#: kp this many times the servo rule's: stiffer than a servo of the table holds
OVER_STIFF = 1.5


def without(v: Variation, part: str) -> Variation:
    """`v` with `part`'s fields at the nominal model's."""
    return dataclasses.replace(v, **{f: getattr(NOMINAL, f) for f in PARTS[part]})


def parts_of(v: Variation, laws_on: bool) -> list[str]:
    """The parts in which `v` departs from the nominal model and which can act on the run:
    the sensors' errors only with a law on (else nothing reads them), a push of no impulse
    never."""
    out = []
    for part, fields in PARTS.items():
        if part == "sensor error" and not laws_on:
            continue
        if part == "push" and v.push_n_s == 0:
            continue
        if any(getattr(v, f) != getattr(NOMINAL, f) for f in fields):
            out.append(part)
    return out


def described(v: Variation, part: str, fall_time_s: float) -> str:
    """`part` of `v` in words with its figures."""
    if part == "push":
        return (
            f"a push of {v.push_n_s:g} N·s at {v.push_time_s:g} s toward {v.push_direction_deg:g}° "
            f"(ccw from the world's x axis; the fall {fall_time_s - v.push_time_s:.2f} s later)"
        )
    fields = [
        f for f in PARTS[part] if getattr(v, f) != getattr(NOMINAL, f) and f != "calibration_deg"
    ]
    figures = [f"{f}={getattr(v, f):g}" for f in fields]
    if part == "servos" and v.calibration_deg != NOMINAL.calibration_deg:
        figures.append("calibration offsets")
    text = ", ".join(figures)
    if part == "sensor error":
        return f"the sensor error ({text})"
    if part == "servos":
        stiff = f"; an over-stiff servo, {v.kp_scale:g} x kp" if v.kp_scale > OVER_STIFF else ""
        return f"the servos' departures ({text}{stiff})"
    return f"the {part} ({text})"


@dataclass(frozen=True)
class FallCause:
    """The parts without which the run walks its whole length (each in words), whether the
    nominal model walks it (None: not run, a part alone explained it)."""

    parts: tuple[str, ...]
    names: tuple[str, ...]
    nominal_walks: bool | None

    def line(self) -> str:
        if self.parts:
            return (
                f"without {' or without '.join(self.parts)} the same run walks its whole "
                "length: that felled it"
            )
        if self.nominal_walks:
            return (
                "no one part of the variation alone felled it; the nominal model walks the "
                "whole run: the variation as a whole did"
            )
        return "the nominal model falls too: the robot and its gait, not the variation"


def fall_cause(
    params: GaitParams,
    motion: Motion,
    variation: Variation,
    fall_time_s: float,
    *,
    robot: RobotModel | None,
    duration_s: float,
    warmup_s: float,
    start_motion: Motion | None = None,
) -> FallCause | None:
    """Runs the same run without each part of `variation` that can act (`parts_of`), and the
    nominal model where no part alone explains the fall; None for the nominal model."""
    from app.sim.headless import run  # the runs: headless imports this module's caller

    parts = parts_of(variation, feedback.any_law_on(params))
    if variation.is_nominal or not parts:
        return None

    def walks(v: Variation) -> bool:
        result = run(params, motion, duration_s=duration_s, warmup_s=warmup_s,
                     start_motion=start_motion, robot=robot, variation=v)  # fmt: skip
        return not result.metrics["fell"]

    found = [p for p in parts if walks(without(variation, p))]
    if found:
        said = tuple(described(variation, p, fall_time_s) for p in found)
        return FallCause(said, tuple(found), None)
    if len(parts) == 1:  # without its one part it is the nominal model, which fell
        return FallCause((), (), False)
    return FallCause((), (), walks(NOMINAL))
