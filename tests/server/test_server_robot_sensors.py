"""A linked robot's sensor frames on a real server (docs/DESIGN.md §15): what `artro link`
posts shows in GET /api/sensors beside the simulation's, in the robot's frame order, each
sole's load and centre of pressure on the dashboard robot's force sensors; a frame posted again
is not kept twice; a bad body is refused with a 422 that says what is allowed, and changes
nothing. The robot view's columns, taken from the declared channels, are the hand-written ones
to the bit."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from app.firmware import protocol as proto
from app.firmware.robot_telemetry import POST_FRAMES
from app.robots.model import RobotModel
from app.server.api.sensors import MAX_POSTED_FRAMES
from app.server.feeds.robot_sensors import COLUMNS, WINDOW_FRAMES, RobotFrame, RobotSensors
from app.server.http.request_gate import MAX_BODY_BYTES
from app.sim.planning import FRAME_S
from app.sim.sensors import SensorReading
from tests.testing.server_harness import client, running_server


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("data")) as (base_url, _app):
        with client(base_url) as http:
            yield http


def frame(n: int, pitch_rad: float = 0.01) -> dict:
    return {
        "frame": n,
        "status": ["imu_present"],
        "imu_failures": 0,
        "laws": ["tilt"],
        "support": 0,
        "attitude_rad": [pitch_rad, -0.02],
        "gyro_rad_s": [0.0, 0.1, -0.05],
        "accel_m_s2": [0.0, 0.0, 9.81],
        "fsr_n": [[3.0, 1.0, 3.0, 1.0], [0.0, 0.0, 0.0, 0.0]],
        "tilt_rad": [0.005, 0.0],
        "a_y_delta": 0.0,
        "cop_rad": [0.0, 0.0],
    }


def test_posted_frames_show_beside_the_simulations(server):
    assert server.post("/api/sensors/robot", json={"frames": [frame(n) for n in range(10, 20)]})
    again = server.post("/api/sensors/robot", json={"frames": [frame(n) for n in range(15, 25)]})
    assert again.status_code == 200 and again.json()["taken"] == 5  # 15..19 held already
    view = server.get("/api/sensors").json()
    assert set(view["columns"]) >= {"t_s", "pitch_est_deg"}  # the simulation's, as before
    robot = view["robot"]
    assert robot["frame"] == 24 and robot["status"] == ["imu_present"]
    assert robot["laws"] == ["tilt"] and robot["imu_failures"] == 0
    columns = robot["columns"]
    assert set(columns) == set(COLUMNS)
    assert columns["frame"] == list(range(10, 25))
    assert columns["t_s"] == pytest.approx([n * 0.02 for n in range(10, 25)])
    assert columns["pitch_est_deg"][-1] == pytest.approx(np.degrees(0.01))
    assert columns["tilt_pitch_deg"][-1] == pytest.approx(np.degrees(0.005))
    assert columns["load_l_n"][-1] == pytest.approx(8.0) and columns["load_r_n"][-1] == 0.0
    # the left sole's centre of pressure: toward its left edge (fl and bl carry 3 of 4 shares)
    positions = RobotModel.load().fsr_positions_m
    corners = np.array([3.0, 1.0, 3.0, 1.0]) @ positions / 8.0 * 1e3
    assert columns["cop_l_x_mm"][-1] == pytest.approx(corners[0], abs=1e-9)
    assert columns["cop_l_y_mm"][-1] == pytest.approx(corners[1]) and corners[1] > 0
    assert columns["cop_r_x_mm"][-1] is None  # the right sole carries nothing
    assert 0.0 <= robot["received_s_ago"] < 2.0


def test_the_window_keeps_the_last_five_seconds_and_a_restart_starts_over(server):
    for first in range(1000, 1000 + 320, MAX_POSTED_FRAMES):
        frames = [frame(n) for n in range(first, first + MAX_POSTED_FRAMES)]
        assert server.post("/api/sensors/robot", json={"frames": frames}).status_code == 200
    held = server.get("/api/sensors").json()["robot"]["columns"]["frame"]
    assert held == list(range(1320 - WINDOW_FRAMES, 1320))
    assert server.post("/api/sensors/robot", json={"frames": [frame(3)]}).json()["taken"] == 1
    assert server.get("/api/sensors").json()["robot"]["columns"]["frame"] == [3]


def _bad(mutate) -> dict:
    body = {"frames": [frame(5000), frame(5001)]}
    mutate(body)
    return body


BAD = {
    "no frames": lambda b: b.update(frames=[]),
    "an unknown field": lambda b: b["frames"][1].update(speed=1.0),
    "a missing field": lambda b: b["frames"][1].pop("attitude_rad"),
    "an unknown status": lambda b: b["frames"][1].update(status=["imu_on_fire"]),
    "an unknown law": lambda b: b["frames"][1].update(laws=["pid"]),
    "support 2": lambda b: b["frames"][1].update(support=2),
    "support true": lambda b: b["frames"][1].update(support=True),
    "a negative frame": lambda b: b["frames"][1].update(frame=-1),
    "a frame as text": lambda b: b["frames"][1].update(frame="5001"),
    "three angles": lambda b: b["frames"][1].update(attitude_rad=[0.0, 0.0, 0.0]),
    "an angle past pi": lambda b: b["frames"][1].update(tilt_rad=[4.0, 0.0]),
    "a gyro past its range": lambda b: b["frames"][1].update(gyro_rad_s=[0.0, 5.0, 0.0]),
    "a negative force": lambda b: b["frames"][1]["fsr_n"][0].__setitem__(2, -1.0),
    "one sole": lambda b: b["frames"][1].update(fsr_n=[[1.0, 1.0, 1.0, 1.0]]),
    "too many frames": lambda b: b.update(frames=[frame(n) for n in range(MAX_POSTED_FRAMES + 1)]),
    "a frame not an object": lambda b: b.update(frames=[1, 2]),
}


@pytest.mark.parametrize("what", list(BAD))
def test_a_bad_body_is_refused_and_changes_nothing(server, what):
    server.post("/api/sensors/robot", json={"frames": [frame(4000)]})
    before = server.get("/api/sensors").json()["robot"]
    bad = server.post("/api/sensors/robot", json=_bad(BAD[what]))
    assert bad.status_code == 422, bad.text
    detail = bad.json()["detail"]
    assert detail and all(item["msg"] for item in detail)
    after = server.get("/api/sensors").json()["robot"]
    assert after["columns"] == before["columns"] and after["frame"] == 4000


def test_not_a_number_and_duplicate_keys_are_refused(server):
    server.post("/api/sensors/robot", json={"frames": [frame(6000)]})
    body = '{"frames": [' + str(frame(6001)).replace("'", '"').replace("0.01", "NaN") + "]}"
    bad = server.post(
        "/api/sensors/robot", content=body, headers={"content-type": "application/json"}
    )
    assert bad.status_code == 422 and "NaN" in bad.json()["message"]
    twice = '{"frames": [], "frames": []}'
    bad = server.post(
        "/api/sensors/robot", content=twice, headers={"content-type": "application/json"}
    )
    assert bad.status_code == 422 and "frames" in bad.json()["message"]
    assert server.get("/api/sensors").json()["robot"]["frame"] == 6000


def test_the_links_batches_fit_the_route_and_its_largest_body_the_gate():
    assert POST_FRAMES <= MAX_POSTED_FRAMES
    longest = -2.2250738585072014e-308  # the longest a float's JSON gets
    worst = frame(2**32 - 1) | {
        "status": list(proto.STATUS_BITS),
        "laws": list(proto.LAW_BITS),  # every law on: the timing law's bit 4 too
        "imu_failures": 255,
        "support": -1,
    }
    for key, value in worst.items():  # every number as long as JSON writes one
        if key == "fsr_n":
            worst[key] = [[longest] * 4, [longest] * 4]
        elif isinstance(value, list) and value and isinstance(value[0], float):
            worst[key] = [longest] * len(value)
        elif isinstance(value, float):
            worst[key] = longest
    body = json.dumps({"frames": [worst] * MAX_POSTED_FRAMES}).encode()
    assert len(body) <= MAX_BODY_BYTES


def test_a_robot_with_every_law_on_is_taken(server):
    """Five laws since the timing law's bit 4 reached SENSORS (decision 0063): all are taken."""
    body = {"frames": [frame(8000) | {"laws": list(proto.LAW_BITS)}]}
    assert server.post("/api/sensors/robot", json=body).status_code == 200
    assert server.get("/api/sensors").json()["robot"]["laws"] == list(proto.LAW_BITS)


