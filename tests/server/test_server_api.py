"""The HTTP and WebSocket API on a real uvicorn server: round trips, and every bad input refused
with a clear 4xx that changes nothing."""

import dataclasses
import json

import pytest
from websockets.sync.client import connect

from app.params.document import ParameterSet
from gait import Motion, joint_angles
from hardware import ChannelMap, ServoCalibration, angles_to_pulses_us, pulse_us_to_ocr
from tests.testing.server_harness import wait_for

PATCH_HEADERS = {"content-type": "application/json"}


def ws_url(base_url: str) -> str:
    return base_url.replace("http://", "ws://") + "/ws/scope"


def frames(base_url: str, n: int) -> list[dict]:
    with connect(ws_url(base_url), open_timeout=10) as ws:
        return [json.loads(ws.recv(timeout=10)) for _ in range(n)]


def test_health_and_state(http):
    health = http.get("/api/health").json()
    assert health["status"] == "ok" and health["version"]
    state = http.get("/api/state").json()
    for key in ("sim_time_s", "rtf", "fell", "trunk", "params_version", "speed", "behind"):
        assert key in state
    assert state["fell"] is False and state["running"] is True


def test_params_round_trip(http):
    before = http.get("/api/params").json()
    body = {"motion": before["motion"], "gait": before["gait"]}
    same = http.put("/api/params", json=body).json()
    assert same["version"] == before["version"]  # nothing changed: no new version
    body["motion"]["a_p"] = 0.05
    body["gait"]["swing"]["v"] = 2.5
    changed = http.put("/api/params", json=body).json()
    assert changed["version"] == before["version"] + 1
    assert changed["motion"]["a_p"] == 0.05 and changed["gait"]["swing"]["v"] == 2.5
    patched = http.patch("/api/params", json={"gait": {"load": {"enabled": False}}}).json()
    assert patched["gait"]["load"]["enabled"] is False and patched["gait"]["swing"]["v"] == 2.5
    assert http.get("/api/params").json() == patched
    assert http.post("/api/params/undo").json()["gait"]["load"]["enabled"] is True
    assert http.post("/api/params/redo").json()["gait"]["load"]["enabled"] is False


BAD_PATCHES = [
    ('{"motion": {"a_p": "fast"}}', "valid number"),
    ('{"motion": {"a_p": true}}', "valid number"),
    ('{"motion": {"a_p": NaN}}', "finite"),
    ('{"motion": {"a_p": Infinity}}', "finite"),
    ('{"motion": {"a_p": 1e999}}', "finite"),
    ('{"motion": {"a_p": 0.9}}', "less than or equal to 0.3"),
    ('{"gait": {"swing": {"v": 0.1}}}', "greater than or equal to 1.5"),
    ('{"gait": {"swing": {"speed": 2}}}', "Extra inputs are not permitted"),
    ('{"gait": {"walk": {}}}', "Extra inputs are not permitted"),
    ('{"motion": {"a_p": 0.1}, "colour": "red"}', "Extra inputs are not permitted"),
    ('{"gait": {"shift": {"enabled": 1}}}', "valid boolean"),
    ('{"motion": [1, 2]}', "valid dictionary"),
    ("[]", "valid dictionary"),
    ("{not json", "JSON decode error"),
    ("", "Field required"),
]


@pytest.mark.parametrize(("body", "message"), BAD_PATCHES)
def test_bad_patch_is_refused_and_changes_nothing(http, body, message):
    before = http.get("/api/params").json()
    response = http.patch("/api/params", content=body, headers=PATCH_HEADERS)
    assert response.status_code == 422
    assert message in json.dumps(response.json()["detail"])
    assert http.get("/api/params").json() == before


ALLOWED_SAID = [  # pydantic's words alone did not say what is allowed (the hostile probe)
    ("PUT", "/api/robot", "", ["body"], "Field required; allowed: a JSON object with name"),
    ("POST", "/api/jobs/robustness", '{"samples": 4.5}', ["body", "samples"],
     "allowed: a whole number 4 to 400"),
    ("POST", "/api/jobs/tune", '{"generations": null}', ["body", "generations"],
     "allowed: a whole number 1 to 100"),
    ("PUT", "/api/sim/drive", '{"drive": "wires"}', ["body", "drive"], "'model', 'firmware'"),
    ("PATCH", "/api/params", '{"gait": {"swing": {"speed": 2}}}',
     ["body", "gait", "swing", "speed"], "Extra inputs are not permitted; allowed: a JSON object"),
    ("PATCH", "/api/params", '{"gait": {"swing": {"v": "fast"}}}', ["body", "gait", "swing", "v"],
     "allowed: a finite number 1.5 to 6"),
]  # fmt: skip


