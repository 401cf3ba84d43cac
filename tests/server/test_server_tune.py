""" "Tune for this robot" on a real server (issue 32 item 4): `artro tune --robot`'s recipe as a
job, a child process writing a real Optuna journal under the data folder; progress, cancel,
one tune at a time, bad input refused with nothing changed, and a tiny tune's result loaded as
one undoable change. The waiting is on the job's state, with a deadline, never on the clock."""

from __future__ import annotations

import json
import os
from pathlib import Path

import optuna
import pytest
import yaml
from optuna.storages import JournalStorage
from optuna.storages.journal import JournalFileBackend

from app.robots.library import MAX_DESCRIPTION_BYTES, load_description, read_description
from app.study.study_files import WriterLock
from tests.study.test_tune_robot import robot_file
from tests.testing.server_harness import client, running_server, wait_for

DEFAULT = load_description("artro").default_preset  # the set the server starts with

pytestmark = pytest.mark.slow

#: the recipe's fields, the sizes cut: forward and its CA pair, one whole cycle of the slowest
#: clock after a 0.5 s warm-up (as tests/study/test_tune_robot.py)
TINY = {"generations": 1, "popsize": 2, "duration_s": 5.6, "warmup_s": 0.5, "cases": ["forward"]}
#: long enough to be cancelled while it runs
LONG = TINY | {"generations": 20, "popsize": 4}
TUNE_DEADLINE = 2400  # polls of 50 ms: 2 min


def trials_in(study: Path, name: str) -> int:
    storage = JournalStorage(JournalFileBackend(str(study)))
    return len(optuna.load_study(study_name=name, storage=storage).trials)


def test_a_tiny_tune_loads_tuned_robot_as_one_undoable_change(tmp_path):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        before = http.get("/api/params").json()
        assert http.get("/api/tune").status_code == 404  # none yet
        assert http.get("/api/state").json()["tune"] is None  # what a page reads first
        started = http.post("/api/jobs/tune", json=TINY)
        assert started.status_code == 202, started.text
        job_id = started.json()["id"]
        assert started.headers["Location"] == f"/api/jobs/{job_id}"
        job = app.state.services.axle_fitter.jobs.get(job_id)
        assert job.finished.wait(TUNE_DEADLINE * 0.05), "the tune did not finish"
        done = http.get(f"/api/jobs/{job_id}").json()
        assert done["status"] == "done" and done["progress"] == 1.0, done
        assert done["detail"]["trials"] == done["detail"]["budget"] == 2
        assert done["detail"]["best_loss"] == pytest.approx(done["result"]["loss"])
        result = done["result"]
        assert result["preset"] == "tuned-artro" and result["applied"] is True
        # the figures the command prints: forward against its target, the CA pair's steering
        runs = {row["run"]: row for row in result["figures"]}
        assert set(runs) == {"forward", "curve forward"}
        assert runs["forward"]["target"] == pytest.approx(3.8) and runs["forward"]["unit"] == "cm/s"
        # saved among the presets, loaded (the motion in use kept) as one change
        assert "tuned-artro" in [p["name"] for p in http.get("/api/presets").json()["presets"]]
        after = http.get("/api/params").json()
        assert after["version"] == result["params_version"] == before["version"] + 1
        assert after["name"] == "tuned-artro" and after["motion"] == before["motion"]
        assert after["gait"] == http.get("/api/presets/tuned-artro").json()["gait"]
        assert after["gait"] != before["gait"]
        # the study: a real Optuna journal in the data folder, one trial per candidate
        study = tmp_path / "studies" / "tune-artro.log"
        assert Path(result["study"]) == study and trials_in(study, result["study_name"]) == 2
        # one undo goes back to the set before
        undone = http.post("/api/params/undo").json()
        assert (undone["name"], undone["gait"]) == (before["name"], before["gait"])
        assert http.get("/api/tune").json()["id"] == job_id
        assert http.get("/api/state").json()["tune"] == {"id": job_id, "status": "done"}
        assert http.get("/api/jobs/tune").status_code == 405
        assert result["replaced"] is False
        # a second tune of the robot replaces its preset, and says so (the study resumes)
        again = http.post("/api/jobs/tune", json=TINY).json()["id"]
        assert app.state.services.axle_fitter.jobs.get(again).finished.wait(TUNE_DEADLINE * 0.05)
        second = http.get(f"/api/jobs/{again}").json()
        assert second["status"] == "done" and second["result"]["replaced"] is True, second


