"""A servo that answers PING, READ, WRITE, SYNC_READ and SYNC_WRITE as the XM430-W350 and the
STS3215 do, on their control tables (`hardware.bus_control_tables`); a bus of twelve (docs/BUS.md,
docs/DESIGN.md §5)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from hardware.bus_control_tables import TABLES, ControlTable
from hardware.bus_packets import (
    BROADCAST_ID,
    ERR_ACCESS,
    ERR_CRC,
    ERR_DATA_LENGTH,
    ERR_DATA_RANGE,
    ERR_INSTRUCTION,
    PING,
    PROTOCOLS,
    READ,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    Malformed,
    Packet,
    dxl_status,
    sts_status,
)
from hardware.bus_timing import (
    CENTER_STEPS,
    MAX_STEPS,
    RAD_PER_STEP,
    RETURN_DELAY_UNIT_US,
    steps_to_angle,
)

#: where the speed and load sit, the sign bit of each on a Feetech (sign-magnitude) servo
_SPEED = {"dynamixel": "present_velocity", "feetech": "present_speed"}
_VOLTAGE = {"dynamixel": "present_input_voltage", "feetech": "present_voltage"}
_SIGN_BIT = {"present_speed": 15, "present_load": 10}


def _encode_signed(table: ControlTable, name: str, value: int, size: int) -> int:
    if table.signed == "twos":
        limit = 1 << (8 * size - 1)
        return max(-limit, min(limit - 1, value)) & ((1 << 8 * size) - 1)
    bit = _SIGN_BIT[name]
    magnitude = min(abs(value), (1 << bit) - 1)
    return magnitude | (1 << bit if value < 0 else 0)


@dataclass(frozen=True)
class Present:
    """What a servo reports: position (rad), velocity (rad/s), load (fraction of stall torque,
    signed), input voltage (V), temperature (°C)."""

    position_rad: float
    velocity_rad_s: float
    load: float
    voltage_v: float
    temperature_c: float = 25.0


class BusServo:
    """One servo's control table and how it answers an instruction (`handle`), as the
    XM430-W350 (Protocol 2.0) or the STS3215 does. Bytes in, bytes out; no clock."""

    def __init__(self, protocol: str, servo_id: int, baud: int) -> None:
        if protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
        if not 0 <= servo_id <= 252:
            raise ValueError(f"a servo's ID must be 0..252, got {servo_id}")
        self.protocol = protocol
        self.table = TABLES[protocol]
        self.memory = bytearray(self.table.size)
        self.set("model_number", self.table.model_number)
        for name, value in self.table.defaults.items():
            self.set(name, value)
        self.set("id", servo_id)
        self.set("baud_rate", self.table.baud_code(baud))

    # the table
    def get(self, name: str) -> int:
        address, size = self.table.fields[name]
        return int.from_bytes(self.memory[address : address + size], "little")

    def set(self, name: str, value: int) -> None:
        address, size = self.table.fields[name]
        self.memory[address : address + size] = (value & ((1 << 8 * size) - 1)).to_bytes(
            size, "little"
        )

    @property
    def servo_id(self) -> int:
        return self.get("id")

    @property
    def torque_on(self) -> bool:
        return bool(self.get("torque_enable"))

    @property
    def goal_rad(self) -> float:
        steps = self.get("goal_position")
        if self.protocol == "dynamixel" and steps >= 1 << 31:
            steps -= 1 << 32
        return float(steps_to_angle(steps))

    @property
    def return_delay_us(self) -> int:
        return RETURN_DELAY_UNIT_US * self.get("return_delay_time")

    def show(self, present: Present) -> None:
        """Write what the servo measures into its table's present fields."""
        steps = round(present.position_rad / RAD_PER_STEP) + CENTER_STEPS
        self.set("present_position", max(0, min(MAX_STEPS, steps)))
        speed = _SPEED[self.protocol]
        _, size = self.table.fields[speed]
        velocity = round(present.velocity_rad_s / self.table.velocity_unit_rad_s)
        self.set(speed, _encode_signed(self.table, speed, velocity, size))
        load = round(present.load / self.table.load_unit)
        self.set("present_load", _encode_signed(self.table, "present_load", load, 2))
        self.set(_VOLTAGE[self.protocol], round(present.voltage_v * 10))
        self.set("present_temperature", round(present.temperature_c))
        self.set("moving", int(abs(velocity) > 1))

    # answering
    def _writable(self, address: int, size: int) -> bool:
        """Every byte of address..address+size lies in a field a WRITE may change (EEPROM ones
        only with the torque off)."""
        for byte in range(address, address + size):
            hit = [n for n, (a, s) in self.table.fields.items() if a <= byte < a + s]
            if not hit or hit[0] not in self.table.writable:
                return False
            if byte < self.table.eeprom_end and self.torque_on:
                return False
        return True

    def read(self, address: int, size: int) -> bytes | None:
        if address + size > self.table.size or size < 1:
            return None
        return bytes(self.memory[address : address + size])

    def write(self, address: int, data: bytes) -> int:
        """Store `data` at `address`: 0, or the Dynamixel error number why not."""
        if not data or address + len(data) > self.table.size:
            return ERR_DATA_LENGTH
        if not self._writable(address, len(data)):
            return ERR_ACCESS
        old = bytes(self.memory)
        self.memory[address : address + len(data)] = data
        for name in ("baud_rate",):
            if self.get(name) not in self.table.bauds:
                self.memory[:] = old
                return ERR_DATA_RANGE
        if self.get("id") > 252 or self.get("torque_enable") > 1:
            self.memory[:] = old
            return ERR_DATA_RANGE
        return 0

    def status(self, error: int, params: bytes = b"") -> bytes:
        if self.protocol == "dynamixel":
            return dxl_status(self.servo_id, error, params)
        return sts_status(self.servo_id, _sts_error(error), params)

    def handle(self, packet: Packet) -> bytes | None:
        """The status this servo sends for `packet` (addressed to it or broadcast), or None
        (a broadcast write, a silent return level, what it does not answer)."""
        if self.protocol == "dynamixel":
            return self._handle_dxl(packet)
        return self._handle_sts(packet)

    def _answers(self, instruction: int, broadcast: bool) -> bool:
        if self.protocol == "feetech":
            return not broadcast or instruction == PING
        level = self.get("status_return_level")
        if instruction == PING:
            return True
        if broadcast:
            return False
        return level >= 2 or (level == 1 and instruction == READ)

    def _handle_dxl(self, p: Packet) -> bytes | None:
        broadcast = p.servo_id == BROADCAST_ID
        if p.instruction == PING:
            model = self.get("model_number").to_bytes(2, "little")
            return self.status(0, model + bytes([self.get("firmware_version")]))
        if p.instruction == READ:
            if len(p.params) != 4:
                return self._answer(p, ERR_DATA_LENGTH, broadcast)
            address, size = (int.from_bytes(p.params[i : i + 2], "little") for i in (0, 2))
            data = self.read(address, size)
            return self._answer(p, ERR_DATA_RANGE if data is None else 0, broadcast, data or b"")
        if p.instruction == WRITE:
            if len(p.params) < 3:
                return self._answer(p, ERR_DATA_LENGTH, broadcast)
            error = self.write(int.from_bytes(p.params[:2], "little"), p.params[2:])
            return self._answer(p, error, broadcast)
        return self._answer(p, ERR_INSTRUCTION, broadcast)

    def _handle_sts(self, p: Packet) -> bytes | None:
        broadcast = p.servo_id == BROADCAST_ID
        if p.instruction == PING:
            return self.status(0)
        if p.instruction == READ and len(p.params) == 2:
            data = self.read(p.params[0], p.params[1])
            return None if data is None or broadcast else self.status(0, data)
        if p.instruction == WRITE and len(p.params) >= 2:
            self.write(p.params[0], p.params[1:])  # an STS ignores what it cannot store
            return None if broadcast else self.status(0)
        return None  # an STS answers nothing it does not know

    def _answer(self, p: Packet, error: int, broadcast: bool, params: bytes = b"") -> bytes | None:
        if not self._answers(p.instruction, broadcast):
            return None
        return self.status(error, params if error == 0 else b"")

    def sync_part(self, packet: Packet) -> tuple[str, bytes] | None:
        """This servo's part of a SYNC_WRITE ("write", its data, stored) or SYNC_READ ("read",
        the status it sends in its turn); None if it is not named or the packet is short."""
        p, dxl = packet.params, self.protocol == "dynamixel"
        head = 4 if dxl else 2
        if len(p) < head:
            return None
        address = int.from_bytes(p[0:2], "little") if dxl else p[0]
        size = int.from_bytes(p[2:4], "little") if dxl else p[1]
        if packet.instruction == SYNC_WRITE:
            step = size + 1
            for at in range(head, len(p) - step + 1, step):
                if p[at] == self.servo_id:
                    self.write(address, p[at + 1 : at + step])
                    return ("write", p[at + 1 : at + step])
            return None
        if packet.instruction == SYNC_READ and self.servo_id in p[head:]:
            data = self.read(address, size)
            if data is None:
                return ("read", self.status(ERR_DATA_RANGE)) if dxl else None
            return ("read", self.status(0, data))
        return None


