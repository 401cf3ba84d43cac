"""Signals on the wires of ArtRo's TDM-PWM drive and their demultiplexing, seed 000 §3.B.

`frame_edges` gives one frame's edges on the nine wires (Figure 7b); `demultiplex` rebuilds each
servo's pulse from them alone, as the actuator driver circuit does (docs/DESIGN.md §5).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hardware.tdm import (
    CHANNELS,
    SELECT_LINES,
    SERVO_NAMES,
    TdmConfig,
    check_ocr,
)
from hardware.timer import FRAME_TICKS, OCR_IDLE, SLOT_TICKS, SLOTS_PER_FRAME, TICK_US

Edge = tuple[int, int]  # (tick from frame start, level after the edge: 0 or 1)


@dataclass(frozen=True)
class FrameEdges:
    """Logic levels of the nine output lines over one frame [0, FRAME_TICKS).

    Attributes:
        names: the lines, CHANNELS then SELECT_LINES: ("OC1A", ..., "OC3C", "S0", "S1", "S2").
        initial: level (0/1) of each line at tick 0, after anything that happens at tick 0 (a slot-0
            pulse is already high; the select lines hold 0, set during slot 7 of the frame before).
        edges: per line, its transitions as (tick, new level), ticks strictly increasing in
            (0, FRAME_TICKS), levels alternating. A scope draws line i as `initial[i]` from tick 0,
            then steps to each new level at its tick.
    """

    names: tuple[str, ...]
    initial: tuple[int, ...]
    edges: tuple[tuple[Edge, ...], ...]

    def __post_init__(self) -> None:
        if self.names != CHANNELS + SELECT_LINES:
            raise ValueError(f"names must be {CHANNELS + SELECT_LINES}, got {self.names}")
        if len(self.initial) != len(self.names) or len(self.edges) != len(self.names):
            raise ValueError(f"initial and edges need one entry per line ({len(self.names)})")
        for name, level, line in zip(self.names, self.initial, self.edges, strict=True):
            ticks = [tick for tick, _ in line]
            levels = [level] + [new for _, new in line]
            if any(not 0 < tick < FRAME_TICKS for tick in ticks) or ticks != sorted(set(ticks)):
                raise ValueError(f"{name}: edge ticks must increase strictly within 1..39999")
            if any(new not in (0, 1) for new in levels) or any(a == b for a, b in pairwise(levels)):
                raise ValueError(f"{name}: levels must be 0 or 1 and change at every edge")

    def line(self, name: str) -> tuple[int, tuple[Edge, ...]]:
        """(initial level, edges) of the line called `name`, e.g. "OC1A" or "S2"."""
        index = self.names.index(name)
        return self.initial[index], self.edges[index]


def _pulse_line(ocr_row: NDArray[np.int64]) -> tuple[int, tuple[Edge, ...]]:
    """One TDM line: high from each active slot's start for OCR + 1 ticks."""
    edges: list[Edge] = []
    for slot, ocr in enumerate(ocr_row.tolist()):
        if ocr == OCR_IDLE:
            continue
        start = slot * SLOT_TICKS
        if start > 0:
            edges.append((start, 1))
        edges.append((start + ocr + 1, 0))
    return int(ocr_row[0] != OCR_IDLE), tuple(edges)


def _select_line(bit: int, config: TdmConfig) -> tuple[int, tuple[Edge, ...]]:
    """Select bit `bit`: the slot index k + 1 (mod 8) is written at k * SLOT + select change."""
    edges: list[Edge] = []
    level = 0
    for slot in range(SLOTS_PER_FRAME):
        new = (((slot + 1) % SLOTS_PER_FRAME) >> bit) & 1
        if new != level:
            edges.append((slot * SLOT_TICKS + config.select_change_ticks, new))
            level = new
    return 0, tuple(edges)


def frame_edges(ocr: ArrayLike, config: TdmConfig) -> FrameEdges:
    """Edges of the six TDM lines and three select lines for ONE frame of OCR values (6, 8).

    What an oscilloscope would show on the nine wires (Figure 7b): each TDM line high from an
    active slot's start for OCR + 1 ticks, the select lines changing at `select_change_ticks`.
    ValueError if `ocr` is not one valid frame (see `check_ocr`).
    """
    frame = check_ocr(ocr)
    if frame.shape != (len(CHANNELS), SLOTS_PER_FRAME):
        raise ValueError(f"frame_edges takes one frame of shape (6, 8), got {frame.shape}")
    lines = [_pulse_line(row) for row in frame]
    lines += [_select_line(bit, config) for bit in range(len(SELECT_LINES))]
    return FrameEdges(
        names=CHANNELS + SELECT_LINES,
        initial=tuple(initial for initial, _ in lines),
        edges=tuple(edges for _, edges in lines),
    )