@pytest.mark.parametrize(("method", "path", "body", "loc", "message"), ALLOWED_SAID)
def test_a_bad_body_is_told_what_is_allowed(http, method, path, body, loc, message):
    before = http.get("/api/params").json()
    response = http.request(method, path, content=body, headers=PATCH_HEADERS)
    assert response.status_code == 422, response.text[:300]
    problem = response.json()["detail"][0]
    assert problem["loc"] == loc and message in problem["msg"], problem
    assert http.get("/api/params").json() == before


def test_put_needs_every_field(http):
    before = http.get("/api/params").json()
    response = http.put("/api/params", json={"motion": {"a_p": 0.1}, "gait": before["gait"]})
    assert response.status_code == 422
    assert "Field required" in response.text
    assert http.get("/api/params").json() == before


def test_sim_control_pause_step_resume_reset_speed(http, server):
    assert http.post("/api/sim/pause").status_code == 200
    # a step pauses and advances exactly one frame; the scope shows that frame
    with connect(ws_url(server[0]), open_timeout=10) as ws:
        http.post("/api/sim/step")
        first = json.loads(ws.recv(timeout=10))
        http.post("/api/sim/step")
        second = json.loads(ws.recv(timeout=10))
    assert second["frame"] == first["frame"] + 1
    state = http.get("/api/state").json()
    assert state["paused"] is True and state["frame"] == second["frame"] + 1
    assert http.post("/api/sim/resume").status_code == 200
    assert http.put("/api/sim/speed", json={"speed": 2.0}).json()["speed"] == 2.0
    for bad in ({"speed": 0.1}, {"speed": 5}, {"speed": "fast"}, {"speed": None}, {}):
        response = http.put("/api/sim/speed", json=bad)
        assert response.status_code == 422, bad
    assert http.put("/api/sim/speed", json={"speed": 1.0}).status_code == 200
    assert http.post("/api/sim/jump").status_code == 404
    wrong = http.post("/api/sim/speed", json={"speed": 1.0})
    assert wrong.status_code == 405 and wrong.headers["allow"] == "PUT"
    assert http.post("/api/sim/reset").status_code == 200
    assert frames(server[0], 1)[0]["frame"] < 100  # the robot restarted from frame 0


def test_scope_frames_over_http_and_websocket(http, server):
    live = frames(server[0], 20)
    numbers = [f["frame"] for f in live]
    assert numbers == sorted(numbers) and numbers[-1] - numbers[0] >= 19
    slot = live[0]["channels"][0]["slots"][0]
    assert slot["servo"] == "l_hip_yaw"
    assert slot["pulse_us"] == (slot["ocr_ticks"] + 1) * 0.5 == slot["decoded_us"]
    assert [line["name"] for line in live[0]["lines"]][-3:] == ["S0", "S1", "S2"]
    recent = http.get("/api/scope", params={"frames": 5}).json()["frames"]
    assert len(recent) == 5
    assert [f["frame"] for f in recent] == list(range(recent[0]["frame"], recent[0]["frame"] + 5))
    for bad in ("0", "251", "abc", "-1"):
        assert http.get("/api/scope", params={"frames": bad}).status_code == 422


