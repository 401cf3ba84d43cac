"""The shipped `tuned` preset still walks like the paper: every criterion of the issue, judged
exactly as `artro tune --select passing` chose it (60 s runs, 5 s warm-up, on this model)."""

import pytest

from app.analysis.cases import CASES, CURVES, JUDGED_RUNS, curve_run_names, measured, steering
from app.evaluation import BatchEvaluator, Job
from app.params.formats import load_parameter_set
from app.params.presets import BUILTIN_DIR
from app.study.tune_loss import meets_all_criteria


@pytest.mark.slow
def test_the_tuned_preset_meets_every_criterion():
    tuned = load_parameter_set(BUILTIN_DIR / "tuned.json").gait
    jobs = [Job(tuned, motion) for _name, motion in JUDGED_RUNS]
    metrics = BatchEvaluator(threads=2).evaluate(jobs, duration_s=60.0, warmup_s=5.0)
    by_run = {name: m for (name, _motion), m in zip(JUDGED_RUNS, metrics, strict=True)}
    report = {c.name: measured(c, by_run[c.name]) for c in CASES} | {
        p.name: steering(*(by_run[n] for n in curve_run_names(p)), by_run[p.straight])
        for p in CURVES
    }
    assert not any(m["fell"] for m in metrics), report
    assert meets_all_criteria(by_run), report
