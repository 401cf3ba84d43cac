"""The built-in `pfs` preset (seed 004's oscillator gait, found by `artro tune --cases
forward,backward`) walks forward and backward on the unchanged model without falling."""

from __future__ import annotations

from app.evaluation import BatchEvaluator, Job
from app.params.formats import load_parameter_set
from app.params.presets import BUILTIN_DIR
from gait import Motion


def test_the_pfs_preset_walks_forward_and_backward():
    pset = load_parameter_set(BUILTIN_DIR / "pfs.json")
    assert pset.gait.engine == "pfs"
    forward, backward = BatchEvaluator().evaluate(
        [Job(pset.gait, Motion(a_p=0.07)), Job(pset.gait, Motion(a_p=-0.07))], duration_s=60.0
    )
    assert not forward["fell"] and not backward["fell"]
    assert forward["forward_cm_s"] > 2.0 and backward["forward_cm_s"] < -2.0  # paper: +-3.8
