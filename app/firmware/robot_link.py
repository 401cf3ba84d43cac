"""A robot's ATmega128 over its serial port (hardware/firmware/PROTOCOL.md; docs/DESIGN.md §15):
a whole set, the dashboard's followed as it changes, the robot's SENSORS forwarded to the
Sensors panel, the servos off at the end. Each request takes only its answer (robot_port.py's
`PortReader` reads while the stream is on); a robot gone quiet or a failed port ends the following
within about a second; a robot that restarted (its frame count went back) gets the set again."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

from app.firmware import protocol as proto
from app.firmware.dashboard_set import dashboard_set, other_robot, plain_set
from app.firmware.link import SerialLink
from app.firmware.protocol import LinkError  # the link's error, raised also by parse
from app.firmware.robot_port import PortLost, PortReader, late_ack, may_answer, port_lost
from app.firmware.robot_telemetry import SensorForwarder
from app.params.document import DEFAULT_ROBOT
from hardware.firmware.schema import FIRMWARE_ENGINE, schema_hash, values_from_document

DEFAULT_BAUD = 57600  # PROTOCOL.md: 57600 with U2X at 16 MHz, -0.8 % (config.h UART_BAUD)
POLL_S = 0.2  # how often the dashboard is asked for its parameter version
KEEPALIVE_S = 1.0  # while following, a PING when the robot said nothing for this long
FRAME_SLACK = 2  # an INFO's frame (the one on) may trail a SENSORS' (the one planned) by this
#: refusals of the line, not of the message (a rejected message changes nothing: sent again once)
LINE_NAKS = (proto.NakReason.BAD_CRC, proto.NakReason.TIMEOUT, proto.NakReason.RX_OVERFLOW)


class RobotRestarted(LinkError):
    """The robot's frame count went back: its MCU was reset (a brown-out as the servos draw, the
    watchdog, its reset button) and it walks in its firmware's own set again."""


class DryRunPort:
    """A port that writes each message as hex to a stream and never answers."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def write(self, data: bytes) -> int:
        known = len(data) > 2 and data[2] in {m.value for m in proto.Msg}
        name = proto.Msg(data[2]).name if known else "?"
        self.out.write(f"-> {name:13s} {data.hex(' ')}\n")
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    def close(self) -> None:
        pass


def _got(message: bytes, reply: proto.Reply) -> str:
    """What came instead of the answer; the host's own message back is an echo."""
    if isinstance(reply, proto.Message) and proto.encode(reply.type, reply.payload) == message:
        return (
            f"its own {proto.type_name(reply.type)} back (an echo: the adapter's TX wired to its "
            "RX, or a loopback plug?)"
        )
    return proto.describe(reply)


