"""`artro bench paper`: a quick real run end to end, and the CA analysis on synthetic data."""

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.analysis.ca_analysis import (
    CircleCheck,
    antisymmetry_pairs,
    eq13_turn_rate_rad_s,
    fit_axle,
    largest_stable_ca,
)
from app.analysis.cases import CASES, speed_scale_of
from app.cli import main
from app.study import runs as paper_runs
from app.study import walks
from app.study.paper_bench import case_rows
from app.study.report import table
from app.study.runs import ca_sweep
from app.study.walks import cycle_mean, resolve_presets
from gait import ARTRO_LEG, LegGeometry

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_quick_bench_prints_every_case_and_writes_pngs_and_json(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench", "paper", "--quick", "--presets", "paper", "--out", str(out)]) == 0
    printed = capsys.readouterr()
    for case in CASES:
        assert case.name in printed.out
    assert "CA CURVE WALKING, FORWARD" in printed.out
    assert "CA CURVE WALKING, BACKWARD" in printed.out
    assert "largest stable |CA|" in printed.out
    assert "runs" in printed.err  # progress went to stderr

    for name in ("paths_paper.png", "ca_stability.png", "ca_heading.png", "ca_limit_speed.png"):
        assert (out / name).read_bytes()[:8] == PNG_MAGIC, name
    results = json.loads((out / "results.json").read_text())
    (paper,) = results["presets"]
    assert [c["case"] for c in paper["cases"]] == [c.name for c in CASES]
    assert len(paper["mirror"]) == sum(c.mirror_of is not None for c in CASES)
    for direction in ("forward", "backward"):
        ca = paper["ca"][direction]
        assert [r["ca"] for r in ca["rows"]] == list(paper_runs.QUICK.ca_values)
        assert ca["axle_cm"] > 0
        assert {"fit", "antisymmetry", "stable_limit"} <= set(ca)
    circle = paper["circle"]
    assert circle["run_s"] == pytest.approx(paper_runs.QUICK.circle_s, abs=0.021)
    assert circle["ca"] == 0.058 and "full circle, CA = 0.058" in printed.out
    assert circle["predicted_radius_m"] == pytest.approx(
        paper["ca"]["forward"]["axle_cm"] / 100 / (2 * 0.058)
    )
    assert "eq (13): b / (2 CA) =" in printed.out
    assert "CA steers at" in printed.out or "b_eff < 0" in printed.out
    # the largest stable CA against speed: the quick config's amplitude and +-0.07 from the sweep
    limits = {round(r["a_p"], 3): r for r in paper["speed_limits"]}
    assert set(limits) == {-0.07, -0.05, 0.07}
    quick_cas = [-0.5, -0.2, 0.0, 0.2, 0.5]
    assert [row["ca"] for row in limits[-0.05]["rows"]] == quick_cas
    assert [row["ca"] for row in limits[0.07]["rows"]] == [-0.2, 0.0, 0.2]  # what the sweep has
    for r in limits.values():
        for sign, k in (("+", 1), ("-", -1)):
            ordered = sorted((x for x in r["rows"] if x["ca"] * k > 0), key=lambda x: abs(x["ca"]))
            stable = [x for x in ordered if x["stable"]]
            expected = None
            for x in ordered:  # every |CA| up to the limit is stable, the next one is not
                if not x["stable"]:
                    break
                expected = abs(x["ca"])
            assert r["limit_stable"][sign] == expected, (r["a_p"], sign, stable)
            assert (r["limit_no_fall"][sign] or 0) >= (r["limit_stable"][sign] or 0)
    assert "largest stable |CA| against speed" in printed.out
    forward = paper["cases"][1]
    assert forward["sim"] == pytest.approx(paper["metrics"]["cases"]["forward"]["forward_cm_s"])

    barely = [d for d in ("forward", "backward") if abs(paper["ca"][d]["speed_cm_s"]) < 0.5]
    assert printed.out.count("the robot barely walks") == len(barely)

    # CA steering at other forward amplitudes: eq (13) from each amplitude's own CA = 0 walk
    by_a_p = paper["steering_by_a_p"]
    assert [r["a_p"] for r in by_a_p] == sorted({0.07, *paper_runs.QUICK.steer_a_p})
    assert "CA = +-0.1 at other forward amplitudes:" in printed.out
    recomputed = 0
    for row in by_a_p:
        if row["a_p"] == 0.07:
            assert row["steering"] == paper["ca"]["forward"]["steering"]
            continue
        minus, straight, plus = paper["metrics"]["steer_probes"][f"{row['a_p']:g}"]
        assert row["speed_cm_s"] == pytest.approx(straight["forward_cm_s"])
        assert row["walks"] == (abs(straight["forward_cm_s"]) >= 0.5)
        if row["fell"]:
            continue
        rate = math.degrees(
            eq13_turn_rate_rad_s(
                0.1, straight["forward_cm_s"] / 100, straight["feet_distance_cm"] / 100
            )
        )
        gain = (plus["turn_deg_s"] - minus["turn_deg_s"]) / (2 * rate)
        assert row["steering"]["gain"] == pytest.approx(gain, rel=1e-9)
        recomputed += 1
    assert recomputed >= 1  # at least one other amplitude walked without a fall and was checked


def test_unknown_preset_is_a_clear_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "paper", "--presets", "no-such-preset"])
    assert exc.value.code == 2
    assert "no-such-preset" in capsys.readouterr().err