def test_a_tune_reports_progress_refuses_a_second_and_cancels_with_nothing_loaded(tmp_path):
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        before = http.get("/api/params").json()
        job_id = http.post("/api/jobs/tune", json=LONG).json()["id"]
        # one tune at a time: 409, saying what is allowed, and the running one untouched
        second = http.post("/api/jobs/tune", json=TINY)
        assert second.status_code == 409, second.text
        said = second.json()["message"]
        assert "already running" in said and f"DELETE /api/jobs/{job_id}" in said
        # nor may the robot change under it
        assert http.put("/api/robot", json={"name": "micro"}).status_code == 409

        def scored():
            now = http.get(f"/api/jobs/{job_id}").json()
            return now if now["detail"]["trials"] >= 1 else None

        running = wait_for(scored, "a candidate scored", attempts=TUNE_DEADLINE)
        assert running["status"] == "running" and 0 < running["progress"] < 1
        assert running["detail"]["budget"] == 80 and running["detail"]["best_loss"] > 0
        # how long the whole tune has left, at the pace of its runs (issue 56, item 13)
        assert running["detail"]["generations"] == 20 and running["detail"]["left_s"] > 0
        pid = running["detail"]["pid"]
        cancelled = http.delete(f"/api/jobs/{job_id}")
        assert cancelled.status_code == 200, cancelled.text
        final = wait_for(
            lambda: (j := http.get(f"/api/jobs/{job_id}").json())["status"] != "running" and j,
            "the tune ended",
        )
        assert final["status"] == "cancelled" and final["result"] is None, final
        with pytest.raises(ProcessLookupError):  # the child is gone, not left running
            os.kill(pid, 0)
        after = http.get("/api/params").json()
        assert after["version"] == before["version"]  # nothing loaded
        names = [p["name"] for p in http.get("/api/presets").json()["presets"]]
        assert "tuned-artro" not in names
        # what it scored is kept in the study, which a tune of the same size resumes
        study = tmp_path / "studies" / "tune-artro.log"
        assert trials_in(study, running["detail"]["study_name"]) >= 1
        lock = WriterLock(study)  # the study's writer lock went with the child: free
        lock.acquire()
        lock.release()


@pytest.mark.parametrize(
    ("body", "status", "said"),
    [
        ({"robot": "nope"}, 404, "this server offers artro, micro"),
        ({"robot": "micro"}, 409, "switch to 'micro' first (PUT /api/robot)"),
        ({"duration_s": 3.0}, 422, "allowed: duration_s of at least 9"),
        ({"cases": ["upside down"]}, 422, "forward"),
        ({"cases": ["forward"] * 7}, 422, "each case once: forward named twice"),
        ({"popsize": 1}, 422, "popsize"),
        ({"budget": 3}, 422, "budget"),
    ],
)
def test_bad_input_is_refused_saying_what_is_allowed_and_changes_nothing(
    tmp_path, body, status, said
):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        before = http.get("/api/params").json()["version"]
        answer = http.post("/api/jobs/tune", json=body)
        assert answer.status_code == status, answer.text
        assert said in answer.text
        assert http.get("/api/tune").status_code == 404  # no job started
        assert app.state.services.axle_fitter.jobs.running() == []
        assert http.get("/api/params").json()["version"] == before
        assert not (tmp_path / "studies").exists()


def test_a_tune_that_cannot_run_fails_saying_why_and_the_server_goes_on(tmp_path):
    """Another writer holds the study (a tune of `artro tune` on the same file): the child is
    refused, the job fails with the command's own words, nothing is loaded."""
    study = tmp_path / "studies" / "tune-artro.log"
    study.parent.mkdir(parents=True)
    lock = WriterLock(study)
    lock.acquire()
    try:
        with running_server(tmp_path) as (base_url, app), client(base_url) as http:
            before = http.get("/api/params").json()["version"]
            job_id = http.post("/api/jobs/tune", json=TINY).json()["id"]
            job = app.state.services.axle_fitter.jobs.get(job_id)
            assert job.finished.wait(TUNE_DEADLINE * 0.05), "the tune did not end"
            failed = http.get(f"/api/jobs/{job_id}").json()
            assert failed["status"] == "failed", failed
            assert "exit status 2" in failed["error"] and "is writing the study" in failed["error"]
            assert http.get("/api/params").json()["version"] == before
            assert http.get("/api/health").json()["status"] == "ok"
    finally:
        lock.release()


def test_the_robot_started_from_a_file_is_tuned_from_its_description(tmp_path):
    robot = robot_file(tmp_path / "big.yaml", "big", 0.117, "DS3218")
    with (
        running_server(tmp_path / "data", robot=str(robot)) as (base_url, app),
        client(base_url) as http,
    ):
        job_id = http.post("/api/jobs/tune", json=TINY | {"robot": "big"}).json()["id"]
        job = app.state.services.axle_fitter.jobs.get(job_id)
        assert job.finished.wait(TUNE_DEADLINE * 0.05), "the tune did not finish"
        done = http.get(f"/api/jobs/{job_id}").json()
        assert done["status"] == "done", done
        assert done["detail"]["start"] == DEFAULT  # legs 0.234 m: ArtRo's preset, scaled
        # speeds scale with the legs: forward's target is ArtRo's 3.8 cm/s x 1.3
        forward = next(r for r in done["result"]["figures"] if r["run"] == "forward")
        assert forward["target"] == pytest.approx(3.8 * 0.234 / 0.18)
        params = http.get("/api/params").json()
        assert (params["name"], params["robot"]) == ("tuned-big", "big")


