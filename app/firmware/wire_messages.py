"""The payloads of hardware/firmware/PROTOCOL.md's fixed layouts on the host
(docs/DESIGN.md §5): a dataclass with `unpack` per reply, `pack_<msg>` per request.
Generated from hardware/firmware/wire.py (`python -m hardware.firmware.wire
--write-python`); do not edit by hand."""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum

from app.firmware.wire_values import NakReason, RunState, nak_reason, run_state


class Msg(IntEnum):
    """PROTOCOL.md's message types: the host's, then the robot's."""

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
    ACK = 0x81
    NAK = 0x82
    INFO = 0x83
    PARAM = 0x84
    PARAMS = 0x85
    TELEMETRY = 0x86
    ANGLES = 0x87
    SENSORS = 0x88


_SET_MOTION = struct.Struct("<4f")
_SET_PARAM = struct.Struct("<Bf")
_SET_PARAMS = struct.Struct("<BB")
_GET_PARAM = struct.Struct("<B")
_GET_PARAMS = struct.Struct("<BB")
_TELEMETRY_ON = struct.Struct("<B")
_ACK = struct.Struct("<BI")
_NAK = struct.Struct("<BBB")
_INFO = struct.Struct("<BBIIB")
_PARAM = struct.Struct("<Bf")
_PARAMS = struct.Struct("<BB")
_TELEMETRY = struct.Struct("<If12HHBB")
_ANGLES = struct.Struct("<I12f")
_SENSORS = struct.Struct("<IBBBb3h3h3h8H2f2ff2f")


def pack_set_motion(values: Sequence[float]) -> bytes:
    """SET_MOTION's payload (0x02): the motion vector (parameter ids 0..3); struct.error for a
    value its C type cannot hold."""
    return _SET_MOTION.pack(*values)


def pack_set_param(id: int, value: float) -> bytes:
    """SET_PARAM's payload (0x03): one parameter's value; struct.error for a value its C type
    cannot hold."""
    return _SET_PARAM.pack(id, value)


def pack_set_params(first: int, values: Sequence[float]) -> bytes:
    """SET_PARAMS's payload (0x04): consecutive parameters' values; struct.error for a value
    its C type cannot hold."""
    return _SET_PARAMS.pack(first, len(values)) + struct.pack(f"<{len(values)}f", *values)


def pack_get_param(id: int) -> bytes:
    """GET_PARAM's payload (0x05): asks for one parameter's value; struct.error for a value its
    C type cannot hold."""
    return _GET_PARAM.pack(id)


def pack_get_params(first: int, count: int) -> bytes:
    """GET_PARAMS's payload (0x06): asks for consecutive parameters' values; struct.error for a
    value its C type cannot hold."""
    return _GET_PARAMS.pack(first, count)


def pack_telemetry_on(mode: int) -> bytes:
    """TELEMETRY_ON's payload (0x0A): what the robot streams; struct.error for a value its C
    type cannot hold."""
    return _TELEMETRY_ON.pack(mode)


@dataclass(frozen=True)
class Ack:
    """ACK (0x81): a request taken."""

    #: the type of the request
    acked: int
    #: the first frame it reaches (Effective frame)
    effective_frame: int

    @classmethod
    def unpack(cls, payload: bytes) -> Ack:
        """struct.error if `payload` is not 5 bytes."""
        v = _ACK.unpack(payload)
        return cls(v[0], v[1])


@dataclass(frozen=True)
class Nak:
    """NAK (0x82): a request refused, which changed nothing."""

    #: the type of the request, 0 if not known
    rejected: int
    #: why: the NAK reasons below
    reason: NakReason | int
    #: the NAK reasons' detail
    detail: int

    @classmethod
    def unpack(cls, payload: bytes) -> Nak:
        """struct.error if `payload` is not 3 bytes."""
        v = _NAK.unpack(payload)
        return cls(v[0], nak_reason("NAK", v[1]), v[2])


@dataclass(frozen=True)
class Info:
    """INFO (0x83): the firmware's protocol, its parameters and where it is."""

    #: protocol version (2)
    version: int
    #: parameter count
    param_count: int
    #: schema hash (Parameter ids)
    schema_hash: int
    #: the frame it is on
    frame: int
    #: state: the states below
    state: RunState

    @classmethod
    def unpack(cls, payload: bytes) -> Info:
        """struct.error if `payload` is not 11 bytes."""
        v = _INFO.unpack(payload)
        return cls(v[0], v[1], v[2], v[3], run_state("INFO", v[4]))


