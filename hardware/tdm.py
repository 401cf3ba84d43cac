"""TDM-PWM frame of ArtRo's servo drive, seed 000 §3.B (Figures 7b, 8, 9; docs/DESIGN.md §5).

OCR frames are (..., 6, 8) = (channel, slot), -1 for idle slots; per-servo arrays are (..., 12) in
SERVO_NAMES order (= the gait's joint order). Select-line timing and the guard: `TdmConfig`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gait.leg_interface import JOINT_NAMES
from hardware.timer import (
    OCR_IDLE,
    OCR_MAX,
    SLOT_TICKS,
    SLOTS_PER_FRAME,
    SLOTS_USED,
    pulse_us_to_ocr,
)

CHANNELS = ("OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C")  # the six TDM lines
SELECT_LINES = ("S0", "S1", "S2")  # demultiplexer select bits, S0 = LSB
SERVO_NAMES = JOINT_NAMES  # one servo per joint, in the one joint order (docs/DESIGN.md)
DEFAULT_SELECT_CHANGE_TICKS = 4900  # 2.45 ms: between a 2.4 ms pulse's end and the next slot


@dataclass(frozen=True)
class ChannelMap:
    """Where each servo's pulse travels: per servo in SERVO_NAMES order, (channel index, slot).

    Channel indexes refer to CHANNELS (0 = OC1A ... 5 = OC3C); slots are 0..SLOTS_USED-1. Slot k
    of a channel carries the pulse of the servo on that channel's demultiplexer output k.

    Raises:
        ValueError: not one pair per servo, a channel or slot out of range, or a pair used twice.
    """

    assignments: tuple[tuple[int, int], ...]

    def __post_init__(self) -> None:
        pairs = tuple((int(channel), int(slot)) for channel, slot in self.assignments)
        object.__setattr__(self, "assignments", pairs)
        if len(pairs) != len(SERVO_NAMES):
            raise ValueError(
                f"assignments needs one (channel, slot) per servo: {len(SERVO_NAMES)} entries in "
                f"the order {SERVO_NAMES}, got {len(pairs)}"
            )
        seen: dict[tuple[int, int], str] = {}
        for name, (channel, slot) in zip(SERVO_NAMES, pairs, strict=True):
            if not 0 <= channel < len(CHANNELS):
                raise ValueError(
                    f"{name}: channel must be 0..{len(CHANNELS) - 1} ({', '.join(CHANNELS)}), "
                    f"got {channel}"
                )
            if not 0 <= slot < SLOTS_USED:
                raise ValueError(f"{name}: slot must be 0..{SLOTS_USED - 1}, got {slot}")
            if (channel, slot) in seen:
                raise ValueError(
                    f"{seen[channel, slot]} and {name} are both on {CHANNELS[channel]} slot "
                    f"{slot}; each (channel, slot) drives one servo"
                )
            seen[channel, slot] = name

    @classmethod
    def default(cls) -> ChannelMap:
        """One channel per leg for the first five joints, one more channel per ankle roll.

        OC1A slots 0–4: left hip yaw .. left ankle pitch; OC1B slots 0–4: the same, right leg;
        OC1C slot 0: l_ankle_roll; OC3A slot 0: r_ankle_roll.
        """
        left = [(0, slot) for slot in range(5)] + [(2, 0)]
        right = [(1, slot) for slot in range(5)] + [(3, 0)]
        return cls(assignments=tuple(left + right))

    @cached_property
    def channel_index(self) -> NDArray[np.intp]:
        """Channel of each servo, shape (12,), read-only."""
        return _read_only([channel for channel, _ in self.assignments])

    @cached_property
    def slot_index(self) -> NDArray[np.intp]:
        """Slot of each servo, shape (12,), read-only."""
        return _read_only([slot for _, slot in self.assignments])

    def servo_at(self, channel: int, slot: int) -> int | None:
        """Index (into SERVO_NAMES) of the servo on (channel, slot), or None if nothing is there."""
        for servo, pair in enumerate(self.assignments):
            if pair == (channel, slot):
                return servo
        return None


@dataclass(frozen=True)
class TdmConfig:
    """The TDM-PWM set-up: channel map and select-line timing.

    Three select lines from an I/O port, shared by all six demultiplexers, hold the index of the
    slot being routed (S0 = least significant bit). The firmware moves them to the next slot's value
    at `select_change_ticks` into each slot: after the longest servo pulse (2.4 ms = 4800 ticks) has
    ended and before the next slot starts (5000 ticks); the default 4900 ticks (2.45 ms) sits in the
    middle of that 100 µs guard. If a line is still high when the select lines change, the
    demultiplexer cuts the pulse there and routes the rest of it to the next output: a guard
    violation (`guard_violations`).

    Attributes:
        channel_map: which (channel, slot) carries which servo.
        select_change_ticks: tick within each slot (0.5 µs ticks from the slot start) at which the
            select lines switch to the next slot's value; must be in (0, SLOT_TICKS).

    Raises:
        ValueError: if `select_change_ticks` is no integer or outside the slot.
    """

    channel_map: ChannelMap = field(default_factory=ChannelMap.default)
    select_change_ticks: int = DEFAULT_SELECT_CHANGE_TICKS

    def __post_init__(self) -> None:
        ticks = self.select_change_ticks
        if isinstance(ticks, bool) or not isinstance(ticks, (int, np.integer)):
            raise ValueError(f"select_change_ticks must be an integer tick count, got {ticks!r}")
        if not 0 < ticks < SLOT_TICKS:
            raise ValueError(
                f"select_change_ticks must be in 1..{SLOT_TICKS - 1} (inside the slot), got {ticks}"
            )
        object.__setattr__(self, "select_change_ticks", int(ticks))


def _read_only(values: list[int]) -> NDArray[np.intp]:
    array = np.array(values, dtype=np.intp)
    array.setflags(write=False)
    return array


def check_ocr(ocr: ArrayLike) -> NDArray[np.int64]:
    """Validate OCR frames: integers of shape (..., 6, 8), each -1 (idle) or 0..OCR_MAX.

    Returns the frames as int64; ValueError on a wrong shape, a non-integer dtype or a bad value.
    """
    array = np.asarray(ocr)
    if array.ndim < 2 or array.shape[-2:] != (len(CHANNELS), SLOTS_PER_FRAME):
        raise ValueError(
            f"ocr must have shape (..., {len(CHANNELS)}, {SLOTS_PER_FRAME}) (channel, slot), "
            f"got {array.shape}"
        )
    if not np.issubdtype(array.dtype, np.integer):
        raise ValueError(f"ocr must be integer timer ticks, got dtype {array.dtype}")
    if np.any((array < OCR_IDLE) | (array > OCR_MAX)):
        raise ValueError(f"ocr values must be {OCR_IDLE} (idle) or 0..{OCR_MAX}")
    return array.astype(np.int64)


def frame_ocr(pulse_us: ArrayLike, config: TdmConfig) -> NDArray[np.int32]:
    """Servo pulse widths -> the OCR value of every (channel, slot). Vectorised.

    Args:
        pulse_us: shape (..., 12), in SERVO_NAMES order.
        config: the channel map decides where each pulse goes.

    Returns:
        int32 array (..., 6, 8); slots that carry no servo are -1 (idle, line low).
    """
    pulse = np.asarray(pulse_us, dtype=np.float64)
    if pulse.ndim == 0 or pulse.shape[-1] != len(SERVO_NAMES):
        raise ValueError(
            f"pulse_us must have shape (..., {len(SERVO_NAMES)}) in SERVO_NAMES order, "
            f"got {pulse.shape}"
        )
    return servo_frame_ocr(pulse_us_to_ocr(pulse), config)


def servo_frame_ocr(servo_ocr: NDArray[np.integer], config: TdmConfig) -> NDArray[np.int32]:
    """Each servo's OCR (..., 12), as `pulse_us_to_ocr` gives it, placed in its (channel, slot)
    of a frame (..., 6, 8); idle slots -1."""
    ocr = np.full((*servo_ocr.shape[:-1], len(CHANNELS), SLOTS_PER_FRAME), OCR_IDLE, np.int32)
    cmap = config.channel_map
    ocr[..., cmap.channel_index, cmap.slot_index] = servo_ocr
    return ocr


def falling_edge_ticks(ocr: ArrayLike, config: TdmConfig) -> NDArray[np.int64]:
    """Tick from frame start at which each servo's demultiplexed pulse falls. Vectorised.

    fall = slot * SLOT_TICKS + min(OCR + 1, select_change_ticks): a pulse still high when the select
    lines switch is cut there. This is when the servo has received its new set-point.

    Args:
        ocr: OCR frames (..., 6, 8), checked as by `check_ocr` (ValueError).
        config: channel map and select-change tick.

    Returns:
        int64 array (..., 12); -1 for a servo whose slot is idle.
    """
    frames = check_ocr(ocr)
    cmap = config.channel_map
    servo_ocr = frames[..., cmap.channel_index, cmap.slot_index]
    fall = servo_falling_edge_ticks(servo_ocr, config)
    return np.where(servo_ocr == OCR_IDLE, -1, fall)


def servo_falling_edge_ticks(
    servo_ocr: NDArray[np.integer], config: TdmConfig
) -> NDArray[np.int64]:
    """`falling_edge_ticks` from each servo's OCR (..., 12) of 0..OCR_MAX (`pulse_us_to_ocr`
    gives no idle value), without building or checking the frame."""
    cmap = config.channel_map
    return cmap.slot_index * SLOT_TICKS + np.minimum(
        servo_ocr.astype(np.int64) + 1, config.select_change_ticks
    )


def guard_violations(ocr: ArrayLike, config: TdmConfig) -> NDArray[np.bool_]:
    """True where a line is still high when the select lines switch (OCR + 1 > change). Vectorised.

    Args:
        ocr: OCR frames (..., 6, 8), checked as by `check_ocr` (ValueError).
        config: its `select_change_ticks` is the switch tick.

    Returns:
        bool array (..., 6, 8) per channel and slot.
    """
    return check_ocr(ocr) + 1 > config.select_change_ticks


def servo_guard_violations(servo_ocr: NDArray[np.integer], config: TdmConfig) -> NDArray[np.bool_]:
    """`guard_violations` of the frame `servo_frame_ocr` makes of `servo_ocr` (..., 12), from
    the servos' values alone (an idle slot never violates the guard)."""
    guard = np.zeros((*servo_ocr.shape[:-1], len(CHANNELS), SLOTS_PER_FRAME), dtype=bool)
    cmap = config.channel_map
    guard[..., cmap.channel_index, cmap.slot_index] = servo_ocr + 1 > config.select_change_ticks
    return guard


def select_value(tick: ArrayLike, config: TdmConfig) -> NDArray[np.int64]:
    """Value on the select lines (0..7) at `tick` ticks from frame start. Vectorised.

    In slot k the value is k until `select_change_ticks`, then k + 1 (wrapping 7 -> 0), so at the
    frame start it is 0, set during slot 7 of the previous frame.
    """
    ticks = np.asarray(tick, dtype=np.int64)
    slot, in_slot = np.divmod(ticks, SLOT_TICKS)
    return (slot + (in_slot >= config.select_change_ticks)) % SLOTS_PER_FRAME
