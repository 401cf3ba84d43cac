"""`artro link` when the robot goes (probe B): its port closed or silent while the dashboard's set
stays the same, a SIGTERM after it died, and a robot that restarted -- the emulated firmware on a
pty whose bridge stops or closes, or a pty robot that answers so (tests/testing/link_support.py)."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import struct
import threading
from collections.abc import Callable, Iterator

import pytest

from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from app.firmware.protocol import LinkError, Msg
from app.firmware.robot_link import PortLost, RobotLink, RobotRestarted
from tests.firmware.test_robot_link_exits import Lines, link_process
from tests.testing.firmware_support import preset
from tests.testing.link_support import (
    Dashboard,
    FakeRobot,
    ack,
    artro,
    bridged_robot,
    fake_dashboard,
    follow_on_a_thread,
    info,
    robot_on,
    serving,
)
from tests.testing.server_harness import running_server, wait_for


@pytest.mark.slow
@pytest.mark.parametrize(
    ("gone", "sensors", "said"),
    [
        ("closed", True, r"the robot's port /dev/pts/\d+ failed \(.*\)$"),  # the reader's error
        ("closed", False, r"the robot's port /dev/pts/\d+ failed \(.*\)$"),  # the keep-alive's
        ("silent", True, r"keep-alive ping: no answer from the robot"),  # the stream stopped
    ],
)
def test_a_robot_gone_ends_the_following(tmp_path, gone, sensors, said):
    with bridged_robot() as gone_robot, running_server(tmp_path) as (base_url, _app):
        robot, lines = robot_on(gone_robot.port, timeout_s=30.0)
        robot.hello()
        ended_with = follow_on_a_thread(robot, base_url, sensors=sensors)
        sent = "the robot's sensors go to" if sensors else "sent"
        wait_for(lambda: any(line.startswith(sent) for line in lines), sent, attempts=1200)
        if gone == "closed":
            gone_robot.close()
        else:
            gone_robot.silence()
            robot.link.timeout_s = 1.0  # not the emulator's 30 s: nothing will answer now
        error = ended_with()  # it ends, though the dashboard's set stays the same
        assert isinstance(error, LinkError) and re.match(said, str(error)), error
        assert isinstance(error, PortLost) == (gone == "closed")
        with pytest.raises(LinkError, match="port .* failed" if gone == "closed" else "no answer"):
            robot.torque_off()
        robot.link.close()


@pytest.mark.slow
def test_the_command_ends_when_the_robot_is_killed(tmp_path):
    """As a process: exit status 2, the port named, the servos said not switched off."""
    with bridged_robot() as killed, running_server(tmp_path) as (base_url, _app):
        link = link_process(killed.port, base_url)
        out = Lines(link.stdout)
        try:
            wait_for(lambda: out.has("the robot's sensors go to"), "the stream", attempts=1200)
            killed.close()  # its side of the pty closed, as by a SIGKILL
            assert link.wait(60) == 2, out.lines
        finally:
            if link.poll() is None:
                link.kill()
    lost = rf"the robot's port {killed.port} failed \(.*\)"
    assert any(re.fullmatch(f"could not switch the servos off: {lost}", x) for x in out.lines)
    assert re.fullmatch(f"artro link: error: {lost}", out.lines[-1]), out.lines


@contextlib.contextmanager
def dashboard_then_hold(on_hold: Callable[[], None]) -> Iterator[str]:
    """A dashboard whose first GET /api/params gives the paper's set and whose next one calls
    `on_hold` and never answers (until the block ends): its URL."""
    doc = json.dumps(preset("paper") | {"version": 1}).encode()
    gets: list[int] = []
    release = threading.Event()

    class Handler(Dashboard):
        def do_GET(self) -> None:
            gets.append(1)
            if len(gets) > 1:
                on_hold()
                release.wait()
                return
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(doc)))
            self.end_headers()
            self.wfile.write(doc)

    with serving(Handler, on_close=release.set) as url:
        yield url


@pytest.mark.slow
def test_sigterm_after_the_robot_died_says_it_and_the_servos(capsys):
    """F3: the robot dies while the link waits on the dashboard; a SIGTERM then (before the
    link's next poll would notice) is said as ever, and so are the servos it cannot reach."""
    before = signal.getsignal(signal.SIGTERM)
    with bridged_robot() as killed:

        def kill_then_term() -> None:  # from the server's thread, while the link waits on it
            killed.close()
            os.kill(os.getpid(), signal.SIGTERM)

        with dashboard_then_hold(kill_then_term) as url:
            code, out, err = artro(["link", "--port", killed.port, "--server", url], capsys)
    lines = out.splitlines()
    assert code == 2 and err == "", out  # the stop was asked for, but the servos may be on
    assert "SIGTERM: stopping" in lines
    lost = rf"the robot's port {killed.port} failed \(.*\)"
    assert re.fullmatch(f"could not switch the servos off: {lost}", lines[-1]), lines
    assert signal.getsignal(signal.SIGTERM) == before  # put back


# ---- a robot that restarted (its MCU reset: frames count from reset) -----------------------


@pytest.mark.parametrize("sensors", [False, True], ids=["no stream", "stream"])
def test_a_robot_that_restarted_is_said_and_sent_the_set_again(sensors):
    """Its frame count goes back at a keep-alive PING: the link says so and sends the
    dashboard's set and START (and asks for the stream) again, as at its start: a reset robot
    walks in its own set. Frames streamed before an INFO may trail it: no restart."""
    at_frame = [5000]
    asked: list[int] = []

    def answer(message: proto.Message) -> bytes:
        asked.append(message.type)
        if message.type != Msg.PING:
            return ack(message.type)
        if at_frame[0] == 40:  # reset: the stream is off
            return info(frame=40)
        at_frame[0] += 50
        return streamed(at_frame[0] - 30) + info(frame=at_frame[0])

    dashboard = json.dumps(preset("paper") | {"version": 4}).encode()
    with FakeRobot(answer) as fake, fake_dashboard(dashboard, "application/json") as url:
        robot, lines = robot_on(fake.port)
        robot.hello()
        ended_with = follow_on_a_thread(robot, url, sensors=sensors, max_updates=1)
        wait_for(lambda: asked.count(Msg.PING) >= 3, "two keep-alive PINGs", attempts=600)
        at_frame[0] = 40  # reset: the next keep-alive PING tells frame 40
        assert ended_with() is None  # the set sent again is the one more update allowed
        robot.link.close()
    said = [line for line in lines if line.startswith("the robot restarted")]
    assert len(said) == 1 and said[0].endswith(
        " back to 40 (a reset: a brown-out as the servos draw, the watchdog or its reset "
        "button), so it walks in its firmware's own set: sending version 4 again"
    ), lines
    assert asked.count(Msg.START) == 2
    assert asked.count(Msg.TELEMETRY_ON) == (3 if sensors else 0)  # on, on again, off


def streamed(frame: int) -> bytes:
    """A SENSORS frame of `frame` with every other value 0."""
    return proto.encode(Msg.SENSORS, struct.pack("<I", frame) + bytes(66))


def test_frames_that_go_on_or_trail_by_a_frame_or_two_are_no_restart():
    robot = RobotLink(SerialLink(object()), dry_run=True, log=lambda _: None)
    for frame in (10, 9, 8, 30, 29):  # an INFO's frame may trail a SENSORS' planned one
        robot._told_frame(frame)
    with pytest.raises(RobotRestarted, match="went from 30 back to 27"):
        robot._told_frame(27)
    robot._told_frame(28)  # counted from the reset on
