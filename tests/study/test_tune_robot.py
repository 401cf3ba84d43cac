"""A starting gait for any robot (issue 32, items 4 and 6): `artro tune --robot FILE` without
`--base` starts from the built-in preset nearest the robot's leg, its clock scaled like a
pendulum's, runs the start's recipe and saves `tuned-ROBOT` among the presets; the README's quick
start runs as written on a robot this test writes. Commands run in this process through `artro`'s
`main`, with the smallest sizes they take."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
import yaml

from app.analysis.robot_start import (
    START_RECIPE,
    nearest_preset,
    reference_legs,
    scaled_freq_hz,
    scaled_gait,
    start_for,
    walks,
)
from app.analysis.robot_tune import RESULT, RUNS, START, TRIAL, read_event
from app.assets import builtin_robots_dir
from app.cli import main
from app.cli._sets import resolve_set
from app.cli.tune import CLASSIC, RECIPE
from app.params.formats import load_parameter_set
from app.params.presets import builtin_presets
from app.robots.library import load_description, read_description
from app.study.tune_space import tunable_fields

ROOT = Path(__file__).resolve().parents[2]
#: the recipe's fields kept, the sizes cut: one generation of two candidates walking forward
#: (and the CA pair at its speed) for 6 s, one whole cycle of the slowest clock (0.2 Hz) after
#: a 0.5 s warm-up
TINY = ["--generations", "1", "--popsize", "2", "--duration", "5.6", "--warmup", "0.5"]
TINY_TUNE = [*TINY, "--cases", "forward", "--threads", "1"]


def robot_file(path: Path, name: str, leg_m: float, servo: str) -> Path:
    """ArtRo's description with another name, legs of `leg_m` each and `servo` everywhere, the
    total mass left to the parts."""
    raw = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
    raw |= {"name": name, "servo": servo}
    raw.pop("total_mass_kg")
    raw["geometry"] |= {"thigh_m": leg_m, "shank_m": leg_m}
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    return path


@pytest.fixture
def work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty working directory and a data directory of its own (`$ARTRO_DATA_DIR`)."""
    monkeypatch.setenv("ARTRO_DATA_DIR", str(tmp_path / "data"))
    (tmp_path / "work").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    return tmp_path


# --- the nearest preset and the scaling rule (hand-computed) ---------------------------------


def test_the_references_are_the_built_in_robots_and_their_presets():
    # each built-in robot's default preset: both with the laws on, micro's scaled to its legs
    assert reference_legs() == {"robust-3": pytest.approx(0.18),
                                "micro-robust": pytest.approx(0.09)}  # fmt: skip


@pytest.mark.parametrize(
    ("leg_m", "preset"),
    [
        (0.234, "tuned"),  # 1.3 x ArtRo's
        (0.18, "tuned"),
        (0.13, "tuned"),  # ln(0.18/0.13) = 0.325 < ln(0.13/0.09) = 0.368
        (0.12, "micro-tuned"),  # ln(0.12/0.09) = 0.288 < ln(0.18/0.12) = 0.405
        (0.05, "micro-tuned"),
    ],
)
def test_the_nearest_preset_is_by_the_ratio_of_leg_lengths(leg_m, preset):
    assert nearest_preset(leg_m, {"tuned": 0.18, "micro-tuned": 0.09}) == preset


def test_the_clock_scales_by_the_square_root_of_the_leg_ratio():
    # 0.683107 Hz x sqrt(0.18 / 0.234) = 0.683107 x 0.877058 = 0.599125 Hz
    assert scaled_freq_hz(0.683107, 0.18, 0.234) == pytest.approx(0.599125, abs=2e-6)
    # micro's 0.910486 Hz for legs of 0.12 m: x sqrt(0.09 / 0.12) = x 0.866025 -> 0.788504 Hz
    assert scaled_freq_hz(0.910486, 0.09, 0.12) == pytest.approx(0.788504, abs=2e-6)
    assert scaled_freq_hz(1.0, 0.18, 0.18) == 1.0
    assert scaled_freq_hz(2.0, 0.18, 0.02) == 3.0  # 6 Hz held at the schema's top
    assert scaled_freq_hz(0.3, 0.09, 0.9) == 0.2  # 0.095 Hz held at its bottom


@pytest.mark.parametrize("name", ["tuned", "robust"])
def test_scaling_changes_the_clock_and_the_yaw_loops_lengths_alone(name):
    gait = builtin_presets()[name].gait
    scaled = scaled_gait(gait, 0.18, 0.234)
    assert scaled.clock.freq_hz == pytest.approx(
        scaled_freq_hz(gait.clock.freq_hz, 0.18, 0.234), abs=2e-6
    )
    # lengths and speeds with the leg (x 1.3): eq (13)'s rate for a CA stays the same
    assert scaled.yaw_rate.axle_m == pytest.approx(gait.yaw_rate.axle_m * 1.3, abs=1e-6)
    assert scaled.yaw_rate.speed_per_a_p == pytest.approx(
        gait.yaw_rate.speed_per_a_p * 1.3, abs=1e-6
    )
    changed = {k for k, v in scaled.flat().items() if v != gait.flat()[k]}
    assert changed == {"clock.freq_hz", "yaw_rate.axle_m", "yaw_rate.speed_per_a_p"}
    tiny = scaled_gait(gait, 0.18, 0.01)  # held within the schema's ranges
    assert tiny.yaw_rate.axle_m == 0.02


