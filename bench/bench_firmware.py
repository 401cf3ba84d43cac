"""Benchmark: the ArtRo firmware's time per 20 ms frame on simavr's ATmega128, by part.

Runs the real firmware (avr-gcc -Os) with its IMU and force sensors attached, driving the
simulated robot closed loop (`app.firmware.closed_loop.run_closed_loop`, sensor errors on), and
counts every frame's CPU cycles by what the main loop was doing (its part marker, control.h):
the sensors' sample decoded, the feedback laws, the plan (ramp, gait eqs 2-45, servos, TDM
table), the UART messages, telemetry; and in interrupts (TDM guard, Timer2, TWI, ADC, UART).
It notes when each next frame's plan was ready: the planning window runs from the guard of slot
3 (tick 19 900) to the latch at the end of slot 7 (tick 39 900); the goal is 20 % of it to spare
in every frame, also in those that receive a whole set (SET_PARAMS, sent at frame 40), with no
overrun. Cases: the laws off and all on, walking forward, turning and with CA.

    python bench/bench_firmware.py [--frames 100] [--json PATH]

Writes the figures (per case: cycles per frame by part, median and worst; when the plan was
ready; the spare; conformance) to bench/results/bench_firmware.json, or --json PATH.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import results

from app.assets import builtin_presets_dir
from app.firmware.build import build_firmware
from app.firmware.closed_loop import PLAN_LATCH_TICK, PLAN_REQUEST_TICK, run_closed_loop
from app.firmware.emulator import FRAME_CYCLES, PROFILE_ISR, PROFILE_SLEEP
from app.worlds.variations import Variation
from hardware.firmware.schema import complete_document

SPARE_GOAL = 0.20  # of the planning window
PARTS = {"other": 0, "sensors": 1, "laws": 2, "plan": 3, "uart": 4, "telemetry": 5,
         "interrupts": PROFILE_ISR}  # fmt: skip
MOTIONS = {
    "forward": {"a_p": 0.05},
    "turn": {"a_p": 0.03, "a_y": 0.1},
    "curve": {"a_p": 0.05, "ca": 0.1},
}
LAWS = ("tilt", "yaw_rate", "damping", "cop")
SENSOR_ERRORS = Variation(
    imu_tilt_bias_deg=1.0, gyro_bias_deg_s=0.5, gyro_noise_deg_s=0.1, imu_delay_ms=10.0,
    fsr_gain=1.15,
)  # fmt: skip
SET_AT_FRAME = 40


def document(motion: dict, laws: bool) -> dict:
    import json

    doc = json.loads((builtin_presets_dir() / "tuned.json").read_text(encoding="utf-8"))
    doc = complete_document({**doc, "motion": {**doc["motion"], **motion}})
    for law in LAWS:
        doc["gait"][law]["enabled"] = laws
    return doc


def measure(motion: dict, laws: bool, frames: int) -> dict:
    doc = document(motion, laws)
    new = document({**motion, "a_p": motion["a_p"] * 0.8}, laws)  # a whole set mid-walk
    start = time.perf_counter()
    run = run_closed_loop(
        doc, frames, variation=SENSOR_ERRORS, changes={SET_AT_FRAME: new}, profile=True
    )
    wall = time.perf_counter() - start
    cycles = np.array(run.part_cycles, dtype=np.int64)[1:]  # frame 0 holds the boot's tail
    ready = np.array(run.plan_ready_ticks)[1:]
    busy = cycles[:, :PROFILE_SLEEP].sum(axis=1)
    window = PLAN_LATCH_TICK - PLAN_REQUEST_TICK
    spare = (PLAN_LATCH_TICK - ready) / window
    receiving = [k - 1 for k in range(SET_AT_FRAME, min(SET_AT_FRAME + 8, frames))]
    c = run.comparison
    return {
        "cycles_per_frame": {
            part: {"median": float(np.median(cycles[:, i])), "worst": int(cycles[:, i].max())}
            for part, i in PARTS.items()
        },
        "busy_median": float(np.median(busy)),
        "busy_worst": int(busy.max()),
        "busy_worst_receiving_set": int(busy[receiving].max()),
        "plan_ready_tick_median": float(np.median(ready)),
        "plan_ready_tick_worst": int(ready.max()),
        "spare_worst": float(spare.min()),
        "spare_worst_receiving_set": float(spare[receiving].min()),
        "overrun": run.overrun,
        "set_reached_frames": run.switch_frames,
        "pulses": c.pulses,
        "pulses_exact": c.exact,
        "pulses_one_tick": c.one_tick,
        "mismatches": len(c.mismatches),
        "law_error_max": run.law_error_max,
        "twi_transactions_per_frame": float(np.mean(run.twi_transactions)),
        "adc_conversions_per_frame": float(np.mean(run.adc_conversions)),
        "frames": frames,
        "emulated_x_real_time": frames * 0.02 / wall,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100, help="frames per case (> 48)")
    args = results.parse_args(parser)
    if args.frames <= SET_AT_FRAME + 8:
        parser.error(f"--frames must be more than {SET_AT_FRAME + 8} (a set is sent at frame 40)")
    cases = []
    for laws in (False, True):
        for label, motion in MOTIONS.items():
            case = {"laws": laws, "motion": label, **measure(motion, laws, args.frames)}
            cases.append(case)
            parts = case["cycles_per_frame"]
            print(
                f"laws {'on ' if laws else 'off'} {label:8s} cycles/frame median: "
                + ", ".join(f"{p} {v['median']:.0f}" for p, v in parts.items())
                + f"; busy worst {case['busy_worst']} ({case['busy_worst_receiving_set']} "
                f"receiving a set); plan ready by tick {case['plan_ready_tick_worst']}: "
                f"{100 * case['spare_worst']:.0f} % of the window to spare "
                f"({100 * case['spare_worst_receiving_set']:.0f} % receiving a set); overrun "
                f"{case['overrun']}; {case['pulses_exact']}/{case['pulses']} pulses exact, "
                f"laws within {case['law_error_max']:.1e}"
            )
    build = build_firmware(document(MOTIONS["forward"], True))
    spare = min(c["spare_worst"] for c in cases)
    verdict = "meets" if spare >= SPARE_GOAL and not any(c["overrun"] for c in cases) else "MISSES"
    print(
        f"worst spare {100 * spare:.0f} % of the {PLAN_LATCH_TICK - PLAN_REQUEST_TICK}-tick "
        f"planning window: {verdict} the {100 * SPARE_GOAL:.0f} % goal; flash "
        f"{build.flash_bytes} B of {build.flash_size}, SRAM {build.sram_bytes} B of "
        f"{build.sram_size} without the stack"
    )
    figures = {
        "frame_cycles": FRAME_CYCLES,
        "plan_window_ticks": [PLAN_REQUEST_TICK, PLAN_LATCH_TICK],
        "spare_goal": SPARE_GOAL,
        "cases": cases,
        "spare_worst": spare,
        "flash_bytes": build.flash_bytes,
        "flash_size_bytes": build.flash_size,
        "sram_bytes": build.sram_bytes,
        "sram_size_bytes": build.sram_size,
    }
    laws_on = [c for c in cases if c["laws"]]
    headline = {
        "worst spare of the planning window (%)": 100 * spare,
        "laws on: busy cycles per frame, median": float(
            np.median([c["busy_median"] for c in laws_on])
        ),
        "laws on: worst busy frame (cycles)": max(c["busy_worst"] for c in laws_on),
        "laws: cycles per frame, median": float(
            np.median([c["cycles_per_frame"]["laws"]["median"] for c in laws_on])
        ),
        "flash (%)": 100 * build.flash_bytes / build.flash_size,
        "SRAM without the stack (%)": 100 * build.sram_bytes / build.sram_size,
    }
    results.write("bench_firmware", args, figures, headline)


if __name__ == "__main__":
    main()
