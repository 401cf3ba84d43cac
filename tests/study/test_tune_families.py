"""`artro tune --robust`'s per-family term and eq (1)'s torque penalty (decision 0062), on
hand-made run metrics: no simulation."""

from __future__ import annotations

import pytest

from app.analysis.robust_cases import ROBUST_CASES, pass_margin_loss
from app.cli import main
from app.study.tune_families import (
    FAMILIES,
    asked_share,
    families_term,
    family_scores,
    torque_penalty,
)
from app.study.tune_loss import LossWeights

STALL = [1.0] * 12


def run(case, along: float, forward: float = 0.0, turn: float = 0.0) -> dict:
    """A run of `case` moving `along` its way (cm/s, or deg/s turning)."""
    m = {"fell": False, "forward_cm_s": forward, "lateral_cm_s": 0.0, "turn_deg_s": turn}
    if case.kind == "forward":
        m["forward_cm_s"] = along * case.way
    elif case.kind == "lateral":
        m["lateral_cm_s"] = along * case.way
    elif case.kind in ("turn", "curve"):
        m["turn_deg_s"] = along * case.way
    return m


def nominal() -> dict[str, dict]:
    return {c.name: run(c, 4.0, forward=3.0 if c.kind == "curve" else 0.0) for c in ROBUST_CASES}


def worlds(alongs: dict[str, float], n: int = 4) -> list[list[dict]]:
    """n worlds in which each family's cases move `alongs[family]` (default 4: as nominal)."""
    return [
        [
            run(c, alongs.get(FAMILIES[c.kind], 4.0), forward=3.0 if c.kind == "curve" else 0.0)
            for c in ROBUST_CASES
        ]
        for _ in range(n)
    ]


def term(alongs: dict[str, float]) -> tuple[float, dict, float]:
    names = [c.name for c in ROBUST_CASES]
    home, ws = nominal(), worlds(alongs)
    families = family_scores(ROBUST_CASES, names, ws, home)
    summed = sum(
        pass_margin_loss(c, m, home[c.name])
        for w in ws
        for c, m in zip(ROBUST_CASES, w, strict=True)
    )  # the old term's kind: every case summed, one family's gain paying for another's loss
    return families_term(families), families, summed


def test_the_families_are_the_robust_cases_kinds():
    names = [c.name for c in ROBUST_CASES]
    families = family_scores(ROBUST_CASES, names, worlds({}), nominal())
    assert list(families) == ["spot", "forward/backward", "sideways", "turning", "curves"]
    assert all(f["share"] == 1.0 and f["objective"] == 0.0 for f in families.values())
    assert families["sideways"]["runs"] == 2 * 4  # left and right in 4 worlds


def test_a_gain_forward_does_not_hide_a_loss_sideways():
    """One holds forward and sideways at 2.1 cm/s (passing: the line is half the nominal 4,
    a little short of the margin line 2.4); the other walks forward at the full 4 but sideways
    1.98, just failing. Its pass margins summed over the cases score better; per family, worse."""
    holds, holding, holds_sum = term({"forward/backward": 2.1, "sideways": 2.1})
    trades, trading, trades_sum = term({"forward/backward": 4.0, "sideways": 1.98})
    assert trading["forward/backward"]["objective"] < holding["forward/backward"]["objective"]
    assert trading["sideways"]["share"] < holding["sideways"]["share"]
    assert trades_sum < holds_sum  # a sum over the cases would have preferred the trade
    assert trades > holds


def test_a_family_that_improves_without_being_the_worst_still_lowers_the_term():
    worse, _, _ = term({"sideways": 1.0, "turning": 2.2})
    better, _, _ = term({"sideways": 1.0, "turning": 4.0})
    assert better < worse


def test_the_torque_term_orders_candidates_by_the_torque_they_ask():
    """Eq (1): a servo should give 1.2 x what it is asked; asking 0.8 of stall is within it."""
    calm = [{"fell": False, "peak_torque_nm": [0.8] * 12, "at_limit_share": [0.0] * 12}]
    assert asked_share(calm[0], STALL)[0] == pytest.approx(0.96)
    assert torque_penalty(calm, STALL) == 0.0
    hard = [{"fell": False, "peak_torque_nm": [0.8] * 11 + [0.9], "at_limit_share": [0.0] * 12}]
    harder = [{"fell": False, "peak_torque_nm": [0.8] * 11 + [0.95], "at_limit_share": [0.1] * 12}]
    assert 0 < torque_penalty(hard, STALL) < torque_penalty(harder, STALL)
    fell = [{"fell": True, "peak_torque_nm": [0.1] * 12, "at_limit_share": [0.0] * 12}]
    assert torque_penalty(fell, STALL) == pytest.approx(2.0)  # the most a run costs
    assert LossWeights().torque > 0 and "torque_weight" not in LossWeights().settings()
    assert LossWeights(torque=1.0).settings() == {"torque_weight": 1.0}


def test_the_tune_options_say_their_defaults(capsys):
    with pytest.raises(SystemExit):
        main(["tune", "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert "decision 0062)" in shown and "(default 0.5;" in shown
    assert "margins (default 0: none)" in shown and "weight of that term (default 1.0)" in shown
    with pytest.raises(SystemExit) as bad:
        main(["tune", "--torque-weight", "-1"])
    assert bad.value.code == 2
    said = capsys.readouterr().err
    assert "--torque-weight" in said