def test_pulses_follow_a_parameter_change_within_two_frames(http, server):
    # the feedback laws off (the server starts with `robust-3`: they correct the plan), one at a
    # time, each applied before the next (two constants at once would ramp over 2 s)
    for law in ("tilt", "yaw_rate", "damping"):
        off = http.patch("/api/params", json={"gait": {law: {"enabled": False}}}).json()
        wait_for(
            lambda v=off["version"]: http.get("/api/state").json()["params_version_applied"] >= v,
            f"{law} off",
        )
    with connect(ws_url(server[0]), open_timeout=10) as ws:
        json.loads(ws.recv(timeout=10))
        # with the motion ramp off (it would send the first of its steps, docs/DESIGN.md §4)
        patch = {"motion": {"a_y": 0.3}, "gait": {"ramp": {"enabled": False}}}
        version = http.patch("/api/params", json=patch).json()["version"]
        seen = 0
        while True:
            frame = json.loads(ws.recv(timeout=10))
            seen += 1
            if frame["params_version"] == version:
                break
    assert seen <= 3  # frames already queued when the change came, then the new one
    # the frame's pulses are the gait's angles at its phase under the new motion, quantised
    doc = http.get("/api/params").json()
    pset = ParameterSet.from_dict({"motion": doc["motion"], "gait": doc["gait"]})

    def ocr(motion: Motion) -> list[int]:
        angles = joint_angles(pset.gait, motion, frame["phase_rad"])
        return pulse_us_to_ocr(angles_to_pulses_us(angles, ServoCalibration.default())[0]).tolist()

    cmap = ChannelMap.default()
    sent = [
        next(s["ocr_ticks"] for s in frame["channels"][c]["slots"] if s["slot"] == slot)
        for c, slot in cmap.assignments
    ]
    assert sent == ocr(pset.motion)
    assert sent != ocr(dataclasses.replace(pset.motion, a_y=0.0))  # the change shows


def test_paths(http):
    path = http.get("/api/path").json()
    for key in ("actual", "predicted", "speed_m_s", "axle_m", "turn_radius_m", "ca"):
        assert key in path
    assert all(len(row) == 4 for row in path["actual"])
    assert http.post("/api/path/anchor", json={"speed_m_s": 0.04}).status_code == 200
    for bad in ({"speed_m_s": "x"}, {"speed_m_s": 9}, {"v": 1}):
        assert http.post("/api/path/anchor", json=bad).status_code == 422


def test_the_prediction_axle_by_hand_fitted_and_back_to_the_feet(http, server):
    assert http.get("/api/path").json()["axle_source"] == "feet"
    assert http.put("/api/path/axle", json={"axle_m": 0.25}).status_code == 200
    path = http.get("/api/path").json()
    assert (path["axle_m"], path["axle_source"]) == (0.25, "manual")
    for bad in ({"axle_m": 0}, {"axle_m": -0.1}, {"axle_m": "x"}, {"axle_m": 5}, {}, {"b": 1}):
        response = http.put("/api/path/axle", json=bad)
        assert response.status_code == 422 and response.json()["message"]
    assert http.get("/api/path").json()["axle_m"] == 0.25  # nothing changed
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})
    started = http.post("/api/jobs/axle-fit")
    assert started.status_code == 202 and started.json()["status"] == "running"
    job_url = started.headers["location"]
    busy = http.post("/api/jobs/axle-fit")  # one fit at a time
    assert busy.status_code == 409 and started.json()["id"] in busy.json()["message"]
    assert http.get("/api/health").status_code == 200  # the server answers meanwhile
    server[1].state.services.axle_fitter.jobs.get(started.json()["id"]).finished.wait(300)
    job = http.get(job_url).json()
    assert job["status"] == "done" and job["progress"] == 1.0, job
    fit = job["result"]
    assert fit["a_p"] == 0.07 and len(fit["turn_deg_s"]) == 3 and fit["feet_m"] > 0.05
    path = http.get("/api/path").json()
    if fit["applied"]:  # b_eff > 0: CA turns the way eq (13) says, and the view uses it
        assert (path["axle_m"], path["axle_source"]) == (fit["axle_eff_m"], "fitted")
        assert fit["gain"] == pytest.approx(fit["feet_m"] / fit["axle_eff_m"])
    else:
        assert fit["reason"] and path["axle_source"] == "manual"
    assert http.put("/api/path/axle", json={"axle_m": None}).json()["axle_source"] == "feet"
    assert http.get("/api/path").json()["axle_source"] == "feet"
    http.patch("/api/params", json={"motion": {"a_p": 0.0}})


def test_openapi_documents_the_ranges(http):
    spec = http.get("/openapi.json").json()
    swing = spec["components"]["schemas"]["SwingParams"]["properties"]["v"]
    assert swing["minimum"] == 1.5 and "eq (23)" in swing["description"]


def test_the_server_survives_abrupt_disconnects(http, server):
    for _ in range(5):
        ws = connect(ws_url(server[0]), open_timeout=10)
        ws.recv(timeout=10)
        ws.socket.close()  # no close handshake
    assert http.get("/api/health").json()["status"] == "ok"
    assert http.get("/api/state").json()["scope"]["clients"] <= 1
