"""The effective axle fitted from simulated curve walks (real batch rollouts of the model)."""

import math

import pytest

from app.analysis.axle_fit import fit_effective_axle, walking_amplitude
from app.params.formats import load_parameter_set
from app.params.presets import BUILTIN_DIR
from app.server.jobs.axle_fitter import AxleFitter
from app.server.sim.path_tracker import PathTracker
from gait import Motion

TUNED = load_parameter_set(BUILTIN_DIR / "tuned.json").gait


def test_standing_still_fits_at_the_papers_forward_amplitude():
    assert walking_amplitude(Motion()) == 0.07
    assert walking_amplitude(Motion(a_p=-0.05)) == -0.05


def test_the_fit_is_consistent_with_its_own_runs():
    r = fit_effective_axle(TUNED, Motion(a_p=0.07), duration_s=12.0, warmup_s=3.0)
    assert r.ca == (-0.1, 0.0, 0.1) and r.sim_s == 36.0
    assert 0.08 < r.feet_m < 0.13 and r.speed_m_s > 0.01
    slope_deg = (r.turn_deg_s[2] - r.turn_deg_s[0]) / 0.2
    # `tuned` steers the way eq (13) says at a_p = 0.07 (models/README.md), so there is an axle
    assert r.axle_eff_m is not None and r.axle_eff_m > 0
    # b_eff = -2 V / k with k the slope of theta_dot over CA
    expected = -2 * r.speed_m_s / math.radians(slope_deg)
    assert r.axle_eff_m == pytest.approx(expected, rel=1e-6)
    assert r.gain == pytest.approx(r.feet_m / r.axle_eff_m)


def test_one_fit_at_a_time():
    fitter = AxleFitter()
    first = fitter.start(TUNED, Motion(a_p=0.07), PathTracker())
    with pytest.raises(RuntimeError, match="already running"):
        fitter.fit(TUNED, Motion(a_p=0.07), PathTracker())
    first.finished.wait()


def test_a_kept_result_applies_its_own_fit_not_a_later_ones():
    """A fit whose version was gone by its end keeps its result for `POST .../apply`; applied
    after another fit had run, it once set that later fit's b_eff (all fits shared one
    `last`). Two real fits of two gaits: the kept one applies its own."""
    import dataclasses

    from app.params.document import ParameterSet
    from app.server.param_store import ParameterStore

    store = ParameterStore(ParameterSet(gait=TUNED, motion=Motion(a_p=0.07)), robot="artro")
    fitter, paths = AxleFitter(store=store), PathTracker()
    snap = store.snapshot()
    kept = fitter.start(snap.gait, snap.motion, paths, params_version=snap.version - 1)
    assert kept.finished.wait(300) and kept.result["conflict"] and kept.applier is not None
    swing = dataclasses.replace(TUNED.swing, v=TUNED.swing.v * 1.3)
    wider = dataclasses.replace(TUNED, swing=swing)
    later = fitter.start(wider, snap.motion, paths, params_version=snap.version)
    assert later.finished.wait(300) and later.result["applied"]
    assert later.result["axle_eff_m"] != pytest.approx(kept.result["axle_eff_m"], rel=1e-3)
    kept.applier(store.snapshot().version)
    assert paths.view()["axle_m"] == kept.result["axle_eff_m"]
