"""`artro tune`: a short run improves its objective and writes a preset that loads; the loss,
the criteria, the robust score per family, and progress (resuming: test_tune_resume.py)."""

import io
import subprocess
import sys

import optuna
import pytest

from app.analysis.cases import CASES, CURVES, JUDGED_RUNS, steering, steers_right, within_eq13
from app.analysis.robust_cases import ROBUST_CASES
from app.params.formats import load_parameter_set
from app.params.presets import stamped, write_parameter_set
from app.study.study_store import DEFAULT_STUDY, OBJECTIVE, open_storage
from app.study.tune import Tuner, dimensions
from app.study.tune_choice import best_passing, families_of, varied_summary
from app.study.tune_families import FAMILIES, families_term, kept_shortfall
from app.study.tune_loss import (
    LossWeights,
    case_loss,
    curve_loss,
    meets_all_criteria,
    total_loss,
)
from gait import GaitParams
from tests.testing.tune_support import (
    EVALUATOR,
    NAMES,
    POOR,
    ROOT,
    SETTINGS,
    Counting,
    base_loss,
    store,
    trials_in,
)


@pytest.mark.slow
def test_a_short_run_improves_and_writes_a_loadable_preset(tmp_path):
    tuner = Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS)
    best = tuner.run(3, store(tmp_path, tuner), progress=None)
    assert tuner.best[0] < base_loss()
    path = stamped(best, "tuned")
    write_parameter_set(tmp_path / "tuned.json", path)
    loaded = load_parameter_set(tmp_path / "tuned.json")
    assert loaded.name == "tuned" and loaded.gait == path.gait
    assert loaded.gait.clock.freq_hz != 0.5 or loaded.gait.short.amp_base != 0.05
    # every evaluation is an Optuna trial in the journal file
    study = optuna.load_study(
        study_name=DEFAULT_STUDY, storage=open_storage(tmp_path / "study.log")
    )
    trials = study.get_trials()
    assert len(trials) == 3 * 4 and study.user_attrs["settings"]["popsize"] == 4
    assert set(trials[0].user_attrs["metrics"]["nominal"]) == {n for n, _m in JUDGED_RUNS}
    assert set(trials[0].params) == set(NAMES)
    assert study.best_value == pytest.approx(tuner.best[0])


def test_loss_rewards_the_paper_figure_and_punishes_falls():
    forward = CASES[1]
    exact = {"fell": False, "forward_cm_s": 3.8, "lateral_cm_s": 0.0, "turn_deg_s": 0.0}
    half = exact | {"forward_cm_s": 1.9}
    assert case_loss(forward, exact, 20) == 0.0
    assert case_loss(forward, half, 20) == pytest.approx(0.25)
    early, late = {"fell": True, "fall_time_s": 1.0}, {"fell": True, "fall_time_s": 19.0}
    assert (
        case_loss(forward, early, 20) > case_loss(forward, late, 20) > case_loss(forward, half, 20)
    )


def test_only_numeric_schema_fields_can_be_tuned():
    assert [d.name for d in dimensions(["swing.v"])] == ["swing.v"]
    for bad in ("swing.enabled", "swing.speed", "walk.v", "freq"):
        with pytest.raises(ValueError, match="not a tunable number"):
            dimensions([bad])


def curve_run(turn: float, predicted: float, fell: bool = False) -> dict:
    return {"fell": fell, "turn_deg_s": turn, "predicted_turn_deg_s": predicted}


def test_steering_compares_the_ca_response_with_eq13_and_ignores_drift():
    forward, backward = CURVES
    straight = curve_run(-1.0, 0.0)  # the robot drifts -1 deg/s at CA = 0
    # eq (13): -3 deg/s at CA = +0.1, +3 at -0.1, on top of the drift
    follows = curve_run(-3.0 - 1.0, -3.0), curve_run(3.0 - 1.0, 3.0)
    s = steering(*follows, straight)
    assert (s.gain, s.bend) == (pytest.approx(1.0), pytest.approx(0.0))
    assert within_eq13(s) and curve_loss(forward, *follows, straight, 20) == pytest.approx(0.0)
    weak = curve_run(-1.0 - 1.0, -3.0), curve_run(1.0 - 1.0, 3.0)
    s = steering(*weak, straight)
    assert s.gain == pytest.approx(1 / 3) and steers_right(s) and not within_eq13(s)
    assert curve_loss(forward, *weak, straight, 20) == pytest.approx((2 / 3) ** 2)
    wrong = curve_run(1.0 - 1.0, -3.0), curve_run(-1.0 - 1.0, 3.0)
    assert not steers_right(steering(*wrong, straight))
    assert steering(curve_run(0, -3, fell=True), curve_run(0, 3), straight) is None
    assert curve_loss(backward, curve_run(0, -3, fell=True), curve_run(0, 3), straight, 20) > 10


