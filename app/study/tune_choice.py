"""Which candidate of a tune to choose and how to say it (`artro tune --select`): the lowest loss
of those that walk every judged run, of those that meet every paper criterion, or the one CA
steers most; with --robust, its varied runs per case family."""

from __future__ import annotations

import math
from typing import Any

from app.analysis.cases import CURVES, curve_run_names, steering
from app.analysis.robot_start import walks
from app.study.tune import Tuner
from app.study.tune_families import describe_families
from app.study.tune_loss import meets_all_criteria
from gait import GaitParams


def varied_summary(tuner: Tuner, chosen: tuple[float, GaitParams, dict[str, Any]]) -> str | None:
    """With --robust: "passes P of N varied runs (S %) in W worlds" for a candidate of
    `evaluated` (None without --robust)."""
    robust = tuner.robust_of.get(id(chosen[2]))
    if robust is None:
        return None
    passed, runs = robust["passed"], robust["runs"]
    share = passed / runs if runs else 0.0
    return (
        f"passes {passed} of {runs} varied runs ({share:.0%}) in {len(robust['losses'])} "
        f"worlds of its generation (`artro bench robust` measures it on more); per family "
        f"{describe_families(robust.get('families', {}))}; eq (1) torque penalty "
        f"{robust.get('torque', 0.0):.3f}"
    )


def families_of(
    tuner: Tuner, chosen: tuple[float, GaitParams, dict[str, Any]]
) -> dict[str, dict[str, float]] | None:
    """With --robust: each family's "passed", "runs" and "share" for a candidate of
    `evaluated` (`app.study.tune_families.family_scores`; None without --robust)."""
    robust = tuner.robust_of.get(id(chosen[2]))
    if robust is None or "families" not in robust:
        return None
    keys = ("passed", "runs", "share")
    return {name: {k: f[k] for k in keys} for name, f in robust["families"].items()}


def best_walking(tuner: Tuner) -> tuple[float, GaitParams, dict[str, dict[str, Any]]] | None:
    """The lowest loss of the candidates that walked every judged run without a fall
    (`app.analysis.robot_start.walks`), or None if none did."""
    walking = [e for e in tuner.evaluated if walks(e[2])]
    return min(walking, key=lambda e: e[0]) if walking else None


def best_passing(
    tuner: Tuner, by: str = "loss"
) -> tuple[float, GaitParams, dict[str, dict[str, Any]]] | None:
    """Of the candidates that meet every paper criterion (if any did): the lowest loss
    (by="loss"), or the one CA steers most, forward (by="steering": the highest gain)."""
    scale = tuner.weights.speed_scale
    passing = [e for e in tuner.evaluated if meets_all_criteria(e[2], scale)]
    if not passing:
        return None
    if by == "steering":
        pair = next(p for p in CURVES if p.required)

        def gain(entry: tuple[float, GaitParams, dict[str, dict[str, Any]]]) -> float:
            plus, minus = (entry[2][name] for name in curve_run_names(pair))
            s = steering(plus, minus, entry[2][pair.straight])
            return -math.inf if s is None else s.gain

        return max(passing, key=gain)
    return min(passing, key=lambda e: e[0])
