"""A bus servo's positions (4096 steps a turn, 2048 = 0 rad) and the bus's timing in integer
µs: 10 bits a byte, a sync write per 20 ms frame, answers after their return delays
(docs/BUS.md)."""

from __future__ import annotations

import math
from collections.abc import Sequence

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
