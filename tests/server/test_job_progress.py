"""How far a long job is and how long it has left (issue 56, item 13): `artro tune` says
"generation 2 of 2" and the time left of the whole tune (on its progress line and in its RUNS
events, which the dashboard's tune job follows), and the dashboard's robustness job says its runs
walked of all and the time left. Real CLI subprocesses and a real server; the waiting is on the
job's state, never on the clock, and no time is asserted but the end's nothing left."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from app.analysis.robot_tune import RUNS, read_event
from app.evaluation.progress import about, time_left_s
from app.server.jobs.robustness_job import runs_of
from tests.testing.server_harness import client, running_server, wait_for

ROOT = Path(__file__).resolve().parents[2]


def test_the_time_left_is_paced_on_what_was_done_and_said_in_words():
    assert time_left_s(10.0, 0, 40) is None  # nothing done: no pace yet
    assert time_left_s(10.0, 10, 40) == pytest.approx(30.0)
    assert time_left_s(10.0, 40, 40) == 0.0
    assert [about(s) for s in (None, 40.4, 89, 90, 725, 7500)] == [
        "~?", "~40 s", "~89 s", "~2 min", "~12 min", "~2 h 5 min",
    ]  # fmt: skip


@pytest.mark.slow
def test_artro_tune_says_the_generation_of_how_many_and_the_time_left(tmp_path):
    events = tmp_path / "events.jsonl"
    command = [
        sys.executable, "-m", "app.cli", "tune", "--base", "paper",
        "--tune", "clock.freq_hz,short.amp_base", "--generations", "2", "--popsize", "2",
        "--duration", "5.6", "--warmup", "0.5", "--cases", "forward", "--threads", "1",
        "--study", str(tmp_path / "study.log"), "--out", str(tmp_path / "out.json"),
        "--events", str(events),
    ]  # fmt: skip
    env = os.environ | {"ARTRO_DATA_DIR": str(tmp_path / "data")}
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stderr.splitlines()  # not a terminal: a line per tenth of each generation
    for generation in (1, 2):
        mine = [line for line in lines if line.startswith(f"generation {generation} of 2: ")]
        assert mine, lines
        assert all(" left in all, best loss " in line for line in mine), mine
    last = [line for line in lines if line.startswith("generation 2 of 2: ")][-1]
    assert ", ~0 s left in all," in last, last  # the tune's end: nothing left
    runs = [
        e
        for e in map(read_event, events.read_text("utf-8").splitlines())
        if e and e["event"] == RUNS
    ]
    assert {e["generations"] for e in runs} == {2}
    assert all(e["left_s"] is None or e["left_s"] >= 0 for e in runs)
    # the first generation's estimate counts the second one too: more left than its own runs
    first = [e for e in runs if e["generation"] == 0 and e["left_s"] is not None]
    assert first and first[-1]["done"] == first[-1]["total"] and first[-1]["left_s"] > 0
    assert runs[-1]["done"] == runs[-1]["total"] and runs[-1]["left_s"] == 0


@pytest.mark.slow
def test_the_robustness_job_says_its_runs_walked_of_all_and_the_time_left(tmp_path):
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        job_id = http.post("/api/jobs/robustness", json={"samples": 4}).json()["id"]

        def walked():
            now = http.get(f"/api/jobs/{job_id}").json()
            detail = now["detail"] or {}
            return now if now["status"] != "running" or detail.get("runs", 0) >= 1 else None

        now = wait_for(walked, "a run of the job walked", attempts=6000)
        assert now["status"] == "running", now
        detail = now["detail"]
        assert detail["runs_total"] == runs_of(4) == 45
        assert 1 <= detail["runs"] < 45 and detail["left_s"] > 0
        assert now["progress"] == pytest.approx(detail["runs"] / 45, abs=1 / 45)
        assert http.delete(f"/api/jobs/{job_id}").status_code == 200
