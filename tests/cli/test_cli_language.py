"""One language on the command line (issue 32, item 5): every option that takes a parameter set
takes a file or a built-in or saved preset's name, `--motion` takes keys by name (the triple
kept), a bad name, key or value is a sentence naming what is allowed with exit status 2, the
tune's result never takes a built-in's name, and `--help` shows defaults and what `--tune` takes.
Each command runs in this process through `artro`'s `main`, with the smallest sizes it takes."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from app.cli import build_parser, main
from app.cli.options import MotionChoice, motion_arg
from app.params.document import ParameterSet
from app.params.formats import load_parameter_set
from app.params.presets import PresetStore, builtin_presets
from app.study.tune_space import tunable_fields
from gait import Motion

SAVED = "my-gait"  # a preset saved in the data directory, as the dashboard saves one
SHORT = ["--duration", "2", "--warmup", "0.5"]  # one whole cycle of 0.87 Hz after the warm-up
TINY_TUNE = [
    *("--tune", "swing.v", "--generations", "1", "--popsize", "2", "--cases", "forward"),
    *(*SHORT, "--threads", "1", "--study", "study.log"),
]


@pytest.fixture
def data_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A data directory holding the saved preset `SAVED` (0.87 Hz, a_p 0.05, CA 0.05), and the
    working directory an empty folder (what a command writes by default lands there)."""
    data = tmp_path / "data"
    monkeypatch.setenv("ARTRO_DATA_DIR", str(data))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    pset = ParameterSet.from_dict(
        {"motion": {"a_p": 0.05, "ca": 0.05}, "gait": {"clock": {"freq_hz": 0.87}}}
    )
    PresetStore(data, builtin_presets()).save(SAVED, pset)
    return data


