"""Switching robots on a running server (docs/DESIGN.md §7): the simulation follows within a
frame, in the new robot's own preset; undo and redo take it back and forth; a robot not on
offer, or a switch while a job or a replay runs, is refused and changes nothing."""

from __future__ import annotations

import pytest

from tests.testing.server_harness import client, running_server, wait_for


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("data")) as (base_url, _app):
        with client(base_url) as http:
            yield http


@pytest.fixture
def http(server):
    """Whatever a test switches, the server is back on ArtRo afterwards."""
    yield server
    server.post("/api/recording/live")
    server.put("/api/robot", json={"name": "artro"})


def _simulated(http, robot: str):
    return wait_for(
        lambda: (s := http.get("/api/state").json())["robot"] == robot and s,
        f"the simulation runs {robot}",
    )


def test_the_robots_on_offer_are_listed_with_their_figures(http):
    offer = http.get("/api/robots").json()
    assert offer["loaded"] == "artro"
    by_name = {r["name"]: r for r in offer["robots"]}
    assert offer["robots"][0]["name"] == "artro" and "micro" in by_name
    assert by_name["artro"]["total_mass_kg"] == pytest.approx(1.65)
    assert by_name["micro"]["total_mass_kg"] < 0.5 * by_name["artro"]["total_mass_kg"]
    assert by_name["micro"]["default_preset"] == "micro-robust"


def test_a_switch_simulates_the_new_robot_in_its_preset_and_undo_takes_it_back(http):
    before = http.get("/api/params").json()
    switched = http.put("/api/robot", json={"name": "micro"})
    assert switched.status_code == 200, switched.text
    body = switched.json()
    assert body["changed"] and body["params"]["robot"] == "micro"
    assert body["params"]["name"] == "micro-robust"
    assert body["params"]["version"] > before["version"]
    state = _simulated(http, "micro")
    micro = http.get("/api/robot").json()
    assert micro["name"] == "micro" and micro["derived"]["total_mass_kg"] < 0.5
    # the recording starts over with the new robot: a replay never mixes two robots' frames
    events = http.get("/api/recording").json()["events"]
    assert events[0]["kind"] == "robot" and events[0]["robot"] == "micro"
    # it walks: frames go on and it stands at the micro robot's height, not ArtRo's
    wait_for(lambda: http.get("/api/state").json()["frame"] > state["frame"] + 25,
             "the micro robot walks on")  # fmt: skip
    standing = http.get("/api/state").json()["trunk"]["z_m"]
    again = http.put("/api/robot", json={"name": "micro"}).json()
    assert not again["changed"] and again["params"]["version"] == body["params"]["version"]

    undone = http.post("/api/params/undo").json()
    assert undone["robot"] == "artro" and undone["name"] == before["name"]
    assert undone["gait"] == before["gait"] and undone["motion"] == before["motion"]
    _simulated(http, "artro")
    wait_for(lambda: http.get("/api/state").json()["trunk"]["z_m"] > standing + 0.03,
             "ArtRo stands taller than the micro robot")  # fmt: skip
    redone = http.post("/api/params/redo").json()
    assert redone["robot"] == "micro" and redone["name"] == "micro-robust"
    _simulated(http, "micro")


@pytest.mark.parametrize(
    "body",
    [
        {"name": "nao"},
        {"name": "../models/robots/micro.yaml"},
        {"name": 3},
        {},
        {"name": "micro", "x": 1},
    ],
)
def test_a_robot_not_on_offer_is_refused_and_changes_nothing(http, body):
    before = http.get("/api/params").json()["version"]
    bad = http.put("/api/robot", json=body)
    not_on_offer = isinstance(body.get("name"), str) and len(body) == 1
    assert bad.status_code == (404 if not_on_offer else 422), bad.text
    if body.get("name") == "nao":
        assert (
            "artro" in bad.json()["detail"][0]["msg"] and "micro" in bad.json()["detail"][0]["msg"]
        )
    assert http.get("/api/params").json()["version"] == before
    assert http.get("/api/state").json()["robot"] == "artro"


def test_no_switch_while_a_job_runs_or_a_replay_is_shown(http):
    before = http.get("/api/params").json()["version"]
    job = http.post("/api/jobs/robustness", json={"samples": 4}).json()
    try:
        busy = http.put("/api/robot", json={"name": "micro"})
        assert busy.status_code == 409 and "job" in busy.json()["detail"][0]["msg"]
    finally:
        http.delete(f"/api/jobs/{job['id']}")
    wait_for(lambda: http.get(f"/api/jobs/{job['id']}").json()["status"] != "running", "cancelled")
    assert http.post("/api/recording/replay", json={}).status_code == 200
    replaying = http.put("/api/robot", json={"name": "micro"})
    assert replaying.status_code == 409 and "replay" in replaying.json()["detail"][0]["msg"]
    assert http.get("/api/params").json()["version"] == before
    assert http.get("/api/state").json()["robot"] == "artro"


