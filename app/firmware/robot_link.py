"""A robot's ATmega128 over its serial port (hardware/firmware/PROTOCOL.md; docs/DESIGN.md §15):
a whole parameter set, the dashboard's set followed as it changes, the robot's SENSORS stream
forwarded to the Sensors panel meanwhile, the servos off at the end. Every request is paired
with its answer; while the stream is on, a `PortReader` thread reads the port alone."""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TextIO

from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from app.firmware.robot_telemetry import SensorForwarder
from app.params.document import ParameterSet
from hardware.firmware.schema import FIRMWARE_ENGINE, schema_hash, values_from_document

DEFAULT_BAUD = 57600  # PROTOCOL.md: 57600 with U2X at 16 MHz, -0.8 %
POLL_S = 0.2  # how often the dashboard is asked for its parameter version


class LinkError(RuntimeError):
    """The robot did not answer, refused a set, or runs firmware of another schema."""


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


def _answers(message: bytes, reply: proto.Reply) -> bool:
    """Whether `reply` can be the answer to `message` (streamed frames answer only a GET)."""
    if isinstance(reply, proto.Sensors):
        return message[2] == proto.Msg.GET_SENSORS
    if isinstance(reply, proto.Telemetry):
        return message[2] == proto.Msg.GET_TELEMETRY
    return True


class PortReader:
    """Reads the robot's port on a thread of its own while the SENSORS stream is on: each
    streamed frame goes to `on_sensors` as it comes, every other message is an answer that
    `request` waits for, so the stream never holds a parameter set up nor is taken for its
    ACK. The port must have a read timeout (the CLI's: 20 ms)."""

    def __init__(self, link: SerialLink, on_sensors: Callable[[proto.Sensors], None]) -> None:
        self.link = link
        self.on_sensors = on_sensors
        self.error: Exception | None = None  # why the port failed, if it did
        self._answers: queue.Queue[proto.Reply] = queue.Queue()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="robot-port", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                for message in self.link.decoder.feed(self.link.serial.read(256)):
                    reply = proto.parse(message)
                    if isinstance(reply, proto.Sensors):
                        self.on_sensors(reply)
                    elif not isinstance(reply, proto.Telemetry):  # not asked for: not kept
                        self._answers.put(reply)
        except Exception as exc:  # an unplugged adapter: the next request says so
            self.error = exc

    def request(self, message: bytes) -> list[proto.Reply]:
        """Send `message`; its answer, or [] after the link's timeout."""
        while not self._answers.empty():  # a late answer to a request that timed out
            self._answers.get_nowait()
        self.link.serial.write(message)
        try:
            return [self._answers.get(timeout=self.link.timeout_s)]
        except queue.Empty:
            if self.error is not None:
                raise LinkError(f"the robot's port failed: {self.error}") from self.error
            return []


@dataclass
class RobotLink:
    """One robot: `send_set` a whole parameter set, `stream_sensors` to a callback,
    `torque_off` at the end."""

    link: SerialLink
    dry_run: bool = False
    log: Callable[[str], None] = print
    _reader: PortReader | None = field(default=None, init=False, repr=False)

    def request(self, message: bytes) -> list[proto.Reply]:
        """Send `message`; its answer (paired: a streamed frame is never taken for it), or []
        after the link's timeout. Nothing is read in a dry run."""
        if self.dry_run:
            self.link.serial.write(message)
            return []
        if self._reader is not None:
            return self._reader.request(message)
        link = self.link
        link.serial.write(message)
        deadline = time.monotonic() + link.timeout_s
        while time.monotonic() < deadline:
            replies = [proto.parse(m) for m in link.decoder.feed(link.serial.read(256))]
            answers = [r for r in replies if _answers(message, r)]
            if answers:
                return answers[:1]
        return []

    def expect(self, message: bytes, what: str) -> proto.Reply | None:
        replies = self.request(message)
        if self.dry_run:
            return None
        if not replies:
            raise LinkError(f"{what}: no answer from the robot (wiring, baud rate, power?)")
        reply = replies[0]
        if isinstance(reply, proto.Nak):
            reason = getattr(reply.reason, "name", reply.reason)
            raise LinkError(f"{what}: the robot refused it ({reason}, detail {reply.detail})")
        return reply

    def hello(self) -> None:
        """PING; the robot's firmware must address parameters as this studio does."""
        info = self.expect(proto.encode(proto.Msg.PING), "ping")
        if info is None:
            return
        if not isinstance(info, proto.Info):
            raise LinkError(f"ping: expected INFO, got {info}")
        if info.schema_hash != schema_hash():
            raise LinkError(
                f"the robot's firmware has schema {info.schema_hash:08x}, this studio "
                f"{schema_hash():08x}: flash the firmware of this version (artro export "
                "--format firmware)"
            )
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
            ack = self.expect(message, "parameter set")
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
        """TELEMETRY_ON 0, then the port is read by each request again (as before the stream)."""
        try:
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
) -> int:
    """Send the dashboard's set, then each new version until `stop` (or `max_updates` sets
    after the first). From the first set on (with `sensors`, not in a dry run) the robot
    streams its SENSORS and they go to the dashboard's Sensors panel; the stream ends with
    this call. A dashboard that stops answering after the first set is said once and asked
    again: the robot walks on in the last set meanwhile. Returns how many sets were sent."""
    import httpx  # ~0.5 s: only to follow a dashboard

    sent = 0
    last = None
    lost: str | None = None
    streaming = False
    forwarder = SensorForwarder(server, robot.log) if sensors and not robot.dry_run else None
    try:
        with httpx.Client(base_url=server, timeout=5) as http:
            while not stop.is_set():
                try:
                    doc = http.get("/api/params").raise_for_status().json()
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
                if doc.get("version") != last:
                    last = doc.get("version")
                    robot.send_set(_plain(doc), last)
                    if sent == 0:
                        robot.start()
                        if forwarder is not None:
                            forwarder.start()
                            streaming = True
                            robot.stream_sensors(forwarder.put)
                            robot.log(f"the robot's sensors go to {server} (Sensors panel)")
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
    except LinkError as exc:
        robot.log(f"could not end the robot's sensor stream: {exc}")


def _plain(doc: dict[str, Any]) -> dict[str, Any]:
    """The parameter-set document of an API answer (validated by the schema)."""
    return ParameterSet.from_dict({"motion": doc["motion"], "gait": doc["gait"]}).to_dict() | {
        "name": doc.get("name") or "dashboard"
    }