def test_missing_named_presets(tmp_path, monkeypatch):
    monkeypatch.setattr(walks, "BUILTIN_DIR", tmp_path)
    presets, notes = resolve_presets(["paper", "tuned"])
    assert [p.name for p in presets] == ["paper"]  # paper falls back to ParameterSet()
    assert any("tuned" in n and "skipped" in n for n in notes)


@given(
    speed_m_s=st.floats(-0.1, 0.1).filter(lambda v: abs(v) > 1e-3),
    axle_m=st.floats(0.03, 0.3),
    drift_rad_s=st.floats(-0.1, 0.1),
)
def test_axle_fit_recovers_a_known_axle(speed_m_s, axle_m, drift_rad_s):
    ca = np.array([-0.1, -0.075, -0.05, -0.025, 0.0, 0.025, 0.05, 0.058, 0.075, 0.1])
    turn = drift_rad_s + eq13_turn_rate_rad_s(ca, speed_m_s, axle_m)
    fit = fit_axle(ca, turn, speed_m_s)
    assert fit.axle_eff_m == pytest.approx(axle_m, rel=1e-9)
    assert fit.drift_rad_s == pytest.approx(drift_rad_s, abs=1e-12)
    assert fit.residual_rms_rad_s == pytest.approx(0.0, abs=1e-12)


def test_axle_fit_needs_two_ca_values():
    with pytest.raises(ValueError, match="two distinct"):
        fit_axle([0.05, 0.05], [0.1, 0.1], 0.04)


SWEEP = np.array(ca_sweep(beyond=()))  # -0.2..0.2 by 0.025, plus 0.058


def test_the_default_sweep_goes_past_the_papers_limits():
    sweep = ca_sweep()
    assert max(sweep) == 0.5 and min(sweep) == -0.5 and 0.0 in sweep and 0.058 in sweep
    assert all(-ca in sweep for ca in sweep if ca != 0.058)


@pytest.mark.parametrize(
    ("falls", "limit", "first_fall"),
    [
        (lambda ca: np.zeros_like(ca, dtype=bool), 0.2, None),  # nothing fell: limit beyond
        (lambda ca: ca >= 0.15, 0.125, 0.15),  # only one sign falls
        (lambda ca: np.isclose(ca, -0.1) | (ca >= 0.2), 0.075, 0.1),  # not monotone in |CA|
        (lambda ca: np.isclose(ca, 0.058), 0.05, 0.058),  # the extra value counts too
        (lambda ca: ca == 0, None, 0.0),  # even walking straight fell
    ],
)
def test_largest_stable_ca(falls, limit, first_fall):
    result = largest_stable_ca(SWEEP, falls(SWEEP))
    assert result.limit == (None if limit is None else pytest.approx(limit))
    assert result.first_fall == (None if first_fall is None else pytest.approx(first_fall))
    assert result.beyond_sweep == (first_fall is None)
    assert result.sweep_max == pytest.approx(0.2)