def test_a_gait_that_tips_into_a_turn_either_way_is_not_steering():
    # it drifts -1.5 deg/s at CA = 0, and +-0.1 only picks between -2.3 and +1.9 deg/s
    straight = curve_run(-1.5, 0.0)
    tips = curve_run(-2.3, -2.6), curve_run(1.9, 2.8)
    s = steering(*tips, straight)
    assert s.gain == pytest.approx(4.2 / 5.4) and s.bend == pytest.approx(2.6 / 5.4)
    assert not steers_right(s) and not within_eq13(s)
    assert curve_loss(CURVES[0], *tips, straight, 20) > 0.9


def test_the_criteria_include_ca_steering():
    speeds = {"forward_cm_s": 0.0, "lateral_cm_s": 0.0, "turn_deg_s": 0.0, "fell": False}
    by_run = {}
    for case in CASES:
        m = dict(speeds) | {"predicted_turn_deg_s": 0.0}
        if case.metric != "drift_cm_s":
            m[case.metric] = case.paper
        by_run[case.name] = m
    names = [name for name, _motion in JUDGED_RUNS[len(CASES) :]]
    for plus, minus in zip(names[::2], names[1::2], strict=True):
        by_run[plus] = curve_run(-1.0, -3.0)  # a third of eq (13), the right way: accepted
        by_run[minus] = curve_run(1.0, 3.0)
    assert meets_all_criteria(by_run)
    by_run[names[0]] = curve_run(1.0, -3.0)  # forward CA steers the wrong way
    by_run[names[1]] = curve_run(-1.0, 3.0)
    assert not meets_all_criteria(by_run)


def test_select_the_passing_set_with_the_lowest_loss_or_the_most_steering():
    def judged(gain: float) -> dict:
        by_run = {}
        for case in CASES:
            m = {"forward_cm_s": 0.0, "lateral_cm_s": 0.0, "turn_deg_s": 0.0, "fell": False}
            if case.metric != "drift_cm_s":
                m[case.metric] = case.paper
            by_run[case.name] = m | {"predicted_turn_deg_s": 0.0}
        names = [name for name, _motion in JUDGED_RUNS[len(CASES) :]]
        for plus, minus in zip(names[::2], names[1::2], strict=True):
            by_run[plus], by_run[minus] = curve_run(-3.0 * gain, -3.0), curve_run(3 * gain, 3.0)
        return by_run

    tuner = Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS)
    params = POOR.gait
    wrong_way = (0.5, params, judged(-0.2))  # the lowest loss, but CA steers the wrong way
    tuner.evaluated = [(1.0, params, judged(0.1)), (2.0, params, judged(0.4)), wrong_way]
    assert best_passing(tuner)[0] == 1.0
    assert best_passing(tuner, by="steering")[0] == 2.0


def test_settings_parse_numbers_and_switches_and_say_the_form():
    from gait.params import merge, parse_settings

    patch = parse_settings(["swing.v=3", "leg.paper_signs=false", "short.enabled=True"])
    assert patch == {"swing": {"v": 3.0}, "leg": {"paper_signs": False}, "short": {"enabled": True}}
    params = merge(GaitParams(), patch)
    assert params.swing.v == 3.0 and params.leg.paper_signs is False
    with pytest.raises(ValueError, match=r"GROUP\.FIELD=VALUE"):
        parse_settings(["swingv=3"])
    with pytest.raises(ValueError, match=r"swing\.v: 'fast' is not a number or true/false"):
        parse_settings(["swing.v=fast"])


