"""Background jobs on a real server (issue 18, items 6 and 11): a job applies its result only onto
the parameter version (and the axle) it fitted; changed meanwhile, it says so with a 409 in its
result and keeps the result for `POST /api/jobs/{id}/apply`; `DELETE /api/jobs/{id}` cancels a
running job; a start takes no options."""

from __future__ import annotations

import pytest

from app.server.jobs.registry import StaleVersion, only_onto
from app.server.param_store import ParameterStore
from tests.testing.server_harness import client, running_server


def _finish(server, job_id: str, timeout_s: float = 600.0) -> dict:
    job = server[1].state.services.axle_fitter.jobs.get(job_id)
    assert job.finished.wait(timeout_s), f"{job_id} did not finish"
    with client(server[0]) as http:
        return http.get(f"/api/jobs/{job_id}").json()


def test_an_axle_set_by_hand_while_the_fit_runs_is_kept(server, http):
    version = http.get("/api/params").json()["version"]
    started = http.post("/api/jobs/axle-fit", json={})
    assert started.status_code == 202, started.text
    assert started.json()["from_version"] == version
    assert http.put("/api/path/axle", json={"axle_m": 0.3}).status_code == 200
    done = _finish(server, started.json()["id"])
    assert done["status"] == "done", done
    result = done["result"]
    assert result["applied"] is False and result["fitted_from_version"] == version
    assert result["conflict"]["status"] == 409 and "axle b was set" in result["conflict"]["msg"]
    path = http.get("/api/path").json()
    assert (path["axle_m"], path["axle_source"]) == (0.3, "manual")  # what the user set stays
    # kept for the user: applied onto the version in use, never onto a stale one
    stale = http.post(f"/api/jobs/{done['id']}/apply", json={"version": version + 1})
    assert stale.status_code == 409 and stale.json()["detail"][0]["type"] == "version_conflict"
    applied = http.post(f"/api/jobs/{done['id']}/apply", json={"version": version})
    assert applied.status_code == 200, applied.text
    assert applied.json()["result"]["applied"] is True
    path = http.get("/api/path").json()
    assert (path["axle_m"], path["axle_source"]) == (result["axle_eff_m"], "fitted")
    again = http.post(f"/api/jobs/{done['id']}/apply", json={"version": version})
    assert again.status_code == 409  # applied once


def test_a_fit_for_a_version_changed_meanwhile_is_not_applied(server, http):
    started = http.post("/api/jobs/axle-fit").json()
    changed = http.patch("/api/params", json={"gait": {"swing": {"v": 2.2}}}).json()
    done = _finish(server, started["id"])
    assert done["result"]["applied"] is False
    assert done["result"]["conflict"]["version"] == changed["version"]
    assert http.get("/api/path").json()["axle_source"] == "feet"
    # the job's result is not for the version in use: applying it onto an older one is refused
    refused = http.post(
        f"/api/jobs/{started['id']}/apply", json={"version": started["from_version"]}
    )
    assert refused.status_code == 409


@pytest.mark.slow
def test_calibrate_ca_never_overwrites_changes_made_while_it_ran(tmp_path):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        started = http.post("/api/jobs/calibrate-ca", json={}).json()
        mine = {"steer": {"yaw_per_ca": 0.05}, "clock": {"freq_hz": 0.75}}
        changed = http.patch("/api/params", json={"gait": mine}).json()
        done = _finish((base_url, app), started["id"])
        assert done["status"] == "done", done
        result = done["result"]
        assert result["applied"] is False and result["conflict"]["status"] == 409
        now = http.get("/api/params").json()
        assert now["version"] == changed["version"]  # the job made no version
        assert (
            now["gait"]["steer"]["yaw_per_ca"] == 0.05 and now["gait"]["clock"]["freq_hz"] == 0.75
        )
        applied = http.post(f"/api/jobs/{started['id']}/apply", json={"version": now["version"]})
        assert applied.status_code == 200, applied.text
        after = http.get("/api/params").json()
        assert after["gait"]["steer"] == result["steer"]
        assert after["version"] == applied.json()["result"]["params_version"] == now["version"] + 1
        assert after["gait"]["clock"]["freq_hz"] == 0.75  # only K is the job's


