"""The effective axle b_eff of the current gait, fitted from simulated curve walks (seed 004 eq 13).

A biped steers by skidding its feet, so the axle that makes eq (13) fit is usually longer than the
feet distance b; the predicted path can use b_eff (docs/DESIGN.md §4).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from app.analysis.ca_analysis import fit_axle
from app.evaluation import BatchEvaluator, Evaluator, Job
from gait import GaitParams, Motion

FIT_CA = (-0.1, 0.0, 0.1)
NOT_APPLIED = "CA does not steer this gait the way eq (13) says (b_eff <= 0)"
DEFAULT_A_P = 0.07  # seed 000's forward amplitude, used when the robot is not walking
MIN_A_P = 0.02  # below this the sagittal step is too short to steer with
DURATION_S = 20.0
WARMUP_S = 4.0


@dataclass(frozen=True)
class AxleFitResult:
    """What `fit_effective_axle` found: lengths in m, speed in m/s, heading rates in deg/s (CCW)."""

    axle_eff_m: float | None  # None when CA does not steer at all
    feet_m: float  # measured mean distance between the feet (eq 13's b)
    speed_m_s: float  # V: forward speed at CA = 0
    drift_deg_s: float  # heading rate at CA = 0 (fit)
    gain: float | None  # b / b_eff: the share of eq (13)'s rate the robot turns
    a_p: float
    ca: tuple[float, ...]
    turn_deg_s: tuple[float, ...]
    sim_s: float

    @property
    def applies(self) -> bool:
        """A prediction can use it: CA turns the robot the way eq (13) says (b_eff > 0)."""
        return self.axle_eff_m is not None and self.axle_eff_m > 0

    def to_dict(self) -> dict:
        """The fields as a JSON-ready dict, plus `applied` and, when not, the `reason`."""
        return dataclasses.asdict(self) | {
            "applied": self.applies,
            "reason": None if self.applies else NOT_APPLIED,
        }


class AxleFitError(RuntimeError):
    """The fit has no answer: the robot fell or did not walk."""


def walking_amplitude(motion: Motion) -> float:
    """The a_p to fit at: the current one if the robot walks sagittally, else forward 0.07."""
    return motion.a_p if abs(motion.a_p) >= MIN_A_P else DEFAULT_A_P


def fit_effective_axle(
    params: GaitParams,
    motion: Motion,
    evaluator: Evaluator | None = None,
    duration_s: float = DURATION_S,
    warmup_s: float = WARMUP_S,
) -> AxleFitResult:
    """Fit b_eff for `params` from walks at CA = -0.1, 0 and +0.1 (`FIT_CA`).

    The walks use the current sagittal amplitude, or forward a_p = 0.07 when the robot stands
    (`walking_amplitude`); they fit theta_dot = drift + k CA and give b_eff = -2 V / k
    (`app.analysis.ca_analysis.fit_axle`). Without an `evaluator` the runs go to a batch
    evaluator with one thread, so a live simulation keeps the other core.

    Args:
        params, motion: the gait and motion vector to fit (the motion's CA is replaced).
        duration_s, warmup_s: simulated length of each walk and the part not measured, in s.

    Raises:
        AxleFitError: the robot fell in a walk, or does not walk at CA = 0 (|V| < 1 mm/s).
    """
    a_p = walking_amplitude(motion)
    base = dataclasses.replace(motion, a_p=a_p)
    jobs = [Job(params, dataclasses.replace(base, ca=ca)) for ca in FIT_CA]
    evaluator = evaluator or BatchEvaluator(threads=1)
    results = evaluator.evaluate(jobs, duration_s=duration_s, warmup_s=warmup_s)
    if any(r["fell"] for r in results):
        fell = [ca for ca, r in zip(FIT_CA, results, strict=True) if r["fell"]]
        raise AxleFitError(f"the robot fell walking at a_p = {a_p:+.3f} with CA = {fell}")
    straight = results[FIT_CA.index(0.0)]
    speed = _figure(straight, "forward_cm_s") / 100.0
    if abs(speed) < 1e-3:
        raise AxleFitError(f"the robot does not walk at a_p = {a_p:+.3f} ({speed * 100:.2f} cm/s)")
    turns = [math.radians(_figure(r, "turn_deg_s")) for r in results]
    fit = fit_axle(FIT_CA, turns, speed)
    feet = _figure(straight, "feet_distance_cm") / 100.0
    gain = None if fit.axle_eff_m is None else feet / fit.axle_eff_m
    return AxleFitResult(
        axle_eff_m=fit.axle_eff_m,
        feet_m=feet,
        speed_m_s=speed,
        drift_deg_s=math.degrees(fit.drift_rad_s),
        gain=gain,
        a_p=a_p,
        ca=FIT_CA,
        turn_deg_s=tuple(_figure(r, "turn_deg_s") for r in results),
        sim_s=duration_s * len(jobs),
    )


def _figure(metrics: Mapping[str, Any], key: str) -> float:
    """The run's figure `key`; AxleFitError if the run was too short to measure it."""
    value = metrics[key]
    if value is None:
        raise AxleFitError(f"the walk was too short to measure {key}: give a longer duration")
    return value