@dataclass
class RobotLink:
    """One robot: `send_set` a whole parameter set, `stream_sensors` to a callback,
    `torque_off` at the end."""

    link: SerialLink
    dry_run: bool = False
    log: Callable[[str], None] = print
    _reader: PortReader | None = field(default=None, init=False, repr=False)
    _lost: PortLost | None = field(default=None, init=False, repr=False)
    _heard: float = field(default_factory=time.monotonic, init=False, repr=False)
    _frame: int | None = field(default=None, init=False, repr=False)  # the newest it told
    #: the types of requests given up on (no answer in time, or their wait interrupted), whose
    #: late ACK is not taken for the next request's answer
    _given_up: set[int] = field(default_factory=set, init=False, repr=False)

    def request(self, message: bytes) -> list[proto.Reply]:
        """Send `message`; its answer (paired: a streamed frame is never taken for it, nor the
        late ACK of a request given up on), or [] after the link's timeout. Nothing is read in
        a dry run. PortLost once the port failed, LinkError for a reply out of protocol."""
        if self._lost is not None:
            raise self._lost
        try:
            replies = self._request(message)
        except OSError as exc:  # pyserial's SerialException is one
            self._lost = port_lost(self.link.serial, exc)
            raise self._lost from exc
        except PortLost as exc:
            self._lost = exc
            raise
        except BaseException:  # a signal ended the wait: its answer may still come
            self._given_up.add(message[2])
            raise
        if replies:
            self._heard = time.monotonic()
        elif not self.dry_run:  # no answer in time: a late one is not the next request's
            self._given_up.add(message[2])
        return replies

    def _request(self, message: bytes) -> list[proto.Reply]:
        if self.dry_run:
            self.link.serial.write(message)
            return []
        if self._reader is not None:
            replies = self._reader.request(message, self._given_up)
            streamed = self._reader.streamed_before  # before the answer: compared at a PING's
            if streamed is not None:
                self._frame = streamed if self._frame is None else max(self._frame, streamed)
            return replies
        link = self.link
        link.serial.write(message)
        deadline = time.monotonic() + link.timeout_s
        while time.monotonic() < deadline:
            replies = [proto.parse(m) for m in link.decoder.feed(link.serial.read(256))]
            answers = [
                r
                for r in replies
                if may_answer(message, r) and not late_ack(message, r, self._given_up)
            ]
            if answers:
                return answers[:1]
        return []

    def expect(self, message: bytes, what: str) -> proto.Reply | None:
        """The answer PROTOCOL.md gives `message` (None in a dry run); LinkError for none, a
        NAK, or anything else, named. A NAK of the line (a bad CRC, a message cut short, an
        overrun: noise, or a stray byte that swallowed its start) sends it once more."""
        for attempt in (1, 2):
            try:
                replies = self.request(message)
            except PortLost:
                raise
            except LinkError as exc:  # a reply out of protocol
                raise LinkError(f"{what}: {exc}") from exc
            if self.dry_run:
                return None
            if not replies:
                raise LinkError(f"{what}: no answer from the robot (wiring, baud rate, power?)")
            reply = replies[0]
            if attempt == 1 and isinstance(reply, proto.Nak) and reply.reason in LINE_NAKS:
                reason = getattr(reply.reason, "name", reply.reason)
                self.log(f"{what}: the line garbled it ({reason}); sent again")
                continue
            break
        if isinstance(reply, proto.Nak):
            reason = getattr(reply.reason, "name", reply.reason)
            raise LinkError(f"{what}: the robot refused it ({reason}, detail {reply.detail})")
        if not proto.answers(message, reply):
            raise LinkError(
                f"{what}: expected {proto.expected_answer(message)}, got {_got(message, reply)}"
            )
        return reply

    def check(self) -> None:
        """LinkError if the robot is gone: the port failed (also on the reader's thread), a
        reply came out of protocol, or a PING after KEEPALIVE_S of silence is not answered;
        RobotRestarted if the PING's INFO tells a frame before one told already (by an INFO,
        or a SENSORS streamed before it)."""
        if self._lost is not None:
            raise self._lost
        if self._reader is not None:
            try:
                self._reader.raise_error()
            except PortLost as exc:
                self._lost = exc
                raise
            self._heard = max(self._heard, self._reader.last_frame)
        if not self.dry_run and time.monotonic() - self._heard >= KEEPALIVE_S:
            info = self.expect(proto.command(proto.Msg.PING), "keep-alive ping")
            if isinstance(info, proto.Info):
                self._told_frame(info.frame)

    def _told_frame(self, frame: int) -> None:
        """Keep the newest frame the robot told, in the order it told them; RobotRestarted if
        this one went back (frames count from reset, PROTOCOL.md)."""
        newest = self._frame
        self._frame = frame if newest is None else max(frame, newest)
        if newest is not None and frame + FRAME_SLACK < newest:
            self._frame = frame  # counted from the reset on
            raise RobotRestarted(
                f"the robot restarted: its frame count went from {newest} back to {frame} (a "
                "reset: a brown-out as the servos draw, the watchdog or its reset button), so it "
                "walks in its firmware's own set"
            )

    def wait_for_firmware(self, timeout_s: float) -> int:
        """PING until the firmware answers (a board that resets as its port opens runs its
        bootloader first); how many PINGs it took. LinkError after `timeout_s`."""
        deadline, pings = time.monotonic() + timeout_s, 0
        while not self.dry_run:
            pings += 1
            if any(isinstance(r, proto.Info) for r in self.request(proto.encode(proto.Msg.PING))):
                break
            if time.monotonic() >= deadline:
                raise LinkError(f"no answer from the robot within {timeout_s:g} s of opening its "
                                "port (its restart: wiring, baud rate, --board?)")  # fmt: skip
        return pings

    def hello(self) -> None:
        """PING; the robot's firmware must address parameters as this studio does."""
        info = self.expect(proto.encode(proto.Msg.PING), "ping")
        if not isinstance(info, proto.Info):  # None: a dry run
            return
        if info.schema_hash != schema_hash():
            raise LinkError(
                f"the robot's firmware has schema {info.schema_hash:08x}, this studio "
                f"{schema_hash():08x}: flash the firmware of this version (artro export "
                "--format firmware)"
            )
        self._told_frame(info.frame)
        self.log(
            f"robot: protocol {info.version}, {info.param_count} parameters, at frame {info.frame}"
        )

    def send_set(self, doc: dict[str, Any], version: int | None = None) -> int | None:
        """The whole set (motion, CA, every constant and the feedback laws) in consecutive
        SET_PARAMS; the frame its last part reaches. LinkError for a set the firmware refuses
        (another gait engine), also in a dry run."""
        engine = doc.get("gait", {}).get("engine", FIRMWARE_ENGINE)
        if engine != FIRMWARE_ENGINE:
            tag = "" if version is None else f" (dashboard version {version})"
            raise LinkError(
                f"the set{tag} names the {engine!r} gait engine; the robot's firmware runs only "
                f"{FIRMWARE_ENGINE!r} and would refuse it: choose engine {FIRMWARE_ENGINE}"
            )
        frame = None
        for message in proto.set_all_params(values_from_document(doc)):
            ack = self.expect(message, "parameter set")  # its ACK: None only in a dry run
            frame = ack.effective_frame if isinstance(ack, proto.Ack) else None
        where = "" if frame is None else f" from frame {frame}"
        tag = "" if version is None else f" (dashboard version {version})"
        self.log(f"sent {doc.get('name') or 'the parameter set'}{tag}{where}")
        return frame

    def start(self) -> None:
        self.expect(proto.command(proto.Msg.START), "start")

    def torque_off(self) -> None:
        self.expect(proto.command(proto.Msg.TORQUE_OFF), "torque off")
        self.log("torque off")

    def stream_sensors(self, on_sensors: Callable[[proto.Sensors], None]) -> None:
        """Ask for one SENSORS per frame (TELEMETRY_ON 2), each handed to `on_sensors` on the
        port's reader thread, until `end_stream`."""
        if self.dry_run:
            self.expect(proto.telemetry_on(2), "sensor stream")
            return
        if self._reader is None:
            self._reader = PortReader(self.link, on_sensors)
            self._reader.start()
        self.expect(proto.telemetry_on(2), "sensor stream")

    def end_stream(self) -> None:
        """TELEMETRY_ON 0, then the port is read by each request again (as before the stream).
        Nothing is sent on a port that failed (the servos' message says it)."""
        reader = self._reader
        if reader is not None and reader.error is not None:  # read by each request from now
            reader.stop()
            self._reader = None
            if isinstance(reader.error, PortLost):
                self._lost = reader.error
        try:
            if self._lost is None:
                self.expect(proto.telemetry_on(0), "end of the sensor stream")
        finally:
            if self._reader is not None:
                self._reader.stop()
                self._reader = None