def test_a_tuner_limited_to_some_cases_walks_only_those_and_their_ca_pairs():
    from app.study.tune import judged_runs

    runs = [name for name, _motion in judged_runs(["forward", "backward"])]
    assert runs[:2] == ["forward", "backward"]
    assert set(runs) == {"forward", "backward", *(n for n in runs if "CA=" in n)}
    assert any("CA=" in n for n in runs)  # the curve pairs at the forward/backward speed
    with pytest.raises(ValueError, match="allowed: on the spot"):
        judged_runs(["forwards"])


def test_a_robust_score_adds_the_worst_familys_term_and_the_torque_penalty(tmp_path):
    """`--robust N`: every candidate walks the same N worlds; its loss is the paper loss on the
    nominal model plus the worst family's term and the torque penalty, and the store keeps how
    many varied runs passed, family by family."""
    tuner = Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS, robust=3)
    tuner.run(1, store(tmp_path, tuner), progress=None)
    trials = trials_in(tmp_path / "study.log")
    assert len(trials) == 4
    for trial in trials:
        robust = trial.user_attrs["metrics"]["robust"]
        assert len(robust["losses"]) == 3 and robust["runs"] == 3 * len(ROBUST_CASES)
        assert 0 <= robust["passed"] <= robust["runs"]
        assert robust["cvar25"] == max(robust["losses"])  # the worst quarter of 3 is 1 world
        nominal = total_loss(trial.user_attrs["metrics"]["nominal"], SETTINGS["duration_s"])
        # the worst family's term and eq (1)'s torque penalty (decision 0062)
        families = robust["families"]
        assert list(families) == ["spot", "forward/backward", "sideways", "turning", "curves"]
        assert sum(f["passed"] for f in families.values()) == robust["passed"]
        assert robust["term"] >= max(f["objective"] for f in families.values())
        torque = LossWeights().torque * robust["torque"]
        assert trial.value == pytest.approx(nominal + robust["term"] + torque)
    # a poor gait fails some varied runs: the margins are not all zero
    assert any(t.user_attrs["metrics"]["robust"]["cvar25"] > 0 for t in trials)
    best = tuner.best
    kept = next(t for t in trials if t.value == pytest.approx(best[0]))
    passed = kept.user_attrs["metrics"]["robust"]["passed"]  # the summary `artro tune` prints
    # optuna-dashboard: a named objective, each trial's time, each figure an attribute
    storage = open_storage(tmp_path / "study.log")
    study = optuna.load_study(study_name=DEFAULT_STUDY, storage=storage)
    assert study.metric_names == [OBJECTIVE]
    assert all(t.datetime_complete > t.datetime_start for t in trials)
    runs = kept.user_attrs["metrics"]["nominal"]
    assert kept.user_attrs["robust.pass_share"] == passed / (3 * len(ROBUST_CASES))
    for run, m in runs.items():
        assert m["fell"] or kept.user_attrs[f"{run}.forward_cm_s"] == m["forward_cm_s"]
    assert varied_summary(tuner, best).startswith(f"passes {passed} of {3 * len(ROBUST_CASES)} ")
    assert "per family spot " in varied_summary(tuner, best)
    assert set(families_of(tuner, best)) == set(FAMILIES.values())
    # bench/robust_frontier.py reads the same store: a table of the frontier and its plot
    png = tmp_path / "frontier.png"
    drawn = subprocess.run(
        [sys.executable, "bench/robust_frontier.py", str(tmp_path / "study.log"),
         "--png", str(png), "--json", str(tmp_path / "frontier.json")],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert drawn.returncode == 0, drawn.stderr
    assert drawn.stdout.startswith("4 candidates") and png.stat().st_size > 10_000
    # a store of two studies (`artro tune` names each tune-ROBOT-DIGEST): it asks which one
    optuna.create_study(study_name="tune-other", storage=storage)
    two = subprocess.run(drawn.args, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert (
        two.returncode == 1
        and f"2 studies; give --study-name, one of: {DEFAULT_STUDY}, tune-other" in two.stderr
    ), two.stderr
    named = [*drawn.args, "--study-name", DEFAULT_STUDY]
    assert subprocess.run(named, cwd=ROOT, capture_output=True, timeout=300).returncode == 0
    # and writes a candidate as a parameter set: the POOR base with that trial's values
    best = min(trials, key=lambda t: t.value)
    saved = subprocess.run(
        [sys.executable, "bench/robust_frontier.py", str(tmp_path / "study.log"),
         "--save", str(best.number), "--out", str(tmp_path / "pick.json"),
         "--base", str(tmp_path / "poor.json"), "--study-name", DEFAULT_STUDY],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert saved.returncode == 1  # the base file does not exist yet
    assert "give it as --base FILE" in saved.stderr
    write_parameter_set(tmp_path / "poor.json", POOR)
    saved = subprocess.run(saved.args, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert saved.returncode == 0, saved.stderr
    pick = load_parameter_set(tmp_path / "pick.json").gait
    assert (pick.clock.freq_hz, pick.short.amp_base) == pytest.approx(
        (best.params["clock.freq_hz"], best.params["short.amp_base"]), abs=1e-6
    )
    assert pick.leg == POOR.gait.leg  # untuned fields come from the base


def test_the_kept_shortfall_sums_each_familys_loss_below_the_base():
    base = {"sideways": {"share": 0.6}, "curves": {"share": 0.95}, "turning": {"share": 1.0}}
    gains_sideways = {
        "sideways": {"share": 0.7},
        "curves": {"share": 0.9},
        "turning": {"share": 1.0},
    }
    assert kept_shortfall(gains_sideways, base) == pytest.approx(0.05)  # the gain buys nothing
    assert kept_shortfall(base, base) == 0.0


def test_keeping_the_base_walks_it_in_the_same_worlds_and_adds_the_shortfall(tmp_path):
    """`--keep-base W` (decision 0070): each generation also walks the base set in its worlds,
    and each candidate's term adds W times its families' shortfall below the base's shares."""
    with pytest.raises(ValueError, match=r"robust N >= 1 variations"):
        Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS, keep_base=2.0)
    Counting.runs = 0
    tuner = Tuner(POOR, NAMES, evaluator=Counting(threads=2), **SETTINGS, robust=2,
                  keep_base=3.0)  # fmt: skip
    assert tuner.settings["keep_base"] == 3.0  # a study of its own: another digest
    tuner.run(1, store(tmp_path, tuner), progress=None)
    per_set = len(tuner.runs) + 2 * len(tuner.robust_runs())
    assert Counting.runs == (SETTINGS["popsize"] + 1) * per_set  # the base once
    for trial in trials_in(tmp_path / "study.log"):
        robust = trial.user_attrs["metrics"]["robust"]
        base, families = robust["base_shares"], robust["families"]
        assert list(base) == list(families) and all(0 <= b <= 1 for b in base.values())
        shortfall = sum(max(0.0, base[f] - fam["share"]) for f, fam in families.items())
        assert robust["kept_shortfall"] == pytest.approx(shortfall)
        assert robust["term"] == pytest.approx(families_term(families) + 3.0 * shortfall)


def test_progress_through_a_pipe_is_a_line_per_tenth_not_one_huge_line(tmp_path):
    """Redirected, `artro tune` once wrote every update on one `\\r`-joined line: now a line per
    tenth of each generation's runs (a bar rewritten in place only on a terminal)."""
    tuner = Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS)
    stream = io.StringIO()  # not a terminal
    tuner.run(2, store(tmp_path, tuner), progress=stream)
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue()
    for generation in (1, 2):
        mine = [line for line in lines if line.startswith(f"generation {generation} of 2: ")]
        assert 2 <= len(mine) <= 11, lines
        total = SETTINGS["popsize"] * len(tuner.runs)
        assert mine[-1].split(": ")[1].startswith(f"{total}/{total} runs"), mine


def test_one_parameter_is_tuned_for_as_many_generations_as_asked():
    """`artro tune --tune swing.v` stopped in its third generation with cma's "not yet
    initialized (dimension needed)": its step-size cap from the bounds fails on one dimension.
    The tuner's own CMA-ES is driven here through 60 generations on a known optimum."""
    tuner = Tuner(POOR, ["swing.v"], evaluator=EVALUATOR, **SETTINGS)
    for _ in range(60):
        points = tuner.es.ask()
        tuner.es.tell(points, [float((p[0] - 0.9) ** 2) for p in points])
    assert tuner.es.result.xbest[0] == pytest.approx(0.9, abs=0.01)
