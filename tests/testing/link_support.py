"""Hostile counterparts for the tests of `artro link` (tests/firmware/test_robot_link_hostile.py,
test_robot_link_gone.py, test_robot_link_edges.py): a pty robot that answers as told
(`FakeRobot`; a real firmware cannot answer wrongly), the emulated firmware on a pty that can go
silent or be killed (`BridgedRobot`), dashboards of any shape (`serving`, `fake_dashboard`), and
the link run in this process or on a thread."""

from __future__ import annotations

import contextlib
import os
import select
import struct
import threading
import tty
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import serial

from app.cli import main
from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from app.firmware.protocol import Msg
from app.firmware.pty_bridge import PtyBridge
from app.firmware.robot_link import DEFAULT_BAUD, RobotLink, follow
from hardware.firmware.schema import param_specs, schema_hash
from tests.testing.firmware_support import emulator, preset

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


def echo(message: proto.Message) -> bytes:
    return proto.encode(message.type, message.payload)


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