def test_what_is_allowed_is_said(server):
    body = {"frames": [copy.deepcopy(frame(7000)) | {"support": 5}]}
    msg = server.post("/api/sensors/robot", json=body).json()["message"]
    assert "support" in msg and "less than or equal to 1" in msg


#: the robot view's columns as they were written by hand before the channels declared them
HAND_WRITTEN_COLUMNS = (
    "t_s", "frame",
    "pitch_est_deg", "roll_est_deg",
    "gyro_x_deg_s", "gyro_y_deg_s", "gyro_z_deg_s",
    "tilt_pitch_deg", "tilt_roll_deg", "a_y_delta", "cop_pitch_deg", "cop_roll_deg",
    "cop_l_x_mm", "cop_l_y_mm", "cop_r_x_mm", "cop_r_y_mm", "load_l_n", "load_r_n",
)  # fmt: skip


def _hand_written_row(frame: RobotFrame, positions_m) -> tuple[float | None, ...]:
    """The robot view's row as robot_sensors.py wrote it by hand before."""
    reading = SensorReading(
        np.asarray(frame.gyro_rad_s), np.asarray(frame.accel_m_s2), np.asarray(frame.fsr_n)
    )
    load = reading.fsr_n.sum(axis=1)
    cop_mm = reading.centre_of_pressure_m(positions_m) * 1e3
    deg = np.degrees
    return (
        frame.frame * FRAME_S, float(frame.frame),
        *(float(v) for v in deg(frame.attitude_rad)),
        *(float(v) for v in deg(frame.gyro_rad_s)),
        *(float(v) for v in deg(frame.tilt_rad)), float(frame.a_y_delta),
        *(float(v) for v in deg(frame.cop_rad)),
        *(None if np.isnan(v) else float(v) for v in cop_mm.reshape(4)),
        float(load[0]), float(load[1]),
    )  # fmt: skip