def refused(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """What `artro` says on stderr when it refuses `args` with exit status 2 (an exception
    leaving `main`, a traceback, would fail the test)."""
    with pytest.raises(SystemExit) as exit_:
        main(args)
    assert exit_.value.code == 2
    return capsys.readouterr().err


# --- preset names: --params, --base, --presets on every command that takes them --------------


def test_run_export_and_link_take_a_saved_and_a_built_in_preset_by_name(data_dir, capsys):
    assert main(["run", "--params", SAVED, *SHORT]) == 0
    said = capsys.readouterr().out
    assert f"parameter set {SAVED!r}" in said and "a_p=0.05" in said
    assert main(["export", "--format", "json", "--params", SAVED]) == 0
    exported = json.loads(capsys.readouterr().out)
    assert exported["name"] == SAVED and exported["gait"]["clock"]["freq_hz"] == 0.87
    assert main(["export", "--format", "json", "--params", "tuned"]) == 0
    assert json.loads(capsys.readouterr().out)["name"] == "tuned"
    assert main(["link", "--dry-run", "--params", SAVED]) == 0
    assert f"sent {SAVED}" in capsys.readouterr().out


def test_calibrate_ca_takes_a_preset_by_name(data_dir, capsys):
    args = ["--iterations", "1", "--direction", "forward", "--threads", "1", *SHORT]
    assert main(["calibrate-ca", "--params", SAVED, *args]) == 0
    assert f"for {SAVED!r}" in capsys.readouterr().out


def test_firmware_build_and_run_take_a_preset_by_name(data_dir, capsys):
    assert main(["firmware", "build", "--params", SAVED, "-o", "fw"]) == 0
    header = (Path("fw") / "gen" / "artro_params.h").read_text(encoding="utf-8")
    assert f'"{SAVED}"' in header and "ARTRO_CLOCK_FREQ_HZ 0.87f" in header
    capsys.readouterr()
    assert main(["firmware", "run", "--params", "tuned", "--frames", "2", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["mismatches"] == 0


def test_tune_starts_from_a_preset_by_name_and_names_its_result_after_the_robot(data_dir, capsys):
    """`artro tune --base NAME` (a file before); the result is tuned-ROBOT, not a built-in's."""
    assert main(["tune", "--base", SAVED, *TINY_TUNE]) == 0
    assert "as 'tuned-artro'" in capsys.readouterr().out
    result = load_parameter_set(Path("out/tune/tuned-artro.json"))
    assert result.name == "tuned-artro" and result.name not in builtin_presets()
    assert result.gait.clock.freq_hz == 0.87  # the base's, swing.v alone was tuned
    again = [*TINY_TUNE, "--study", "other.log"]  # other settings: a study of its own
    assert main(["tune", "--base", "tuned", "--name", "mine", "--out", "t.json", *again]) == 0
    assert load_parameter_set(Path("t.json")).name == "mine"


def test_bench_robust_takes_a_saved_preset_by_name(data_dir, capsys):
    args = ["--samples", "1", "--threads", "1", "--out", "robust-out", "--json", *SHORT]
    assert main(["bench", "robust", "--presets", SAVED, *args]) == 0
    results = json.loads((Path("robust-out") / "results.json").read_text(encoding="utf-8"))
    assert [p["preset"] for p in results["presets"]] == [SAVED]


@pytest.mark.parametrize(
    ("args", "option", "spec"),
    [
        (["run", "--params", "no-such"], "--params", "no-such"),
        (["export", "--format", "json", "--params", "no-such"], "--params", "no-such"),
        (["calibrate-ca", "--params", "no-such"], "--params", "no-such"),
        (["firmware", "build", "--params", "no-such", "-o", "fw"], "--params", "no-such"),
        (["firmware", "run", "--params", "no-such"], "--params", "no-such"),
        (["link", "--dry-run", "--params", "no-such"], "--params", "no-such"),
        (["tune", "--base", "no-such"], "--base", "no-such"),
        (["bench", "paper", "--presets", "paper,no-such"], "--presets", "no-such"),
        (["bench", "robust", "--presets", "no-such"], "--presets", "no-such"),
        (["run", "--params", "missing/file.json"], "--params", "missing/file.json"),
    ],
)
def test_an_unknown_name_or_missing_file_names_the_built_in_and_saved_presets(
    data_dir, capsys, args, option, spec
):
    said = refused(args, capsys)
    assert f"No such file or preset {spec!r} for {option}" in said
    assert "built-in presets: paper, " in said and "tuned" in said
    assert f"saved presets (in {data_dir / 'presets'}): {SAVED}" in said
    assert "Traceback" not in said
    assert list(Path().iterdir()) == []  # nothing ran, nothing written


def test_serve_looks_for_saved_presets_in_its_data_dir(data_dir, tmp_path, capsys):
    other = tmp_path / "other"
    PresetStore(other, builtin_presets()).save("elsewhere", ParameterSet())
    said = refused(["serve", "--data-dir", str(other), "--params", SAVED], capsys)
    assert f"saved presets (in {other / 'presets'}): elsewhere" in said


# --- motions by name ------------------------------------------------------------------------


def test_a_motion_by_name_walks_as_the_triple(data_dir, capsys):
    def metrics(*motion: str) -> dict:
        assert main(["run", *motion, *SHORT, "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        return {k: v for k, v in out.items() if k not in ("wall_s", "rtf")}

    forward = metrics("--motion", "a_p=0.07")
    assert forward == metrics("--motion", "0,0.07,0")
    assert forward["forward_cm_s"] > 0
    assert metrics("--motion", "a_p=0.07,ca=0.1") == metrics("--motion", "0,0.07,0", "--ca", "0.1")


def test_keys_left_out_are_zero_and_the_triple_keeps_the_sets_ca():
    sets = Motion(a_r=0.02, a_p=0.05, a_y=0.1, ca=0.05)
    assert motion_arg("a_p=0.07").applied(sets) == Motion(a_p=0.07)
    assert motion_arg("0,0.07,0").applied(sets) == Motion(a_p=0.07, ca=0.05)
    assert motion_arg(" a_y = -0.2 , ca=0.1").applied(sets) == Motion(a_y=-0.2, ca=0.1)
    assert motion_arg("a_r=0.05").applied(sets, ca=0.2) == Motion(a_r=0.05, ca=0.2)
    assert motion_arg("a_p=0.07,a_r=-0.1") == MotionChoice({"a_p": 0.07, "a_r": -0.1}, True)
    with pytest.raises(ValueError, match="CA is given twice"):
        motion_arg("ca=0.1").applied(sets, ca=0.2)


@pytest.mark.parametrize(
    ("motion", "what"),
    [
        ("a_q=0.07", "'a_q=0.07' is not KEY=VALUE with a motion key"),
        ("a_p=0.07,speed=1", "'speed=1' in 'a_p=0.07,speed=1' is not KEY=VALUE"),
        ("a_p", "expected three numbers a_r,a_p,a_y"),
        ("a_p=0.9", "a_p in 'a_p=0.9' is not a number in its range; allowed: -0.3 to 0.3 rad"),
        ("ca=fast", "ca in 'ca=fast' is not a number in its range; allowed: -0.5 to 0.5;"),
        ("a_y=nan", "a_y in 'a_y=nan' is not a number in its range; allowed: -0.6 to 0.6 rad"),
        ("0,0.9,0", "a_p in '0,0.9,0' is not a number in its range"),
        ("a_p=0.1,a_p=0.2", "a_p is given twice"),
    ],
)
@pytest.mark.parametrize("command", [["run"], ["firmware", "run"]])
def test_a_bad_motion_key_or_value_names_the_keys_and_ranges(capsys, command, motion, what):
    said = refused([*command, "--motion", motion], capsys)
    assert f"argument --motion: {what}" in said
    if "twice" not in what:
        assert "allowed keys: a_r (-0.3 to 0.3 rad), a_p (-0.3 to 0.3 rad), " in said
        assert "a_y (-0.6 to 0.6 rad), ca (-0.5 to 0.5)" in said


# --- the tune's name ------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(builtin_presets()))
def test_a_built_in_name_for_the_tunes_result_is_refused_before_anything_runs(
    data_dir, capsys, name
):
    said = refused(["tune", "--name", name, *TINY_TUNE], capsys)
    assert f"--name {name} is a built-in preset's name, and built-ins are read-only" in said
    assert "leave --name out for tuned-artro" in said
    assert list(Path().iterdir()) == []  # no study, no result


def test_a_name_no_preset_may_have_is_refused(data_dir, capsys):
    said = refused(["tune", "--name", "../up", *TINY_TUNE], capsys)
    assert "invalid preset name '../up'; allowed: 1 to 64 characters" in said


# --- --help ---------------------------------------------------------------------------------


def options_of(parser: argparse.ArgumentParser, path: str):
    """(command, option, its help as printed) for every option that takes a value."""
    formatter = parser._get_formatter()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from options_of(child, f"{path} {name}")
        elif action.option_strings and action.nargs != 0 and not action.required:
            yield path, action.option_strings[-1], formatter._expand_help(action)


def test_every_option_that_takes_a_value_shows_its_default_in_help():
    found = list(options_of(build_parser(), "artro"))
    assert len(found) > 60  # every command's, the action parsers' (firmware run, ...) too
    silent = [(c, o) for c, o, text in found if "default" not in text.lower()]
    assert silent == []
    objects = [(c, o) for c, o, text in found if "Variation(" in text or " object at " in text]
    assert objects == []  # a default that is no plain value is said in words
    shown = {(c, o): text for c, o, text in found}
    # without --base the start's recipe (tests/study/test_tune_robot.py), with it the earlier
    # defaults
    assert (
        "(default: 10 without --base, the start's recipe; 30 with it)"
        in shown[("artro tune", "--generations")]
    )
    assert "(default: the built-in preset nearest the robot's" in shown[("artro tune", "--base")]
    assert "(default: tuned-ROBOT, e.g. tuned-artro)" in shown[("artro tune", "--name")]


def test_tune_help_lists_every_tunable_field_and_the_default_name(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["tune", "--help"])
    assert exit_.value.code == 0
    text = capsys.readouterr().out
    listing = text.split("what --tune accepts", 1)[1]
    words = listing.replace(",", " ").split()
    for group, fields in tunable_fields().items():
        assert f"{group}:" in words
        assert set(fields) <= set(words), group
    assert "(default: tuned-ROBOT" in " ".join(text.split())
