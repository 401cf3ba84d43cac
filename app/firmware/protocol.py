"""The host side of the ArtRo UART protocol (hardware/firmware/PROTOCOL.md; docs/DESIGN.md §5):
`0xA5 | LEN | TYPE | PAYLOAD | CRC-16/CCITT-FALSE`, little-endian, float32 values; `encode`
builds messages, `Decoder` splits a byte stream, `parse` types the robot's replies (LinkError for
one whose payload is not its type's), `answers` pairs a reply with its request."""

from __future__ import annotations

import binascii
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import IntEnum

from gait.params import LAW_GROUPS
from hardware.firmware.wire import SENSORS as SENSORS_LAYOUT
from hardware.firmware.wire import TELEMETRY as TELEMETRY_LAYOUT

SYNC = 0xA5
MAX_LEN = 200  # TYPE + PAYLOAD
VERSION = 2
#: values in one SET_PARAMS or PARAMS (3 + 4 * 48 <= MAX_LEN): a whole set takes several
MAX_VALUES = 48


class LinkError(RuntimeError):
    """The robot did not answer, answered out of protocol, refused a request, or runs firmware
    of another schema."""


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
    if len(payload) + 1 == SYNC:  # the robot takes a LEN of 0xA5 for a new message's sync
        raise ValueError(f"a payload of {SYNC - 1} bytes is reserved (PROTOCOL.md, Framing)")
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
    reason: NakReason | int  # an int if PROTOCOL.md names no such reason
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
    """The plan sent last (PROTOCOL.md); fields: hardware/firmware/wire.py's TELEMETRY layout."""

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


@dataclass(frozen=True)
class Sensors:
    """The balance sensors and laws of the frame the firmware planned last (PROTOCOL.md); its
    fields are those of hardware/firmware/wire.py's SENSORS layout, by name and in order."""

    frame: int  # the frame the laws corrected
    status: int  # IMU_PRESENT | IMU_STALE | ...
    imu_failures: int  # failed IMU reads since boot (255: at least)
    laws: int  # bit 0 tilt, 1 yaw rate, 2 damping, 3 CoP, 4 step timing (LAW_BITS)
    support: int  # 0 left, 1 right, -1 neither
    gyro_offset: tuple[int, ...]  # the boot calibration, counts
    accel_raw: tuple[int, int, int]  # counts, the part's axes
    gyro_raw: tuple[int, int, int]  # counts, before the offset
    adc: tuple[int, ...]  # 8 channels, left foot fl, fr, bl, br first
    attitude_rad: tuple[float, float]  # pitch, roll estimate
    tilt_rad: tuple[float, float]  # tilt trim
    a_y_delta: float  # yaw-rate loop's change of a_y
    cop_rad: tuple[float, float]  # support foot's ankle pitch and roll correction


def _sensors(p: bytes) -> Sensors:
    return Sensors(**SENSORS_LAYOUT.unpack(p))


Reply = Ack | Nak | Info | Telemetry | Angles | Params | Sensors | Message

#: payload bytes of each reply of a fixed size (PROTOCOL.md); PARAMS: 2 + 4 x count
PAYLOAD_BYTES = {Msg.ACK: 5, Msg.NAK: 3, Msg.INFO: 11, Msg.PARAM: 5,
                 Msg.TELEMETRY: TELEMETRY_LAYOUT.size,
                 Msg.ANGLES: 52, Msg.SENSORS: SENSORS_LAYOUT.size}  # fmt: skip


def type_name(msg_type: int) -> str:
    """A message type as PROTOCOL.md names it, e.g. TORQUE_OFF, or its number if it names none."""
    return Msg(msg_type).name if msg_type in Msg._value2member_map_ else f"type 0x{msg_type:02x}"


def _check_length(t: int, p: bytes) -> None:
    if t == Msg.PARAMS:
        count = p[1] if len(p) >= 2 else 0
        if not 1 <= count <= MAX_VALUES or len(p) != 2 + 4 * count:
            of = f" for count {count}" if len(p) >= 2 else ""
            raise LinkError(
                f"the robot's PARAMS has {len(p)} payload bytes{of}, expected 2 + 4 x count, "
                f"count 1..{MAX_VALUES} (firmware of another protocol?)"
            )
    elif t in PAYLOAD_BYTES and len(p) != PAYLOAD_BYTES[Msg(t)]:
        raise LinkError(
            f"the robot's {Msg(t).name} has {len(p)} payload byte{'' if len(p) == 1 else 's'}, "
            f"expected {PAYLOAD_BYTES[Msg(t)]} (firmware of another protocol?)"
        )