def test_a_robot_the_server_accepted_is_one_its_tune_accepts(tmp_path):
    """Issue 56, item 11: a description within the limit was handed to the tune's child as a
    JSON file over it (every default written out: 50 KiB of YAML became 281 KiB), and the child
    refused it. The hand-off is the description written out as the one limit measures it."""
    raw = yaml.safe_load(robot_file(tmp_path / "many.yaml", "many", 0.09, "MG996R").read_text())
    raw["trunk"] += [{"name": f"washer {i}", "mass_kg": 0.0} for i in range(1600)]
    robot = tmp_path / "many.yaml"
    robot.write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    accepted = read_description(robot)
    assert len(json.dumps(accepted.model_dump(mode="json"))) > MAX_DESCRIPTION_BYTES  # as before
    with (
        running_server(tmp_path / "data", robot=str(robot)) as (base_url, _app),
        client(base_url) as http,
    ):
        job_id = http.post("/api/jobs/tune", json=LONG | {"robot": "many"}).json()["id"]

        def started_or_ended():
            now = http.get(f"/api/jobs/{job_id}").json()
            return now if now["detail"].get("start") or now["status"] != "running" else None

        started = wait_for(started_or_ended, "the child read the robot", attempts=TUNE_DEADLINE)
        assert started["status"] == "running", started.get("error")
        assert started["detail"]["start"] == DEFAULT
        assert http.delete(f"/api/jobs/{job_id}").status_code == 200
        wait_for(lambda: http.get(f"/api/jobs/{job_id}").json()["status"] != "running", "ended")
    (handed,) = (tmp_path / "data" / "studies").glob("*.robot.yaml")
    assert handed.stat().st_size <= MAX_DESCRIPTION_BYTES
    assert read_description(handed) == accepted


def test_a_gait_changed_while_the_tune_ran_is_kept_and_the_result_saved_not_loaded(tmp_path):
    """A tune overwrote what the user changed while it ran (every other job answers 409): the
    result is now saved, not loaded, and says why; a motion moved meanwhile does not count."""
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        job_id = http.post("/api/jobs/tune", json=TINY).json()["id"]
        http.patch("/api/params", json={"motion": {"a_p": 0.03}})  # kept by a tune anyway
        edited = http.patch("/api/params", json={"gait": {"damping": {"ankle_pitch": 0.2}}})
        assert edited.status_code == 200
        job = app.state.services.axle_fitter.jobs.get(job_id)
        assert job.finished.wait(TUNE_DEADLINE * 0.05), "the tune did not finish"
        result = http.get(f"/api/jobs/{job_id}").json()["result"]
        assert result["applied"] is False and result["params_version"] is None
        assert result["not_loaded"].startswith("the gait changed while the tune ran (version ")
        assert result["not_loaded"].endswith(
            "'tuned-artro' is saved, not loaded; the set in use stays (load it from the presets "
            "to try it)"
        )
        now = http.get("/api/params").json()
        assert now["version"] == edited.json()["version"] and now["name"] == DEFAULT
        assert "tuned-artro" in [p["name"] for p in http.get("/api/presets").json()["presets"]]


def test_a_tune_whose_candidates_all_fell_is_saved_not_loaded(tmp_path):
    """A tiny tune on a robot of one's own replaced `tuned-my`, which walked, by a set that fell
    in every walking case ("the lowest loss kept")."""
    from app.params.presets import PresetStore, builtin_presets
    from app.robots.model import RobotModel
    from app.server.jobs.registry import Jobs
    from app.server.jobs.tune_job import TuneRunner
    from app.server.param_store import ParameterStore

    presets = PresetStore(tmp_path, builtin_presets())
    store = ParameterStore(builtin_presets()["robust"])
    presets.save("tuned-artro", builtin_presets()["tuned"])
    runner = TuneRunner(Jobs(), store, presets, RobotModel.load)
    before = store.snapshot()
    detail = {"study": "s.log", "study_name": "s", "budget": 2}
    fell = runner._load("artro", "tuned-artro", {"walked": False, "loss": 9.0}, detail, before)
    assert fell["applied"] is False and fell["not_loaded"].startswith(
        "no candidate walked every run without a fall (the lowest loss was saved): "
        "'tuned-artro' is saved, not loaded"
    )
    assert store.snapshot() == before
    walked = runner._load("artro", "tuned-artro", {"walked": True}, detail, before)
    assert walked["applied"] is True and store.snapshot().name == "tuned-artro"