def _random_frame(rng: np.random.Generator, n: int) -> RobotFrame:
    """Frame `n` with values anywhere the route allows; a sole (or both) unloaded now and then,
    a negative zero here and there."""

    def values(k: int, limit: float) -> tuple[float, ...]:
        drawn = rng.uniform(-limit, limit, k)
        drawn[rng.random(k) < 0.1] = -0.0
        return tuple(float(v) for v in drawn)

    soles = np.abs(rng.normal(0.0, 20.0, (2, 4)))
    soles[rng.random(2) < 0.3] = 0.0
    return RobotFrame(
        frame=n, status=("imu_present",), imu_failures=0, laws=("tilt", "cop"), support=0,
        attitude_rad=values(2, np.pi), gyro_rad_s=values(3, 4.37), accel_m_s2=values(3, 19.6),
        fsr_n=(tuple(soles[0].tolist()), tuple(soles[1].tolist())), tilt_rad=values(2, 0.2),
        a_y_delta=values(1, 1.0)[0], cop_rad=values(2, 0.2),
    )  # fmt: skip


def test_the_robot_view_is_the_hand_written_one_to_the_bit():
    """As decision 0064 pinned the simulation's trace: the same columns in the same order, and
    the view's JSON the same to the bit over a window of frames (None for an unloaded sole)."""
    assert COLUMNS == HAND_WRITTEN_COLUMNS
    positions = RobotModel.load().fsr_positions_m
    rng = np.random.default_rng(69)
    frames = [_random_frame(rng, n) for n in range(1000, 1000 + WINDOW_FRAMES)]
    robot = RobotSensors()
    assert robot.add(frames, positions, now=0.0) == WINDOW_FRAMES
    view = robot.view(now=0.25)
    assert view is not None
    rows = [_hand_written_row(f, positions) for f in frames]
    columns = {name: [row[i] for row in rows] for i, name in enumerate(HAND_WRITTEN_COLUMNS)}
    assert None in columns["cop_l_x_mm"] and None in columns["cop_r_y_mm"]
    assert json.dumps(view) == json.dumps(view | {"columns": columns})
