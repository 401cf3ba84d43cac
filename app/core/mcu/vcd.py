"""Emulated drive-line traces as a Value Change Dump (IEEE 1364 VCD), for GTKWave or sigrok.

Signals `OC1A OC1B OC1C OC3A OC3B OC3C SEL0 SEL1 SEL2`, one bit each; time in picoseconds from
the start of frame 0 (one CPU cycle = 62.5 ns at 16 MHz). docs/DESIGN.md §5.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.core.mcu.emulator import Edges

VCD_NAMES = ("OC1A", "OC1B", "OC1C", "OC3A", "OC3B", "OC3C", "SEL0", "SEL1", "SEL2")
PS_PER_CYCLE = 62_500  # 16 MHz


def write_vcd(path: Path | str, edges: Edges, t0_cycle: int, *, comment: str = "") -> None:
    """Write the edges from frame 0 on (earlier ones set the initial values)."""
    codes = [chr(ord("!") + i) for i in range(len(VCD_NAMES))]
    lines = [
        "$date artro firmware emulation $end",
        "$version artro-gait-studio (simavr atmega128) $end",
    ]
    if comment:
        lines.append(f"$comment {comment} $end")
    lines += ["$timescale 1ps $end", "$scope module artro $end"]
    lines += [f"$var wire 1 {c} {n} $end" for c, n in zip(codes, VCD_NAMES, strict=True)]
    lines += ["$upscope $end", "$enddefinitions $end"]
    time = np.maximum(edges.cycle.astype(np.int64) - t0_cycle, 0) * PS_PER_CYCLE
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
    Path(path).write_text("\n".join(lines) + "\n", encoding="ascii")
