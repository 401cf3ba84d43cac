"""The loss `artro tune` minimises and the criteria a tuned set must meet (docs/DESIGN.md
§12): each paper case's speed against its target, CA steering against eq (13), falls, cross-talk
and a calm trunk; `meets_all_criteria` is the pass/fail of `--select passing`."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.analysis.cases import (
    CASES,
    CURVES,
    MIRROR_TOLERANCE,
    SPOT_DRIFT_LIMIT_CM_S,
    CurvePair,
    PaperCase,
    curve_run_names,
    measured,
    passes,
    steering,
    steers_right,
    target,
)

FALL_LOSS = 20.0  # a fall costs this much, plus as much again scaled by how early it came
GYRO_WEIGHT = 0.05
BAND_MARGIN = 0.2  # the band penalty starts at 20 % error, inside the 25 % tolerance
STEERING_WEIGHT = {True: 1.0, False: 0.5}  # the required (forward) pair, the backward one
BEND_WEIGHT = 4.0  # tipping into a turn either way is not steering


@dataclass(frozen=True)
class LossWeights:
    """The weights `artro tune` lets one change; a results file records those not at default."""

    band: float = 0.0  # > 0: a steep extra penalty per case for errors beyond BAND_MARGIN
    steering: float = 1.0  # scale of the CA steering terms (gain toward eq (13), bend)
    cross_talk: float = 0.2  # unwanted rotation while translating, translation while turning
    #: the robot's legs against ArtRo's: its speed targets are the paper's times this (1: ArtRo)
    speed_scale: float = 1.0
    #: with --robust, weight of `app.study.tune_families.torque_penalty` on the nominal runs (eq
    #: (1)'s margin): a run within the margin costs 0; one whose worst servo asks its stall torque
    #: with the margin and sits at its limit throughout costs 0.5 x 2 = 1, as much as a family
    #: losing every pass (decision 0062)
    torque: float = 0.5

    def settings(self) -> dict[str, float]:
        default = LossWeights()
        return {
            (f.name if f.name == "speed_scale" else f"{f.name}_weight"): getattr(self, f.name)
            for f in dataclasses.fields(self)
            if getattr(self, f.name) != getattr(default, f.name)
        }


def case_loss(
    case: PaperCase,
    metrics: dict[str, Any],
    duration_s: float,
    weights: LossWeights = LossWeights(),
) -> float:
    """One case's loss: the relative speed error squared, plus the cross-talk terms."""
    if metrics["fell"]:
        fall_time = metrics.get("fall_time_s", 0.0)
        return FALL_LOSS * (2.0 - fall_time / duration_s)
    value = measured(case, metrics)
    if value is None:
        return FALL_LOSS
    if case.metric == "drift_cm_s":
        loss = (value / (SPOT_DRIFT_LIMIT_CM_S * weights.speed_scale)) ** 2
        turn = metrics["turn_deg_s"] or 0.0
        return loss + weights.cross_talk * (turn / 5.0) ** 2
    goal = target(case, weights.speed_scale)
    error = (value - goal) / goal
    loss = error**2 + weights.band * max(0.0, abs(error) - BAND_MARGIN) ** 2
    if case.metric == "turn_deg_s":
        drift = math.hypot(metrics["forward_cm_s"], metrics["lateral_cm_s"])
        loss += weights.cross_talk * (drift / 1.0) ** 2
    else:
        loss += weights.cross_talk * ((metrics["turn_deg_s"] or 0.0) / 5.0) ** 2
    return loss


def curve_loss(
    pair: CurvePair,
    plus: dict[str, Any],
    minus: dict[str, Any],
    straight: dict[str, Any],
    duration_s: float,
    weights: LossWeights = LossWeights(),
) -> float:
    """A fall as in `case_loss` (the straight walk is a case of its own); else the squared
    distance of the steering gain from 1 and the squared bend (`app.analysis.cases.Steering`)."""
    falls = [m for m in (plus, minus) if m["fell"]]
    if falls:
        return sum(FALL_LOSS * (2.0 - m.get("fall_time_s", 0.0) / duration_s) for m in falls)
    s = steering(plus, minus, straight)
    if s is None:
        return FALL_LOSS if not straight["fell"] else 0.0
    weight = weights.steering * STEERING_WEIGHT[pair.required]
    return weight * ((s.gain - 1.0) ** 2 + BEND_WEIGHT * s.bend**2)


def total_loss(
    by_run: dict[str, dict[str, Any]], duration_s: float, weights: LossWeights = LossWeights()
) -> float:
    """The loss of one parameter set from its runs' metrics, keyed by JUDGED_RUNS names.

    JUDGED_RUNS: on the spot, forward, sideways, turning, their mirror images, and curve walking at
    CA = +-0.1 forward and backward. The loss rewards each case's speed being the paper's (relative
    error squared), walking on the spot without drift, CA steering as eq (13) says (the gain of
    `steering` near 1), not falling (a fall costs more the earlier it happens), little unwanted
    rotation or translation, and a calm trunk (gyro RMS).
    """
    loss = sum(case_loss(c, by_run[c.name], duration_s, weights) for c in CASES if c.name in by_run)
    for pair in CURVES:
        if not is_judged(pair, by_run):
            continue
        plus, minus = (by_run[name] for name in curve_run_names(pair))
        loss += curve_loss(pair, plus, minus, by_run[pair.straight], duration_s, weights)
    gyro = [m["gyro_rms"] for m in by_run.values() if m.get("gyro_rms") is not None]
    return loss + GYRO_WEIGHT * (float(np.mean(gyro)) if gyro else 10.0)


def is_judged(pair: Any, by_run: dict[str, Any]) -> bool:
    """The curve pair was walked (a tuner limited to some cases walks only theirs)."""
    return pair.straight in by_run and all(n in by_run for n in curve_run_names(pair))


def meets_all_criteria(by_run: dict[str, dict[str, Any]], speed_scale: float = 1.0) -> bool:
    """No fall, every case within its tolerance, mirror pairs within 15 % of each other, and CA
    steering forward the way eq (13) says, in proportion (`steers_right`). How close the rate
    comes to eq (13)'s (the issue's 30 %) is reported, not required: no gait on this model has
    been found to reach it without tipping (models/README.md)."""
    values = {c.name: measured(c, by_run[c.name]) for c in CASES if c.name in by_run}
    for case in CASES:
        fell = by_run.get(case.name, {}).get("fell", True)
        if case.name in values and not passes(case, values[case.name], fell, speed_scale):
            return False
    for pair in CURVES:
        if not is_judged(pair, by_run):
            continue
        plus, minus = (by_run[name] for name in curve_run_names(pair))
        if pair.required and not steers_right(steering(plus, minus, by_run[pair.straight])):
            return False
    for case in CASES:
        if case.mirror_of and case.name in values and case.mirror_of in values:
            a, b = values[case.name], values[case.mirror_of]
            assert a is not None and b is not None  # the loop above returned on a missing one
            a, b = abs(a), abs(b)
            if abs(a - b) > MIRROR_TOLERANCE * 0.5 * (a + b):
                return False
    return True