def _sts_error(error: int) -> int:
    """The STS status byte for a Dynamixel error number: it has no bit for one (0)."""
    return 0 if error in (ERR_ACCESS, ERR_DATA_RANGE, ERR_DATA_LENGTH) else error


@dataclass(frozen=True)
class Answer:
    """A status one servo sends, after its return delay (µs)."""

    servo_id: int
    data: bytes
    return_delay_us: int


class ServoBus:
    """Servos on one line: `handle(item)` gives the answers to a parsed packet in the order they
    go on the wire, and counts what was malformed (by reason) and what no servo took."""

    def __init__(self, servos: Iterable[BusServo]) -> None:
        self.servos = list(servos)
        protocols = {s.protocol for s in self.servos}
        if len(protocols) != 1:
            raise ValueError(f"a bus has servos of one protocol, got {sorted(protocols)}")
        self.protocol = protocols.pop()
        self.malformed: dict[str, int] = {}
        self.unanswered = 0

    def by_id(self, servo_id: int) -> BusServo | None:
        return next((s for s in self.servos if s.servo_id == servo_id), None)

    def handle(self, item: Packet | Malformed) -> list[Answer]:
        if isinstance(item, Malformed):
            self.malformed[item.reason] = self.malformed.get(item.reason, 0) + 1
            servo = None if item.servo_id is None else self.by_id(item.servo_id)
            if servo is None or self.protocol != "dynamixel" or not servo._answers(WRITE, False):
                return []  # noise, a broadcast, or an STS: silence
            return [Answer(servo.servo_id, servo.status(ERR_CRC), servo.return_delay_us)]
        if item.instruction in (SYNC_WRITE, SYNC_READ):
            if item.servo_id != BROADCAST_ID:
                return self._single(item)
            answers = []
            ids = item.params[4:] if self.protocol == "dynamixel" else item.params[2:]
            order = list(ids) if item.instruction == SYNC_READ else []
            parts = {s.servo_id: s.sync_part(item) for s in self.servos}
            for servo_id in order:
                part, servo = parts.get(servo_id), self.by_id(servo_id)
                if part is not None and servo is not None:
                    answers.append(Answer(servo_id, part[1], servo.return_delay_us))
            return answers
        if item.servo_id == BROADCAST_ID:
            return [
                Answer(s.servo_id, a, s.return_delay_us)
                for s in sorted(self.servos, key=lambda s: s.servo_id)
                if (a := s.handle(item)) is not None
            ]
        return self._single(item)

    def _single(self, item: Packet) -> list[Answer]:
        servo = self.by_id(item.servo_id)
        if servo is None:
            self.unanswered += 1
            return []
        if item.instruction in (SYNC_WRITE, SYNC_READ):  # only to the broadcast ID
            status = (
                servo._answer(item, ERR_INSTRUCTION, False)
                if servo.protocol == ("dynamixel")
                else None
            )
        else:
            status = servo.handle(item)
        return [] if status is None else [Answer(servo.servo_id, status, servo.return_delay_us)]
