"""The protocol's named values and its error on the host (hardware/firmware/PROTOCOL.md;
docs/DESIGN.md §5): `LinkError`, the NAK reasons and run states, and the converters the generated
app/firmware/wire_messages.py reads those fields with."""

from __future__ import annotations

from enum import IntEnum


class LinkError(RuntimeError):
    """The robot did not answer, answered out of protocol, refused a request, or runs firmware
    of another schema."""


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


def nak_reason(message: str, value: int) -> NakReason | int:
    """A NAK's reason: the int itself if PROTOCOL.md names no such reason."""
    return NakReason(value) if value in NakReason._value2member_map_ else value


def run_state(message: str, value: int) -> RunState:
    """The state `message` (INFO, TELEMETRY) names; LinkError for one PROTOCOL.md does not."""
    if value not in RunState._value2member_map_:
        raise LinkError(
            f"the robot's {message} names state {value}; PROTOCOL.md's are 0 walking, 1 stopped, "
            "2 torque off (firmware of another protocol?)"
        )
    return RunState(value)
