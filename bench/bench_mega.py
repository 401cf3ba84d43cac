"""Benchmark: the firmware on an Arduino Mega 2560 + PCA9685, emulated closed loop (docs/BOARDS.md).

Walks the simulated ArtRo with the Mega build of its default set (laws on) for --seconds of
frames, through the emulated PCA9685 and the IMU on the same I2C bus
(`app.firmware.mega.run_mega_closed_loop`), and reports: the largest difference between a
PCA9685 pulse (from its output edges in simulated time) and the model's pulse, against one step
(4.88 us); the pulses off the model's step; frames a period repeated; the worst frame's time on
the 400 kHz bus and its margin in the 20 ms frame; the CPU's busiest frame; flash and SRAM.

    python bench/bench_mega.py [--seconds 60] [--json PATH]
"""

from __future__ import annotations

import argparse
import time

import results

from app.firmware.mega import STEP_S, run_mega_closed_loop
from app.params.presets import builtin_presets
from app.robots.model import RobotModel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="walk length (default 60)")
    args = results.parse_args(parser)
    robot = RobotModel.load()
    doc = builtin_presets()[robot.description.default_preset].to_dict()
    frames = round(args.seconds / 0.02)
    start = time.perf_counter()
    run = run_mega_closed_loop(doc, frames, robot)
    wall = time.perf_counter() - start
    summary = run.summary()
    print(
        f"{frames} frames ({args.seconds:g} s): {run.pulses} pulses in {run.periods} PCA9685 "
        f"periods, the largest off the model by {summary['pulse_error_max_us']:.2f} us (one step "
        f"{STEP_S * 1e6:.2f} us), {run.step_mismatches} off the model's step, "
        f"{run.output_mismatches} off the firmware's own; frames repeated "
        f"{run.repeated_frames}; worst frame's I2C {summary['i2c_bus_ms_per_frame_max']:.2f} ms "
        f"of 20 ({100 * summary['i2c_margin']:.1f} % margin); CPU busiest frame "
        f"{100 * run.busy_max:.1f} %; overrun {run.overrun}; flash {run.flash_bytes} B of "
        f"{run.flash_size}, SRAM {run.sram_bytes} B of {run.sram_size}; failures "
        f"{run.failures() or 'none'}; {frames * 0.02 / wall:.1f}x real time"
    )
    figures = {**summary, "seconds": args.seconds, "emulated_x_real_time": frames * 0.02 / wall}
    headline = {
        "largest pulse error (us)": summary["pulse_error_max_us"],
        "one PCA9685 step (us)": STEP_S * 1e6,
        "pulses off the model's step": run.step_mismatches,
        "pulses off the firmware's own step": run.output_mismatches,
        "worst frame on the I2C bus (ms)": summary["i2c_bus_ms_per_frame_max"],
        "I2C margin in the frame (%)": 100 * summary["i2c_margin"],
        "CPU busiest frame (%)": 100 * run.busy_max,
        "flash (%)": 100 * run.flash_bytes / run.flash_size,
        "SRAM without the stack (%)": 100 * run.sram_bytes / run.sram_size,
    }
    results.write("bench_mega", args, figures, headline)


if __name__ == "__main__":
    main()
