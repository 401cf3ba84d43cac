"""How a fit is judged (docs/FIT.md, decision 0067): converged only when each field's spread
left in its search is within its precision, the nominal kept otherwise; and the search's stages,
two rounds of standing then walking when the fields are of both kinds."""

from __future__ import annotations

import numpy as np
import pytest

from app.analysis.identify_replay import Traces
from app.study import fit_space
from app.study.fit import STAGES, stages
from app.study.fit_result import CONVERGED_SPREAD, _ends, judged
from app.worlds.variations import NOMINAL


def _traces(offset: float, at_limit_frames: int = 0) -> Traces:
    n = 40
    rows = np.arange(n, dtype=float)[:, None]
    effort = np.full((n, 12), 0.5)
    effort[:at_limit_frames, 3] = 1.0
    return Traces(
        commanded=np.zeros((n, 12)),
        gyro=np.sin(rows / 5) * np.ones((1, 3)) * 0.1 + offset,
        accel=np.tile([0.0, 0.0, 9.81], (n, 1)) + offset,
        fsr=np.ones((n, 8)) + offset,
        joints=np.zeros((n, 12)),
        pose=np.zeros((n, 3)),
        effort=effort,
    )


def _judge(spread: dict[str, float], at_limit_frames: int = 10):
    dims = [fit_space.PHYSICS[k] for k in ("latency_ms", "kp_scale", "torque_scale")]
    values = {"latency_ms": 20.0, "kp_scale": 0.9, "torque_scale": 0.85}
    recorded, nominal = _traces(0.0), _traces(0.05)
    fitted = _traces(0.001, at_limit_frames)
    return judged(dims, values, np.array([0.1, 0.001, 0.001]), np.eye(3), [nominal, fitted],
                  recorded, False, NOMINAL, 1.0, 0.1, 100, spread)  # fmt: skip


def test_a_search_settled_within_each_fields_precision_has_converged():
    result = _judge({"latency_ms": 4.9 * CONVERGED_SPREAD, "kp_scale": 0.01})
    assert result.converged, result.why_not
    assert result.variation.latency_ms == 20.0 and result.variation.kp_scale == 0.9
    assert result.identified == {"latency_ms": True, "kp_scale": True, "torque_scale": True}


def test_a_torque_the_routine_never_leans_on_is_not_told():
    """A servo at its torque limit in 0 of 40 frames: the torque scale is not told, whatever
    its σ; in 10 of 40 it is."""
    result = _judge({}, at_limit_frames=0)
    assert not result.identified["torque_scale"] and result.identified["kp_scale"]
    assert "torque limit in 0.0 %" in result.still["torque_scale"]
    assert "torque_scale" not in _judge({}, at_limit_frames=10).still


def test_a_search_still_wide_in_one_field_keeps_the_nominal_and_names_it():
    result = _judge({"latency_ms": 1.0, "kp_scale": 0.2})
    assert not result.converged
    assert "kp_scale" in result.why_not and "--budget" in result.why_not
    assert result.variation == NOMINAL


def test_both_kinds_of_field_take_two_rounds_one_kind_one_search():
    both = stages(True, True)
    assert both == list(STAGES)
    assert [s.standing for s in both] == [True, False, True, False]
    assert sum(s.share for s in both) == pytest.approx(1.0)
    assert stages(True, False)[0].standing and stages(True, False)[0].share == 1.0
    assert len(stages(False, True)) == 1 and stages(False, False) == []


def test_the_uncertaintys_differences_stay_inside_each_fields_bounds():
    """A latency fitted at 0.5 ms: its difference is taken at 0 and 3.5 ms (a variation refuses
    a negative latency: a fit of a robot with little latency once failed there)."""
    latency = fit_space.PHYSICS["latency_ms"]
    assert _ends(latency, 0.5) == (3.5, 0.0)
    assert _ends(latency, 20.0) == (23.0, 17.0)
    assert _ends(latency, 80.0) == (80.0, 77.0)
