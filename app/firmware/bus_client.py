"""The host's side of a servo bus (docs/BUS.md, "Driving a robot from the host"): PING,
SYNC_WRITE and SYNC_READ to Dynamixel 2.0 or Feetech STS servos over a serial port (pyserial's
`Serial`, or anything with its `read`, `write`, `reset_input_buffer` and `timeout`), with the
packet makers of `hardware.servo_bus`; each status matched to its servo by ID."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from hardware.servo_bus import (
    PING,
    TABLES,
    WRITE,
    BusFrame,
    Packet,
    Parser,
    bus_frame,
    dxl_packet,
    dxl_sync_read,
    dxl_sync_write,
    sts_packet,
    sts_sync_read,
    sts_sync_write,
)


class SerialPort(Protocol):
    """What the client needs of a port: pyserial's `Serial` has it. `read(n)` returns when `n`
    bytes arrived or `timeout` seconds passed, whichever is first."""

    timeout: float | None

    def write(self, data: bytes, /) -> int | None: ...

    def read(self, size: int = 1, /) -> bytes: ...

    def reset_input_buffer(self) -> None: ...


class BusClient:
    """The 12 servos `ids` (joint order) on `port`: the `protocol`'s packets, statuses awaited
    at most `timeout_s` (set as the port's timeout) each exchange."""

    def __init__(
        self,
        port: SerialPort,
        *,
        protocol: str,
        baud: int,
        ids: Sequence[int],
        timeout_s: float,
    ) -> None:
        if protocol not in TABLES:
            raise ValueError(f"protocol must be one of {tuple(TABLES)}, got {protocol!r}")
        self.port = port
        self.protocol = protocol
        self.baud = baud
        self.ids = list(ids)
        self.table = TABLES[protocol]
        self.parser = Parser(protocol)
        port.timeout = timeout_s

    # --- packets ---------------------------------------------------------------------------

    def _status_size(self, n_data: int) -> int:
        """Bytes of a status carrying `n_data` bytes: Dynamixel FF FF FD 00, ID, length (2),
        0x55, error, data, CRC (2); STS FF FF, ID, length, error, data, checksum."""
        return (11 if self.protocol == "dynamixel" else 6) + n_data

    def _data(self, packet: Packet) -> bytes | None:
        """A status's data, None if it says an error (or is no status)."""
        if self.protocol == "dynamixel":
            if packet.instruction != 0x55 or not packet.params or packet.params[0] != 0:
                return None
            return packet.params[1:]
        return packet.params if packet.instruction == 0 else None

    def _exchange(self, packet: bytes, answers: Sequence[int], n_data: int) -> dict[int, bytes]:
        """Send `packet`, then read the statuses of `answers` (IDs), each `n_data` bytes of
        data, until all are in or the timeout: ID -> data of those that answered well."""
        self.port.reset_input_buffer()  # a late status of an earlier exchange is not this one's
        self.parser.buffer.clear()
        self.port.write(packet)
        if not answers:
            return {}
        raw = self.port.read(len(answers) * self._status_size(n_data))
        got: dict[int, bytes] = {}
        for item in self.parser.feed(raw):
            if isinstance(item, Packet) and item.servo_id in answers:
                data = self._data(item)
                if data is not None and len(data) == n_data:
                    got[item.servo_id] = data
        return got

    def ping(self, servo_id: int) -> bool:
        """True if servo `servo_id` answered a PING within the timeout."""
        make = dxl_packet if self.protocol == "dynamixel" else sts_packet
        n_data = 3 if self.protocol == "dynamixel" else 0  # model number and firmware version
        return servo_id in self._exchange(make(servo_id, PING), [servo_id], n_data)

    def missing(self, tries: int = 2) -> list[int]:
        """The IDs that answered none of `tries` PINGs."""
        return [i for i in self.ids if not any(self.ping(i) for _ in range(tries))]

    def write(self, servo_id: int, name: str, value: int) -> bool:
        """WRITE `value` into the field `name` of one servo; True if its status said no error
        (an STS at a silent return level, or any servo that did not answer: False)."""
        address, size = self.table.fields[name]
        data = value.to_bytes(size, "little")
        if self.protocol == "dynamixel":
            packet = dxl_packet(servo_id, WRITE, address.to_bytes(2, "little") + data)
        else:
            packet = sts_packet(servo_id, WRITE, bytes([address]) + data)
        return servo_id in self._exchange(packet, [servo_id], 0)

    def sync_write(self, name: str, values: Sequence[int]) -> None:
        """One SYNC_WRITE of the field `name`, `values` in the order of `ids` (no answer)."""
        address, size = self.table.fields[name]
        make = dxl_sync_write if self.protocol == "dynamixel" else sts_sync_write
        self._exchange(make(address, size, dict(zip(self.ids, values, strict=True))), [], 0)

    def sync_read(self, name: str) -> dict[int, int]:
        """One SYNC_READ of the field `name` from every servo: ID -> value (unsigned) of those
        that answered within the timeout without an error."""
        address, size = self.table.fields[name]
        make = dxl_sync_read if self.protocol == "dynamixel" else sts_sync_read
        got = self._exchange(make(address, size, self.ids), self.ids, size)
        return {i: int.from_bytes(data, "little") for i, data in got.items()}

    def goals(self, frame_index: int, angles_rad: ArrayLike) -> BusFrame:
        """Frame `frame_index`'s goals (rad, joint order) as one SYNC_WRITE, the packet
        `hardware.servo_bus.bus_frame` makes (the simulation's bus sends the same)."""
        frame = bus_frame(
            frame_index,
            np.asarray(angles_rad, dtype=np.float64),
            protocol=self.protocol,
            baud=self.baud,
            ids=self.ids,
        )
        self._exchange(frame.packet, [], 0)
        return frame

    def torque(self, on: bool) -> None:
        """Every servo's torque on or off: one SYNC_WRITE of torque enable (no answer)."""
        self.sync_write("torque_enable", [int(on)] * len(self.ids))


__all__ = ["BusClient", "SerialPort"]
