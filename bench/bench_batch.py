"""Benchmark: the batch evaluator's throughput against raw mj_step, nominal and with variations.

Prints, for the same 10 s walks (a_p = 0.07, CA spread over -0.1..0.1):
  - raw mj_step, one thread: the walk's set-points replayed with MuJoCo's own C loop,
    mj_step(nstep=20) per frame with the frame's set-points written at its start (as the C-loop
    variant of bench_pipeline.py), no Python between steps;
  - BatchEvaluator.evaluate with N threads (N = os.cpu_count()), end to end (planning the gait
    + hardware for every step, the rollout, measuring) and the rollout alone;
  - ProcessEvaluator.evaluate with N worker processes of one MuJoCo thread each, end to end
    (does the loss of N MuJoCo threads in one process go away in N processes?);
  - the machine's ceiling: N separate processes each running the raw C loop at the same time
    (no Python threads, no shared MuJoCo data), in total;
  - the goals: end to end >= 0.95 of that ceiling, and >= 0.9 of raw steps per CPU second;
  - all of it once for nominal runs and once with every run on its own sampled variation
    (a list of models in one rollout call, and the set-point path), and the seconds per stage
    (planning, rollout, measuring; planning and measuring overlap the rollout).
Steps per CPU second stay meaningful when other processes compete for the cores (the
wall-clock ratio then only says how many were free).

    python bench/bench_batch.py [--seconds 10] [--runs 16] [--repeats 3]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import time

import mujoco
import numpy as np

from app.core.batch import BatchEvaluator, Job
from app.core.frame_loop import FrameLoop, plan_frames
from app.core.processes import ProcessEvaluator
from app.core.variations import NOMINAL, VariationRanges, sample
from gait import GaitParams, Motion

CEILING_GOAL = 0.95  # end to end, of N raw processes at once
CPU_GOAL = 0.9  # steps per CPU second, of raw's


def cpu_times() -> list[int] | None:
    """The machine's CPU time counters (/proc/stat: user nice system idle iowait irq softirq
    steal ...), or None where there is no /proc."""
    try:
        with open("/proc/stat") as stat:
            return [int(x) for x in stat.readline().split()[1:]]
    except OSError:
        return None


def steal_share(before: list[int] | None, after: list[int] | None) -> float | None:
    """The share of the CPU time the hypervisor gave to others in between (0 on bare metal)."""
    if before is None or after is None or len(before) < 8:
        return None
    delta = [b - a for a, b in zip(before, after, strict=True)]
    return delta[7] / max(1, sum(delta[:8]))


def walks(runs: int, varied: bool = False) -> list[Job]:
    worlds = sample(VariationRanges(), runs, seed=0) if varied else [NOMINAL] * runs
    return [
        Job(GaitParams(), Motion(a_p=0.07, ca=ca), variation=v)
        for ca, v in zip(np.linspace(-0.1, 0.1, runs), worlds, strict=True)
    ]


def raw_steps_per_s(job: Job, frames: int, walks: int = 1) -> tuple[float, float]:
    """Single thread: the walk's frame set-points, MuJoCo's C loop for the 20 steps of a frame,
    `walks` times from the start (as much work as a share of one evaluate call).

    Returns (steps per wall second, steps per CPU second of this process)."""
    sim = FrameLoop(params=job.params, motion=job.motion)
    plan = plan_frames(
        job.params, job.motion, sim.hardware, sim.phase, frames, sim.steps_per_frame, sim.timestep_s
    )
    model, data, act, steps = sim.model, sim.data, sim.robot.actuator_ids, sim.steps_per_frame
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    start_state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, start_state, spec)
    start, cpu_start = time.perf_counter(), time.process_time()
    for _ in range(walks):
        mujoco.mj_setState(model, data, start_state, spec)
        for k in range(frames):
            data.ctrl[act] = plan.setpoint[k]
            mujoco.mj_step(model, data, steps)
    total = walks * frames * steps
    return total / (time.perf_counter() - start), total / (time.process_time() - cpu_start)


def _raw_in_process(args: tuple[Job, int, int]) -> tuple[float, float]:
    return raw_steps_per_s(*args)


def concurrent_raw_steps_per_s(job: Job, frames: int, processes: int, walks: int) -> float:
    """Total steps/s of `processes` raw C loops running at once, one per process, each doing
    `walks` walks (together as much work as one evaluate call)."""
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(processes) as pool:
        pool.map(_raw_in_process, [(job, 10, 1)] * processes)  # import and load the model first
        results = pool.map(_raw_in_process, [(job, frames, walks)] * processes)
    return sum(wall for wall, _cpu in results)


def batch_steps_per_s(
    evaluator: BatchEvaluator, jobs: list[Job], seconds: float
) -> tuple[float, float, float]:
    """One evaluate call: steps per wall second end to end and for the rollout alone, and
    steps per CPU second of this process (all its threads) end to end."""
    steps_per_run = round(seconds / evaluator.robot.model.opt.timestep)
    start, cpu_start = time.perf_counter(), time.process_time()
    metrics = evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    rollout_wall = sum(m["wall_s"] for m in metrics)  # wall_s = a call's rollout time / its runs
    total = steps_per_run * len(jobs)
    return total / wall, total / rollout_wall, total / cpu


def processes_steps_per_s(evaluator: ProcessEvaluator, jobs: list[Job], seconds: float) -> float:
    """One evaluate call on worker processes: steps per wall second end to end."""
    steps_per_run = round(seconds / evaluator.robot.model.opt.timestep)
    start = time.perf_counter()
    evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    return steps_per_run * len(jobs) / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per walk")
    parser.add_argument("--runs", type=int, default=16, help="walks per evaluate call")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    n_threads = os.cpu_count() or 1
    kinds = {"nominal": walks(args.runs), "varied": walks(args.runs, varied=True)}
    frames = round(args.seconds / 0.02)
    load_before, counters_before = os.getloadavg()[0], cpu_times()
    raw, raw_cpu, raw_parallel = [], [], []
    evaluators = {k: BatchEvaluator(threads=n_threads) for k in kinds}
    batch: dict[str, list[tuple[float, float, float]]] = {k: [] for k in kinds}
    in_processes: dict[str, list[float]] = {k: [] for k in kinds}
    workers = ProcessEvaluator(processes=n_threads)
    workers.evaluate(kinds["varied"][:n_threads], duration_s=0.5, warmup_s=0.2)  # start, load
    for _ in range(args.repeats):  # interleaved, so machine load affects all alike
        trials = [raw_steps_per_s(j, frames) for j in kinds["nominal"][:4]]
        raw.append(statistics.median(t[0] for t in trials))
        raw_cpu.append(statistics.median(t[1] for t in trials))
        share = max(1, args.runs // n_threads)  # each process: its share of a call's walks
        raw_parallel.append(
            concurrent_raw_steps_per_s(kinds["nominal"][0], frames, n_threads, share)
        )
        for kind, jobs in kinds.items():
            batch[kind].append(batch_steps_per_s(evaluators[kind], jobs, args.seconds))
            in_processes[kind].append(processes_steps_per_s(workers, jobs, args.seconds))
    workers.close()
    steal = steal_share(counters_before, cpu_times())
    raw_m, raw_cpu_m = statistics.median(raw), statistics.median(raw_cpu)
    ceiling = statistics.median(raw_parallel)

    print(
        f"model: artro (generated), timestep {evaluators['nominal'].model.opt.timestep * 1e3:g} ms"
    )
    print(
        f"{args.runs} walks of {args.seconds:g} s (a_p = 0.07, CA -0.1..0.1), "
        f"{args.repeats} repeats, medians; {n_threads} CPU(s), load average before "
        f"{load_before:.2f}, after {os.getloadavg()[0]:.2f}"
        + ("" if steal is None else f"; CPU time stolen by the hypervisor {100 * steal:.1f} %")
    )
    print(f"raw mj_step, 1 thread (C loop): {raw_m:8.0f} steps/s wall, {raw_cpu_m:8.0f} per CPU s")
    print(f"raw mj_step, {n_threads} processes at once (the ceiling): {ceiling:8.0f} steps/s")
    for kind, results in batch.items():
        e2e, roll, per_cpu = (statistics.median(r[i] for r in results) for i in range(3))
        # side by side: each repeat's batch against the ceiling measured just before it
        pairs = sorted(r[0] / c for r, c in zip(results, raw_parallel, strict=True))
        stages = evaluators[kind].stage_s
        per_stage = ", ".join(f"{k} {v / args.repeats:.2f} s" for k, v in stages.items())
        print(
            f"batch, {kind:7s}, {n_threads} threads: {e2e:8.0f} steps/s end to end = "
            f"{statistics.median(pairs):.3f} of the ceiling (repeats {pairs[0]:.3f}…"
            f"{pairs[-1]:.3f}; goal >= {CEILING_GOAL}), rollout alone "
            f"{roll:8.0f}; {per_cpu:8.0f} per CPU s = {per_cpu / raw_cpu_m:.3f} of raw "
            f"(goal >= {CPU_GOAL}); per call: {per_stage}"
        )
        pairs = sorted(p / c for p, c in zip(in_processes[kind], raw_parallel, strict=True))
        print(
            f"processes, {kind:7s}, {n_threads} x 1 thread: "
            f"{statistics.median(in_processes[kind]):8.0f} steps/s end to end = "
            f"{statistics.median(pairs):.3f} of the ceiling (repeats {pairs[0]:.3f}…"
            f"{pairs[-1]:.3f})"
        )
    if load_before > 0.5:
        print(
            "note: other processes were running (load average above); the wall-clock ratios "
            "then say how many cores were free, the per-CPU-second figures how efficient the "
            "batch is"
        )


if __name__ == "__main__":
    main()