def _state(name: str, value: int) -> RunState:
    if value not in RunState._value2member_map_:
        raise LinkError(
            f"the robot's {name} names state {value}; PROTOCOL.md's are 0 walking, 1 stopped, "
            "2 torque off (firmware of another protocol?)"
        )
    return RunState(value)


def parse(message: Message) -> Reply:
    """A robot message as a typed record (a Message if the type is not a reply); LinkError for
    a reply whose payload is not as long as PROTOCOL.md gives its type."""
    t, p = message.type, message.payload
    _check_length(t, p)
    if t == Msg.ACK:
        acked, frame = struct.unpack("<BI", p)
        return Ack(acked, frame)
    if t == Msg.NAK:
        reason = NakReason(p[1]) if p[1] in NakReason._value2member_map_ else p[1]
        return Nak(p[0], reason, p[2])
    if t == Msg.INFO:
        version, count, schema, frame, state = struct.unpack("<BBIIB", p)
        return Info(version, count, schema, frame, _state("INFO", state))
    if t == Msg.TELEMETRY:
        fields = TELEMETRY_LAYOUT.unpack(p)
        return Telemetry(**{**fields, "state": _state("TELEMETRY", fields["state"])})
    if t == Msg.ANGLES:
        frame = struct.unpack_from("<I", p)[0]
        return Angles(frame, struct.unpack_from("<12f", p, 4))
    if t == Msg.SENSORS:
        return _sensors(p)
    if t == Msg.PARAM:
        pid, value = struct.unpack("<Bf", p)
        return Params(pid, (value,))
    if t == Msg.PARAMS:
        return Params(p[0], struct.unpack_from(f"<{p[1]}f", p, 2))
    return message


#: what PROTOCOL.md gives as the answer to each request: ACK of that type, or a data reply
ACKED = frozenset({Msg.SET_MOTION, Msg.SET_PARAM, Msg.SET_PARAMS, Msg.START, Msg.STOP,
                   Msg.TORQUE_OFF, Msg.TELEMETRY_ON, Msg.RESET_PARAMS})  # fmt: skip
DATA_REPLIES: dict[int, tuple[Msg, type]] = {
    Msg.PING: (Msg.INFO, Info),
    Msg.GET_PARAM: (Msg.PARAM, Params),
    Msg.GET_PARAMS: (Msg.PARAMS, Params),
    Msg.GET_TELEMETRY: (Msg.TELEMETRY, Telemetry),
    Msg.GET_ANGLES: (Msg.ANGLES, Angles),
    Msg.GET_SENSORS: (Msg.SENSORS, Sensors),
}


def expected_answer(request: bytes) -> str:
    """The answer PROTOCOL.md gives for the message `request` (a whole frame), in words."""
    t = request[2]
    if t in ACKED:
        return f"ACK of {type_name(t)}"
    return DATA_REPLIES[t][0].name if t in DATA_REPLIES else "no answer PROTOCOL.md names"


def answers(request: bytes, reply: Reply) -> bool:
    """Whether `reply` is the answer PROTOCOL.md gives for `request` (a whole frame): the ACK
    of its type, or the data it asks for (the ids it asks for); a NAK is not one."""
    t = request[2]
    if t in ACKED:
        return isinstance(reply, Ack) and reply.acked == t
    if t not in DATA_REPLIES or not isinstance(reply, DATA_REPLIES[t][1]):
        return False
    if t == Msg.GET_PARAM:
        return isinstance(reply, Params) and (reply.first, len(reply.values)) == (request[3], 1)
    if t == Msg.GET_PARAMS:
        return isinstance(reply, Params) and (reply.first, len(reply.values)) == tuple(request[3:5])
    return True


def describe(reply: Reply) -> str:
    """A reply in a few words, for a message that says what came instead of the answer."""
    if isinstance(reply, Ack):
        return f"ACK of {type_name(reply.acked)}"
    if isinstance(reply, Nak):
        return f"NAK of {type_name(reply.rejected)}"
    if isinstance(reply, Params):
        return f"PARAMS of ids {reply.first}..{reply.first + len(reply.values) - 1}"
    if isinstance(reply, Message):
        if reply.type in Msg._value2member_map_ and reply.type < Msg.ACK:
            return f"{type_name(reply.type)}, a message of the host's"
        return f"a message of {type_name(reply.type)}, which PROTOCOL.md does not name"
    return type(reply).__name__.upper()


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
