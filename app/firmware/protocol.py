"""The host side of the ArtRo UART protocol (hardware/firmware/PROTOCOL.md; docs/DESIGN.md §5):
`0xA5 | LEN | TYPE | PAYLOAD | CRC-16/CCITT-FALSE`, little-endian, float32 values; `encode`
builds messages, `Decoder` splits a byte stream, `parse` types the robot's replies."""

from __future__ import annotations

import binascii
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import IntEnum

from gait.params import LAW_GROUPS

SYNC = 0xA5
MAX_LEN = 200  # TYPE + PAYLOAD
VERSION = 2
#: values in one SET_PARAMS or PARAMS (3 + 4 * 48 <= MAX_LEN): a whole set takes several
MAX_VALUES = 48


class Msg(IntEnum):
    # host -> robot
    PING = 0x01
    SET_MOTION = 0x02
    SET_PARAM = 0x03
    SET_PARAMS = 0x04
    GET_PARAM = 0x05
    GET_PARAMS = 0x06
    START = 0x07
    STOP = 0x08
    TORQUE_OFF = 0x09
    TELEMETRY_ON = 0x0A
    GET_TELEMETRY = 0x0B
    GET_ANGLES = 0x0C
    RESET_PARAMS = 0x0D
    GET_SENSORS = 0x0E
    # robot -> host
    ACK = 0x81
    NAK = 0x82
    INFO = 0x83
    PARAM = 0x84
    PARAMS = 0x85
    TELEMETRY = 0x86
    ANGLES = 0x87
    SENSORS = 0x88


class NakReason(IntEnum):
    BAD_CRC = 1
    UNKNOWN_TYPE = 2
    BAD_LENGTH = 3
    UNKNOWN_ID = 4
    OUT_OF_RANGE = 5
    TIMEOUT = 6
    RX_OVERFLOW = 7


