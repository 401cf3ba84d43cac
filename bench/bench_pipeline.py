"""Benchmark: raw MuJoCo stepping vs the full frame pipeline on the built-in ArtRo model.

Prints, from one run:
  - raw mj_step throughput, two ways: (a) the same walk, the same set-points at the same physics
    steps, replayed as plain ctrl writes and one mj_step per step from a precomputed table;
    (b) stricter: MuJoCo's own C loop, mj_step(nstep=20) per frame with the frame's set-points
    written once at its start (slightly different motion, no Python between steps);
  - the full pipeline (`FrameLoop.step_frame`: gait, servo, timer, TDM-PWM, set-points switched at
    each pulse's falling edge) on the same model and motion;
  - their ratio (goal >= 0.9);
  - the cost of gait + hardware model per frame in us (goal <= 30), as the loop pays it (evaluated
    in blocks of 50 frames) and for a single frame evaluated alone.

    python bench/bench_pipeline.py [--seconds 20] [--repeats 5] [--json PATH]

Writes the figures to bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import numpy as np
import results

from app.sim.frame_loop import FrameLoop
from app.sim.planning import plan_frames
from gait import GaitParams, Motion

MOTION = Motion(a_p=0.07)


def best_of(repeats: int, fn) -> float:
    return min(fn() for _ in range(repeats))


def raw_steps_per_s(frames: int, plan) -> float:
    """Replay the plan's set-points with bare MuJoCo calls: one mj_step per physics step."""
    sim = FrameLoop(motion=MOTION)
    model, data, act = sim.model, sim.data, sim.robot.actuator_ids
    steps = sim.steps_per_frame
    # ctrl for each physics step of each frame, built before the clock starts
    ctrl = np.empty((frames, steps, len(act)))
    previous = data.ctrl[act].copy()
    for k in range(frames):
        switched = np.arange(steps)[:, None] >= plan.substep[k][None, :]
        ctrl[k] = np.where(switched, plan.setpoint[k], previous)
        previous = plan.setpoint[k]
    full = np.tile(data.ctrl, (frames, steps, 1))
    full[..., act] = ctrl
    start = time.perf_counter()
    for k in range(frames):
        for j in range(steps):
            data.ctrl[:] = full[k, j]
            mujoco.mj_step(model, data)
    return frames * steps / (time.perf_counter() - start)


def c_loop_steps_per_s(frames: int, plan) -> float:
    sim = FrameLoop(motion=MOTION)
    model, data, act = sim.model, sim.data, sim.robot.actuator_ids
    steps = sim.steps_per_frame
    start = time.perf_counter()
    for k in range(frames):
        data.ctrl[act] = plan.setpoint[k]
        mujoco.mj_step(model, data, steps)
    return frames * steps / (time.perf_counter() - start)


def pipeline_steps_per_s(frames: int) -> float:
    sim = FrameLoop(motion=MOTION)
    start = time.perf_counter()
    for _ in range(frames):
        sim.step_frame()
    return frames * sim.steps_per_frame / (time.perf_counter() - start)


def gait_hardware_us_per_frame(block: int, calls: int) -> float:
    sim = FrameLoop(motion=MOTION)
    params, hw = GaitParams(), sim.hardware
    start = time.perf_counter()
    for i in range(calls):
        plan_frames(params, MOTION, hw, 0.01 * i, block, sim.steps_per_frame, sim.timestep_s)
    return (time.perf_counter() - start) / (calls * block) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per trial")
    parser.add_argument("--repeats", type=int, default=5)
    args = results.parse_args(parser)
    frames = round(args.seconds / 0.02)

    reference = FrameLoop(motion=MOTION)
    plan = plan_frames(GaitParams(), MOTION, reference.hardware, reference.phase, frames, 20, 0.001)
    raw, c_loop, pipe = [], [], []
    for _ in range(args.repeats):  # interleaved, so machine load affects all alike
        raw.append(raw_steps_per_s(frames, plan))
        c_loop.append(c_loop_steps_per_s(frames, plan))
        pipe.append(pipeline_steps_per_s(frames))
    raw_med, c_med, pipe_med = (statistics.median(x) for x in (raw, c_loop, pipe))
    block_us = best_of(args.repeats, lambda: gait_hardware_us_per_frame(50, 40))
    single_us = best_of(args.repeats, lambda: gait_hardware_us_per_frame(1, 400))

    print(f"model: artro (generated), timestep {reference.timestep_s * 1e3:g} ms, 20 steps/frame")
    print(
        f"motion: a_p={MOTION.a_p}, {args.seconds:g} s simulated per trial, {args.repeats} trials"
    )
    for label, value in (
        ("raw, step replay", raw_med),
        ("raw, C loop", c_med),
        ("pipeline", pipe_med),
    ):
        print(f"{label:18}: {value:10.0f} steps/s  (median; {1e6 / value:.1f} us/step)")
    print(f"ratio vs replay   : {pipe_med / raw_med:10.3f}       (goal >= 0.9)")
    print(f"ratio vs C loop   : {pipe_med / c_med:10.3f}")
    print(f"real-time factor  : {pipe_med / 1000:10.1f} x      (pipeline, 1 ms steps)")
    print(f"gait + hardware   : {block_us:10.1f} us/frame (blocks of 50 frames, as the loop runs)")
    print(f"                    {single_us:10.1f} us/frame (one frame at a time; goal <= 30)")
    figures = {
        "timestep_ms": reference.timestep_s * 1e3,
        "a_p": MOTION.a_p,
        "raw_step_replay_steps_per_s": raw_med,
        "raw_c_loop_steps_per_s": c_med,
        "pipeline_steps_per_s": pipe_med,
        "pipeline_of_replay": pipe_med / raw_med,
        "pipeline_of_c_loop": pipe_med / c_med,
        "real_time_factor": pipe_med * reference.timestep_s,
        "gait_hardware_us_per_frame_blocks_of_50": block_us,
        "gait_hardware_us_per_frame_alone": single_us,
        "goals": {"pipeline_of_replay": 0.9, "gait_hardware_us_per_frame_alone": 30.0},
        "trials": {"raw_step_replay": raw, "raw_c_loop": c_loop, "pipeline": pipe},
    }
    headline = {
        "pipeline, of raw step replay (goal ≥ 0.9)": pipe_med / raw_med,
        "pipeline (steps/s)": pipe_med,
        "gait + hardware, one frame alone (µs; goal ≤ 30)": single_us,
    }
    results.write("bench_pipeline", args, figures, headline)


if __name__ == "__main__":
    main()
