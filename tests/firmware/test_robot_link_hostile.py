"""`artro link` against what a hostile tester found (probe B): a reply of the wrong length, type
or request, a robot gone while the set stays the same, a dashboard of the wrong shape, a bad
--server, --port or --baud. Wrong answers come from a pty robot that answers so (a real firmware
cannot); a robot gone, from the emulated firmware on a pty whose bridge stops or closes."""

from __future__ import annotations

import contextlib
import json
import os
import re
import select
import signal
import struct
import threading
import tty
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest
import serial

from app.cli import main
from app.firmware import protocol as proto
from app.firmware.emulator import FRAME_CYCLES
from app.firmware.link import EmulatedLink, SerialLink
from app.firmware.protocol import Info, LinkError, Msg
from app.firmware.pty_bridge import PtyBridge
from app.firmware.robot_link import DEFAULT_BAUD, PortLost, RobotLink, RobotRestarted, follow
from hardware.firmware.schema import param_specs, schema_hash
from tests.firmware.test_robot_link_exits import Lines, link_process
from tests.testing.firmware_support import emulator, preset
from tests.testing.server_harness import running_server, wait_for

ROOT = Path(__file__).resolve().parents[2]
Answer = Callable[[proto.Message], bytes]


def info(state: int = 0, frame: int = 5) -> bytes:
    """The INFO this studio's firmware sends: its schema, so `hello` passes."""
    payload = struct.pack("<BBIIB", proto.VERSION, len(param_specs()), schema_hash(), frame, state)
    return proto.encode(Msg.INFO, payload)


def ack(acked: int, frame: int = 7) -> bytes:
    return proto.encode(Msg.ACK, struct.pack("<BI", acked, frame))


def honest(message: proto.Message) -> bytes:
    """What the firmware answers: INFO to a PING, the ACK of its type to the rest."""
    return info() if message.type == Msg.PING else ack(message.type)


class FakeRobot:
    """A robot on a pty that answers each whole message of the host with `answer(message)`."""

    def __init__(self, answer: Answer) -> None:
        self.answer = answer
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def _serve(self) -> None:
        decoder = proto.Decoder()
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if ready:
                for message in decoder.feed(os.read(self._master, 4096)):
                    os.write(self._master, self.answer(message))

    def __enter__(self) -> FakeRobot:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self._master)
        os.close(self._slave)


def robot_on(port: str, timeout_s: float = 5.0) -> tuple[RobotLink, list[str]]:
    """The link to the robot on `port`, and the lines it logs."""
    lines: list[str] = []
    link = SerialLink(serial.Serial(port, DEFAULT_BAUD, timeout=0.02), timeout_s=timeout_s)
    return RobotLink(link, log=lines.append), lines


def follow_on_a_thread(
    robot: RobotLink, server: str, **kwargs: Any
) -> Callable[[], BaseException | None]:
    """`follow` on a thread of its own (never stopped from outside): the function that waits
    for it to end by itself (60 s at most) and gives what it raised."""
    ended: list[BaseException | None] = []

    def run() -> None:
        try:
            follow(robot, server, threading.Event(), **kwargs)
            ended.append(None)
        except BaseException as exc:  # handed to the test
            ended.append(exc)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()

    def ended_with() -> BaseException | None:
        worker.join(60)
        assert not worker.is_alive(), "the following did not end"
        return ended[0]

    return ended_with


def artro(argv: list[str], capsys) -> tuple[int, str, str]:
    """`artro ARGV` in this process: its exit status, stdout and stderr."""
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


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


def echo(message: proto.Message) -> bytes:
    return proto.encode(message.type, message.payload)


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


# ---- F2: a robot gone while the dashboard's set stays the same -----------------------------


class BridgedRobot:
    """The emulated robot (paper) on a pty, served until `silence` (the robot stops answering,
    its side of the pty still open) or `close` (its side closed too: a robot killed)."""

    def __init__(self, mcu) -> None:
        self.bridge = PtyBridge(mcu, realtime=False)
        self.port = self.bridge.port
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self.bridge.serve, args=(self._stop, 600.0), daemon=True
        )
        self._thread.start()
        self._closed = False

    def silence(self) -> None:
        self._stop.set()
        self._thread.join()

    def close(self) -> None:
        self.silence()
        if not self._closed:  # once: the numbers of closed descriptors are soon another's
            self._closed = True
            self.bridge.close()


@contextlib.contextmanager
def bridged_robot() -> Iterator[BridgedRobot]:
    with emulator(preset("paper")) as mcu:
        robot = BridgedRobot(mcu)
        try:
            yield robot
        finally:
            robot.close()


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


class Dashboard(BaseHTTPRequestHandler):
    """A handler that logs nothing and takes every POST (the robot's sensors)."""

    def log_message(self, *args: object) -> None:
        pass

    def do_POST(self) -> None:
        self.rfile.read(int(self.headers.get("Content-Length", 0)))
        self.send_response(200)
        self.send_header("Content-Length", "0")
        self.end_headers()


@contextlib.contextmanager
def serving(
    handler: type[BaseHTTPRequestHandler], on_close: Callable[[], None] = lambda: None
) -> Iterator[str]:
    """An HTTP server on a free port answering with `handler`, on threads of its own: its URL.
    `on_close` is called first at the end (to let a held request go)."""
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        on_close()
        server.shutdown()
        thread.join()
        server.server_close()


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


# ---- F5: a dashboard of the wrong shape ---------------------------------------------------


