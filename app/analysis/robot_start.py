"""A starting gait for any robot of ArtRo's structure and the recipe that tunes it to walk
(docs/DESIGN.md §12; issue 32 item 4): the nearest preset (`nearest_preset`), the scaling rule
(`scaled_gait`), the recipe (`START_RECIPE`). Shared by `artro tune` and the dashboard's "Tune
for this robot" job (`app/server/jobs/tune_job.py`, which runs the command: `app.server` may not
import `app.study`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from app.robots.description import RobotDescription
from app.robots.library import builtin_robot_names, load_description
from gait import GaitParams
from gait.params import describe_fields, group_class, merge


@dataclass(frozen=True)
class StartRecipe:
    """What `artro tune` runs when it is given no base: the options' values (docs/DESIGN.md §12).

    `START_RECIPE`: CMA-ES over the eight fields that set the timing, the lateral weight shift,
    the step height and the sideways lean (the fields the `micro-tuned` tune chose, decision
    0015), 10 generations of 8 candidates, each walking the paper's seven cases and the CA =
    ±0.1 pairs (11 runs of 20 s, 4 s warm-up: 17,600 simulated s), from a step of 6 % of each
    range, with the band penalty of 20; kept: the lowest loss of the candidates that walk every
    run without a fall (`walks`), else the lowest loss.
    """

    names: tuple[str, ...]  # the tuned fields, GROUP.FIELD
    generations: int
    popsize: int
    sigma: float  # initial step, share of each field's range
    duration_s: float  # simulated s per run
    warmup_s: float  # not measured
    band_weight: float
    select: str  # "walking": the lowest loss of the candidates that never fell

    def simulated_s(self, runs: int) -> float:
        """Simulated seconds the whole search costs for `runs` runs per candidate."""
        return self.generations * self.popsize * runs * self.duration_s


START_RECIPE = StartRecipe(
    names=(
        "clock.freq_hz",
        "shift.amp_base",
        "shift.amp_lateral",
        "short.amp_base",
        "short.amp_speed",
        "short.foot_lift",
        "swing.o",
        "balance.leg_roll_offset",
    ),
    generations=10,
    popsize=8,
    sigma=0.06,
    duration_s=20.0,
    warmup_s=4.0,
    band_weight=20.0,
    select="walking",
)


def leg_length_m(robot: RobotDescription) -> float:
    """L = L_UL + L_LL, the leg at η = 1 (eq (3))."""
    return robot.geometry.thigh_m + robot.geometry.shank_m


def reference_legs() -> dict[str, float]:
    """Each built-in robot's preset -> that robot's leg length in m, the default robot first."""
    out: dict[str, float] = {}
    for name in builtin_robot_names():
        robot = load_description(name)
        out.setdefault(robot.default_preset, leg_length_m(robot))
    return out


def nearest_preset(leg_m: float, references: Mapping[str, float]) -> str:
    """The preset whose robot's leg is nearest `leg_m` in ratio (smallest |ln(L / L_ref)|;
    the first of equals). With the built-in robots' legs L = L_UL + L_LL (eq (3)): ArtRo's
    0.18 m (`robust-3`) or micro's 0.09 m (`micro-robust`), the crossover at their geometric mean,
    0.127 m."""
    if not references or not math.isfinite(leg_m) or leg_m <= 0:
        raise ValueError(f"a leg length > 0 and references are needed, got {leg_m}")
    return min(references, key=lambda name: abs(math.log(leg_m / references[name])))


def _scaled_field(group: str, field: str, value: float, ratio: float) -> float:
    """`value` × `ratio`, within the field's range, to 6 digits."""
    meta = next(m for f, _d, m in describe_fields(group_class(group)) if f == field)
    return round(min(max(value * ratio, meta["min"]), meta["max"]), 6)


def scaled_freq_hz(freq_ref_hz: float, leg_ref_m: float, leg_m: float) -> float:
    """The clock for a leg of `leg_m`: f_ref × √(L_ref / L) (a pendulum), within the schema."""
    return _scaled_field("clock", "freq_hz", freq_ref_hz, math.sqrt(leg_ref_m / leg_m))