def test_antisymmetry_pairs_skip_fallen_and_unpaired_runs():
    ca = [-0.1, -0.05, 0.0, 0.05, 0.058, 0.1]
    turn = [2.0, 1.0, 0.0, -1.1, -1.2, -3.0]
    fell = [False, False, False, False, False, True]
    (pair,) = antisymmetry_pairs(ca, turn, fell)
    assert pair.ca == 0.05
    assert pair.mismatch == pytest.approx(0.1 / 1.05)
    assert pair.even_part == pytest.approx(-0.05)
    assert pair.ok


def test_full_circle_check():
    done = CircleCheck(turned_deg=-365.0, run_s=60.0, rate_deg_s=-6.2, predicted_rate_deg_s=-5.0)
    assert done.completed
    short = CircleCheck(turned_deg=120.0, run_s=60.0, rate_deg_s=2.0, predicted_rate_deg_s=None)
    assert not short.completed
    assert short.circle_s == pytest.approx(180.0)
    assert short.predicted_circle_s is None


def test_cycle_mean_removes_a_sway_of_one_cycle():
    t = np.arange(500) * 0.02
    x = 0.01 * t + 0.03 * np.sin(2 * math.pi * t)  # 1 Hz sway of 3 cm on a 1 cm/s walk
    smooth = cycle_mean(x, 50)
    ok = np.isfinite(smooth)
    assert ok.sum() == 500 - 49
    assert np.allclose(smooth[ok], 0.01 * (t[ok] - 0.01), atol=1e-12)  # half-sample lag


def test_table_columns_line_up():
    lines = table(
        [("", ("case",)), ("a long preset name", ("sim", "ok")), ("b", ("sim", "ok"))],
        [["forward", "+0.96", "NO", "+3.80", "yes"], ["on the spot", "+0.1", "yes", "-", "no"]],
    )
    separator = lines[2]
    assert set(separator) == {"-", "+"}
    joints = [i for i, ch in enumerate(separator) if ch == "+"]
    for line in lines[:2] + lines[3:]:  # every group separator in the same column on every line
        assert [i for i, ch in enumerate(line) if ch == "|"] == joints


def test_another_robots_targets_are_scaled_by_its_legs():
    """A robot with legs 1.5 times ArtRo's is held to 1.5 times the paper's speeds (turn rates
    unscaled): 5.7 cm/s forward passes it, 3.8 cm/s (ArtRo's figure) no longer does."""
    longer = LegGeometry(upper_m=ARTRO_LEG.upper_m * 1.5, lower_m=ARTRO_LEG.lower_m * 1.5)
    scale = speed_scale_of(longer)
    assert scale == pytest.approx(1.5)
    walked = {"fell": False, "gyro_rms": 0.1}

    def runs(forward_cm_s: float) -> SimpleNamespace:
        metrics = walked | {"forward_cm_s": forward_cm_s, "lateral_cm_s": 0.0, "turn_deg_s": -12.1}
        return SimpleNamespace(cases={c.name: SimpleNamespace(metrics=metrics) for c in CASES})

    rows = {r["case"]: r for r in case_rows(runs(3.8 * 1.5), 5.0, scale)}
    assert rows["forward"]["target"] == pytest.approx(3.8 * 1.5) and rows["forward"]["pass"]
    assert rows["forward"]["paper"] == 3.8 and rows["forward"]["ratio"] == pytest.approx(1.0)
    assert rows["turn clockwise"]["target"] == -12.1 and rows["turn clockwise"]["pass"]
    assert not {r["case"]: r for r in case_rows(runs(3.8), 5.0, scale)}["forward"]["pass"]
    assert {r["case"]: r for r in case_rows(runs(3.8), 5.0)}["forward"]["pass"]
