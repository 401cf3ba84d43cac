"""`artro link` against what a hostile tester found (probe B): a reply of the wrong length, type
or request, and noise on the line. Wrong answers come from a pty robot that answers so (a real
firmware cannot; `tests/testing/link_support.py`). A robot gone or restarted:
test_robot_link_gone.py; a bad dashboard, --server, --port or --baud: test_robot_link_edges.py."""

from __future__ import annotations

from typing import Any

import pytest
import serial

from app.firmware import protocol as proto
from app.firmware.protocol import Info, LinkError, Msg
from tests.testing.firmware_support import preset
from tests.testing.link_support import (
    FakeRobot,
    ack,
    artro,
    bridged_robot,
    echo,
    follow_on_a_thread,
    honest,
    info,
    robot_on,
)
from tests.testing.server_harness import running_server

# ---- F4: a well-framed reply of the wrong length ------------------------------------------


@pytest.mark.parametrize(
    ("kind", "right"),
    [(Msg.ACK, 5), (Msg.NAK, 3), (Msg.INFO, 11), (Msg.PARAM, 5), (Msg.TELEMETRY, 36),
     (Msg.ANGLES, 52), (Msg.SENSORS, 70)],
)  # fmt: skip
def test_parse_checks_each_replys_payload_length(kind, right):
    name = kind.name
    for wrong in (0, 1, right - 1, right + 1):
        said = rf"the robot's {name} has {wrong} payload bytes?, expected {right}"
        with pytest.raises(LinkError, match=said):
            proto.parse(proto.Message(kind, bytes(wrong)))
    payload = bytearray(right)
    if kind == Msg.NAK:
        payload[1] = proto.NakReason.BAD_CRC
    assert not isinstance(proto.parse(proto.Message(kind, bytes(payload))), proto.Message)


def test_parse_checks_params_count_and_states():
    said = r"PARAMS has \d+ payload bytes.*expected 2 \+ 4 x count, count 1\.\.48"
    short, no_values, wrong_count = b"\x00", bytes([0, 0]), bytes([0, 2]) + bytes(5)
    for payload in (b"", short, no_values, wrong_count, bytes([0, 49]) + bytes(196)):
        with pytest.raises(LinkError, match=said):
            proto.parse(proto.Message(Msg.PARAMS, payload))
    two = proto.parse(proto.Message(Msg.PARAMS, bytes([3, 2]) + bytes(8)))
    assert two == proto.Params(3, (0.0, 0.0))
    with pytest.raises(LinkError, match=r"INFO names state 9; PROTOCOL\.md's are 0 walking"):
        proto.parse(proto.Message(Msg.INFO, bytes(10) + b"\x09"))
    nak = proto.parse(proto.Message(Msg.NAK, bytes([Msg.PING, 42, 0])))
    assert isinstance(nak, proto.Nak) and nak.reason == 42  # an unknown reason is a refusal still


def test_a_short_reply_is_an_error_not_a_traceback(capsys):
    with FakeRobot(lambda m: proto.encode(Msg.INFO, b"\x02")) as robot:
        code, out, err = artro(["link", "--port", robot.port, "--params", "tuned"], capsys)
    assert code == 2
    assert err == (
        "artro link: error: ping: the robot's INFO has 1 payload byte, expected 11 "
        "(firmware of another protocol?)\n"
    )
    assert "could not switch the servos off: torque off: the robot's INFO has 1 payload byte" in out


def test_a_short_streamed_frame_ends_the_following_said(tmp_path):
    """On the reader's thread: the reading stops, and the follow loop says why at its next poll."""

    def answer(message: proto.Message) -> bytes:
        streaming = message.type == Msg.TELEMETRY_ON and message.payload == b"\x02"
        return honest(message) + (proto.encode(Msg.SENSORS, bytes(3)) if streaming else b"")

    with FakeRobot(answer) as fake, running_server(tmp_path) as (base_url, _app):
        robot, lines = robot_on(fake.port)
        error = follow_on_a_thread(robot, base_url)()
        assert isinstance(error, LinkError)
        assert "the robot's SENSORS has 3 payload bytes, expected 70" in str(error)
        robot.torque_off()  # the port is fine: the servos go off
        robot.link.close()
    assert "torque off" in lines


# ---- F6: only the answer PROTOCOL.md gives counts -----------------------------------------


@pytest.mark.parametrize(
    ("answer", "got"),
    [
        (echo, r"its own TORQUE_OFF back \(an echo: the adapter's TX wired to its RX"),
        (lambda m: info(), "INFO"),
        (
            lambda m: proto.encode(0x99, b"\x01\x02"),
            "a message of type 0x99, which PROTOCOL.md does not name",
        ),
        (lambda m: ack(Msg.START), "ACK of START"),
        (lambda m: proto.encode(Msg.PARAMS, bytes([0, 1]) + bytes(4)), "PARAMS of ids 0..0"),
    ],
    ids=["echo", "info", "unknown type", "ack of another", "params"],
)
def test_torque_off_takes_only_its_ack(answer, got):
    with FakeRobot(answer) as fake:
        robot, lines = robot_on(fake.port)
        with pytest.raises(LinkError, match=rf"^torque off: expected ACK of TORQUE_OFF, got {got}"):
            robot.torque_off()
        robot.link.close()
    assert "torque off" not in lines


