"""`artro link` against the emulated robot behind a pseudo-terminal and a real dashboard server:
the dashboard's set arrives whole, a change follows, the servos go off at the end."""

from __future__ import annotations

import struct
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
import serial

from app.cli.link import command as cmd_link
from app.firmware import protocol as proto
from app.firmware.dashboard_set import plain_set
from app.firmware.link import SerialLink, read_params
from app.firmware.robot_link import LinkError, RobotLink, follow
from hardware.firmware.schema import values_from_document
from tests.testing.server_harness import client, running_server

ARTRO = str(Path(sys.executable).with_name("artro"))


def dry_link(cwd: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    """`artro link --dry-run` with `extra`, a process of its own."""
    return subprocess.run(
        [ARTRO, "link", "--dry-run", *extra], capture_output=True, text=True, timeout=120, cwd=cwd
    )


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
        expected = np.float32(values_from_document(plain_set(changed)))
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


def test_a_dashboard_on_another_robot_is_refused_naming_both(tmp_path):
    """Issue 56 item 3: with the dashboard on `micro`, `artro link --server` sent
    `micro-robust` to a firmware built for ArtRo without a word. Now refused, naming both
    robots, no SET_PARAMS sent and the servos switched off; `--robot micro` (a firmware built
    for micro) takes it. One set of another robot (`--params`) is refused before a port opens."""

    def link(*extra: str) -> subprocess.CompletedProcess[str]:
        return dry_link(tmp_path, *extra)

    with running_server(tmp_path / "data", robot="micro") as (base_url, _app):
        refused = link("--server", base_url)
        taken = link("--server", base_url, "--robot", "micro")
    assert refused.returncode == 2, refused.stderr
    assert (
        f"the dashboard at {base_url} simulates the robot 'micro', and its set 'micro-robust'"
        in refused.stderr
    ), refused.stderr
    assert "the firmware on the port is built for 'artro' (--robot): nothing sent" in refused.stderr
    sent = [line.split()[1] for line in refused.stdout.splitlines() if line.startswith("->")]
    assert sent == ["PING", "TORQUE_OFF"], refused.stdout
    assert taken.returncode == 0 and "sent micro-robust" in taken.stdout, taken.stderr
    one = link("--params", "micro-robust")
    assert one.returncode == 2 and "->" not in one.stdout, one.stdout
    assert (
        "the set 'micro-robust' is tuned for the robot 'micro'; the firmware on the port is "
        "built for 'artro' (--robot)" in one.stderr
    ), one.stderr


def test_a_password_in_the_servers_address_is_never_printed(tmp_path):
    """Issue 56 item 18: `--server http://me:s3cret@host` printed the password in what the link
    said and in its errors; it is shown as ***."""
    with running_server(tmp_path / "data") as (base_url, _app):
        url = base_url.replace("http://", "http://me:s3cret@")
        followed = dry_link(tmp_path, "--server", url)
    gone = dry_link(tmp_path, "--server", url)  # the server has ended: no answer
    malformed = dry_link(tmp_path, "--server", "http://me:s3cret@127.0.0.1:port")
    shown = url.replace("s3cret", "***")
    assert followed.returncode == 0 and f"would follow {shown}:" in followed.stdout, followed
    assert gone.returncode == 2 and f"the dashboard at {shown} did not answer" in gone.stderr
    assert malformed.returncode == 2 and "'http://me:***@127.0.0.1:port'" in malformed.stderr
    for run in (followed, gone, malformed):
        assert "s3cret" not in run.stdout + run.stderr, run
