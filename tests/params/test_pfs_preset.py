"""The built-in `pfs` preset (seed 004's oscillator gait, found by `artro tune --cases
forward,backward`) walks forward and backward on the unchanged model without falling, and its
CA steers within 30 % of eq (13) at the paper's speed through the yaw-rate law (decision 0069)."""

from __future__ import annotations

from app.analysis.cases import CA_PROBE, steering, within_eq13
from app.evaluation import BatchEvaluator, Job
from app.params.formats import load_parameter_set
from app.params.presets import BUILTIN_DIR
from gait import Motion
from gait.params import merge, parse_settings


def test_the_pfs_preset_walks_forward_and_backward():
    pset = load_parameter_set(BUILTIN_DIR / "pfs.json")
    assert pset.gait.engine == "pfs"
    forward, backward = BatchEvaluator().evaluate(
        [Job(pset.gait, Motion(a_p=0.07)), Job(pset.gait, Motion(a_p=-0.07))], duration_s=60.0
    )
    assert not forward["fell"] and not backward["fell"]
    assert forward["forward_cm_s"] > 2.0 and backward["forward_cm_s"] < -2.0  # paper: +-3.8


def test_the_pfs_preset_steers_by_eq13_at_the_papers_speed():
    gait = load_parameter_set(BUILTIN_DIR / "pfs.json").gait
    motions = [Motion(a_p=0.07, ca=CA_PROBE), Motion(a_p=0.07, ca=-CA_PROBE), Motion(a_p=0.07)]
    plus, minus, straight = BatchEvaluator().evaluate(
        [Job(gait, m) for m in motions], duration_s=30.0, warmup_s=5.0
    )
    s = steering(plus, minus, straight)
    assert within_eq13(s), s  # without the law its gain was ~0.14 (decision 0061)
    off = BatchEvaluator().evaluate(
        [Job(merge(gait, parse_settings(["yaw_rate.enabled=false"])), m) for m in motions],
        duration_s=30.0,
        warmup_s=5.0,
    )
    assert not within_eq13(steering(*off))
