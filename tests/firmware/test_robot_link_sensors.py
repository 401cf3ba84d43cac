"""`artro link` shows a real robot's sensors in the dashboard (issue 30, item 5), against the
emulated robot with its IMU and force sensors attached, on a pseudo-terminal, and a real
dashboard server: the robot's SENSORS stream reaches GET /api/sensors with the IMU present and
the attitude its registers give, the laws the dashboard switched on, while the dashboard's
changes still reach the robot whole (each ACK paired with its request); a dashboard gone away
costs the link nothing."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import serial

from app.firmware import protocol as proto
from app.firmware.dashboard_set import plain_set
from app.firmware.link import SerialLink, read_params
from app.firmware.robot_link import RobotLink, follow
from app.firmware.robot_telemetry import SensorForwarder, frame_json
from app.firmware.sensor_feed import (
    GYRO_ZERO_RATE_COUNTS,
    decoded,
    sample_of,
)
from gait.attitude import accel_tilt
from hardware.firmware.schema import values_from_document
from tests.testing.firmware_support import (
    PITCH_RAD,
    emulator,
    preset,
    served_on_a_pty,
    tilted,
)
from tests.testing.server_harness import client, running_server, wait_for


@pytest.fixture
def robot_with_sensors():
    """The emulated robot (paper) with its IMU and force sensors reading `tilted()`, on a pty."""
    with (
        emulator(preset("paper"), sensors=sample_of(tilted())) as mcu,
        served_on_a_pty(mcu) as port,
    ):
        yield port


def still_frame() -> proto.Sensors:
    """A SENSORS frame 0 of the robot leaning as `tilted()`, still, the soles unloaded."""
    return proto.Sensors(
        frame=0, status=proto.IMU_PRESENT, imu_failures=0, laws=0, support=-1,
        gyro_offset=GYRO_ZERO_RATE_COUNTS, accel_raw=tilted().accel,
        gyro_raw=GYRO_ZERO_RATE_COUNTS, adc=(0,) * 8, attitude_rad=(0.1, 0.0),
        tilt_rad=(0.0, 0.0), a_y_delta=0.0, cop_rad=(0.0, 0.0),
    )  # fmt: skip


class Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def __call__(self, line: str) -> None:
        self.lines.append(line)

    def has(self, part: str) -> bool:
        return any(part in line for line in self.lines)


def _robot_frames(http) -> dict | None:
    robot = http.get("/api/sensors").json()["robot"]
    return robot if robot and len(robot["columns"]["frame"]) >= 20 else None


def test_the_robots_sensors_reach_the_dashboard_while_its_sets_go_on(robot_with_sensors, tmp_path):
    log = Log()
    link = SerialLink(serial.Serial(robot_with_sensors, 57600, timeout=0.02), timeout_s=30.0)
    robot = RobotLink(link, log=log)
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        robot.hello()
        stop = threading.Event()
        done: list[int] = []
        worker = threading.Thread(
            target=lambda: done.append(follow(robot, base_url, stop, max_updates=1)), daemon=True
        )
        worker.start()
        try:
            frames = wait_for(lambda: _robot_frames(http), "the robot's frames in the dashboard")
        finally:  # the next set ends the link's following (max_updates=1), and the stream
            changed = http.patch("/api/params", json={"motion": {"a_p": 0.05}}).json()
            worker.join(60)
        assert done == [2], log.lines

        # the robot's own frames, in its order, as its IMU's registers give them
        assert frames["status"] == ["imu_present"] and frames["imu_failures"] == 0
        # the dashboard's set, `robust` as the server starts, with its laws on
        assert frames["laws"] == ["tilt", "yaw_rate", "damping"]
        columns = frames["columns"]
        assert np.all(np.diff(columns["frame"]) >= 1)
        raw = tilted()
        pitch, roll = np.degrees(accel_tilt(decoded(raw, GYRO_ZERO_RATE_COUNTS).accel_m_s2))
        assert columns["pitch_est_deg"][-1] == pytest.approx(pitch, abs=1e-3)
        assert columns["roll_est_deg"][-1] == pytest.approx(roll, abs=1e-3)
        assert abs(pitch - np.degrees(PITCH_RAD)) < 0.01  # the sample leans as meant
        assert max(abs(v) for v in columns["tilt_pitch_deg"]) > 0  # the trim acts on the lean
        assert columns["load_l_n"][-1] == pytest.approx(
            float(decoded(raw, (0, 0, 0)).fsr_n[0].sum())
        )
        assert columns["load_r_n"][-1] == 0.0

        # each set was paired with its ACK amid the stream: the robot holds the new set whole,
        # and after the stream's end a request gets its own answer
        expected = np.float32(values_from_document(plain_set(changed)))
        np.testing.assert_array_equal(np.float32(read_params(link, len(expected))), expected)
        (info,) = link.request(proto.encode(proto.Msg.PING))
        assert isinstance(info, proto.Info) and info.state == proto.RunState.WALK
        robot.torque_off()
    link.close()
    assert log.has("the robot's sensors go to")
    sets = [line for line in log.lines if line.startswith("sent")]
    assert len(sets) == 2 and all("from frame" in line for line in sets)  # each set's ACK


def test_a_dashboard_gone_away_costs_the_link_nothing(robot_with_sensors, tmp_path):
    log = Log()
    link = SerialLink(serial.Serial(robot_with_sensors, 57600, timeout=0.02), timeout_s=30.0)
    robot = RobotLink(link, log=log)
    stop = threading.Event()
    done: list[int] = []
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        worker = threading.Thread(
            target=lambda: done.append(follow(robot, base_url, stop)), daemon=True
        )
        worker.start()
        wait_for(lambda: _robot_frames(http), "the robot's frames in the dashboard")
    # the server is gone: the link says so once for each, and goes on
    wait_for(lambda: log.has("did not answer"), "the lost dashboard said")
    wait_for(lambda: log.has("did not take the robot's sensors"), "the lost sensors said")
    assert worker.is_alive()
    stop.set()
    worker.join(60)
    assert done == [1], log.lines
    robot.torque_off()  # the robot answers as ever: the stream ended with the link
    (info,) = link.request(proto.encode(proto.Msg.PING))
    assert info.state == proto.RunState.TORQUE_OFF
    link.close()
    assert sum("did not answer" in line for line in log.lines) == 1


def test_frames_wait_for_a_dashboard_that_does_not_answer_and_put_never_blocks():
    """A forwarder to a port where nothing listens keeps the newest 5 s and says so once."""
    from tests.testing.server_harness import free_port

    log = Log()
    forwarder = SensorForwarder(f"http://127.0.0.1:{free_port()}", log)
    forwarder.start()
    try:
        sensors = still_frame()
        for n in range(400):
            forwarder.put(sensors.__class__(**{**sensors.__dict__, "frame": n}))
        wait_for(lambda: log.has("did not take the robot's sensors"), "the failure said")
    finally:
        forwarder.stop()
    waiting = list(forwarder._pending)
    assert [f["frame"] for f in waiting] == list(range(150, 400))  # the newest 250
    assert forwarder.posted == 0 and len(log.lines) == 1
    nan = sensors.__class__(**{**sensors.__dict__, "attitude_rad": (float("nan"), 0.0)})
    assert frame_json(nan) is None


def test_a_frame_the_dashboard_refuses_costs_only_itself(tmp_path):
    """A frame out of the dashboard's bounds (an attitude past π, as the firmware sent before
    it wrapped the roll) was refused with its whole batch of up to 16: now the others go again."""
    log = Log()
    sensors = still_frame()
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        forwarder = SensorForwarder(base_url, log)
        for n in range(1, 41):
            roll = 5.5 if n in (7, 30) else 0.0
            forwarder.put(sensors.__class__(**{**sensors.__dict__, "frame": n,
                                               "attitude_rad": (0.1, roll)}))  # fmt: skip
        forwarder.start()
        try:
            wait_for(lambda: forwarder.posted + forwarder.refused == 40, "every frame handled")
        finally:
            forwarder.stop()
        frames = http.get("/api/sensors").json()["robot"]["columns"]["frame"]
    assert forwarder.refused == 2 and forwarder.posted == 38
    assert frames == [n for n in range(1, 41) if n not in (7, 30)]
    assert len(log.lines) == 1 and log.lines[0].startswith(
        "the dashboard refused the robot's sensor frame 7 (frames.6.attitude_rad.1: Input "
        "should be less than or equal to 3.14"
    ), log.lines
