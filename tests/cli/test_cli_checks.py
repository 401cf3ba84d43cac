"""The CLI's bad input (issue 18, item 10), through the installed `artro` command: each is an
error that names what is allowed, exit status 2, no traceback, nothing written or run."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ARTRO = shutil.which("artro", path=str(Path(sys.executable).parent)) or "artro"
ROBOT_FILE = Path(__file__).resolve().parents[2] / "models" / "robots" / "micro.yaml"

CASES = {
    "tune: duration within the warm-up": (
        ["tune", "--generations", "1", "--popsize", "2", "--duration", "1"],
        "allowed: --duration of at least",
    ),
    "tune: duration equal to the warm-up": (
        ["tune", "--duration", "4", "--warmup", "4", "--tune", "swing.v"],
        "leaves no whole gait cycle",
    ),
    "tune: no population": (["tune", "--popsize", "0"], "popsize must be a whole number 2 to"),
    "tune: nan weight": (["tune", "--band-weight", "nan"], "band weight must be 0 to 1000"),
    "tune: infinite sigma": (["tune", "--sigma", "inf"], "sigma must be > 0 and at most 1"),
    "tune: no generations": (["tune", "--generations", "0"], "generations must be a whole"),
    "run: infinite duration": (["run", "--duration", "inf"], "duration must be > 0 and at most"),
    "run: a duration of ages": (["run", "--duration", "1e12"], "at most 3600"),
    "run: all warm-up": (
        ["run", "--warmup", "10", "--duration", "2"],
        "allowed: --duration of at least 11",
    ),
    "run: nan warm-up": (["run", "--warmup", "nan"], "warmup must be 0 to 3600"),
    "firmware: --pty with comparison options": (
        ["firmware", "run", "--pty", "--frames", "5", "--json"],
        "--frames, --json belong to the comparison run",
    ),
    "firmware: --pty with a VCD": (["firmware", "run", "--pty", "--vcd", "x.vcd"], "--vcd belongs"),
    "firmware: frames for hours": (["firmware", "run", "--frames", "1000000"], "2 to 15000"),
    "serve: a port past 65535": (["serve", "--port", "70000"], "--port must be a whole number 1"),
    "serve: a 3D view's port past 65535": (
        ["serve", "--viser-port", "70000"],
        "--viser-port must be a whole number 0 to 65535",
    ),
    "bench: infinite duration": (
        ["bench", "robust", "--duration", "inf"],
        "--duration must be > 0 and at most 3600",
    ),
    "bench: variations by the billion": (
        ["bench", "robust", "--samples", "99999999999"],
        "--samples must be a whole number 1 to 100000",
    ),
    "bench: no threads": (["bench", "robust", "--threads", "-3"], "--threads must be a whole"),
    "tune: robust by the billion": (
        ["tune", "--robust", "99999999999"],
        "--robust must be a whole number 0 to 100000",
    ),
    "tune: nothing to tune": (
        ["tune", "--base", "paper", "--tune", ",,", "--generations", "1", "--popsize", "2"],
        "nothing to tune: name at least one of",
    ),
    "tune: a parameter twice": (
        ["tune", "--base", "paper", "--tune", "swing.v,swing.v", "--generations", "1"],
        "swing.v named twice",
    ),
    "tune: a negative seed": (["tune", "--seed", "-1"], "seed must be a whole number 0 to 4294967"),
    "tune: a device as the study": (
        ["tune", "--tune", "swing.v", "--study", "/dev/full"],
        "/dev/full is not a regular file",
    ),
    "export: a full disk": (
        ["export", "--format", "json", "-o", "/dev/full"],
        "cannot write /dev/full: No space left on device",
    ),
    # the fourteenth session's probe of every command's options
    "tune: a device as the output": (
        ["tune", "--base", "tuned", "--generations", "1", "-o", "/dev/full"],
        "/dev/full is not a regular file (a device, a pipe or a socket)",  # root: was replaced
    ),
    "tune: a folder as the output": (["tune", "-o", "/tmp"], "/tmp is a folder; give the file"),
    "tune: an empty output": (["tune", "-o", ""], "an empty file name"),
    "bench: a file as the folder": (["bench", "robust", "--out", "/dev/null"], "is a file, not"),
    "bench: less than a cycle measured": (
        ["bench", "robust", "--samples", "2", "--duration", "4", "--warmup", "3.9"],
        "leaves no whole gait cycle after --warmup 3.9",
    ),
    "bench paper: less than a cycle measured": (
        ["bench", "paper", "--quick", "--duration", "2", "--warmup", "1.9"],
        "leaves no whole gait cycle after --warmup 1.9",
    ),
    "bench paper: an option of bench robust": (
        ["bench", "paper", "--quick", "--json", "--samples", "3"],
        "--samples, --json: options of bench robust",
    ),
    "run: a robot as the set": (
        ["run", "--params", str(ROBOT_FILE)],
        "this is a robot description, not a parameter set: a robot is given with --robot",
    ),
    "run: an empty set": (["run", "--params", ""], "--params is empty; leave it out"),
    "bench: empty presets": (["bench", "robust", "--presets", ""], "--presets is empty"),
    "tune: empty cases": (["tune", "--cases", ""], "--cases is empty"),
    "export: an empty output": (["export", "--format", "yaml", "-o", ""], "-o is empty"),
    "firmware: an empty VCD": (["firmware", "run", "--vcd", ""], "an empty file name"),
    "bench: a range twice": (
        ["bench", "robust", "--range", "friction=0.3:0.6", "--range", "friction=0.2:0.5"],
        "--range friction given twice",
    ),
    "tune: a range without --robust": (
        ["tune", "--range", "friction=0.3:0.6"],
        "--range narrows the variations of --robust N",
    ),
    "tune: keeping the base without --robust": (
        ["tune", "--keep-base", "2"],
        "--keep-base keeps the base's passes in --robust N's worlds: give --robust",
    ),
    "tune: a negative keep weight": (["tune", "--keep-base", "-1"], "--keep-base must be"),
    "calibrate-ca: threads by the hundred thousand": (
        ["calibrate-ca", "--threads", "100000"],
        "--threads must be a whole number 1 to 1024",
    ),
    "calibrate-ca: no threads": (["calibrate-ca", "--threads", "-1"], "--threads must be a whole"),
    "calibrate-ca: no duration": (["calibrate-ca", "--duration", "0"], "--duration must be > 0"),
    "calibrate-ca: a duration of ages": (["calibrate-ca", "--duration", "1e9"], "at most 3600"),
    "calibrate-ca: a negative warm-up": (["calibrate-ca", "--warmup", "-1"], "--warmup must be"),
    "calibrate-ca: less than a cycle measured": (
        ["calibrate-ca", "--duration", "4", "--warmup", "3.9"],
        "leaves no whole gait cycle after --warmup 3.9",
    ),
    "calibrate-ca: a step too short": (["calibrate-ca", "--a-p", "0"], "allowed |a_p| >= 0.02"),
    "calibrate-ca: a_p against the direction": (
        ["calibrate-ca", "--a-p", "-0.07", "--direction", "forward"],
        "walks the other way than --direction forward",
    ),
    "serve: a file as the data folder": (
        ["serve", "--data-dir", "/dev/null", "--port", "1"],
        "/dev/null is a file, not a folder",
    ),
    "serve: an empty address": (["serve", "--host", "", "--port", "1"], "an empty address"),
    "export: a firmware folder where a file is": (
        ["export", "--format", "firmware", "-o", "/dev/full"],
        "cannot write the firmware folder /dev/full: Not a directory (/dev/full/src)",
    ),
    # the fifteenth session: paths, ranges and options left unsaid
    "run: a folder as the set": (["run", "--params", "/"], "/ is a folder for --params"),
    "run: a device as the set": (["run", "--params", "/dev/null"], "/dev/null is not a regular"),
    "calibrate-ca: a folder as output": (["calibrate-ca", "-o", "/"], "/ is a folder; give the"),
    "firmware: build into a device": (
        ["firmware", "build", "-o", "/dev/full"],
        "/dev/full is a file, not a folder",
    ),
    "firmware: build inside a device": (
        ["firmware", "build", "-o", "/dev/full/fw"],
        "/dev/full/fw is inside a file, not a folder",
    ),
    "firmware: nan frames": (["firmware", "run", "--frames", "nan"], "whole number 2 to 15000"),
    "run: an empty curve amount": (["run", "--ca", ""], "--ca must be -0.5 to 0.5, got ''"),
    "run: a curve amount out of range": (["run", "--ca", "0.9"], "--ca must be -0.5 to 0.5"),
    "link: nan baud": (["link", "--dry-run", "--baud", "nan"], "--baud must be a whole number"),
    "bench: --wait-workers without a cluster": (
        ["bench", "robust", "--wait-workers", "5"],
        "--wait-workers is how long to wait for a --cluster's workers",
    ),
    "serve: --wait-workers without a cluster": (
        ["serve", "--wait-workers", "5", "--port", "1"],
        "--wait-workers is how long to wait",
    ),
    "link: a dashboard with one set": (
        ["link", "--dry-run", "--params", "tuned", "--server", "http://x:1"],
        "--params sends one set and follows no dashboard",
    ),
    "link: a port with --dry-run": (
        ["link", "--dry-run", "--port", "/dev/ttyUSB0"],
        "--dry-run opens no port",
    ),
    "run: an empty variation": (["run", "--vary", ""], "an empty variation; leave it out"),
    "robot check: -o without --suggest": (
        ["robot", "check", "artro", "-o", "x.yaml"],
        "-o FILE goes with --suggest",
    ),
    "tune: events into a folder": (["tune", "--events", "/"], "/ is a folder"),
    "tune: a nan robust weight": (["tune", "--robust-weight", "nan"], "--robust-weight must be"),
    # the sixteenth session: a file two folders below a file (the parent alone was looked at)
    "calibrate-ca: output deep inside a device": (
        ["calibrate-ca", "-o", "/dev/full/a/ca.json"],
        "/dev/full/a/ca.json is inside a file, not a folder",
    ),
    "tune: events deep inside a device": (
        ["tune", "--events", "/dev/full/a/e.jsonl"],
        "/dev/full/a/e.jsonl is inside a file, not a folder",
    ),
}
# issue 56 item 8: a name the file system refuses (over 255 bytes) was an OSError traceback
LONG = "a" * 300
TOO_LONG = "has a name of 30"  # ... bytes (aaa...aaa); a name is at most 255 bytes
CASES |= {
    "a name too long: " + " ".join(a for a in args if LONG not in a): (args, TOO_LONG)
    for args in (
        ["robot", "check", "artro", "--suggest", "-o", f"{LONG}.yaml"],
        ["firmware", "run", "--vcd", f"{LONG}.vcd"],
        ["tune", "--events", LONG],
        ["tune", "--study", f"{LONG}.log"],
        ["bench", "robust", "--out", LONG],
        ["calibrate-ca", "-o", f"{LONG}.json"],
        ["firmware", "build", "-o", LONG],
        ["robot", "export-mjcf", "artro", "-o", f"{LONG}.xml"],
        ["serve", "--data-dir", LONG, "--port", "1"],
        ["tune", "--base", "paper", "-o", f"x/{LONG}/y.json"],
        ["tune", "--study", f"sqlite:///{LONG}.db"],
    )
}
CASES |= {
    "robot check: -o - (it wrote a file named -)": (
        ["robot", "check", "artro", "--suggest", "-o", "-"],
        "- is not a file name here: leave the option out for its default",
    ),
    # issue 56 item 18: an option a command does not take was said with artro's usage
    "link: an unknown option, said with link's usage": (
        ["link", "--dry-run", "--robots", "micro"],
        "usage: artro link [-h]",
    ),
    "firmware build: an unknown option, said with its usage": (
        ["firmware", "build", "--motion", "a_p=0.05"],
        "artro firmware build: error: unrecognized arguments: --motion a_p=0.05",
    ),
    # issue 56 item 18: a push after the run's end never acted, and the run seemed to bear it
    "run: a push after the end": (
        ["run", "--vary", "push_n_s=1,push_time_s=40"],
        "--vary push_time_s=40 in a run of --duration 30: a push then comes after the run's end",
    ),
    "firmware run: a push after the last frame": (
        ["firmware", "run", "--vary", "push_n_s=1,push_time_s=5"],
        "in a run of 250 frames of 0.02 s: a push then comes after the run's end (5 s)",
    ),
    "bench: pushes drawn after the end": (
        ["bench", "robust", "--range", "push_n_s=0:2", "--duration", "10"],
        "--range push_time_s reaches 12 s (its default 6:12): a push then comes after the run's",
    ),
    "tune: pushes drawn after the end": (
        ["tune", "--robust", "2", "--range", "push_n_s=1:2", "--range", "push_time_s=1:30"],
        "allowed: --range push_time_s below 20 s, or longer runs",
    ),
    "robot check: YAML into a .json": (
        ["robot", "check", "artro", "--suggest", "-o", "x.json"],
        "x.json: this writes a YAML description; give a file ending in .yaml or .yml",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_is_an_error_that_says_what_is_allowed(tmp_path, case):
    args, message = CASES[case]
    out = subprocess.run([ARTRO, *args], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert out.returncode == 2, (out.returncode, out.stdout[-2000:], out.stderr[-2000:])
    assert message in out.stderr, out.stderr
    assert "Traceback" not in out.stderr
    assert list(tmp_path.iterdir()) == []  # no results file, no VCD: nothing ran


def test_a_tune_whose_events_cannot_be_written_says_so_before_the_work(tmp_path):
    """`--events /dev/full`: the first event fails, named by its option, not as raw errno."""
    out = subprocess.run(
        [ARTRO, "tune", "--events", "/dev/full", "--generations", "1", "--popsize", "2",
         "--duration", "6", "--warmup", "1", "--study", str(tmp_path / "study.log")],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 2, (out.stdout[-2000:], out.stderr[-2000:])
    assert "cannot write --events /dev/full: No space left on device" in out.stderr
    assert "Traceback" not in out.stderr and "tuned" not in out.stdout.split("\n")[-2]


@pytest.mark.parametrize("mode", [0o644, 0o444])
def test_suggest_writes_over_no_file_but_a_writable_description(tmp_path, mode):
    """Issue 56 item 8: `--suggest -o notes.yaml` replaced an unrelated file (a read-only one
    too, as root) without a word; now refused, the file as it was. A description written
    before (a writable one) is replaced, and that said."""
    notes = tmp_path / "notes.yaml"
    notes.write_text("my notes\n", encoding="utf-8")
    notes.chmod(mode)
    cmd = [ARTRO, "robot", "check", "artro", "--suggest", "-o", str(notes)]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    why = "is a read-only file" if mode == 0o444 else "exists and is not a robot description"
    assert why in out.stderr and "give another file" in out.stderr, out.stderr
    assert notes.read_text(encoding="utf-8") == "my notes\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.yaml"]


def test_suggest_says_it_replaces_the_description_written_before(tmp_path):
    cmd = [ARTRO, "robot", "check", "artro", "--suggest", "-o", "mine.yaml"]
    first = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert first.returncode == again.returncode == 0, (first.stderr, again.stderr)
    assert "replacing" not in first.stdout
    assert "wrote mine.yaml (1.650 kg, replacing the robot 'artro-suggested' there)" in again.stdout
