"""Output-line traces as a Value Change Dump (IEEE 1364 VCD), for GTKWave, PulseView or sigrok.

Signals `OC1A OC1B OC1C OC3A OC3B OC3C SEL0 SEL1 SEL2`, one bit each; time in 100 ns units from
frame 0's start, each edge at the start of its Timer tick (0.5 µs = 5 units). docs/DESIGN.md §5.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from app.firmware.emulator import CYCLES_PER_TICK, Edges
from hardware import FRAME_TICKS, TICK_US, FrameEdges

VCD_NAMES = ("OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C", "SEL0", "SEL1", "SEL2")
#: The time unit. The Timer's 0.5 µs tick is what the firmware sets and `conformance` compares,
#: but a VCD timescale is 1, 10 or 100 of a unit, so the coarsest that holds a tick is 100 ns: a
#: viewer samples the lines at 10 MHz (200 000 samples a frame: sigrok-cli's pwm decoder reads
#: three frames of a line in 0.04 s). The CPU's cycle (62.5 ns) would need 100 ps, 1000 times the
#: samples (8.6 s for the same three frames; at 1 ps, minutes for two), to show lags of a few
#: cycles that nothing depends on: Timer3 starts a cycle after Timer1 (`timer3_start_lag_cycles`
#: reports it), the select lines are written some cycles into their tick. On the tick grid every
#: pulse is exactly its (OCR + 1) ticks, as `conformance` counts them.
TIMESCALE = "100ns"
UNITS_PER_TICK = round(TICK_US * 1000 / 100)  # 5


def write_vcd(path: Path | str, edges: Edges, t0_cycle: int, *, comment: str = "") -> None:
    """Write the edges from frame 0 (CPU cycle `t0_cycle`) on; earlier ones, and those in frame 0's
    first tick, set the initial values. Time: see TIMESCALE."""
    Path(path).write_text(vcd_text(edges, t0_cycle, comment=comment), encoding="ascii")


def edges_of_frames(frames: list[FrameEdges]) -> Edges:
    """Consecutive frames' edges as one trace, cycle 0 = the first frame's start (a line whose
    level at a frame's start differs from where the frame before left it changes at tick 0)."""
    cycles, lines, levels = [], [], []
    level = list(frames[0].initial) if frames else []
    for k, frame in enumerate(frames):
        start = k * FRAME_TICKS
        for line, (initial, edges) in enumerate(zip(frame.initial, frame.edges, strict=True)):
            if initial != level[line] or k == 0:
                cycles.append(start * CYCLES_PER_TICK)
                lines.append(line)
                levels.append(initial)
            for tick, new in edges:
                cycles.append((start + tick) * CYCLES_PER_TICK)
                lines.append(line)
                levels.append(new)
            level[line] = edges[-1][1] if edges else initial
    order = np.argsort(np.asarray(cycles, np.int64), kind="stable")
    return Edges(
        np.asarray(cycles, np.uint64)[order],
        np.asarray(lines, np.uint8)[order],
        np.asarray(levels, np.uint8)[order],
    )


def vcd_text(edges: Edges, t0_cycle: int, *, comment: str = "") -> str:
    """The VCD file's text (see `write_vcd`)."""
    codes = [chr(ord("!") + i) for i in range(len(VCD_NAMES))]
    lines = [
        f"$date {datetime.now(UTC).isoformat(timespec='seconds')} $end",
        "$version artro-gait-studio $end",
    ]
    if comment:
        lines.append(f"$comment {comment} $end")
    lines += [f"$timescale {TIMESCALE} $end", "$scope module artro $end"]
    lines += [f"$var wire 1 {c} {n} $end" for c, n in zip(codes, VCD_NAMES, strict=True)]
    lines += ["$upscope $end", "$enddefinitions $end"]
    ticks = np.maximum(edges.cycle.astype(np.int64) - t0_cycle, 0) // CYCLES_PER_TICK
    time = ticks * UNITS_PER_TICK  # the tick an edge falls in, as `conformance` counts it
    initial = [0] * len(VCD_NAMES)
    start = int(np.searchsorted(time, 1))  # edges at or before t0 give the initial levels
    for line, level in zip(edges.line[:start].tolist(), edges.level[:start].tolist(), strict=True):
        initial[line] = level
    lines += ["#0", "$dumpvars", *(f"{v}{c}" for v, c in zip(initial, codes, strict=True)), "$end"]
    last = 0
    for t, line, level in zip(
        time[start:].tolist(),
        edges.line[start:].tolist(),
        edges.level[start:].tolist(),
        strict=True,
    ):
        if t != last:
            lines.append(f"#{t}")
            last = t
        lines.append(f"{level}{codes[line]}")
    return "\n".join(lines) + "\n"
