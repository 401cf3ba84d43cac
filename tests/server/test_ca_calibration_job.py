"""'Calibrate CA' on a real server: a background job with progress; both K land as one undoable
change of the store, and a second start while it runs is refused."""

from __future__ import annotations

import pytest

from tests.testing.server_harness import client, running_server

pytestmark = pytest.mark.slow


def test_calibrate_ca_runs_in_the_background_and_applies_both_k(tmp_path):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        # `tuned`, open loop: CA steers it by K alone (the default's yaw-rate law steers it
        # backward at K = 0, so its calibration keeps K = 0 there)
        assert http.post("/api/presets/tuned/load").is_success
        before = http.get("/api/params").json()
        started = http.post("/api/jobs/calibrate-ca", json={})
        assert started.status_code == 202 and started.headers["Location"].startswith("/api/jobs/")
        job_id = started.json()["id"]
        assert http.post("/api/jobs/calibrate-ca", json={}).status_code == 409  # one at a time
        job = app.state.services.axle_fitter.jobs.get(job_id)
        assert job.finished.wait(600), "the calibration did not finish"
        done = http.get(f"/api/jobs/{job_id}").json()
        assert done["status"] == "done" and done["progress"] == 1.0, done
        result = done["result"]
        after = http.get("/api/params").json()
        assert after["version"] == result["params_version"] > before["version"]
        assert after["gait"]["steer"] == result["steer"]
        forward, backward = result["forward"], result["backward"]
        assert after["gait"]["steer"]["yaw_per_ca"] == forward["yaw_per_ca"] != 0.0
        assert after["gait"]["steer"]["yaw_per_ca_backward"] == backward["yaw_per_ca"] != 0.0
        # the fitted K steers the `tuned` gait closer to eq (13) than CA alone does
        for d in (forward, backward):
            gains = {t["yaw_per_ca"]: t["gain"] for t in d["trials"]}
            assert abs(gains[d["yaw_per_ca"]] - 1) < abs(gains[0.0] - 1)
        undone = http.post("/api/params/undo").json()
        assert undone["gait"]["steer"] == before["gait"]["steer"]
        assert http.get("/api/jobs/calibrate-ca").status_code == 405


def test_a_running_job_ends_with_the_server(tmp_path):
    """No simulation outlives the server: stopping it cancels the job at its next report."""
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        job_id = http.post("/api/jobs/calibrate-ca", json={}).json()["id"]
        job = app.state.services.axle_fitter.jobs.get(job_id)
    assert job.finished.is_set()  # the server's stop waited for it
    assert job.status == "failed" and "server stopped" in job.error
