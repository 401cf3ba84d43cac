"""The shipped `robust` preset (docs/DESIGN.md §15): `tuned` with the yaw-rate loop, ankle-pitch
gyro damping and a pitch trim on (mostly proportional, toward an upright trunk: the integral-only
trim swung the trunk's pitch into falls on soft servos, decision 0054), its stance leaned
0.03 rad forward (the balance offset of eq (38)) and its clock 2.5 % faster, read-only like
every built-in. On the nominal model it walks the paper's table within 25 % without a fall, CA
steering the right way, and its yaw-rate loop makes CA turn as eq (13) says within 30 %, forward
and backward: what no open-loop gait on this model reached (models/README.md). Leaning forward
costs the tuner's mirror rule: backward walks ~20 % faster than forward (decision 0052)."""

import dataclasses

import pytest

from app.analysis.cases import (
    CASES,
    CURVES,
    JUDGED_RUNS,
    curve_run_names,
    measured,
    passes,
    steering,
    steers_right,
)
from app.evaluation import BatchEvaluator, Job
from app.params.presets import PresetError, PresetStore, builtin_presets

ROBUST = builtin_presets()["robust"]
TUNED = builtin_presets()["tuned"]


def test_the_robust_preset_is_tuned_with_the_laws_on_and_read_only(tmp_path):
    gait = ROBUST.gait
    assert gait.yaw_rate.enabled and gait.damping.enabled
    # proportional, a slow integral, upright expected: integral-only swung into falls (0040)
    assert gait.tilt.enabled and gait.tilt.kp > gait.tilt.ki_per_s
    assert (gait.tilt.pitch_offset_rad, gait.tilt.pitch_per_a_p) == (0.0, 0.0)
    # pitch only: the hips' roll trim cost the servo swap sideways (94 -> 83 %, decision 0054)
    assert gait.tilt.roll_share == 0.0
    assert not gait.cop.enabled  # measured: it lost robustness (models/README.md)
    for group in ("shift", "short", "swing", "load", "leg", "steer"):
        assert getattr(gait, group) == getattr(TUNED.gait, group), group
    assert gait.clock.freq_hz == pytest.approx(1.025 * TUNED.gait.clock.freq_hz, rel=1e-3)
    lean = gait.balance.foot_pitch_offset - TUNED.gait.balance.foot_pitch_offset
    assert lean == pytest.approx(0.03, abs=1e-6)  # leaned forward, the rest of eq (38) as tuned
    assert dataclasses.replace(gait.balance, foot_pitch_offset=0.0) == dataclasses.replace(
        TUNED.gait.balance, foot_pitch_offset=0.0
    )
    with pytest.raises(PresetError, match="read-only"):
        PresetStore(tmp_path, builtin_presets()).save("robust", TUNED)


@pytest.mark.slow
def test_the_robust_preset_walks_the_paper_and_steers_as_eq_13_says():
    jobs = [Job(ROBUST.gait, motion) for _name, motion in JUDGED_RUNS]
    metrics = BatchEvaluator(threads=2).evaluate(jobs, duration_s=60.0, warmup_s=5.0)
    by_run = {name: m for (name, _motion), m in zip(JUDGED_RUNS, metrics, strict=True)}
    report = {c.name: measured(c, by_run[c.name]) for c in CASES}
    assert not any(m["fell"] for m in metrics), report
    for case in CASES:  # the paper's table within 25 % (the mirror rule is the tuner's)
        assert passes(case, report[case.name], False), (case.name, report)
    for pair in CURVES:
        s = steering(*(by_run[n] for n in curve_run_names(pair)), by_run[pair.straight])
        assert steers_right(s), pair.name
        assert abs(s.gain - 1.0) <= 0.3, (pair.name, s.gain)  # eq (13) within 30 %
