"""Reading a robot's serial port (hardware/firmware/PROTOCOL.md; docs/DESIGN.md §15): which reply
may answer which request, a late ACK told from an answer, and `PortReader`, the thread that reads
the port while the SENSORS stream is on so that each request takes only its answer; `PortLost`
when the port fails. `robot_link.RobotLink` speaks through it."""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable

from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from app.firmware.protocol import LinkError


class PortLost(LinkError):
    """The robot's port failed (the adapter unplugged, the robot's side of a pty closed): every
    later request says so at once."""


def port_name(port: object) -> str:
    name = getattr(port, "port", None)  # pyserial's Serial names its device
    return f"the robot's port {name}" if isinstance(name, str) else "the robot's port"


def port_lost(port: object, exc: BaseException) -> PortLost:
    return PortLost(f"{port_name(port)} failed ({exc})")


def late_ack(message: bytes, reply: proto.Reply, given_up: set[int]) -> bool:
    """Whether `reply` is the late ACK of a request given up on (`given_up`: their types), not
    an answer to `message`: e.g. a START whose wait a signal ended, acknowledged while the
    TORQUE_OFF after it waits. Taken off `given_up` then: a robot that keeps answering with
    another message's ACK is still named."""
    if isinstance(reply, proto.Ack) and reply.acked != message[2] and reply.acked in given_up:
        given_up.discard(reply.acked)
        return True
    return False


def may_answer(message: bytes, reply: proto.Reply) -> bool:
    """Whether `reply` may be the answer to `message`, not a streamed frame (those answer only
    a GET); `proto.answers` then says whether it is the right one."""
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
        self.error: LinkError | None = None  # why the reading ended, if it did
        self.last_frame = time.monotonic()  # when a streamed frame came last
        self.streamed_before: int | None = None  # the last frame streamed before the answer
        self._streamed: int | None = None  # the last frame streamed since the last answer
        # each answer with the last frame streamed before it; None: the reader ended
        self._answers: queue.Queue[tuple[proto.Reply, int | None] | None] = queue.Queue()
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
                        self.last_frame = time.monotonic()
                        self._streamed = reply.frame
                        self.on_sensors(reply)
                    elif not isinstance(reply, proto.Telemetry):  # not asked for: not kept
                        self._answers.put((reply, self._streamed))
                        self._streamed = None
        except LinkError as exc:  # a reply out of protocol
            self.error = exc
        except OSError as exc:  # pyserial's SerialException too: an unplugged adapter
            self.error = port_lost(self.link.serial, exc)
        except Exception as exc:  # e.g. a frame the forwarder cannot take: said, not lost
            self.error = LinkError(f"reading {port_name(self.link.serial)} stopped: {exc!r}")
        finally:  # a request waiting learns it at once, the follow loop at its next poll
            self._answers.put(None)

    def request(self, message: bytes, given_up: set[int]) -> list[proto.Reply]:
        """Send `message`; its answer, or [] after the link's timeout; LinkError if the
        reading ended (the port failed, or a reply out of protocol). A late ACK of a request
        given up on (`_late`) is passed over. `streamed_before` is then the last frame
        streamed before that answer (and after the one before it), if any."""
        self.raise_error()
        while not self._answers.empty():  # a late answer to a request that timed out
            self._answers.get_nowait()
        self.link.serial.write(message)
        self.streamed_before = None
        deadline = time.monotonic() + self.link.timeout_s
        answer = None
        while answer is None and (left := deadline - time.monotonic()) > 0:
            try:
                answer = self._answers.get(timeout=left)
            except queue.Empty:
                break
            if answer is None:  # the reader ended
                break
            if late_ack(message, answer[0], given_up):
                answer = None
        self.raise_error()
        if answer is None:
            return []
        reply, self.streamed_before = answer
        return [reply]

    def raise_error(self) -> None:
        if self.error is not None:
            raise self.error
