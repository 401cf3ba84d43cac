"""`artro tune --robust`'s term per case family (decision 0062): each family's varied runs scored
apart (pass share and pass margin), the worst family setting the term so that a gain forward
cannot hide a loss sideways; and eq (1)'s margin of the torque the runs asked (`torque_penalty`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from app.analysis.robust_cases import RobustCase, pass_margin_loss, passes
from app.robots.checks import SAFETY_FACTOR

#: ROBUST_CASES's kinds as the families a tune is judged on, in the order they are said
FAMILIES = {
    "spot": "spot",
    "forward": "forward/backward",
    "lateral": "sideways",
    "turn": "turning",
    "curve": "curves",
}
#: the term is the worst family's objective plus this share of the families' mean: the mean
#: lets the search see a family improve that is not the worst, small enough that a loss in the
#: worst family is not bought back by a gain in another (5 families, each objective <= 4: a gain
#: in one moves the mean term by at most 0.03 x 4 / 5 = 0.024)
MEAN_SHARE = 0.03


def family_of(case: RobustCase) -> str:
    return FAMILIES[case.kind]


def cvar25(values: Sequence[float]) -> float:
    """The mean of the worst quarter (at least one) of `values`."""
    tail = sorted(values)[-max(1, math.ceil(len(values) / 4)) :]
    return float(np.mean(tail))


def family_scores(
    cases: Sequence[RobustCase],
    names: Sequence[str],
    worlds: Sequence[Sequence[dict[str, Any]]],
    home: dict[str, dict[str, Any]],
) -> dict[str, dict[str, Any]]:
    """Per family (of the families `cases` cover): "passed" of "runs" varied runs, "share",
    "margin" (the worst quarter of worlds of the mean pass-margin loss of the family's cases in
    a world, `pass_margin_loss`) and "objective" = (1 - share) + margin. `worlds[w][k]` is run
    k of world w, walking `cases[k]`, whose nominal run is `home[names[k]]`."""
    out: dict[str, dict[str, Any]] = {}
    for family in dict.fromkeys(family_of(c) for c in cases):
        ks = [k for k, c in enumerate(cases) if family_of(c) == family]
        per_world = [
            float(np.mean([pass_margin_loss(cases[k], world[k], home[names[k]]) for k in ks]))
            for world in worlds
        ]
        passed = sum(passes(cases[k], world[k], home[names[k]]) for world in worlds for k in ks)
        runs = len(ks) * len(worlds)
        share = passed / runs if runs else 0.0
        margin = cvar25(per_world) if per_world else 0.0
        out[family] = {
            "passed": passed,
            "runs": runs,
            "share": share,
            "margin": margin,
            "objective": (1.0 - share) + margin,
        }
    return out


def world_losses(
    cases: Sequence[RobustCase],
    names: Sequence[str],
    worlds: Sequence[Sequence[dict[str, Any]]],
    home: dict[str, dict[str, Any]],
) -> list[float]:
    """Each world's pass-margin losses summed over its runs (as `family_scores` takes them):
    the store's "losses", and before decision 0062 the robust term's worst quarter."""
    return [
        sum(pass_margin_loss(c, m, home[n]) for c, n, m in zip(cases, names, world, strict=True))
        for world in worlds
    ]


def families_term(families: dict[str, dict[str, Any]]) -> float:
    """The robust term: the worst family's objective plus MEAN_SHARE of their mean (0 for none)."""
    objectives = [f["objective"] for f in families.values()]
    if not objectives:
        return 0.0
    return max(objectives) + MEAN_SHARE * float(np.mean(objectives))


def kept_shortfall(families: dict[str, dict[str, Any]], base: dict[str, dict[str, Any]]) -> float:
    """How far a candidate's pass share falls below the base set's, summed over the families
    (the base walked in the same worlds; `Tuner(keep_base=W)`, decision 0070): 0 where every
    family passes at least as often. The worst family alone lets a gain there buy a loss in
    another family; this term does not."""
    return sum(
        max(0.0, base[f]["share"] - fam["share"]) for f, fam in families.items() if f in base
    )


def asked_share(metrics: dict[str, Any], stall_nm: Sequence[float]) -> list[float]:
    """Eq (1) on a run, per servo: (1 + sf) x its peak torque over its stall torque; above 1 the
    servo lacks eq (1)'s margin (margin = 1 - this). A fall counts as asking the limit (1 + sf)."""
    if metrics.get("fell", True) or "peak_torque_nm" not in metrics:
        return [1.0 + SAFETY_FACTOR] * len(stall_nm)
    return [
        (1.0 + SAFETY_FACTOR) * peak / stall if stall > 0 else 0.0
        for peak, stall in zip(metrics["peak_torque_nm"], stall_nm, strict=True)
    ]


def torque_penalty(runs: Sequence[dict[str, Any]], stall_nm: Sequence[float]) -> float:
    """How far the runs' servos are from eq (1)'s margin, per run the worst servo's shortfall
    (max(0, asked - 1) / sf, 0 to 1) plus its largest share of frames at the torque limit,
    averaged over the runs (0: every servo carries what the gait asks with the margin)."""
    if not runs:
        return 0.0
    per_run = []
    for m in runs:
        over = max(max(0.0, a - 1.0) for a in asked_share(m, stall_nm)) / SAFETY_FACTOR
        limit = max(m.get("at_limit_share") or [0.0]) if not m.get("fell", True) else 1.0
        per_run.append(min(1.0, over) + limit)
    return float(np.mean(per_run))


def describe_families(families: dict[str, dict[str, Any]]) -> str:
    """ "forward/backward 12/12 (100 %), sideways 3/12 (25 %), ..." """
    return ", ".join(
        f"{name} {f['passed']}/{f['runs']} ({f['share']:.0%})" for name, f in families.items()
    )