def test_the_start_of_a_file_robot_is_its_nearest_preset_scaled(tmp_path):
    small = read_description(robot_file(tmp_path / "s.yaml", "s", 0.06, "MG90S"))
    start = start_for(small, builtin_presets())
    assert (start.preset, start.leg_ref_m, start.leg_m) == ("micro-robust", 0.09, 0.12)
    micro = builtin_presets()["micro-robust"].gait
    assert start.gait == scaled_gait(micro, 0.09, 0.12)
    assert start.gait.clock.freq_hz == scaled_freq_hz(0.910486, 0.09, 0.12)
    assert "'micro-robust'" in start.describe() and "0.789 Hz" in start.describe()
    assert start.gait.yaw_rate.enabled and start.gait.tilt.enabled  # a tune starts closed-loop


# --- the recipe --------------------------------------------------------------------------------


def test_the_recipe_tunes_eight_tunable_fields_and_its_size_is_stated():
    tunable = {f"{g}.{f}" for g, fs in tunable_fields().items() for f in fs}
    assert len(START_RECIPE.names) == 8 and set(START_RECIPE.names) <= tunable
    assert "clock.freq_hz" in START_RECIPE.names
    # 10 generations x 8 candidates x 11 runs (7 cases, 2 CA pairs) x 20 s
    assert START_RECIPE.simulated_s(runs=11) == 17_600.0
    assert RECIPE["tune"] == ",".join(START_RECIPE.names) and RECIPE["select"] == "walking"
    assert CLASSIC["generations"] == 30 and CLASSIC["select"] == "best"  # with --base


def test_walking_means_no_run_fell():
    assert walks({"forward": {"fell": False}, "backward": {"fell": False}})
    assert not walks({"forward": {"fell": False}, "backward": {"fell": True}})
    assert not walks({})