def scaled_gait(gait: GaitParams, leg_ref_m: float, leg_m: float) -> GaitParams:
    """`gait` (tuned for a leg of `leg_ref_m`) for a leg of `leg_m`.

    The gait's own fields are angles (rad), shares of the leg length (eq (3)'s η, the
    shortening amplitudes) or plain ratios, none a length: a gait of the same values on a leg s
    times as long is geometrically similar, so they are kept. The clock is a pendulum's, f =
    f_ref × √(L_ref / L) (Froude similarity, f ∝ √(g/L)), within the schema's range. Speeds
    then scale with L (the targets, DESIGN §7), turn rates do not; so the yaw-rate loop's two
    lengths do too, each within its range: its axle b (m) and its speed per unit a_p (m/s),
    with which it turns CA into eq (13)'s rate -2 CA V / b (the same rate, as the targets').
    """
    ratio = leg_m / leg_ref_m
    yaw = gait.yaw_rate
    return merge(
        gait,
        {
            "clock": {"freq_hz": scaled_freq_hz(gait.clock.freq_hz, leg_ref_m, leg_m)},
            "yaw_rate": {
                "axle_m": _scaled_field("yaw_rate", "axle_m", yaw.axle_m, ratio),
                "speed_per_a_p": _scaled_field(
                    "yaw_rate", "speed_per_a_p", yaw.speed_per_a_p, ratio
                ),
            },
        },
    )


@dataclass(frozen=True)
class Start:
    """Where a robot's tune starts: the preset it comes from and that preset's gait scaled."""

    preset: str
    leg_ref_m: float
    leg_m: float
    gait: GaitParams

    def describe(self) -> str:
        ratio = self.leg_m / self.leg_ref_m
        return (
            f"starting from {self.preset!r} (legs {self.leg_ref_m:.3f} m) scaled to legs "
            f"{self.leg_m:.3f} m ({ratio:.2f}x): clock {self.gait.clock.freq_hz:.3f} Hz "
            f"(x sqrt(L_ref/L) = {math.sqrt(1 / ratio):.3f}), the yaw-rate loop's axle and "
            f"speed x {ratio:.2f}, angles and leg shares kept"
        )


def start_for(robot: RobotDescription, presets: Mapping[str, Any]) -> Start:
    """The start for `robot`: `presets` maps a built-in preset's name to its parameter set (an
    object with `.gait`, e.g. `app.params.presets.builtin_presets()`)."""
    legs = {name: leg for name, leg in reference_legs().items() if name in presets}
    leg = leg_length_m(robot)
    name = nearest_preset(leg, legs)
    return Start(name, legs[name], leg, scaled_gait(presets[name].gait, legs[name], leg))


def start_set(robot: RobotDescription, pset: Any) -> Any:
    """The set `robot` starts in when it has none of its own (`pset`: its default preset, a
    `ParameterSet`): as it is where it was tuned for `robot` or for legs as long, else scaled to
    `robot`'s legs as a tune's start scales it (`scaled_gait`: the clock by √(L_ref/L), the
    yaw-rate loop's axle and speed by L/L_ref; the laws' angles and gains kept), from the legs of
    the built-in robot it was tuned for (issue 56: ArtRo's `robust` at ArtRo's clock felled
    legs of 0.11 + 0.10 m at 11 s on the spot, open loop at 7.5 s; scaled it stands). A set
    tuned for a robot not built in is kept as it is: its legs are not known here."""
    if pset.robot == robot.name or pset.robot not in builtin_robot_names():
        return pset
    leg_ref, leg = leg_length_m(load_description(pset.robot)), leg_length_m(robot)
    if math.isclose(leg, leg_ref, rel_tol=1e-9):
        return pset
    return dataclasses.replace(pset, gait=scaled_gait(pset.gait, leg_ref, leg))


def walks(by_run: Mapping[str, Mapping[str, Any]]) -> bool:
    """Every judged run walked its whole duration without a fall."""
    return bool(by_run) and not any(m.get("fell", True) for m in by_run.values())
