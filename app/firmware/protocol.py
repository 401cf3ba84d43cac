"""The host side of the ArtRo UART protocol (hardware/firmware/PROTOCOL.md; docs/DESIGN.md §5):
`0xA5 | LEN | TYPE | PAYLOAD | CRC-16/CCITT-FALSE`, little-endian, float32 values; `encode`
builds messages, `Decoder` splits a byte stream, `parse` types the robot's replies (LinkError for
one whose payload is not its type's), `answers` pairs a reply with its request. The payloads'
layouts: app/firmware/wire_messages.py, generated from hardware/firmware/wire.py."""

from __future__ import annotations

import binascii
import struct
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from app.firmware import wire_messages as wm
from app.firmware.wire_messages import Ack, Angles, Info, Msg, Nak, Params, Sensors, Telemetry
from app.firmware.wire_values import LinkError
from app.firmware.wire_values import NakReason as NakReason
from app.firmware.wire_values import RunState as RunState
from gait.params import LAW_GROUPS
from hardware.firmware.wire import LAYOUTS
from hardware.firmware.wire import PARAMS as PARAMS_LAYOUT

SYNC = 0xA5
MAX_LEN = 200  # TYPE + PAYLOAD
VERSION = 2
#: values in one SET_PARAMS or PARAMS (3 + 4 * 48 <= MAX_LEN): a whole set takes several
MAX_VALUES = 48


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
    return encode(Msg.SET_MOTION, wm.pack_set_motion((a_r, a_p, a_y, ca)))


def set_param(pid: int, value: float) -> bytes:
    return encode(Msg.SET_PARAM, wm.pack_set_param(pid, value))


def set_params(values: Sequence[float], first: int = 0) -> bytes:
    """One SET_PARAMS of at most MAX_VALUES values from id `first`."""
    if not 1 <= len(values) <= MAX_VALUES:
        raise ValueError(f"a SET_PARAMS carries 1..{MAX_VALUES} values, got {len(values)}")
    return encode(Msg.SET_PARAMS, wm.pack_set_params(first, values))


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
    return encode(Msg.GET_PARAMS, wm.pack_get_params(first, count))


def get_param(pid: int) -> bytes:
    return encode(Msg.GET_PARAM, wm.pack_get_param(pid))


def telemetry_on(mode: int = 1) -> bytes:
    return encode(Msg.TELEMETRY_ON, wm.pack_telemetry_on(mode))


def command(msg_type: Msg) -> bytes:
    """A message without payload: PING, START, STOP, TORQUE_OFF, GET_SENSORS, ..."""
    return encode(msg_type)


@dataclass(frozen=True)
class Message:
    type: int
    payload: bytes


#: SENSORS status bits (hardware/firmware/src/sensors.h)
IMU_PRESENT, IMU_STALE, IMU_NACK, IMU_SHORT, FSR_STALE = 0x01, 0x02, 0x04, 0x08, 0x10
#: their names, and the laws' bits by name (the feedback groups in schema order)
STATUS_BITS = {"imu_present": IMU_PRESENT, "imu_stale": IMU_STALE, "imu_nack": IMU_NACK,
               "imu_short": IMU_SHORT, "fsr_stale": FSR_STALE}  # fmt: skip
LAW_BITS = {law: 1 << i for i, law in enumerate(LAW_GROUPS)}


Reply = Ack | Nak | Info | Telemetry | Angles | Params | Sensors | Message

#: payload bytes of each reply of a fixed size (PROTOCOL.md); PARAMS: 2 + 4 x count
PAYLOAD_BYTES = {
    Msg[layout.name]: layout.size
    for layout in LAYOUTS
    if layout.sender == "robot" and layout.repeated is None
}


def type_name(msg_type: int) -> str:
    """A message type as PROTOCOL.md names it, e.g. TORQUE_OFF, or its number if it names none."""
    return Msg(msg_type).name if msg_type in Msg._value2member_map_ else f"type 0x{msg_type:02x}"


def _check_length(t: int, p: bytes) -> None:
    if t == Msg.PARAMS:
        head = PARAMS_LAYOUT.size
        count = p[PARAMS_LAYOUT.names.index("count")] if len(p) >= head else 0
        if not 1 <= count <= MAX_VALUES or len(p) != head + 4 * count:
            of = f" for count {count}" if len(p) >= 2 else ""
            raise LinkError(
                f"the robot's PARAMS has {len(p)} payload bytes{of}, expected {head} + 4 x count, "
                f"count 1..{MAX_VALUES} (firmware of another protocol?)"
            )
    elif t in PAYLOAD_BYTES and len(p) != PAYLOAD_BYTES[Msg(t)]:
        raise LinkError(
            f"the robot's {Msg(t).name} has {len(p)} payload byte{'' if len(p) == 1 else 's'}, "
            f"expected {PAYLOAD_BYTES[Msg(t)]} (firmware of another protocol?)"
        )


#: the reply of each type with a layout of its own, read from its payload
_UNPACK: dict[int, Callable[[bytes], Reply]] = {
    Msg.ACK: Ack.unpack,
    Msg.NAK: Nak.unpack,
    Msg.INFO: Info.unpack,
    Msg.TELEMETRY: Telemetry.unpack,
    Msg.ANGLES: Angles.unpack,
    Msg.SENSORS: Sensors.unpack,
    Msg.PARAMS: Params.unpack,
}


def parse(message: Message) -> Reply:
    """A robot message as a typed record (a Message if the type is not a reply); LinkError for
    a reply whose payload is not as long as PROTOCOL.md gives its type, or that names a state
    PROTOCOL.md does not."""
    t, p = message.type, message.payload
    _check_length(t, p)
    if t == Msg.PARAM:  # one value, as the PARAMS of one id
        param = wm.Param.unpack(p)
        return Params(param.id, (param.value,))
    return _UNPACK[t](p) if t in _UNPACK else message


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