@dataclass(frozen=True)
class Param:
    """PARAM (0x84): one parameter's value."""

    #: parameter id
    id: int
    #: its value
    value: float

    @classmethod
    def unpack(cls, payload: bytes) -> Param:
        """struct.error if `payload` is not 5 bytes."""
        v = _PARAM.unpack(payload)
        return cls(v[0], v[1])


@dataclass(frozen=True)
class Params:
    """PARAMS (0x85): consecutive parameters' values."""

    #: the first one's id
    first: int
    #: their values, from id first
    values: tuple[float, ...]

    @classmethod
    def unpack(cls, payload: bytes) -> Params:
        """struct.error if `payload` is not as long as its count says."""
        v = _PARAMS.unpack_from(payload)
        if len(payload) != 2 + 4 * v[1]:
            raise struct.error(f"PARAMS of {len(payload)} bytes")
        values = struct.unpack_from(f"<{v[1]}f", payload, 2)
        return cls(v[0], values)


@dataclass(frozen=True)
class Telemetry:
    """TELEMETRY (0x86): the plan sent last, the clock's phase, flags."""

    #: the frame of the plan sent last
    frame: int
    #: the walking clock's phase φ_Trunk (rad)
    phase_rad: float
    #: OCR of each servo's pulse, in the gait's joint order
    ocr: tuple[int, ...]
    #: bit i: servo i clipped
    saturated: int
    #: flags: the TELEMETRY flags below
    flags: int
    #: state: the states below
    state: RunState

    @classmethod
    def unpack(cls, payload: bytes) -> Telemetry:
        """struct.error if `payload` is not 36 bytes."""
        v = _TELEMETRY.unpack(payload)
        return cls(v[0], v[1], v[2:14], v[14], v[15], run_state("TELEMETRY", v[16]))


@dataclass(frozen=True)
class Angles:
    """ANGLES (0x87): the joint angles of the plan sent last."""

    #: the frame of the plan sent last
    frame: int
    #: joint angles (rad), in the gait's joint order
    angles_rad: tuple[float, ...]

    @classmethod
    def unpack(cls, payload: bytes) -> Angles:
        """struct.error if `payload` is not 52 bytes."""
        v = _ANGLES.unpack(payload)
        return cls(v[0], v[1:13])


@dataclass(frozen=True)
class Sensors:
    """SENSORS (0x88): the balance sensors and laws of the frame the firmware planned last."""

    #: the frame the laws corrected
    frame: int
    #: status: the SENSORS status bits below
    status: int
    #: IMU failures since boot, 255 at most
    imu_failures: int
    #: laws on: bit 0 tilt, 1 yaw rate, 2 damping, 3 CoP, 4 step timing
    laws: int
    #: support foot: 0 left, 1 right, −1 none
    support: int
    #: gyro offsets x, y, z (the boot calibration, counts)
    gyro_offset: tuple[int, int, int]
    #: accelerometer x, y, z (raw counts)
    accel_raw: tuple[int, int, int]
    #: gyro x, y, z (raw counts, before the offset)
    gyro_raw: tuple[int, int, int]
    #: ADC: left foot front-left, front-right, back-left, back-right, then the right foot's
    adc: tuple[int, ...]
    #: attitude estimate pitch, roll (rad)
    attitude_rad: tuple[float, float]
    #: tilt trim pitch, roll (rad)
    tilt_rad: tuple[float, float]
    #: the yaw-rate loop's change of a_y
    a_y_delta: float
    #: CoP correction: the support foot's ankle pitch, roll (rad)
    cop_rad: tuple[float, float]

    @classmethod
    def unpack(cls, payload: bytes) -> Sensors:
        """struct.error if `payload` is not 70 bytes."""
        v = _SENSORS.unpack(payload)
        return cls(
            v[0],
            v[1],
            v[2],
            v[3],
            v[4],
            (v[5], v[6], v[7]),
            (v[8], v[9], v[10]),
            (v[11], v[12], v[13]),
            v[14:22],
            (v[22], v[23]),
            (v[24], v[25]),
            v[26],
            (v[27], v[28]),
        )
