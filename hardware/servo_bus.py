"""Bus servos, pure (docs/DESIGN.md §5, docs/BUS.md): Dynamixel Protocol 2.0 and Feetech STS
packets (CRC-16, byte stuffing, checksum), a stream parser, the XM430-W350 and STS3215 control
tables and a servo that answers as they do, angle <-> position (4096 steps a turn, 2048 = 0 rad),
and the bus's timing in integer µs (10 bits a byte, a sync write per 20 ms frame)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hardware.bus_control_tables import STS3215, TABLES, XM430_W350, ControlTable
from hardware.bus_packets import (
    ACTION,
    BROADCAST_ID,
    DXL_HEADER,
    DXL_STATUS,
    ERR_ACCESS,
    ERR_CRC,
    ERR_DATA_LENGTH,
    ERR_DATA_LIMIT,
    ERR_DATA_RANGE,
    ERR_INSTRUCTION,
    ERR_RESULT_FAIL,
    MAX_LENGTH,
    PING,
    PROTOCOLS,
    READ,
    REBOOT,
    REG_WRITE,
    STS_HEADER,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    Malformed,
    Packet,
    Parser,
    crc16,
    dxl_packet,
    dxl_status,
    dxl_sync_read,
    dxl_sync_write,
    sts_checksum,
    sts_packet,
    sts_status,
    sts_sync_read,
    sts_sync_write,
    stuff,
    unstuff,
)
from hardware.bus_servos import Answer, BusServo, Present, ServoBus
from hardware.bus_timing import (
    BITS_PER_BYTE,
    CENTER_STEPS,
    FRAME_US,
    MAX_STEPS,
    RAD_PER_STEP,
    RETURN_DELAY_UNIT_US,
    STEPS_PER_TURN,
    angle_to_steps,
    answers_done_us,
    steps_to_angle,
    wire_us,
)

# --- the bus drive: a sync write per frame ---------------------------------------------------


@dataclass(frozen=True)
class BusLink:
    """The serial bus a robot's 12 servos sit on, their IDs in the gait's joint order."""

    protocol: str = "dynamixel"
    baud: int = 1_000_000  # what small bipeds on Dynamixel or Feetech buses run at
    ids: tuple[int, ...] = tuple(range(1, 13))

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
    substep = np.empty(steps.shape, dtype=np.int64)
    rows, ends = steps.reshape(-1, steps.shape[-1]), substep.reshape(-1, steps.shape[-1])
    for k, row in enumerate(steps_to_angle(rows)):  # angles that quantise to the same steps
        sent = bus_frame(0, row, protocol=link.protocol, baud=link.baud, ids=link.ids)
        ends[k] = sent.substep(timestep_us)
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


__all__ = [
    "ACTION",
    "BITS_PER_BYTE",
    "BROADCAST_ID",
    "CENTER_STEPS",
    "DXL_HEADER",
    "DXL_STATUS",
    "ERR_ACCESS",
    "ERR_CRC",
    "ERR_DATA_LENGTH",
    "ERR_DATA_LIMIT",
    "ERR_DATA_RANGE",
    "ERR_INSTRUCTION",
    "ERR_RESULT_FAIL",
    "FRAME_US",
    "MAX_LENGTH",
    "MAX_STEPS",
    "PING",
    "PROTOCOLS",
    "RAD_PER_STEP",
    "READ",
    "REBOOT",
    "REG_WRITE",
    "RETURN_DELAY_UNIT_US",
    "STEPS_PER_TURN",
    "STS3215",
    "STS_HEADER",
    "SYNC_READ",
    "SYNC_WRITE",
    "TABLES",
    "WRITE",
    "XM430_W350",
    "Answer",
    "BusFrame",
    "BusLink",
    "BusServo",
    "ControlTable",
    "Malformed",
    "Packet",
    "Parser",
    "Present",
    "ServoBus",
    "angle_to_steps",
    "answers_done_us",
    "bus_frame",
    "crc16",
    "dxl_packet",
    "dxl_status",
    "dxl_sync_read",
    "dxl_sync_write",
    "steps_to_angle",
    "sts_checksum",
    "sts_packet",
    "sts_status",
    "sts_sync_read",
    "sts_sync_write",
    "stuff",
    "sync_write_substeps",
    "unstuff",
    "wire_us",
]