def test_a_running_job_is_cancelled_and_applies_nothing(server, http):
    started = http.post("/api/jobs/axle-fit", json={}).json()
    cancelled = http.delete(f"/api/jobs/{started['id']}")
    assert cancelled.status_code == 200, cancelled.text
    assert cancelled.json()["status"] == "cancelled" and "cancelled" in cancelled.json()["error"]
    assert http.get("/api/path").json()["axle_source"] == "feet"
    again = http.delete(f"/api/jobs/{started['id']}")
    assert again.status_code == 409 and "already finished" in again.json()["message"]
    unknown = http.delete("/api/jobs/axle-fit-999")
    assert unknown.status_code == 404 and unknown.json()["detail"][0]["loc"] == ["path", "job_id"]
    for kind in ("axle-fit", "calibrate-ca", "tune", "robustness"):  # they start jobs (POST)
        assert http.get(f"/api/jobs/{kind}").status_code == 405
    # the kind is free again at once
    restarted = http.post("/api/jobs/axle-fit", json={})
    assert restarted.status_code == 202
    http.delete(f"/api/jobs/{restarted.json()['id']}")


@pytest.mark.parametrize("kind", ["axle-fit", "calibrate-ca"])
def test_a_job_start_takes_no_options(http, kind):
    r = http.post(f"/api/jobs/{kind}", json={"duration_s": 5})
    assert r.status_code == 422, r.text
    assert r.json()["detail"][0]["loc"] == ["body", "duration_s"]
    assert "Extra inputs are not permitted" in r.json()["message"]


def test_a_result_fitted_on_one_robot_never_applies_to_another():
    """`POST /api/jobs/{id}/apply` once applied a CA calibration fitted on `micro` to `mybot`
    (K 0.18 -> 0.60): a job's result applies only while its robot is the one in use."""
    store = ParameterStore(robot="micro")
    fitted = store.snapshot()
    store.replace(fitted.parameter_set(), "robot", robot="artro")
    with pytest.raises(StaleVersion, match="fitted on the robot 'micro'; the robot in use is"):
        store.update({"gait": {"steer": {}}}, "calibration", check=only_onto(2, "micro"))
    assert store.snapshot().robot == "artro" and store.snapshot().version == 2


def test_a_job_registered_as_the_robot_changed_lets_itself_go():
    """A switch of robots passed its guard (no job ran) just before a job registered: the job,
    reading the robot once the switch has landed, refuses to walk the old one (two of 60 tries
    of a concurrent switch and start had both accepted)."""
    from app.params.document import ParameterSet
    from app.server.jobs.registry import Jobs, RobotChanged

    store = ParameterStore(ParameterSet(), robot="artro")
    jobs = Jobs()
    jobs.robot_in_use = store.settled_robot
    ran = []
    store.replace(ParameterSet(), "robot", robot="micro")  # the switch, landed
    with pytest.raises(RobotChanged, match="changed from 'artro' to 'micro'"):
        jobs.start("axle-fit", ran.append, robot="artro")
    assert jobs.running() == [] and ran == []
    job = jobs.start("axle-fit", lambda progress: {"ok": True}, robot="micro")  # its own: runs
    assert job.finished.wait(30) and job.status == "done"


def test_a_running_job_is_never_forgotten_for_newer_ones():
    """Past KEEP_JOBS newer jobs a running one stays readable, cancellable and busy: it was
    dropped as the oldest, and a second tune then started beside it (the hostile probe)."""
    import threading

    from app.server.jobs.registry import KEEP_JOBS, JobBusy, Jobs

    jobs = Jobs()
    release = threading.Event()

    def long_work(progress):
        while not release.wait(0.05):
            progress()  # a cancel lands at a progress report
        return {}

    long_job = jobs.start("tune", long_work)
    quick = []
    for _ in range(KEEP_JOBS + 5):  # one of a kind at a time: each finishes before the next
        quick.append(jobs.start("robustness", lambda progress: {}))
        assert quick[-1].finished.wait(30)
    assert jobs.get(long_job.id) is long_job
    assert jobs.running() == [long_job]
    with pytest.raises(JobBusy):
        jobs.start("tune", lambda progress: {})
    kept = [job for job in quick if jobs.get(job.id) is not None]
    assert kept == quick[-(KEEP_JOBS - 1) :]  # the oldest finished ones go, the newest stay
    assert jobs.cancel(long_job) and long_job.status == "cancelled"