def follow(
    robot: RobotLink,
    server: str,
    stop: threading.Event,
    *,
    max_updates: int | None = None,
    sensors: bool = True,
    firmware_robot: str = DEFAULT_ROBOT,
) -> int:
    """Send the dashboard's set, then each new version until `stop` (or `max_updates` sets
    after the first). From the first set on (with `sensors`, not in a dry run) the robot
    streams its SENSORS and they go to the dashboard's Sensors panel; the stream ends with
    this call. A dashboard that stops answering after the first set is said once and asked
    again: the robot walks on in the last set meanwhile. A robot that restarted is said and
    sent the set again (and started, and its stream asked for). LinkError for a robot gone (its port
    failed, or silent for KEEPALIVE_S and a PING unanswered) and for a server whose answer is
    not a dashboard's parameter set, and for a dashboard on another robot than
    `firmware_robot`, the one the firmware was built for (`other_robot`): nothing is sent then.
    Returns how many sets were sent."""
    import httpx  # ~0.5 s: only to follow a dashboard

    sent = 0
    last = None
    lost: str | None = None
    streaming = False
    restarted = False
    forwarder = SensorForwarder(server, robot.log) if sensors and not robot.dry_run else None
    try:
        with httpx.Client(base_url=server, timeout=5) as http:
            while not stop.is_set():
                try:  # a robot gone ends the link, also while the set stays the same
                    robot.check()
                except RobotRestarted as exc:
                    robot.log(f"{exc}: sending version {last} again")
                    restarted = True
                try:
                    doc = dashboard_set(http.get("/api/params").raise_for_status(), server)
                except httpx.HTTPError as exc:
                    if sent == 0:
                        raise  # never reached: the command says so and ends
                    if lost is None:
                        robot.log(
                            f"the dashboard at {server} did not answer ({exc}); the robot walks "
                            f"on in version {last}, asking again"
                        )
                    lost = str(exc)
                    stop.wait(POLL_S)
                    continue
                if lost is not None:
                    lost = None
                    robot.log(f"the dashboard at {server} answers again")
                if doc["version"] != last or restarted:
                    other_robot(doc, server, firmware_robot)
                    last = doc["version"]
                    robot.send_set(plain_set(doc, server), last)
                    if sent == 0 or restarted:
                        robot.start()
                    if forwarder is not None and (sent == 0 or restarted):
                        if not streaming:
                            forwarder.start()
                            streaming = True
                        robot.stream_sensors(forwarder.put)
                        if not restarted:
                            robot.log(f"the robot's sensors go to {server} (Sensors panel)")
                    restarted = False
                    sent += 1
                    if max_updates is not None and sent > max_updates:
                        break
                stop.wait(POLL_S)
    finally:
        if streaming:
            _end_stream(robot)
        if forwarder is not None:
            forwarder.stop()
    return sent


def _end_stream(robot: RobotLink) -> None:
    """The robot's stream off, or said why not: the servos must still be switched off after."""
    try:
        robot.end_stream()
    except (LinkError, OSError) as exc:
        robot.log(f"could not end the robot's sensor stream: {exc}")