def test_no_undo_back_to_another_robot_while_a_replay_is_shown(http):
    """A replay of one robot once outlived an undo back to another (its frames drawn on the
    wrong legs): every change of robots, a switch or an undo, is decided by one guard."""
    assert http.put("/api/robot", json={"name": "micro"}).status_code == 200
    state = _simulated(http, "micro")
    wait_for(lambda: http.get("/api/state").json()["frame"] > state["frame"] + 5,
             "the micro robot's first frames recorded")  # fmt: skip
    replay = http.post("/api/recording/replay", json={})
    assert replay.status_code == 200, replay.text
    version = http.get("/api/params").json()["version"]
    undo = http.post("/api/params/undo")
    assert undo.status_code == 409 and undo.json()["detail"][0]["type"] == "robot_busy"
    assert "from 'micro' to 'artro'" in undo.json()["detail"][0]["msg"]
    assert http.get("/api/params").json()["version"] == version
    assert http.get("/api/state").json()["robot"] == "micro"
    http.post("/api/recording/live")
    assert http.post("/api/params/undo").json()["robot"] == "artro"
    _simulated(http, "artro")


def test_the_errors_start_over_with_each_robot(http):
    """What the state's errors said was of the robot in use: a switch ends the ghost (ArtRo's),
    said so; undone, the state does not keep that line on ArtRo (issue 33, low: "firmware drive
    ended: the robot is now ..." once stayed after an undo and a redo)."""
    earlier = http.get("/api/params").json()["version"]
    http.patch("/api/params", json={"motion": {"a_p": 0.03}})
    assert http.put("/api/ghost", json={"version": earlier}).status_code == 200
    assert http.put("/api/robot", json={"name": "micro"}).status_code == 200
    state = _simulated(http, "micro")
    assert any("it walked 'artro'" in e for e in state["errors"]), state["errors"]
    assert http.post("/api/params/undo").json()["robot"] == "artro"
    state = _simulated(http, "artro")
    assert not any("it walked" in e for e in state["errors"]), state["errors"]


def test_an_export_after_a_switch_and_a_push_imports_on_its_robot_only(http):
    """The recorder logs `robot` and `push` events, which the import refused ("not a
    recording"); a file of one robot imported on another replayed its poses and pulses on the
    wrong bodies (the hostile probe). Now it is the robot's own file back, and refused by
    name elsewhere."""
    assert http.put("/api/robot", json={"name": "micro"}).status_code == 200
    _simulated(http, "micro")
    pushed = http.post("/api/sim/push", json={"impulse_n_s": 0.05, "direction_deg": 90})
    assert pushed.status_code == 200, pushed.text

    def recorded():  # the push's event can come a frame before the frame that holds it
        summary = http.get("/api/recording").json()
        kinds = {e["kind"] for e in summary["events"]}
        return summary["frames"] > 0 and {"robot", "push"} <= kinds

    wait_for(recorded, "frames, the switch and the push recorded")
    exported = http.get("/api/recording/export").json()
    assert exported["model"] == "micro"
    back = http.post("/api/recording/import", json=exported)
    assert back.status_code == 200, back.text[:400]
    assert back.json()["origin"] == "file"
    assert http.post("/api/recording/live").status_code == 200
    assert http.put("/api/robot", json={"name": "artro"}).status_code == 200
    _simulated(http, "artro")
    before = http.get("/api/recording").json()["replay"]
    refused = http.post("/api/recording/import", json=exported)
    assert refused.status_code == 409, refused.text[:400]
    problem = refused.json()["detail"][0]
    assert problem["type"] == "other_robot" and problem["loc"] == ["body", "model"]
    assert "recorded on the robot 'micro'; the robot in use is 'artro'" in problem["msg"]
    assert http.get("/api/recording").json()["replay"] == before  # no replay started


def test_a_ghost_of_another_robots_set_is_warned_of(http):
    """A ghost walks its set on the robot here: a set tuned for another robot is said so, as a
    preset load says it (the hostile probe)."""
    assert http.put("/api/robot", json={"name": "micro"}).status_code == 200
    try:
        other = http.put("/api/ghost", json={"preset": "robust"})
        assert other.status_code == 200, other.text
        assert other.json()["warnings"] == [
            "parameter set 'robust' was tuned for the robot 'artro'; the robot here is 'micro': "
            "it may walk differently or fall"
        ]
        own = http.put("/api/ghost", json={"preset": "micro-robust"})
        assert own.status_code == 200 and own.json()["warnings"] == []
    finally:
        http.delete("/api/ghost")
