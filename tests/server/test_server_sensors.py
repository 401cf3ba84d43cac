"""The Sensors panel's API and the Push on a real server (docs/DESIGN.md §15): the sensors'
last frames in columns of one length, the soles carrying the robot's weight, the estimate
following the true tilt; a push reaches the robot and the state says so; a bad one, or one at a
fallen robot, is refused and changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

from app.robots.model import RobotModel
from app.server.feeds.robot_sensors import COLUMNS as ROBOT_COLUMNS
from app.server.recording.sensor_trace import COLUMNS
from tests.testing.server_harness import client, running_server, wait_for


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("data")) as (base_url, _app):
        with client(base_url) as http:
            yield http


def full_window(server) -> dict:
    view = server.get("/api/sensors").json()
    return view if len(view["columns"]["t_s"]) >= 200 else None


def test_the_sensors_last_frames_read_as_the_robot_stands_on_them(server):
    view = wait_for(lambda: full_window(server), "four seconds of sensor frames")
    columns = view["columns"]
    assert set(columns) == set(COLUMNS)
    assert {len(values) for values in columns.values()} == {len(columns["t_s"])}
    assert np.all(np.diff(columns["t_s"]) > 0)  # oldest first, one row per frame
    load = np.array(columns["load_l_n"]) + np.array(columns["load_r_n"])
    weight = RobotModel.load().total_mass_kg() * 9.81
    assert abs(load.mean() - weight) < 0.15 * weight  # the soles carry the robot
    for axis in ("pitch", "roll"):  # the estimate follows the truth over the window
        estimated = np.array(columns[f"{axis}_est_deg"])
        true = np.array(columns[f"{axis}_true_deg"])
        assert abs(estimated.mean() - true.mean()) < 3.0
    assert view["sole_mm"][0] > view["sole_mm"][1] > 0  # a sole longer than wide
    assert len(view["fsr_mm"]) == 4


def test_a_push_reaches_the_robot_and_the_state_says_so(server):
    frame = server.get("/api/state").json()["frame"]
    answer = server.post("/api/sim/push", json={"impulse_n_s": 0.2, "direction_deg": 450 - 360})
    assert answer.status_code == 200
    state = wait_for(
        lambda: (s := server.get("/api/state").json())["push"] is not None and s, "the push acted"
    )
    push = state["push"]
    assert push["impulse_n_s"] == 0.2 and push["sim_time_s"] >= frame * 0.02
    yaw_deg = np.degrees(state["trunk"]["yaw_rad"])
    assert abs((push["direction_deg"] - yaw_deg - 90.0 + 180.0) % 360.0 - 180.0) < 5.0
    # and as it was given, from where the robot faced (the fall notice names it so: issue 56, 17)
    assert push["toward_deg"] == pytest.approx(90.0, abs=1e-6)
    server.post("/api/sim/reset")
    wait_for(lambda: server.get("/api/state").json()["push"] is None, "a reset forgets it")


@pytest.mark.parametrize(
    "body",
    [
        {"impulse_n_s": 0.0},
        {"impulse_n_s": 5.0},
        {"impulse_n_s": 0.2, "direction_deg": "left"},
        {"impulse_n_s": 0.2, "strength": 1},
        {},
    ],
)
def test_a_bad_push_is_refused_and_changes_nothing(server, body):
    server.post("/api/sim/reset")
    wait_for(lambda: server.get("/api/state").json()["push"] is None, "no push yet")
    bad = server.post("/api/sim/push", json=body)
    assert bad.status_code == 422 and bad.json()["detail"]
    frame = server.get("/api/state").json()["frame"]
    wait_for(lambda: server.get("/api/state").json()["frame"] > frame + 5, "it walks on")
    assert server.get("/api/state").json()["push"] is None


def test_pushes_waiting_while_paused_are_bounded_as_one_push(server):
    """60 pushes of 2 N·s sent while paused all acted in the next step, as one of 120 N·s (600
    blew the physics up): what waits is now bounded by one push's cap, past it refused in words,
    changing nothing; once a step lets them act, pushing works again."""
    server.post("/api/sim/reset")
    wait_for(lambda: server.get("/api/state").json()["push"] is None, "no push yet")
    server.post("/api/sim/pause")
    wait_for(lambda: server.get("/api/state").json()["paused"], "paused")
    for impulse in (1.5, 0.5):  # up to the cap, together
        assert server.post("/api/sim/push", json={"impulse_n_s": impulse}).status_code == 200

    def both_taken() -> dict | None:  # the state published after the second push
        s = server.get("/api/state").json()
        return s if s["push"] and s["push"]["impulse_n_s"] == pytest.approx(2.0) else None

    waiting = wait_for(both_taken, "both taken")
    refused = server.post("/api/sim/push", json={"impulse_n_s": 0.01})
    assert refused.status_code == 409, refused.text
    error = refused.json()["detail"][0]
    assert error["type"] == "pushes_pending"
    assert "2.00 N·s of pushes already wait for the next physics step" in error["msg"]
    assert "at most 2 N·s may wait, so at most 0.00 N·s more now" in error["msg"]
    assert "resume or step (POST /api/sim/resume or /api/sim/step)" in error["msg"]
    assert server.get("/api/state").json()["push"] == waiting["push"]  # the refused one not in
    frame = waiting["frame"]
    server.post("/api/sim/step")
    wait_for(lambda: server.get("/api/state").json()["frame"] > frame, "the step: they acted")
    again = server.post("/api/sim/push", json={"impulse_n_s": 0.2})
    assert again.status_code == 200, again.text
    server.post("/api/sim/reset")
    server.post("/api/sim/resume")
    wait_for(lambda: not server.get("/api/state").json()["paused"], "running again")


def test_a_fallen_robot_is_not_pushed_and_the_answer_says_to_reset(server):
    server.post("/api/sim/reset")
    wait_for(lambda: server.get("/api/state").json()["push"] is None, "no push yet")

    def pushed_over() -> bool:
        if server.get("/api/state").json()["fell"]:
            return True
        server.post("/api/sim/push", json={"impulse_n_s": 2.0, "direction_deg": 0.0})
        return False

    wait_for(pushed_over, "the robot pushed over")
    mark = server.get("/api/state").json()["push"]
    refused = server.post("/api/sim/push", json={"impulse_n_s": 1.0})
    assert refused.status_code == 409, refused.text
    assert "reset first (POST /api/sim/reset)" in refused.json()["detail"][0]["msg"]
    assert server.get("/api/state").json()["push"] == mark  # no new mark, nothing recorded
    server.post("/api/sim/reset")
    wait_for(lambda: not server.get("/api/state").json()["fell"], "standing again")


def test_the_channels_say_what_each_column_is_and_how_the_panel_draws_it(server):
    declared = server.get("/api/sensors/channels").json()
    assert [c["key"] for c in declared["channels"]] == list(COLUMNS)
    charts = {chart["key"] for chart in declared["charts"]}
    assert charts == {"attitude", "gyro", "laws"}
    assert {c["chart"] for c in declared["channels"]} == charts | {None}
    pitch = next(c for c in declared["channels"] if c["key"] == "pitch_est_deg")
    assert pitch["unit"] == "°" and pitch["chart"] == "attitude" and pitch["dashed"] is False
    groups = [law["group"] for law in declared["laws"]]
    assert groups == ["tilt", "yaw_rate", "damping", "cop", "timing"]  # the switch bits' order
    robot = declared["robot"]  # a linked robot's series of each chart: its columns, drawn
    assert set(robot) == charts
    assert robot["gyro"][2] == {"key": "gyro_z_deg_s", "label": "yaw rate z", "colour": "#b2f2bb"}
    assert {s["key"] for chart in robot.values() for s in chart} <= set(ROBOT_COLUMNS)