class Pulse(NamedTuple):
    """One high pulse on a demultiplexer output, in ticks from frame start."""

    rise_tick: int
    fall_tick: int
    cut: bool  # ended because the select lines moved on while the TDM line was still high


@dataclass(frozen=True, eq=False)
class DemuxResult:
    """What the demultiplexer outputs carried in one frame.

    Attributes:
        pulse_us: per servo (SERVO_NAMES order) the width of the first pulse on its output in µs;
            NaN if it saw none.
        fall_ticks: per servo the falling edge of that pulse (ticks from frame start); -1 if none.
        glitch: per servo, its output saw more than one pulse or a pulse that did not begin at its
            slot start (the remainder of a cut pulse spilling in from the previous slot).
        cut: per servo, its own pulse was cut short by a select change (guard violation).
        outputs: outputs[channel][k] = the pulses on output k of that channel.
        stray: (channel, output) pairs that carried a pulse although no servo is assigned there.
    """

    pulse_us: NDArray[np.float64]
    fall_ticks: NDArray[np.int64]
    glitch: NDArray[np.bool_]
    cut: NDArray[np.bool_]
    outputs: tuple[tuple[tuple[Pulse, ...], ...], ...]
    stray: tuple[tuple[int, int], ...]


def _output_pulses(edges: FrameEdges) -> list[list[list[Pulse]]]:
    """Rebuild every output (TDM line AND select == k) from the edges; measure its pulses."""
    changes = [dict(line) for line in edges.edges]
    ticks = sorted({0}.union(*changes))
    levels = list(edges.initial)
    n_channels = len(CHANNELS)
    pulses: list[list[list[Pulse]]] = [[[] for _ in range(SLOTS_PER_FRAME)] for _ in CHANNELS]
    rising: dict[tuple[int, int], int] = {}  # (channel, output) -> tick it went high
    for tick in ticks:
        for line, line_changes in enumerate(changes):
            levels[line] = line_changes.get(tick, levels[line])
        select = sum(level << bit for bit, level in enumerate(levels[n_channels:]))
        high = {(channel, select) for channel in range(n_channels) if levels[channel]}
        for channel, output in [key for key in rising if key not in high]:
            start = rising.pop((channel, output))
            pulses[channel][output].append(Pulse(start, tick, bool(levels[channel])))
        for key in high - rising.keys():
            rising[key] = tick
    for (channel, output), start in rising.items():  # still high at the frame end
        pulses[channel][output].append(Pulse(start, FRAME_TICKS, False))
    return pulses


def demultiplex(edges: FrameEdges, config: TdmConfig) -> DemuxResult:
    """Decode one frame's edges the way the actuator driver circuit does (Figure 10b).

    From the edges alone it rebuilds each demultiplexer output (output k of a channel = TDM line
    AND select == k) and measures every pulse, as the oscilloscope of Figure 8 does. For in-range
    pulses the measured width equals (OCR + 1) * 0.5 µs exactly; a pulse cut by a select change
    (guard violation) and the remainder it spills into the next output are flagged.

    Args:
        edges: one frame, as `frame_edges` gives it.
        config: its channel map says which output feeds which servo.

    Returns:
        `DemuxResult`, per servo in SERVO_NAMES order.
    """
    pulses = _output_pulses(edges)
    n_servos = len(SERVO_NAMES)
    pulse_us = np.full(n_servos, np.nan)
    fall_ticks = np.full(n_servos, -1, dtype=np.int64)
    glitch = np.zeros(n_servos, dtype=bool)
    cut = np.zeros(n_servos, dtype=bool)
    for servo, (channel, slot) in enumerate(config.channel_map.assignments):
        seen = pulses[channel][slot]
        if not seen:
            continue
        first = seen[0]
        pulse_us[servo] = (first.fall_tick - first.rise_tick) * TICK_US
        fall_ticks[servo] = first.fall_tick
        cut[servo] = any(pulse.cut for pulse in seen)
        glitch[servo] = len(seen) > 1 or first.rise_tick != slot * SLOT_TICKS
    stray = tuple(
        (channel, output)
        for channel, outputs in enumerate(pulses)
        for output, seen in enumerate(outputs)
        if seen and config.channel_map.servo_at(channel, output) is None
    )
    return DemuxResult(
        pulse_us=pulse_us,
        fall_ticks=fall_ticks,
        glitch=glitch,
        cut=cut,
        outputs=tuple(tuple(tuple(seen) for seen in outputs) for outputs in pulses),
        stray=stray,
    )
