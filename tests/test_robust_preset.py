"""The shipped `robust` preset (docs/DESIGN.md §15): `tuned` with the tilt trim, the yaw-rate loop
and ankle-pitch gyro damping on, read-only like every built-in. On the nominal model it meets
every criterion `tuned` meets (the paper's table within 25 %, mirror pairs alike, CA steering the
right way), and its yaw-rate loop makes CA turn as eq (13) says within 30 %, forward and
backward: what no open-loop gait on this model reached (models/README.md)."""

import pytest

from app.analysis.cases import CASES, CURVES, JUDGED_RUNS, curve_run_names, measured, steering
from app.evaluation import BatchEvaluator, Job
from app.params.presets import PresetError, PresetStore, builtin_presets
from app.study.tune_loss import meets_all_criteria

ROBUST = builtin_presets()["robust"]
TUNED = builtin_presets()["tuned"]


def test_the_robust_preset_is_tuned_with_the_laws_on_and_read_only(tmp_path):
    gait = ROBUST.gait
    assert gait.tilt.enabled and gait.yaw_rate.enabled and gait.damping.enabled
    assert not gait.cop.enabled  # measured: it lost robustness (models/README.md)
    for group in ("clock", "shift", "short", "swing", "load", "balance", "leg", "steer"):
        assert getattr(gait, group) == getattr(TUNED.gait, group), group
    with pytest.raises(PresetError, match="read-only"):
        PresetStore(tmp_path, builtin_presets()).save("robust", TUNED)


@pytest.mark.slow
def test_the_robust_preset_walks_the_paper_and_steers_as_eq_13_says():
    jobs = [Job(ROBUST.gait, motion) for _name, motion in JUDGED_RUNS]
    metrics = BatchEvaluator(threads=2).evaluate(jobs, duration_s=60.0, warmup_s=5.0)
    by_run = {name: m for (name, _motion), m in zip(JUDGED_RUNS, metrics, strict=True)}
    report = {c.name: measured(c, by_run[c.name]) for c in CASES}
    assert not any(m["fell"] for m in metrics), report
    assert meets_all_criteria(by_run), report
    for pair in CURVES:
        gain = steering(*(by_run[n] for n in curve_run_names(pair)), by_run[pair.straight]).gain
        assert abs(gain - 1.0) <= 0.3, (pair.name, gain)  # eq (13) within 30 %
