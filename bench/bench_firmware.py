"""Benchmark: CPU cycles the ArtRo firmware spends per 20 ms frame, on simavr's ATmega128.

For the `paper` and `tuned` presets and a few motion vectors, runs the real firmware (avr-gcc -Os)
for one gait cycle and counts the cycles per frame in which the CPU was not asleep: the gait
(eqs 2-45), the servo model and TDM table for the next frame, the Timer2 ticks and guards with
their wait for the select tick, and the UART. Prints the worst and mean frame against the budget
(goal <= 80 000 cycles = 25 % of the 320 000-cycle frame), the flash and SRAM use (avr-size), and
how fast the emulator runs (emulated time / wall time; the firmware drive needs > 1).

    python bench/bench_firmware.py [--cycles 1.0] [--json PATH]

Writes the figures (per preset and motion: worst and mean cycles per frame; the ramp; flash, SRAM,
the emulator's speed) to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import results

from app.assets import builtin_presets_dir
from app.firmware.build import build_firmware
from app.firmware.emulator import FRAME_CYCLES, Mcu

BUDGET_CYCLES = 80_000
MOTIONS = {
    "forward": {"a_p": 0.07},
    "sideways": {"a_r": 0.1},
    "turn": {"a_y": 0.2},
    "curve": {"a_p": 0.07, "ca": 0.1},
}


def frame_cycles(doc: dict, gait_cycles: float) -> tuple[np.ndarray, float]:
    """Busy cycles of each frame over `gait_cycles` cycles (frame 0, with start-up, excluded),
    and the emulator's speed over them (emulated seconds per wall second)."""
    n = int(gait_cycles / (doc["gait"]["clock"]["freq_hz"] * 0.02)) + 2
    with Mcu(build_firmware(doc).elf) as mcu:
        busy = []
        start = time.perf_counter()
        for k in range(1, n + 1):
            mcu.run_to_frame(k)
            busy.append(mcu.busy_cycles)
        speed = n * 0.02 / (time.perf_counter() - start)
    return np.diff(busy), speed


def ramp_cycles(doc: dict) -> np.ndarray:
    """Busy cycles of each frame while a whole set sent over the UART (SET_PARAMS: a_p 0.07,
    a_y 0.2, CA 0.1 from standing) is received and its motion ramped in (`ramp.c`)."""
    from app.firmware.pulses import FirmwarePulses

    standing = {**doc, "motion": {"a_r": 0.0, "a_p": 0.0, "a_y": 0.0, "ca": 0.0}}
    drive = FirmwarePulses(standing)
    try:
        for _ in range(3):
            drive.next_frame()
        drive.send_parameters({**doc, "motion": {"a_r": 0.0, "a_p": 0.07, "a_y": 0.2, "ca": 0.1}})
        return np.array([drive.next_frame().busy_cycles for _ in range(90)])
    finally:
        drive.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=float, default=1.0, help="gait cycles per case")
    args = results.parse_args(parser)
    worst_all, worst_uart, speeds = 0, 0, []
    cases: list[dict] = []
    for name in ("paper", "tuned"):
        base = json.loads((builtin_presets_dir() / f"{name}.json").read_text())
        for label, motion in MOTIONS.items():
            doc = {**base, "motion": {**base["motion"], **motion}}
            cycles, speed = frame_cycles(doc, args.cycles)
            speeds.append(speed)
            worst_all = max(worst_all, int(cycles.max()))
            cases.append(
                {"preset": name, "motion": label, "worst_cycles": cycles.max(),
                 "mean_cycles": cycles.mean(), "frames": len(cycles), "emulator_x_real_time": speed}
            )  # fmt: skip
            print(
                f"{name:6s} {label:9s} cycles/frame: worst {cycles.max():6d}  "
                f"mean {cycles.mean():8.0f}  ({100 * cycles.max() / FRAME_CYCLES:4.1f} % of the "
                f"frame, {len(cycles)} frames)"
            )
        cycles = ramp_cycles(base)
        worst_uart = max(worst_uart, int(cycles.max()))
        cases.append(
            {"preset": name, "motion": "ramp", "worst_cycles": cycles.max(),
             "mean_cycles": cycles.mean(), "frames": len(cycles)}
        )  # fmt: skip
        print(
            f"{name:6s} {'ramp':9s} cycles/frame: worst {cycles.max():6d}  "
            f"mean {cycles.mean():8.0f}  ({100 * cycles.max() / FRAME_CYCLES:4.1f} % of the "
            f"frame, {len(cycles)} frames: a set received over the UART, its motion ramped in)"
        )
    build = build_firmware(json.loads((builtin_presets_dir() / "paper.json").read_text()))
    verdict = "within" if worst_all <= BUDGET_CYCLES else "OVER"
    print(
        f"worst frame {worst_all} cycles walking (gait and TDM): {verdict} the "
        f"{BUDGET_CYCLES}-cycle budget; {worst_uart} in frames that receive and check a whole "
        f"set over the UART ({100 * worst_uart / FRAME_CYCLES:.0f} % of the frame)"
    )
    flash_pct = 100 * build.flash_bytes / build.flash_size
    sram_pct = 100 * build.sram_bytes / build.sram_size
    print(
        f"flash {build.flash_bytes} B of {build.flash_size} ({flash_pct:.1f} %), "
        f"SRAM {build.sram_bytes} B of {build.sram_size} ({sram_pct:.1f} %) without the stack"
    )
    print(f"emulator speed {min(speeds):.1f}-{max(speeds):.1f}x real time (simavr, this machine)")
    figures = {
        "frame_cycles": FRAME_CYCLES,
        "budget_cycles": BUDGET_CYCLES,
        "cases": cases,
        "worst_walking_cycles": worst_all,
        "worst_uart_cycles": worst_uart,
        "flash_bytes": build.flash_bytes,
        "flash_size_bytes": build.flash_size,
        "sram_bytes": build.sram_bytes,
        "sram_size_bytes": build.sram_size,
        "emulator_x_real_time_min": min(speeds),
        "emulator_x_real_time_max": max(speeds),
    }
    headline = {
        f"worst frame walking (cycles; budget {BUDGET_CYCLES})": worst_all,
        "worst frame receiving a set over the UART (cycles)": worst_uart,
        "flash (%)": flash_pct,
        "SRAM without the stack (%)": sram_pct,
        "emulator, slowest case (x real time)": min(speeds),
    }
    results.write("bench_firmware", args, figures, headline)


if __name__ == "__main__":
    main()
