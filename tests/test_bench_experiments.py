"""The experiments and benchmarks in bench/ run end to end on the real model; bad options fail."""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=300
    )


def test_ca_response_prints_the_sweep_and_the_pair():
    done = run_script("bench/ca_response.py", "--duration", "8", "--yaw-per-ca", "0.1")
    assert done.returncode == 0, done.stderr
    assert "a_y = 0.1 CA" in done.stdout.splitlines()[0]
    rows = [line for line in done.stdout.splitlines() if re.match(r"^[+-]0\.\d{3} ", line)]
    assert len(rows) == 11  # the SWEEP, -0.2 .. +0.2
    assert all(re.match(r"^[+-]0\.\d{3} +[+-]\d+\.\d\d +[+-]\d+\.\d\d$", r) for r in rows), rows
    assert re.search(r"CA = \+-0\.1: gain -?\d+\.\d\d ", done.stdout)


def test_ca_response_says_when_a_run_is_too_short_to_measure():
    done = run_script("bench/ca_response.py", "--duration", "4")
    assert done.returncode == 0, done.stderr
    assert "nothing measured after the 4 s warm-up: run longer" in done.stdout
    assert "CA = +-0.1: no steering figure" in done.stdout


def test_ca_phases_bins_add_up_to_the_cycle_turn():
    done = run_script("bench/ca_phases.py", "--duration", "2", "--bins", "4", "--ca", "0.1")
    assert done.returncode == 0, done.stderr
    sections = re.findall(
        r"CA = ([+-][\d.]+): trunk ([+-][\d.]+) deg per cycle\n.*\n((?: +\d+ .*\n?){4})",
        done.stdout,
    )
    assert [float(ca) for ca, _total, _rows in sections] == [0.0, 0.1, -0.1]
    for ca, total, rows in sections:
        cells = [line.split() for line in rows.strip().splitlines()]
        assert abs(sum(float(c[2]) for c in cells) - float(total)) < 0.05
        if float(ca) == 0.0:
            assert all(float(c[7]) == 0.0 for c in cells)  # CA = 0 adds nothing to itself


def test_bad_options_are_refused_with_what_is_allowed():
    out_of_range = run_script("bench/ca_response.py", "--set", "swing.v=9")
    assert out_of_range.returncode != 0
    assert "swing.v = 9.0 is out of range; allowed: 1.5 to 6.0" in out_of_range.stderr
    not_a_number = run_script("bench/ca_phases.py", "--set", "swing.v=fast")
    assert not_a_number.returncode != 0
    assert "'fast' is not a number" in not_a_number.stderr


def test_robust_factors_tries_each_departure_alone():
    done = run_script(
        "bench/robust_factors.py", "--presets", "tuned", "--duration", "3", "--warmup", "1"
    )
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if re.search(r" \d/9$", line)]
    # 16 ends of 11 fields' ranges that depart from the model, 4 tilts, 2 calibrations
    assert len(rows) == 22, done.stdout
    assert rows[0].startswith("friction 0.4") and "downhill behind" in rows[18]
    assert all(len(r[34:].split()) >= 10 for r in rows)  # nine cells and the pass count


def test_bench_batch_measures_both_goals_against_a_ceiling_of_the_same_runs():
    done = run_script("bench/bench_batch.py", "--seconds", "0.4", "--runs", "2", "--repeats", "1")
    assert done.returncode == 0, done.stderr
    for kind in ("nominal", "varied"):
        ceiling = re.search(
            rf"raw mj_step, {kind} *, the same walks in \d+ processes at once \(the ceiling\): +"
            r"(\d+) steps/s, +(\d+) per CPU s",
            done.stdout,
        )
        assert ceiling and int(ceiling[1]) > 0 and int(ceiling[2]) > 0, done.stdout
        batch = re.search(
            rf"batch, {kind} *, \d+ threads: +\d+ steps/s end to end = (\d\.\d+) of the ceiling"
            r".* = (\d\.\d+) of raw's .*plan (\d+\.\d) ms.*lanes busy (\d+\.\d) % of the call",
            done.stdout,
        )
        assert batch, done.stdout
        assert 0 < float(batch[1]) < 2 and 0 < float(batch[2]) < 2 and float(batch[3]) > 0
        assert 0 < float(batch[4]) <= 100


def test_bench_rollout_threads_compares_rollout_alone_with_raw_processes():
    done = run_script("bench/bench_rollout_threads.py", "--repeats", "1", "--runs", "2")
    assert done.returncode == 0, done.stderr
    ratios = re.findall(r"rollout alone, (.+?): median (\d\.\d+) of raw", done.stdout)
    assert len(ratios) == 3 and ratios[0][0] == "1 thread", done.stdout
    assert all(0 < float(value) < 2 for _, value in ratios)
