"""`artro link` against the emulated robot behind a pseudo-terminal and a real dashboard server:
the dashboard's set arrives whole, a change follows, the servos go off at the end."""

from __future__ import annotations

import struct
import threading

import numpy as np
import pytest
import serial

from app.cli.link import command as cmd_link
from app.firmware import protocol as proto
from app.firmware.link import SerialLink, read_params
from app.firmware.robot_link import LinkError, RobotLink, _plain, follow
from hardware.firmware.schema import values_from_document
from tests.testing.server_harness import client, running_server


def test_the_dashboards_set_and_its_change_reach_the_robot(robot_on_a_pty, tmp_path):
    sent: list[str] = []
    first_sent = threading.Event()

    def log(line: str) -> None:
        sent.append(line)
        if line.startswith("sent"):
            first_sent.set()

    link = SerialLink(serial.Serial(robot_on_a_pty, 57600, timeout=0.02), timeout_s=30.0)
    robot = RobotLink(link, log=log)
    with running_server(tmp_path) as (base_url, _app), client(base_url) as http:
        robot.hello()
        stop = threading.Event()
        done: list[int] = []
        worker = threading.Thread(
            target=lambda: done.append(follow(robot, base_url, stop, max_updates=1)), daemon=True
        )
        worker.start()
        assert first_sent.wait(60), sent
        changed = http.patch("/api/params", json={"motion": {"a_p": 0.05, "ca": -0.02}}).json()
        worker.join(60)
        assert done == [2], sent
        # the robot holds exactly the dashboard's new set (as float32)
        expected = np.float32(values_from_document(_plain(changed)))
        np.testing.assert_array_equal(np.float32(read_params(link, len(expected))), expected)
        (info,) = link.request(proto.encode(proto.Msg.PING))
        assert info.state == proto.RunState.WALK
        robot.torque_off()
        (info,) = link.request(proto.encode(proto.Msg.PING))
        assert info.state == proto.RunState.TORQUE_OFF
    link.close()
    assert any("dashboard version" in line for line in sent)


def test_a_port_where_no_robot_answers_is_a_clear_error(tmp_path):
    class Silent:
        def write(self, data: bytes) -> int:
            return len(data)

        def read(self, size: int = 1) -> bytes:
            return b""

        def close(self) -> None:
            pass

    robot = RobotLink(SerialLink(Silent(), timeout_s=0.05))
    with pytest.raises(LinkError, match="no answer from the robot"):
        robot.hello()


def test_dry_run_prints_the_messages_and_switches_off(tmp_path):
    import argparse
    import io

    out = io.StringIO()
    (tmp_path / "set.json").write_text('{"motion": {"a_p": 0.07}}')
    args = argparse.Namespace(
        dry_run=True,
        port=None,
        baud=57600,
        server=None,  # one set, no dashboard to follow
        params=str(tmp_path / "set.json"),
    )
    assert cmd_link(args, out) == 0
    lines = out.getvalue().splitlines()
    kinds = [line.split()[1] for line in lines if line.startswith("->")]
    assert kinds == ["PING", "SET_PARAMS", "SET_PARAMS", "START", "TORQUE_OFF"]  # laws, gait
    with pytest.raises(ValueError, match="--port is needed"):
        cmd_link(argparse.Namespace(dry_run=False, port=None, baud=57600), io.StringIO())


def test_a_set_with_a_feedback_law_on_goes_to_the_robot_whole():
    """The firmware runs the laws: a set with one on is sent, laws and gait, every id once."""
    written: list[bytes] = []

    class Recording:
        def write(self, data: bytes) -> int:
            written.append(data)
            return len(data)

        def read(self, size: int = 1) -> bytes:
            return b""

        def close(self) -> None:
            pass

    robot = RobotLink(SerialLink(Recording(), timeout_s=0.05), dry_run=True)
    doc = {"motion": {"a_p": 0.07}, "gait": {"tilt": {"enabled": True, "kp": 0.5}}}
    robot.send_set(doc)
    values = values_from_document(doc)
    sent = {}
    for message in written:
        first, count = message[3], message[4]
        values_sent = struct.unpack_from(f"<{count}f", message, 5)
        sent.update(zip(range(first, first + count), values_sent, strict=True))
    assert sorted(sent) == list(range(len(values)))
    got = np.float32([sent[i] for i in range(len(values))])
    np.testing.assert_array_equal(got, np.float32(values))
