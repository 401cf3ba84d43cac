"""The world panel's API and the robustness job on a real server (docs/DESIGN.md §8, §12): a
variation reaches the live simulation and the state says so; a bad one changes nothing; the
robustness job reports per case; the robot is named."""

from __future__ import annotations

import re

import pytest

from tests.testing.server_harness import client, running_server, wait_for


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("data")) as (base_url, _app):
        with client(base_url) as http:
            yield http


def test_a_variation_reaches_the_live_robot_and_the_state_says_so(server):
    assert server.get("/api/state").json()["world"] == "nominal"
    put = server.put("/api/world", json={"variation": "friction=0.5,tilt_deg=1"})
    assert put.status_code == 200 and put.json()["variation"] == "friction=0.5,tilt_deg=1"
    wait_for(lambda: server.get("/api/state").json()["world"] == "friction=0.5,tilt_deg=1",
             "the simulation thread took the world")  # fmt: skip
    world = server.get("/api/world").json()
    assert world["values"]["friction"] == 0.5 and world["ranges"]["latency_ms"] == [0.0, 60.0]
    frame = server.get("/api/state").json()["frame"]
    wait_for(lambda: server.get("/api/state").json()["frame"] > frame + 10, "it walks on")
    assert server.delete("/api/world").json()["variation"] == "nominal"
    wait_for(lambda: server.get("/api/state").json()["world"] == "nominal", "back to nominal")


@pytest.mark.parametrize(
    "body",
    [
        {"variation": "friction=3"},
        {"variation": "gravity=2"},
        {"variation": 5},
        {},
        {"variation": "latency_ms=1e308"},  # it once killed the simulation thread
        {"variation": "kp_scale=1e308"},
        {"variation": "cal.l_knee=1e300"},
    ],
)
def test_a_bad_world_is_refused_and_changes_nothing(server, body):
    before = server.get("/api/state").json()["world"]
    bad = server.put("/api/world", json=body)
    assert bad.status_code == 422 and bad.json()["detail"]
    if "e30" in str(body):
        assert "≤" in str(bad.json()["detail"])  # the allowed range is said
    assert server.get("/api/state").json()["world"] == before
    assert server.get("/api/state").json()["running"]


def test_the_robot_is_named_with_its_figures(server):
    assert server.get("/api/state").json()["robot"] == "artro"
    robot = server.get("/api/robot").json()
    assert robot["name"] == "artro" and robot["derived"]["total_mass_kg"] == pytest.approx(1.65)
    assert len(robot["derived"]["eq1"]) == 12
    schema = server.get("/api/robot/schema").json()
    assert "geometry" in schema["properties"] and "tdm_channels" in schema["required"]


@pytest.mark.slow
def test_the_robustness_job_reports_every_case(server):
    assert server.get("/api/state").json()["robustness_report"] is False  # none run yet
    started = server.post("/api/jobs/robustness", json={"samples": 4, "seed": 2})
    assert started.status_code == 202
    job_id = started.json()["id"]
    busy = server.post("/api/jobs/robustness", json={"samples": 4})
    assert busy.status_code == 409
    job = wait_for(
        lambda: (j := server.get(f"/api/jobs/{job_id}").json())["status"] != "running" and j,
        "the robustness job ends",
        attempts=12000,
    )
    assert job["status"] == "done", job
    report = job["result"]["presets"][0]
    assert len(report["cases"]) == 9 and all(c["runs"] == 4 for c in report["cases"])
    assert server.post("/api/jobs/robustness", json={"samples": 2}).status_code == 422
    # kept for the gait: the state says so (a page asks only then), a new gait has none
    assert server.get("/api/state").json()["robustness_report"] is True
    kept = server.get("/api/world/robustness").json()
    assert kept["presets"] == job["result"]["presets"]
    server.patch("/api/params", json={"gait": {"swing": {"v": 2.5}}})
    assert server.get("/api/state").json()["robustness_report"] is False
    assert server.get("/api/world/robustness").status_code == 404
    server.post("/api/params/undo")
    assert server.get("/api/state").json()["robustness_report"] is True


def test_a_robustness_job_on_warp_is_cancelled_between_its_chunks(tmp_path):
    """Issue 56, item 12: on MuJoCo Warp (its CPU device here) a robustness job went on to its
    end after a DELETE (265 s): the batch reports progress only as its worlds end, and the job
    looked at its cancel only there. The job now hands its cancel to the evaluation, which
    every executor looks at between its chunks (a Warp batch between segments)."""
    with (
        running_server(tmp_path, backend="warp", device="cpu") as (base_url, app),
        client(base_url) as http,
    ):
        job_id = http.post("/api/jobs/robustness", json={"samples": 4}).json()["id"]
        # the DELETE waits up to 10 s for the job to end: while the job still imports Warp
        # (seconds, on a busy machine) that wait is spent, so the client waits longer
        assert http.delete(f"/api/jobs/{job_id}", timeout=60).status_code == 200
        job = app.state.services.axle_fitter.jobs.get(job_id)
        assert job.finished.wait(600), "the cancelled job did not end"
        ended = http.get(f"/api/jobs/{job_id}").json()
    assert ended["status"] == "cancelled" and ended["result"] is None, ended
    said = f"cancelled (DELETE /api/jobs/{job_id}); nothing was applied"
    assert re.fullmatch(re.escape(said) + r" \(cancelled after \d+ of 45 runs\)", ended["error"])
