""" "Fit to a recording" on a real server (issue 53 items 1, 3): the recording's schema, a bad
recording refused before anything starts, `artro fit` run as a child on a simulated recording
(progress, its summary, the report's plot, the fit set as the world), cancel ending the child."""

from __future__ import annotations

import json
import os

import pytest

from app.robots.fitted import Fitted, write_fitted
from app.robots.model import RobotModel
from tests.testing.fit_support import simulated_recording
from tests.testing.server_harness import client, running_server, wait_for

pytestmark = pytest.mark.slow

SMALL = {"fields": "gyro_bias_deg_s,imu_tilt_bias", "budget": 10}
FIT_DEADLINE_S = 900


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> str:
    """A simulated recording of the identify routine, its truth known."""
    return simulated_recording(tmp_path_factory.mktemp("fit")).read_text(encoding="utf-8")


def _post(http, text: str, **params):
    return http.post(
        "/api/fit", content=text, params=params, headers={"Content-Type": "application/json"}
    )


def test_the_schema_and_a_bad_recording_refused_with_nothing_started(tmp_path, recording):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        schema = http.get("/api/fit/schema")
        assert schema.status_code == 200
        assert {"format", "robot", "frames", "segments"} <= set(schema.json()["properties"])
        assert http.get("/api/fit").status_code == 404  # none yet
        assert http.get("/api/state").json()["fit"] is None  # what a page reads first
        cut = _post(http, recording[: len(recording) // 2])
        assert cut.status_code == 422 and "truncated" in cut.json()["message"], cut.text
        other = json.loads(recording) | {"robot": "micro"}
        refused = _post(http, json.dumps(other))
        assert refused.status_code == 422, refused.text
        assert "recorded on the robot 'micro'" in refused.json()["message"]
        foreign = _post(http, json.dumps({"format": "something else"}))
        assert "not an identification recording" in foreign.json()["message"]
        assert _post(http, recording, budget=5).status_code == 422  # the budget's bounds
        # nothing started, nothing written
        assert app.state.services.jobs.running() == []
        assert http.get("/api/fit").status_code == 404
        assert not (tmp_path / "fits").exists()
        assert http.get("/api/fit/fit-1/traces.png").status_code == 404


def test_a_small_fit_runs_to_done_and_its_fit_becomes_the_world(tmp_path, recording):
    with running_server(tmp_path) as (base_url, app), client(base_url) as http:
        started = _post(http, recording, **SMALL)
        assert started.status_code == 202, started.text
        job_id = started.json()["id"]
        assert started.json()["kind"] == "fit"
        assert started.headers["Location"] == f"/api/jobs/{job_id}"
        job = app.state.services.jobs.get(job_id)
        assert job.finished.wait(FIT_DEADLINE_S), "the fit did not finish"
        done = http.get(f"/api/jobs/{job_id}").json()
        assert done["status"] == "done" and done["progress"] == 1.0, done
        # the IMU's fields alone are found in closed form: no search, so no progress lines
        assert done["detail"]["recording"].endswith(f"{job_id}.json")
        result = done["result"]
        fields = result["fields"]
        assert {"gyro_bias_deg_s", "imu_tilt_x_deg", "imu_tilt_y_deg"} <= set(fields)
        gyro = fields["gyro_bias_deg_s"]
        assert gyro["truth"] == pytest.approx(0.6) and gyro["sigma"] > 0
        assert result["source"] == "simulation"
        assert (tmp_path / "fits" / f"{job_id}-fitted.yaml").is_file()
        png = http.get(result["traces"])
        assert png.status_code == 200 and png.content[:4] == b"\x89PNG"
        assert http.get("/api/fit").json()["id"] == job_id
        assert http.get("/api/state").json()["fit"] == {"id": job_id, "status": "done"}
        # the fit set as the world: the World panel says whose fit it is
        # the simulation thread takes the world at its next frame: the GET waits for it
        wait_for(lambda: http.get("/api/world").json()["fitted"] is None, "the fit no longer said")
        put = http.put("/api/world", json={"variation": result["variation"]})
        assert put.status_code == 200 and put.json()["variation"] == result["world"]
        world = wait_for(
            lambda: (w := http.get("/api/world").json())["variation"] == result["world"] and w,
            "the fit in force",
        )
        assert world["fitted"] == job_id


def test_a_fit_cancelled_ends_its_child(tmp_path, recording):
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        # a physics field is searched by CMA-ES: its progress lines are followed
        job_id = _post(http, recording, fields="trunk_mass_scale", budget=400).json()["id"]
        busy = _post(http, recording, **SMALL)
        assert busy.status_code == 409 and "one fit runs at a time" in busy.json()["message"]
        running = wait_for(
            lambda: (
                ((j := http.get(f"/api/jobs/{job_id}").json())["detail"] or {}).get("percent") and j
            ),
            "the search reported progress",
            attempts=FIT_DEADLINE_S * 20,
        )
        assert running["status"] == "running" and 0 < running["progress"] < 1, running
        assert running["detail"]["best_loss"] >= 0 and running["detail"]["left"]
        pid = running["detail"]["pid"]
        assert http.delete(f"/api/jobs/{job_id}").status_code == 200
        final = wait_for(
            lambda: (j := http.get(f"/api/jobs/{job_id}").json())["status"] != "running" and j,
            "the fit ended",
        )
        assert final["status"] == "cancelled" and final["result"] is None, final
        with pytest.raises(ProcessLookupError):  # the child is gone, not left running
            os.kill(pid, 0)


def test_a_fitted_robot_served_walks_its_fit_and_the_world_says_so(tmp_path):
    path = tmp_path / "artro-fitted.yaml"
    fit = Fitted(variation="gyro_bias_deg_s=0.4", recording="rec.json")
    write_fitted(RobotModel.load("artro").description, fit, path)
    with running_server(tmp_path, robot=str(path)) as (base_url, _app), client(base_url) as http:
        world = wait_for(
            lambda: (w := http.get("/api/world").json())["variation"] != "nominal" and w,
            "the fit in force",
        )
        assert world["values"]["gyro_bias_deg_s"] == pytest.approx(0.4)
        assert world["fitted"] == "rec.json"
        assert http.delete("/api/world").status_code == 200  # Nominal: the nominal values
        # the simulation thread takes the world at its next frame: the GET waits for it
        wait_for(lambda: http.get("/api/world").json()["fitted"] is None, "the fit no longer said")
