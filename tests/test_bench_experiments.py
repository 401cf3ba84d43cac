"""The experiments and benchmarks in bench/ run end to end on the real model and write their
figures as JSON (bench/results.py); the checks read that JSON, never the printed text. Bad
options fail with what is allowed."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def run_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=300
    )


def run_bench(tmp_path: Path, name: str, *args: str) -> dict[str, Any]:
    """Runs bench/<name>.py with `args`, its results written under tmp_path: the document."""
    out = tmp_path / f"{name}.json"
    done = run_script(f"bench/{name}.py", *args, "--json", str(out))
    assert done.returncode == 0, done.stderr
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["bench"] == name
    assert doc["command"] == " ".join(["python", f"bench/{name}.py", *args])
    env = doc["environment"]
    assert env["machine"]["logical_cpus"] >= 1 and env["machine"]["cpu_model"]
    assert env["mujoco"] and env["numpy"] and env["python"] and env["project_version"]
    assert env["finished_utc"].endswith("+00:00")
    return doc


def finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def test_ca_response_writes_the_sweep_and_the_pair(tmp_path):
    doc = run_bench(tmp_path, "ca_response", "--duration", "8", "--yaw-per-ca", "0.1")
    assert doc["arguments"]["duration"] == 8.0 and doc["arguments"]["yaw_per_ca"] == 0.1
    assert "a_y = 0.1 CA" in doc["figures"]["variant"]
    sweep = doc["figures"]["sweep"]
    assert [row["ca"] for row in sweep] == [
        -0.2, -0.15, -0.1, -0.05, -0.025, 0.0, 0.025, 0.05, 0.1, 0.15, 0.2
    ]  # fmt: skip
    for row in sweep:
        assert row["measured"] and not row["fell"], row
        assert finite(row["turn_deg_s"]) and finite(row["eq13_turn_deg_s"]), row
        assert row["a_y"] == pytest.approx(0.1 * row["ca"])
    pair = doc["figures"]["pair_ca_0.1"]
    assert finite(pair["gain"]) and finite(pair["bend"])
    assert doc["headline"]["steering gain, CA ±0.1 (eq 13: 1)"] == pair["gain"]


def test_ca_response_says_when_a_run_is_too_short_to_measure(tmp_path):
    doc = run_bench(tmp_path, "ca_response", "--duration", "4")
    sweep = doc["figures"]["sweep"]
    assert len(sweep) == 11
    assert all(not row["measured"] and row["turn_deg_s"] is None for row in sweep)
    assert doc["figures"]["pair_ca_0.1"] is None  # no steering figure
    assert doc["headline"]["steering gain, CA ±0.1 (eq 13: 1)"] is None


def test_ca_phases_bins_add_up_to_the_cycle_turn(tmp_path):
    doc = run_bench(tmp_path, "ca_phases", "--duration", "2", "--bins", "4", "--ca", "0.1")
    walks = doc["figures"]["walks"]
    assert [w["ca"] for w in walks] == [0.0, 0.1, -0.1]
    for w in walks:
        bins = w["bins"]
        assert [b["bin"] for b in bins] == [0, 1, 2, 3]
        assert abs(sum(b["trunk_deg_per_cycle"] for b in bins) - w["trunk_deg_per_cycle"]) < 0.05
        assert all(finite(b["l_load_n"]) and finite(b["r_load_n"]) for b in bins)
        if w["ca"] == 0.0:  # CA = 0 adds nothing to itself
            assert all(b["ca_adds_trunk_deg_per_cycle"] == 0.0 for b in bins)
        else:
            zero = walks[0]["bins"]
            for b, z in zip(bins, zero, strict=True):
                added = b["trunk_deg_per_cycle"] - z["trunk_deg_per_cycle"]
                assert b["ca_adds_trunk_deg_per_cycle"] == pytest.approx(added, abs=1e-4)


def test_bad_options_are_refused_with_what_is_allowed(tmp_path):
    out = tmp_path / "never.json"
    out_of_range = run_script("bench/ca_response.py", "--set", "swing.v=9", "--json", str(out))
    assert out_of_range.returncode != 0
    assert "swing.v = 9.0 is out of range; allowed: 1.5 to 6.0" in out_of_range.stderr
    not_a_number = run_script("bench/ca_phases.py", "--set", "swing.v=fast", "--json", str(out))
    assert not_a_number.returncode != 0
    assert "'fast' is not a number" in not_a_number.stderr
    assert not out.exists()  # a refused run writes no results


def test_robust_factors_tries_each_departure_alone(tmp_path):
    doc = run_bench(
        tmp_path, "robust_factors", "--presets", "tuned", "--duration", "3", "--warmup", "1"
    )
    tuned = doc["figures"]["presets"]["tuned"]
    rows = tuned["departures"]
    # 16 ends of 11 fields' ranges that depart from the model, 4 tilts, 2 calibrations
    assert len(rows) == 22
    assert rows[0]["departure"].startswith("friction 0.4")
    assert "downhill behind" in rows[18]["departure"]
    for row in rows:
        assert len(row["cases"]) == 9  # nine cells and the pass count
        assert row["passed"] == sum(c["passes"] for c in row["cases"])
        for c in row["cases"]:
            assert not (c["passes"] and c["fell"])
            if c["kind"] != "spot" and c["figure"] is not None and c["nominal_figure"]:
                assert c["share_of_nominal"] == pytest.approx(
                    c["figure"] / c["nominal_figure"], rel=1e-4
                )
    assert tuned["passed"] == sum(r["passed"] for r in rows) and tuned["runs"] == 22 * 9


def test_sensor_factors_tries_each_sensor_error_alone(tmp_path):
    """The closed-loop preset's sensors, each error alone: the robot's own IMU delay (17 ms)
    and an uncalibrated accelerometer (2.9°) among them."""
    doc = run_bench(
        tmp_path, "sensor_factors", "--presets", "robust", "--duration", "3", "--warmup", "1"
    )
    robust = doc["figures"]["presets"]["robust"]
    labels = [row["departure"] for row in robust["departures"]]
    assert labels[:2] == ["imu_delay_ms 17", "imu_delay_ms 25"]
    assert "IMU tilted 2.9° behind" in labels and "IMU tilted 1° left" in labels
    assert robust["runs"] == 13 * 9 == sum(len(row["cases"]) for row in robust["departures"])


def test_bench_batch_measures_both_goals_against_a_ceiling_of_the_same_runs(tmp_path):
    doc = run_bench(tmp_path, "bench_batch", "--seconds", "0.4", "--runs", "2", "--repeats", "1")
    kinds = doc["figures"]["kinds"]
    assert set(kinds) == {"nominal", "varied"}
    for kind in kinds.values():
        assert kind["ceiling"]["steps_per_s"] > 0 and kind["ceiling"]["steps_per_cpu_s"] > 0
        batch = kind["batch"]
        # ratios of two timings: sane, not tight (another process on the machine moves them)
        assert 0 < batch["of_ceiling"] < 50 and 0 < batch["of_raw_per_cpu_s"] < 50
        assert len(batch["of_ceiling_repeats"]) == 1
        assert batch["stage_ms_per_run"]["plan"] > 0 and batch["planning_alone_ms"] > 0
        assert 0 < batch["lanes_busy_pct"] <= 100
        assert 0 < kind["processes"]["of_ceiling"] < 50
        assert kind["walks"] == 2 and 0 <= kind["falls"] <= 2
    closed = doc["figures"]["closed_loop"]  # the closed loop's cost against the open loop
    assert closed["laws"] == {
        "every law": ["tilt", "yaw_rate", "damping", "cop", "timing"],
        "robust's laws": ["tilt", "yaw_rate", "damping"],  # the shipped preset's (no CoP)
    }
    for name in closed["laws"]:
        assert 0.5 < closed["of_open"][name] < 50 and len(closed["of_open_repeats"][name]) == 1
    # on worker processes, wall time (a walk's closed-loop runs go as whole groups)
    assert 0.2 < closed["processes_robust_laws_wall_of_open"] < 50
    assert len(closed["processes_robust_laws_wall_of_open_repeats"]) == 1
    # a frame a call against fifty frames a call (on runs this short, timing noise alone)
    assert closed["floor_one_frame_per_call_of_open"] > 0 and len(closed["floor_repeats"]) == 1


def test_bench_rollout_threads_compares_rollout_alone_with_raw_processes(tmp_path):
    doc = run_bench(tmp_path, "bench_rollout_threads", "--repeats", "1", "--runs", "2")
    ratios = doc["figures"]["ratios"]
    assert len(ratios) == 3 and ratios[0]["way"] == "1 thread"
    # ratios of two timings: sane, not tight (another process on the machine moves them)
    assert all(0 < r["median"] < 50 and len(r["repeats"]) == 1 for r in ratios)


def test_bench_pipeline_session_and_firmware_write_their_figures(tmp_path):
    pipeline = run_bench(tmp_path, "bench_pipeline", "--seconds", "0.2", "--repeats", "1")[
        "figures"
    ]
    for key in ("raw_step_replay", "raw_c_loop", "pipeline"):
        assert pipeline[f"{key}_steps_per_s"] > 0
    assert pipeline["pipeline_of_replay"] > 0 and pipeline["gait_hardware_us_per_frame_alone"] > 0
    session = run_bench(tmp_path, "bench_session", "--frames", "10")["figures"]
    assert session["live_frame_ms"] > 0 and session["ghost_frame_ms"] > 0
    assert session["ring_frames"] > 0 and session["ring_mb"] > 0
    firmware = run_bench(tmp_path, "bench_firmware", "--frames", "50")["figures"]
    cases = {(c["laws"], c["motion"]) for c in firmware["cases"]}
    assert cases == {(laws, m) for laws in (False, True) for m in ("forward", "turn", "curve")}
    assert firmware["spare_worst"] == min(c["spare_worst"] for c in firmware["cases"])
    for case in firmware["cases"]:
        parts = case["cycles_per_frame"]
        assert parts["plan"]["median"] > 0 and parts["sensors"]["median"] > 0
        assert case["set_reached_frames"] and case["twi_transactions_per_frame"] == 1
    assert 0 < firmware["flash_bytes"] < firmware["flash_size_bytes"]


def test_bench_warp_host_times_the_host_work_open_and_closed_loop(tmp_path):
    args = ("--samples", "1", "--duration", "1", "--processes", "2")
    figures = run_bench(tmp_path, "bench_warp_host", *args)["figures"]
    assert figures["worlds"] == 18 and figures["plan"]["ms_per_world"] > 0
    assert figures["host_processes"]["same_controls_and_initial_rows"] is True
    closed = figures["closed_loop"]  # robust's worlds of every case: one walk, one group
    assert closed["worlds"] == 18 and closed["groups"] == 1 and closed["frames"] == 50
    assert closed["us_per_world_frame"] > 0 and closed["plan_ms_per_frame"] > 0


def test_bench_api_load_writes_what_the_clients_saw(tmp_path):
    doc = run_bench(
        tmp_path, "bench_api_load",
        "--seconds", "2", "--warmup", "1", "--pollers", "2", "--sockets", "1",
    )  # fmt: skip
    figures = doc["figures"]
    assert figures["rtf_samples"] > 0 and figures["rtf_min"] > 0
    assert figures["polls_per_s"] > 0 and len(figures["ws_frames_received"]) == 1
    assert doc["arguments"]["pollers"] == 2


def test_bench_server_memory_reads_the_servers_rss_over_rounds_of_jobs(tmp_path):
    doc = run_bench(tmp_path, "bench_server_memory", "--rounds", "2")
    figures = doc["figures"]
    assert figures["statuses"] and sum(figures["statuses"].values()) == 4  # 2 jobs a round
    assert set(figures["statuses"]) <= {"cancelled", "done"}
    assert len(figures["rss_mib_every_round"]) == 3 and figures["rss_mib_start"] > 10
    assert finite(figures["mib_per_round_second_half"])