class RunState(IntEnum):
    WALK = 0
    STOP = 1
    TORQUE_OFF = 2


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE."""
    return binascii.crc_hqx(data, 0xFFFF)


def encode(msg_type: int, payload: bytes = b"") -> bytes:
    body = bytes([len(payload) + 1, msg_type]) + payload
    if len(payload) + 1 > MAX_LEN:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_LEN - 1}")
    return bytes([SYNC]) + body + struct.pack("<H", crc16(body))


def set_motion(a_r: float, a_p: float, a_y: float, ca: float) -> bytes:
    return encode(Msg.SET_MOTION, struct.pack("<4f", a_r, a_p, a_y, ca))


def set_param(pid: int, value: float) -> bytes:
    return encode(Msg.SET_PARAM, struct.pack("<Bf", pid, value))


def set_params(values: Sequence[float], first: int = 0) -> bytes:
    """One SET_PARAMS of at most MAX_VALUES values from id `first`."""
    if not 1 <= len(values) <= MAX_VALUES:
        raise ValueError(f"a SET_PARAMS carries 1..{MAX_VALUES} values, got {len(values)}")
    return encode(Msg.SET_PARAMS, struct.pack(f"<BB{len(values)}f", first, len(values), *values))


def param_parts(count: int) -> list[tuple[int, int]]:
    """(first id, count) of each SET_PARAMS of a whole set of `count` values, in sending order:
    the highest ids first (the feedback laws' part), then the one with the motion and the gait,
    whose ACK names the frame from which the whole set is in force."""
    firsts = range(0, count, MAX_VALUES)
    return [(first, min(MAX_VALUES, count - first)) for first in reversed(firsts)]


def set_all_params(values: Sequence[float]) -> list[bytes]:
    """A whole set (every id from 0) as the SET_PARAMS of `param_parts`."""
    return [set_params(values[first : first + n], first) for first, n in param_parts(len(values))]


def get_params(first: int, count: int) -> bytes:
    """GET_PARAMS of ids first..first+count-1 (count 1..MAX_VALUES)."""
    return encode(Msg.GET_PARAMS, bytes([first, count]))


def get_param(pid: int) -> bytes:
    return encode(Msg.GET_PARAM, bytes([pid]))


def telemetry_on(mode: int = 1) -> bytes:
    return encode(Msg.TELEMETRY_ON, bytes([mode]))


def command(msg_type: Msg) -> bytes:
    """A message without payload: PING, START, STOP, TORQUE_OFF, GET_SENSORS, ..."""
    return encode(msg_type)


@dataclass(frozen=True)
class Message:
    type: int
    payload: bytes


@dataclass(frozen=True)
class Ack:
    acked: int
    effective_frame: int  # first frame the change reaches


@dataclass(frozen=True)
class Nak:
    rejected: int  # message type, 0 if unknown
    reason: NakReason
    detail: int  # parameter id, or the bad length


@dataclass(frozen=True)
class Info:
    version: int
    param_count: int
    schema_hash: int
    frame: int
    state: RunState


@dataclass(frozen=True)
class Telemetry:
    frame: int
    phase_rad: float
    ocr: tuple[int, ...]  # per servo
    saturated: int  # bit per servo
    flags: int
    state: RunState


@dataclass(frozen=True)
class Angles:
    frame: int
    angles_rad: tuple[float, ...]


@dataclass(frozen=True)
class Params:
    first: int
    values: tuple[float, ...]


#: SENSORS status bits (hardware/firmware/src/sensors.h)
IMU_PRESENT, IMU_STALE, IMU_NACK, IMU_SHORT, FSR_STALE = 0x01, 0x02, 0x04, 0x08, 0x10
#: their names, and the laws' bits by name (the feedback groups in schema order)
STATUS_BITS = {"imu_present": IMU_PRESENT, "imu_stale": IMU_STALE, "imu_nack": IMU_NACK,
               "imu_short": IMU_SHORT, "fsr_stale": FSR_STALE}  # fmt: skip
LAW_BITS = {law: 1 << i for i, law in enumerate(LAW_GROUPS)}
_SENSORS = struct.Struct("<IBBBb3h3h3h8H2f2ff2f")


@dataclass(frozen=True)
class Sensors:
    """The balance sensors and laws of the frame the firmware planned last (PROTOCOL.md)."""

    frame: int  # the frame the laws corrected
    status: int  # IMU_PRESENT | IMU_STALE | ...
    imu_failures: int  # failed IMU reads since boot (255: at least)
    laws: int  # bit 0 tilt, 1 yaw rate, 2 damping, 3 CoP
    support: int  # 0 left, 1 right, -1 neither
    gyro_offset: tuple[int, ...]  # the boot calibration, counts
    accel_raw: tuple[int, ...]  # counts, the part's axes
    gyro_raw: tuple[int, ...]  # counts, before the offset
    adc: tuple[int, ...]  # 8 channels, left foot fl, fr, bl, br first
    attitude_rad: tuple[float, float]  # pitch, roll estimate
    tilt_rad: tuple[float, float]  # tilt trim
    a_y_delta: float  # yaw-rate loop's change of a_y
    cop_rad: tuple[float, float]  # support foot's ankle pitch and roll correction


def _sensors(p: bytes) -> Sensors:
    v = _SENSORS.unpack(p)
    return Sensors(
        frame=v[0], status=v[1], imu_failures=v[2], laws=v[3], support=v[4],
        gyro_offset=v[5:8], accel_raw=v[8:11], gyro_raw=v[11:14], adc=v[14:22],
        attitude_rad=v[22:24], tilt_rad=v[24:26], a_y_delta=v[26], cop_rad=v[27:29],
    )  # fmt: skip


Reply = Ack | Nak | Info | Telemetry | Angles | Params | Sensors | Message


def parse(message: Message) -> Reply:
    """A robot message as a typed record (a Message if the type is not a reply)."""
    t, p = message.type, message.payload
    if t == Msg.ACK:
        acked, frame = struct.unpack("<BI", p)
        return Ack(acked, frame)
    if t == Msg.NAK:
        return Nak(p[0], NakReason(p[1]), p[2])
    if t == Msg.INFO:
        version, count, schema, frame, state = struct.unpack("<BBIIB", p)
        return Info(version, count, schema, frame, RunState(state))
    if t == Msg.TELEMETRY:
        frame, phase = struct.unpack_from("<If", p)
        ocr = struct.unpack_from("<12H", p, 8)
        saturated, flags, state = struct.unpack_from("<HBB", p, 32)
        return Telemetry(frame, phase, ocr, saturated, flags, RunState(state))
    if t == Msg.ANGLES:
        frame = struct.unpack_from("<I", p)[0]
        return Angles(frame, struct.unpack_from("<12f", p, 4))
    if t == Msg.SENSORS:
        return _sensors(p)
    if t in (Msg.PARAMS, Msg.PARAM):
        if t == Msg.PARAM:
            pid, value = struct.unpack("<Bf", p)
            return Params(pid, (value,))
        first, count = p[0], p[1]
        return Params(first, struct.unpack_from(f"<{count}f", p, 2))
    return message


class Decoder:
    """Splits a byte stream into messages; bytes that do not form a valid message are skipped
    (and counted)."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.skipped = 0

    def feed(self, data: Iterable[int] | bytes) -> list[Message]:
        self._buf.extend(data)
        out: list[Message] = []
        buf = self._buf
        while True:
            start = buf.find(SYNC)
            if start < 0:
                self.skipped += len(buf)
                buf.clear()
                break
            if start:
                self.skipped += start
                del buf[:start]
            if len(buf) < 2:
                break
            length = buf[1]
            if not 1 <= length <= MAX_LEN:
                self.skipped += 1
                del buf[0]
                continue
            if len(buf) < length + 4:
                break
            body = bytes(buf[1 : length + 2])
            (crc,) = struct.unpack_from("<H", buf, length + 2)
            if crc != crc16(body):
                self.skipped += 1
                del buf[0]
                continue
            out.append(Message(body[1], body[2:]))
            del buf[: length + 4]
        return out
