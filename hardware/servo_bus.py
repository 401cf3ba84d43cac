"""Bus servos, pure (docs/DESIGN.md §5, docs/BUS.md): Dynamixel Protocol 2.0 and Feetech STS
packets (CRC-16, byte stuffing, checksum), a stream parser, the XM430-W350 and STS3215 control
tables and a servo that answers as they do, angle <-> position (4096 steps a turn, 2048 = 0 rad),
and the bus's timing in integer µs (10 bits a byte, a sync write per 20 ms frame)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

# --- positions ------------------------------------------------------------------------------

STEPS_PER_TURN = 4096
CENTER_STEPS = 2048  # 0 rad
MAX_STEPS = STEPS_PER_TURN - 1
RAD_PER_STEP = 2.0 * math.pi / STEPS_PER_TURN


def angle_to_steps(angle_rad: ArrayLike) -> NDArray[np.int64]:
    """Goal position in steps of a 4096-step turn, 2048 = 0 rad, rounded half to even and held
    to 0..4095 (a bus servo's position range in joint mode)."""
    steps = np.rint(np.asarray(angle_rad, dtype=np.float64) / RAD_PER_STEP) + CENTER_STEPS
    return np.clip(steps, 0, MAX_STEPS).astype(np.int64)


def steps_to_angle(steps: ArrayLike) -> NDArray[np.float64]:
    """The angle (rad) a position in steps stands for: (steps − 2048) · 2π / 4096."""
    return (np.asarray(steps, dtype=np.float64) - CENTER_STEPS) * RAD_PER_STEP


# --- timing ---------------------------------------------------------------------------------

BITS_PER_BYTE = 10  # start bit, 8 data bits, stop bit
FRAME_US = 20_000  # a sync write per frame
RETURN_DELAY_UNIT_US = 2  # both tables count the return delay in 2 µs


def wire_us(n_bytes: int, baud: int) -> int:
    """Time `n_bytes` take on the wire at `baud`, µs, rounded up (10 bits a byte)."""
    if baud <= 0 or n_bytes < 0:
        raise ValueError(f"baud must be > 0 and bytes >= 0, got {baud}, {n_bytes}")
    return -(-n_bytes * BITS_PER_BYTE * 1_000_000 // baud)


def answers_done_us(
    instruction_end_us: int, answer_bytes: Sequence[int], delays_us: Sequence[int], baud: int
) -> list[int]:
    """When each answer's last byte is on the wire, µs: each servo waits its return delay after
    the bus fell quiet (the instruction's end, then the answer before its own), then sends."""
    done, now = [], instruction_end_us
    for n, delay in zip(answer_bytes, delays_us, strict=True):
        now += delay + wire_us(n, baud)
        done.append(now)
    return done


# --- Dynamixel Protocol 2.0 -----------------------------------------------------------------

DXL_HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
DXL_STATUS = 0x55
PING, READ, WRITE, REG_WRITE, ACTION, REBOOT = 0x01, 0x02, 0x03, 0x04, 0x05, 0x08
SYNC_READ, SYNC_WRITE = 0x82, 0x83
#: the status's error numbers (e-Manual, Protocol 2.0 "Error")
ERR_RESULT_FAIL, ERR_INSTRUCTION, ERR_CRC, ERR_DATA_RANGE = 0x01, 0x02, 0x03, 0x04
ERR_DATA_LENGTH, ERR_DATA_LIMIT, ERR_ACCESS = 0x05, 0x06, 0x07


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return table


_CRC_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """The CRC-16 of Protocol 2.0 (polynomial 0x8005, initial 0, not reflected, as the
    e-Manual's `update_crc`) over `data`."""
    crc = 0
    for byte in data:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(packet_head: bytes, body: bytes) -> bytes:
    """`body` (instruction and parameters) with 0xFD added after every FF FF FD, the pattern
    looked for across the head's last bytes too, as the SDK does."""
    out = bytearray(packet_head[-2:])
    for byte in body:
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff":
            out.append(0xFD)
    return bytes(out[2:])


def unstuff(body: bytes, before: bytes = b"") -> bytes:
    """`body` with the stuffing removed: FF FF FD FD becomes FF FF FD."""
    out = bytearray(before[-2:])
    skip = False
    for i, byte in enumerate(body):
        if skip:
            skip = False
            continue
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff" and body[i + 1 : i + 2] == b"\xfd":
            skip = True
    return bytes(out[len(before[-2:]) :])


def dxl_packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A Protocol 2.0 packet: FF FF FD 00, ID, length (LE, after stuffing), instruction,
    parameters (stuffed), CRC-16 (LE) over everything before it."""
    _check_byte(servo_id, "ID")
    head = DXL_HEADER + bytes([servo_id])
    body = stuff(head + b"\x00\x00", bytes([instruction]) + params)
    head += (len(body) + 2).to_bytes(2, "little")
    crc = crc16(head + body)
    return head + body + crc.to_bytes(2, "little")


def dxl_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    """A status packet: instruction 0x55, the error byte, then the parameters."""
    return dxl_packet(servo_id, DXL_STATUS, bytes([error]) + params)


def dxl_sync_write(address: int, size: int, values: dict[int, int]) -> bytes:
    """SYNC_WRITE of `size`-byte values (ID -> value, LE) at `address`, to the broadcast ID."""
    params = address.to_bytes(2, "little") + size.to_bytes(2, "little")
    for servo_id, value in values.items():
        params += bytes([servo_id]) + (value & ((1 << 8 * size) - 1)).to_bytes(size, "little")
    return dxl_packet(BROADCAST_ID, SYNC_WRITE, params)


# --- Feetech STS ----------------------------------------------------------------------------

STS_HEADER = b"\xff\xff"


def sts_checksum(data: bytes) -> int:
    """Feetech's checksum: the low byte of the inverted sum of ID, length, instruction and
    parameters."""
    return ~sum(data) & 0xFF


def sts_packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """An STS packet: FF FF, ID, length (parameters + 2), instruction, parameters, checksum."""
    _check_byte(servo_id, "ID")
    if len(params) > 250:
        raise ValueError(f"an STS packet carries at most 250 parameter bytes, got {len(params)}")
    body = bytes([servo_id, len(params) + 2, instruction]) + params
    return STS_HEADER + body + bytes([sts_checksum(body)])


def sts_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    """An STS status: the error byte where the instruction was."""
    return sts_packet(servo_id, error, params)


def sts_sync_write(address: int, size: int, values: dict[int, int]) -> bytes:
    """SYNC_WRITE (0x83) of `size`-byte values (ID -> value, LE) at `address`."""
    params = bytes([address, size])
    for servo_id, value in values.items():
        params += bytes([servo_id]) + (value & ((1 << 8 * size) - 1)).to_bytes(size, "little")
    return sts_packet(BROADCAST_ID, SYNC_WRITE, params)


def _check_byte(value: int, what: str) -> None:
    if not 0 <= value <= 0xFF:
        raise ValueError(f"{what} must be 0..255, got {value}")


# --- parsing a byte stream ------------------------------------------------------------------

PROTOCOLS = ("dynamixel", "feetech")
MAX_LENGTH = 1024  # a longer length field is taken for noise


@dataclass(frozen=True)
class Packet:
    """A whole packet off the wire: for a status, `instruction` is 0x55 (Dynamixel) or the error
    byte (Feetech); `params` unstuffed."""

    servo_id: int
    instruction: int
    params: bytes
    size: int  # bytes on the wire


@dataclass(frozen=True)
class Malformed:
    """Bytes that were no packet: `servo_id` when the header and ID were whole (a servo of that
    ID hears it), None for noise; `reason` one of "noise", "length", "crc", "checksum"."""

    servo_id: int | None
    reason: str
    size: int


@dataclass
class Parser:
    """Splits a byte stream into packets of one protocol; `feed` returns what it completed."""

    protocol: str
    buffer: bytearray = field(default_factory=bytearray)

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {self.protocol!r}")

    def feed(self, data: bytes) -> list[Packet | Malformed]:
        self.buffer += data
        found: list[Packet | Malformed] = []
        while True:
            item = self._next()
            if item is None:
                return found
            found.append(item)

    def drop(self) -> Malformed | None:
        """Forget a partial packet (the line fell quiet in the middle of one)."""
        if not self.buffer:
            return None
        size, self.buffer = len(self.buffer), bytearray()
        return Malformed(None, "partial", size)

    def _skip_to_header(self, header: bytes) -> Malformed | None:
        at = self.buffer.find(header)
        keep = len(self.buffer) - len(header) + 1 if at < 0 else at
        keep = max(keep, 0)
        if at < 0:  # a header's start may sit at the end: keep what could begin one
            while keep < len(self.buffer) and not header.startswith(bytes(self.buffer[keep:])):
                keep += 1
        if keep == 0:
            return None
        del self.buffer[:keep]
        return Malformed(None, "noise", keep)

    def _next(self) -> Packet | Malformed | None:
        if self.protocol == "dynamixel":
            return self._next_dxl()
        return self._next_sts()

    def _next_dxl(self) -> Packet | Malformed | None:
        noise = self._skip_to_header(DXL_HEADER)
        if noise is not None:
            return noise
        buf = self.buffer
        if len(buf) < 7:
            return None
        servo_id, length = buf[4], int.from_bytes(buf[5:7], "little")
        if length < 3 or length > MAX_LENGTH or servo_id == 0xFF:
            del buf[:1]  # no packet starts here: look for the next header
            return Malformed(None, "length", 1)
        total = 7 + length
        if len(buf) < total:
            return None
        raw = bytes(buf[:total])
        del buf[:total]
        if crc16(raw[:-2]) != int.from_bytes(raw[-2:], "little"):
            return Malformed(servo_id, "crc", total)
        body = unstuff(raw[7:-2], raw[5:7])
        return Packet(servo_id, body[0], body[1:], total)

    def _next_sts(self) -> Packet | Malformed | None:
        noise = self._skip_to_header(STS_HEADER)
        if noise is not None:
            return noise
        buf = self.buffer
        if len(buf) >= 3 and buf[2] == 0xFF:  # FF FF FF: the header is one byte later
            del buf[:1]
            return Malformed(None, "noise", 1)
        if len(buf) < 4:
            return None
        servo_id, length = buf[2], buf[3]
        if length < 2:
            del buf[:1]
            return Malformed(None, "length", 1)
        total = 4 + length
        if len(buf) < total:
            return None
        raw = bytes(buf[:total])
        del buf[:total]
        if sts_checksum(raw[2:-1]) != raw[-1]:
            return Malformed(servo_id, "checksum", total)
        return Packet(servo_id, raw[4], raw[5:-1], total)


# --- control tables -------------------------------------------------------------------------


@dataclass(frozen=True)
class ControlTable:
    """A servo model's control table: name -> (address, bytes), little-endian; what a WRITE may
    change; the power-on values; the baud rates by the baud field's value."""

    model: str
    model_number: int
    size: int
    fields: dict[str, tuple[int, int]]
    writable: frozenset[str]
    eeprom_end: int  # addresses below: written only with the torque off
    defaults: dict[str, int]
    bauds: dict[int, int]
    velocity_unit_rad_s: float
    load_unit: float  # fraction of the stall torque per count
    signed: str  # "twos" (Dynamixel) or "magnitude" (Feetech: a sign bit above the value)

    def baud_code(self, baud: int) -> int:
        for code, rate in self.bauds.items():
            if rate == baud:
                return code
        raise ValueError(f"{self.model} runs at {sorted(self.bauds.values())} baud, got {baud}")


XM430_W350 = ControlTable(
    model="XM430-W350",
    model_number=1020,
    size=148,
    fields={
        "model_number": (0, 2),
        "firmware_version": (6, 1),
        "id": (7, 1),
        "baud_rate": (8, 1),
        "return_delay_time": (9, 1),
        "operating_mode": (11, 1),
        "torque_enable": (64, 1),
        "led": (65, 1),
        "status_return_level": (68, 1),
        "hardware_error_status": (70, 1),
        "goal_velocity": (104, 4),
        "profile_acceleration": (108, 4),
        "profile_velocity": (112, 4),
        "goal_position": (116, 4),
        "moving": (122, 1),
        "present_load": (126, 2),
        "present_velocity": (128, 4),
        "present_position": (132, 4),
        "present_input_voltage": (144, 2),
        "present_temperature": (146, 1),
    },
    writable=frozenset(
        {
            "id",
            "baud_rate",
            "return_delay_time",
            "operating_mode",
            "torque_enable",
            "led",
            "status_return_level",
            "goal_velocity",
            "profile_acceleration",
            "profile_velocity",
            "goal_position",
        }
    ),
    eeprom_end=64,
    defaults={
        "firmware_version": 52,
        "baud_rate": 3,
        "return_delay_time": 250,
        "operating_mode": 3,
        "status_return_level": 2,
        "goal_position": CENTER_STEPS,
        "present_position": CENTER_STEPS,
        "present_temperature": 25,
    },
    bauds={
        0: 9600,
        1: 57_600,
        2: 115_200,
        3: 1_000_000,
        4: 2_000_000,
        5: 3_000_000,
        6: 4_000_000,
        7: 4_500_000,
    },
    velocity_unit_rad_s=0.229 * 2.0 * math.pi / 60.0,  # 0.229 rev/min
    load_unit=0.001,  # 0.1 %
    signed="twos",
)

STS3215 = ControlTable(
    model="STS3215",
    model_number=777,
    size=71,
    fields={
        "firmware_version": (0, 1),
        "model_number": (3, 2),
        "id": (5, 1),
        "baud_rate": (6, 1),
        "return_delay_time": (7, 1),
        "torque_enable": (40, 1),
        "acceleration": (41, 1),
        "goal_position": (42, 2),
        "goal_time": (44, 2),
        "goal_speed": (46, 2),
        "lock": (55, 1),
        "present_position": (56, 2),
        "present_speed": (58, 2),
        "present_load": (60, 2),
        "present_voltage": (62, 1),
        "present_temperature": (63, 1),
        "moving": (66, 1),
    },
    writable=frozenset(
        {
            "id",
            "baud_rate",
            "return_delay_time",
            "torque_enable",
            "acceleration",
            "goal_position",
            "goal_time",
            "goal_speed",
            "lock",
        }
    ),
    eeprom_end=40,
    defaults={
        "firmware_version": 3,
        "baud_rate": 0,
        "return_delay_time": 250,
        "goal_position": CENTER_STEPS,
        "present_position": CENTER_STEPS,
        "present_temperature": 25,
    },
    bauds={
        0: 1_000_000,
        1: 500_000,
        2: 250_000,
        3: 128_000,
        4: 115_200,
        5: 76_800,
        6: 57_600,
        7: 38_400,
    },
    velocity_unit_rad_s=RAD_PER_STEP,  # steps/s
    load_unit=0.001,  # 0.1 %
    signed="magnitude",
)

TABLES = {"dynamixel": XM430_W350, "feetech": STS3215}
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


# --- the bus drive: a sync write per frame ---------------------------------------------------


@dataclass(frozen=True)
class BusLink:
    """The serial bus a robot's 12 servos sit on, IDs 1..12 in the gait's joint order."""

    protocol: str = "dynamixel"
    baud: int = 1_000_000  # what small bipeds on Dynamixel or Feetech buses run at

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS or self.baud <= 0:
            raise ValueError(f"a bus is one of {PROTOCOLS} at a baud > 0, got {self!r}")


def sync_write_substeps(
    angles_rad: NDArray[np.float64], link: BusLink, timestep_us: int
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Frames (n, 12) of joint angles sent as a sync write each: the angle each servo's goal
    stands for (4096 steps a turn) and the physics step of the frame at which it acts (the
    packet's last byte received; its length varies with the byte stuffing of its values)."""
    steps = angle_to_steps(angles_rad)
    ids = range(1, steps.shape[-1] + 1)
    substep = np.empty(steps.shape, dtype=np.int64)
    address, size = TABLES[link.protocol].fields["goal_position"]
    make = dxl_sync_write if link.protocol == "dynamixel" else sts_sync_write
    for k, row in enumerate(steps.reshape(-1, steps.shape[-1])):
        packet = make(address, size, dict(zip(ids, row.tolist(), strict=True)))
        substep.reshape(-1, steps.shape[-1])[k] = -(-wire_us(len(packet), link.baud) // timestep_us)
    return steps_to_angle(steps), substep


@dataclass(frozen=True)
class BusFrame:
    """One frame's sync write: its packet, when it starts and ends on the wire (µs from the
    run's start), each servo's goal in steps and the angle it stands for (rad)."""

    packet: bytes
    start_us: int
    wire_us: int
    effect_us: int  # every servo takes its goal when the packet's last byte has arrived
    goal_steps: tuple[int, ...]
    goal_rad: tuple[float, ...]

    def substep(self, timestep_us: int = 1000) -> int:
        """The frame's first physics step (of `timestep_us`) starting at or after the goals
        take effect: where the simulation switches every servo's set-point (§2's rule)."""
        return -(-(self.effect_us - self.start_us) // timestep_us)


def bus_frame(
    frame_index: int,
    angles_rad: ArrayLike,
    *,
    protocol: str = "dynamixel",
    baud: int = 1_000_000,
    ids: Sequence[int] | None = None,
) -> BusFrame:
    """Frame `frame_index`'s sync write of the goal positions of `angles_rad` (12,), joint
    order, IDs 1..12 unless `ids`; sent at the frame's start. ValueError on a wrong protocol."""
    steps = angle_to_steps(angles_rad)
    ids = list(range(1, len(steps) + 1)) if ids is None else list(ids)
    values = dict(zip(ids, steps.tolist(), strict=True))
    table = TABLES.get(protocol)
    if table is None:
        raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    address, size = table.fields["goal_position"]
    make = dxl_sync_write if protocol == "dynamixel" else sts_sync_write
    packet = make(address, size, values)
    start = frame_index * FRAME_US
    on_wire = wire_us(len(packet), baud)
    return BusFrame(
        packet=packet,
        start_us=start,
        wire_us=on_wire,
        effect_us=start + on_wire,
        goal_steps=tuple(steps.tolist()),
        goal_rad=tuple(steps_to_angle(steps).tolist()),
    )