@contextlib.contextmanager
def fake_dashboard(body: bytes, content_type: str) -> Iterator[str]:
    """A server that answers every GET with `body` and takes every POST: its URL."""

    class Handler(Dashboard):
        def do_GET(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    with serving(Handler) as url:
        yield url


def _out_of_range() -> bytes:
    doc = preset("tuned") | {"version": 3}
    doc["gait"]["clock"]["freq_hz"] = 99.0
    return json.dumps(doc).encode()


@pytest.mark.parametrize(
    ("body", "content_type", "gave"),
    [
        (
            b"[1, 2]",
            "application/json",
            "GET /api/params gave a JSON list; expected a parameter set",
        ),
        (
            b'{"version": "x", "gait": 5}',
            "application/json",
            "gave a JSON object without motion;",
        ),
        (b"<html>hi</html>", "text/html", "gave text/html, not JSON ('<html>hi</html>');"),
        (
            _out_of_range(),
            "application/json",
            "gave a parameter set this studio cannot take (clock.freq_hz = 99",
        ),
    ],
    ids=["list", "no motion", "html", "out of range"],
)
def test_a_server_that_is_not_a_dashboard_is_named(capsys, body, content_type, gave):
    with fake_dashboard(body, content_type) as url:
        code, out, err = artro(["link", "--dry-run", "--server", url], capsys)
    assert code == 2, err
    assert err.startswith(f"artro link: error: the server at {url} ")
    assert gave in err and "Traceback" not in err + out
    assert "(a JSON object with version, motion and gait)" in err
    assert "TORQUE_OFF" in out  # the servos were switched off all the same


# ---- F7, F14: what is checked before a port is opened, and the port's own words ------------


@pytest.mark.parametrize("server", ["notaurl", "ftp://x", "http://", "http://127.0.0.1:99999"])
def test_a_bad_server_is_refused_before_the_port_is_opened(tmp_path, capsys, server):
    port = tmp_path / "no-such-port"  # opened first, it would be the error
    code, out, err = artro(["link", "--port", str(port), "--server", server], capsys)
    assert code == 2 and out == ""
    assert err.startswith(
        "artro link: error: --server must be a dashboard's address, http://HOST[:PORT] or "
        "https://HOST[:PORT], e.g. http://127.0.0.1:8000;"
    )
    assert repr(server) in err


def test_a_port_that_is_no_serial_device_is_named(tmp_path, capsys):
    regular = tmp_path / "regfile"
    regular.write_text("x")
    folder = tmp_path / "d"
    folder.mkdir()
    missing = tmp_path / "none"
    allowed = "give the robot's serial adapter, e.g. /dev/ttyUSB0, /dev/ttyACM0 or a pty"
    said = {
        regular: f"the port {regular} is not a serial device (a regular file): {allowed}",
        folder: f"the port {folder} is not a serial device (a folder): {allowed}",
        Path("/dev/null"): "the port /dev/null is not a serial device (it takes no line "
        f"settings: Inappropriate ioctl for device): {allowed}",
        missing: f"could not open the port {missing}: No such file or directory",
    }
    for port, message in said.items():
        code, _out, err = artro(["link", "--port", str(port), "--params", "tuned"], capsys)
        assert (code, err) == (2, f"artro link: error: {message}\n")


def test_a_baud_rate_other_than_the_firmwares_is_warned(capsys):
    code, out, _ = artro(["link", "--dry-run", "--baud", "12345", "--params", "tuned"], capsys)
    assert code == 0
    assert out.splitlines()[0] == (
        "warning: --baud 12345: the ArtRo firmware talks at 57600 (hardware/firmware/src/config.h "
        "UART_BAUD); another rate reaches only a firmware built with it"
    )
    code, out, _ = artro(["link", "--dry-run", "--params", "tuned"], capsys)
    assert code == 0 and "warning" not in out


def test_the_default_baud_is_the_firmwares():
    config = (ROOT / "hardware" / "firmware" / "src" / "config.h").read_text(encoding="utf-8")
    (baud,) = re.findall(r"#define UART_BAUD (\d+)UL", config)
    assert int(baud) == DEFAULT_BAUD


# ---- F13, F14: what PROTOCOL.md now says of dropped answers and of BAD_LENGTH's detail ----


def test_a_flood_of_requests_loses_answers_and_the_next_telemetry_says_so():
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        link.send(proto.command(Msg.PING) * 200)
        replies: list[proto.Reply] = []
        quiet = 0  # frames in a row without a reply, every PING read
        for _ in range(200):  # frames, at most
            got = link.run(FRAME_CYCLES)
            replies += got
            quiet = 0 if got or mcu.uart_queued else quiet + 1
            if quiet == 3:
                break
        answered = sum(isinstance(r, proto.Info) for r in replies)
        assert 0 < answered < 200 and len(replies) == answered  # dropped without a NAK
        (telemetry,) = link.request(proto.command(Msg.GET_TELEMETRY))
        assert telemetry.flags & 0x20
        (telemetry,) = link.request(proto.command(Msg.GET_TELEMETRY))
        assert not telemetry.flags & 0x20  # sticky only until the TELEMETRY that said it


def test_bad_lengths_detail_is_len_at_framing_and_the_payloads_length_after():
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        (framing,) = link.request(bytes([proto.SYNC, 201]))
        (message,) = link.request(proto.encode(Msg.PING, b"\x00\x00"))
        (a_set,) = link.request(proto.encode(Msg.SET_PARAMS, bytes([0, 2, 0, 0, 0, 0])))
    assert framing == proto.Nak(0, proto.NakReason.BAD_LENGTH, 201)
    assert message == proto.Nak(Msg.PING, proto.NakReason.BAD_LENGTH, 2)
    assert a_set == proto.Nak(Msg.SET_PARAMS, proto.NakReason.BAD_LENGTH, 6)


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