def test_tune_help_states_the_recipe_defaults(capsys):
    with pytest.raises(SystemExit):
        main(["tune", "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert "(default: 10 without --base, the start's recipe; 30 with it)" in shown
    assert "the built-in preset nearest the robot's leg length" in shown


# --- end to end --------------------------------------------------------------------------------


def test_tune_robot_without_base_saves_tuned_robot_among_the_presets(work, capsys):
    robot = robot_file(work / "big.yaml", "big", 0.117, "DS3218")
    assert main(["tune", "--robot", str(robot), *TINY_TUNE, "--study", "s.log"]) == 0
    said = capsys.readouterr().out
    assert "starting from 'robust-3' (legs 0.180 m) scaled to legs 0.234 m" in said
    assert "clock 0.614 Hz" in said  # robust's 0.70 Hz x sqrt(0.18 / 0.234)
    saved = work / "data" / "presets" / "tuned-big.json"
    assert f"saved preset 'tuned-big' in {saved.parent}" in said
    assert not Path("out").exists()  # no -o: among the presets only
    chosen = resolve_set("tuned-big", "--params")  # what every --params and the dashboard do
    assert chosen.path == saved and not chosen.builtin
    assert chosen.pset.name == "tuned-big" and chosen.pset.robot == "big"
    # the recipe's fields were searched around the scaled start: the others are the start's,
    # ArtRo's default (the yaw-rate loop's lengths scaled with the legs)
    start = builtin_presets()[load_description("artro").default_preset].gait.flat()
    moved = {k for k, v in chosen.pset.gait.flat().items() if v != start[k]}
    assert moved and moved <= {*START_RECIPE.names, "yaw_rate.axle_m", "yaw_rate.speed_per_a_p"}
    # -o also writes the file where asked; the same study replays
    again = ["tune", "--robot", str(robot), *TINY_TUNE, "--study", "s.log", "-o", "t.json"]
    assert main(again) == 0
    assert load_parameter_set(Path("t.json")).name == "tuned-big"
    run = ["run", "--robot", str(robot), "--params", "tuned-big", "--duration", "3"]
    run += ["--warmup", "1"]
    assert main(run) == 0


def test_tune_events_say_what_the_dashboard_follows(work, capsys):
    """--events FILE: the start, each candidate scored with the best loss so far, and the result
    with the figures the command prints (what the dashboard's "Tune for this robot" reads)."""
    events = work / "events.jsonl"
    tune = ["tune", "--robot", "micro", *TINY_TUNE, "--study", "s.log", "--events", str(events)]
    assert main(tune) == 0
    said = capsys.readouterr().out
    read = [read_event(line) for line in events.read_text(encoding="utf-8").splitlines()]
    assert None not in read
    kinds = [e["event"] for e in read]
    assert kinds[0] == START and kinds[-1] == RESULT and RUNS in kinds
    trials = [e for e in read if e["event"] == TRIAL]
    assert [t["done"] for t in trials] == [1, 2] and {t["budget"] for t in trials} == {2}
    assert trials[-1]["best"] == min(t["loss"] for t in trials)
    result = read[-1]
    assert result["name"] == "tuned-micro" and result["trials"] == 2
    forward = next(row for row in result["figures"] if row["run"] == "forward")
    shown = "fell" if forward["fell"] else f"{forward['value']:+.2f} cm/s"
    assert f"target {forward['target']:+6.2f} cm/s   tuned {shown}" in said  # with units
    assert "next: artro run --robot micro --params tuned-micro" in said
    # --events -: standard output carries the events alone, the words go to standard error
    again = ["tune", "--robot", "micro", *TINY_TUNE, "--study", "s2.log", "--events", "-"]
    assert main(again) == 0
    both = capsys.readouterr()
    streamed = [read_event(line) for line in both.out.splitlines()]
    assert streamed and None not in streamed and streamed[-1]["event"] == RESULT
    assert "next: artro run --robot micro --params tuned-micro" in both.err


def quick_start() -> list[str]:
    """The README's quick start for your robot: the commands of the block after its marker."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    found = re.search(r"<!-- quick start:[^\n]*-->\n```sh\n(.*?)```", readme, re.DOTALL)
    assert found, "the README's 'Your robot' section has the quick start block"
    return [line.split(" #")[0].strip() for line in found[1].splitlines() if line.strip()]


#: what the test adds to a quick-start command to keep it small (documented options only)
SMALLER = {
    "tune": TINY_TUNE,
    "bench": ["--samples", "1", "--duration", "3", "--warmup", "0.5", "--threads", "1", "--json"],
}


def test_the_readme_quick_start_runs_as_written(work, capsys):
    """check -> suggest -> tune -> bench robust -> firmware on a robot of other link lengths and
    other servos (MG90S, short at the hip and ankle rolls by eq (1)), each line as the README has
    it, sizes cut."""
    lines = quick_start()
    assert [shlex.split(line)[1:3] for line in lines] == [
        ["robot", "check"],
        ["robot", "check"],
        ["tune", "--robot"],  # its name given: --suggest names the robot my-suggested
        ["bench", "robust"],
        ["firmware", "build"],
    ]
    raw = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
    raw |= {"name": "my", "servo": "MG90S"}
    raw.pop("total_mass_kg")
    raw["geometry"] |= {"thigh_m": 0.06, "shank_m": 0.06}
    Path("my.yaml").write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    for line in lines:
        words = shlex.split(line)
        assert words[0] == "artro"
        assert main([*words[1:], *SMALLER.get(words[1], [])]) == 0, line
    said = capsys.readouterr().out
    assert "l_hip_roll: MG90S -> " in said  # the suggestion swapped a servo in
    suggested = read_description(Path("my2.yaml"))  # its own file: my.yaml kept as written
    assert suggested.joints["l_hip_roll"].servo != "MG90S"
    assert read_description(Path("my.yaml")).joint_servo("l_hip_roll") == "MG90S"
    assert (
        Path("my2.yaml")
        .read_text(encoding="utf-8")
        .startswith("# my-suggested: written by `artro robot check my.yaml --suggest`,")
    )
    assert (work / "data" / "presets" / "tuned-my.json").is_file()
    header = (Path("my_firmware") / "gen" / "artro_params.h").read_text(encoding="utf-8")
    assert '"tuned-my"' in header


def test_a_tune_on_servos_too_weak_says_so_and_points_to_them(work, capsys):
    """A robot eq (1) finds short (MG90Ss on ArtRo's legs): the tune warned of nothing, saved a
    set that fell in every run and advised more generations or `--select walking`, which is
    already its default. It now says at the start that no tune makes up for the servos, marks
    each figure, and sends the falls to `robot check --suggest`."""
    robot = robot_file(work / "weak.yaml", "weak", 0.09, "MG90S")
    assert main(["tune", "--robot", str(robot), *TINY_TUNE, "--study", "s.log"]) == 0
    out, err = capsys.readouterr()
    assert "warning: eq (1) finds the servos of" in err
    assert f"a tune cannot make up for them: artro robot check {robot} --suggest" in err
    note = next(line for line in out.splitlines() if "note: the saved set falls in" in line)
    assert note.endswith(f"stronger servos first: artro robot check {robot} --suggest")
    assert "--select walking" not in note
    assert re.search(r"forward +target .* tuned (fell|.* (ok|off))$", out, re.MULTILINE)
    assert "(ok: within 25% of the target" in out
