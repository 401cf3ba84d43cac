"""Talking to the firmware: the emulated UART (`EmulatedLink`) and the robot's serial port
(`SerialLink`, over any port object with read/write such as pyserial's), both with
`request(message) -> replies`. docs/DESIGN.md §5.
"""

from __future__ import annotations

import time
from typing import Protocol

from app.firmware import protocol as proto
from app.firmware.emulator import FRAME_CYCLES, Mcu
from app.firmware.protocol import Decoder, Msg, Reply, Telemetry, parse

SLOT_CYCLES = FRAME_CYCLES // 8


class Link(Protocol):
    def request(self, message: bytes, *, replies: int = 1) -> list[Reply]: ...


class EmulatedLink:
    """The protocol over the emulated UART0 of an `Mcu`; time advances only while waiting."""

    def __init__(self, mcu: Mcu, *, step_cycles: int = SLOT_CYCLES) -> None:
        self.mcu = mcu
        self.step_cycles = step_cycles
        self.decoder = Decoder()
        self.telemetry: list[Telemetry] = []  # TELEMETRY messages seen while waiting

    def send(self, message: bytes) -> None:
        self.mcu.send(message)

    def poll(self) -> list[Reply]:
        """Messages that arrived so far (TELEMETRY also collected in `telemetry`)."""
        _, data = self.mcu.take_uart()
        replies = [parse(msg) for msg in self.decoder.feed(data)]
        self.telemetry += [r for r in replies if isinstance(r, Telemetry)]
        return replies

    def run(self, cycles: int) -> list[Reply]:
        self.mcu.run_until(self.mcu.cycle + cycles)
        return self.poll()

    def request(self, message: bytes, *, replies: int = 1, timeout_frames: int = 20) -> list[Reply]:
        """Send and run the MCU until `replies` answers came (or the timeout passed).

        Streamed TELEMETRY does not count as an answer, except to GET_TELEMETRY."""
        self.send(message)
        got: list[Reply] = []
        deadline = self.mcu.cycle + timeout_frames * FRAME_CYCLES
        while len(got) < replies and self.mcu.cycle < deadline:
            got += [r for r in self.run(self.step_cycles) if _answers(message, r)]
        return got


def _answers(message: bytes, reply: Reply) -> bool:
    return not isinstance(reply, Telemetry) or message[2] == Msg.GET_TELEMETRY


class SerialPort(Protocol):
    """What SerialLink needs of a port, e.g. `serial.Serial(port, 57600, timeout=0.02)`."""

    def read(self, size: int = 1) -> bytes: ...
    def write(self, data: bytes) -> int | None: ...
    def close(self) -> None: ...


class SerialLink:
    """The protocol over a serial port: the robot, or `artro firmware run --pty`.

    The caller opens the port (pyserial's `serial.Serial(port, 57600, timeout=0.02)` in the
    CLI and server), so this module needs no serial library."""

    def __init__(self, port: SerialPort, timeout_s: float = 0.5) -> None:
        self.serial = port
        self.timeout_s = timeout_s
        self.decoder = Decoder()
        self.telemetry: list[Telemetry] = []

    def close(self) -> None:
        self.serial.close()

    def request(self, message: bytes, *, replies: int = 1) -> list[Reply]:
        self.serial.write(message)
        got: list[Reply] = []
        deadline = time.monotonic() + self.timeout_s
        while len(got) < replies and time.monotonic() < deadline:
            for msg in self.decoder.feed(self.serial.read(256)):
                reply = parse(msg)
                if isinstance(reply, Telemetry):
                    self.telemetry.append(reply)
                if _answers(message, reply):
                    got.append(reply)
        return got


def read_params(link: Link, count: int) -> list[float]:
    """Every value the robot holds, ids 0..count-1, in GET_PARAMS of at most MAX_VALUES each."""
    values: list[float] = []
    for first in range(0, count, proto.MAX_VALUES):
        (reply,) = link.request(proto.get_params(first, min(proto.MAX_VALUES, count - first)))
        if not isinstance(reply, proto.Params) or reply.first != first:
            raise ValueError(f"GET_PARAMS from id {first} was answered by {reply}")
        values += reply.values
    return values