@pytest.mark.parametrize("streaming", [False, True], ids=["read by the request", "reader"])
def test_the_late_ack_of_a_start_given_up_on_is_not_the_torque_offs(streaming):
    """A START given up on (its wait ended: no answer in time, or SIGTERM) is acknowledged late,
    just before the TORQUE_OFF after it: the servos still go off. The fresh-clone CI once saw
    "torque off: expected ACK of TORQUE_OFF, got ACK of START" after a SIGTERM."""

    def late_start(message: proto.Message) -> bytes:
        if message.type == Msg.START:
            return b""  # its ACK comes later, with the next answer
        if message.type == Msg.TORQUE_OFF:
            return ack(Msg.START) + ack(Msg.TORQUE_OFF)
        return honest(message)

    with FakeRobot(late_start) as fake:
        robot, lines = robot_on(fake.port, timeout_s=0.3)
        if streaming:
            robot.stream_sensors(lambda frame: None)
        with pytest.raises(LinkError, match=r"^start: no answer from the robot"):
            robot.start()
        robot.torque_off()
        if streaming:
            robot.end_stream()
        robot.link.close()
    assert "torque off" in lines


def test_a_set_and_the_start_take_only_their_acks():
    """A robot that answers every message with INFO passes the PING, and nothing after it."""
    with FakeRobot(lambda m: info()) as fake:
        robot, lines = robot_on(fake.port)
        robot.hello()
        with pytest.raises(
            LinkError, match=r"^parameter set: expected ACK of SET_PARAMS, got INFO$"
        ):
            robot.send_set(preset("tuned"))
        with pytest.raises(LinkError, match=r"^start: expected ACK of START, got INFO$"):
            robot.start()
        robot.link.close()
    assert not any(line.startswith("sent") for line in lines)


def test_an_echo_is_said_at_the_ping_and_the_servos_not_called_off(capsys):
    with FakeRobot(echo) as fake:
        code, out, err = artro(["link", "--port", fake.port, "--params", "tuned"], capsys)
    assert code == 2
    assert err.startswith("artro link: error: ping: expected INFO, got its own PING back (an echo")
    assert "torque off" not in out.splitlines()
    assert "could not switch the servos off: torque off: expected ACK of TORQUE_OFF" in out


def test_answers_pairs_a_reply_with_its_request():
    get = proto.get_params(4, 2)
    assert proto.answers(get, proto.Params(4, (0.0, 0.0)))
    assert not proto.answers(get, proto.Params(0, (0.0, 0.0)))  # another request's ids
    assert not proto.answers(get, proto.Params(4, (0.0,)))
    assert proto.answers(proto.get_param(3), proto.Params(3, (1.0,)))
    assert proto.answers(proto.set_params([0.0]), proto.Ack(Msg.SET_PARAMS, 9))
    assert not proto.answers(proto.set_params([0.0]), proto.Ack(Msg.SET_PARAM, 9))
    refused = proto.Nak(Msg.PING, proto.NakReason.BAD_CRC, 0)
    assert not proto.answers(proto.command(Msg.PING), refused)  # a refusal: `expect` says it
    assert proto.expected_answer(proto.command(Msg.GET_SENSORS)) == "SENSORS"
    assert proto.expected_answer(proto.telemetry_on(2)) == "ACK of TELEMETRY_ON"


# ---- a stray byte on the line (probe B of the thirteenth session) -----------------------------


class NoiseBefore:
    """A port whose next write has `noise` on the line just before it, back to back (a gap of
    8 TDM slots would end the noise with NAK TIMEOUT instead)."""

    def __init__(self, port: serial.Serial, noise: bytes) -> None:
        self.port, self.noise = port, noise

    def write(self, data: bytes) -> int | None:
        data, self.noise = self.noise + data, b""
        return self.port.write(data)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.port, name)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("noise", "garbled"),
    [
        # a lone sync byte: the firmware takes the request's own sync for a new start
        (b"\xa5", []),
        # a sync and a LEN of 2: the request's first bytes are the noise's body and checksum
        (b"\xa5\x02", ["parameter set: the line garbled it (BAD_CRC); sent again"]),
    ],
)
def test_noise_before_a_request_costs_at_most_one_resend_not_the_link(noise, garbled):
    """Line noise (at power-up, say) just before a request. A lone 0xA5 costs nothing (no
    message is 165 long, so the firmware reads the request's sync as a new start); noise that
    looks like a message's start swallows the request, which is NAKed and sent once more. The
    link goes on either way, and the set arrives whole."""
    with bridged_robot() as noisy:
        robot, lines = robot_on(noisy.port, timeout_s=30.0)
        robot.hello()
        robot.link.serial = NoiseBefore(robot.link.serial, noise)
        robot.send_set(preset("tuned"))
        (info,) = robot.link.request(proto.command(Msg.PING))
        robot.link.close()
    assert [line for line in lines if "the line garbled it" in line] == garbled, lines
    assert any(line.startswith("sent tuned") for line in lines), lines
    assert isinstance(info, Info)
