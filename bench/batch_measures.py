"""bench_batch's measurements (bench/bench_batch.py says what each is and why): the walks, raw
mj_step replays of them (one core, and N processes at once: the machine's ceiling), the batch
and process evaluators' throughput, and the closed loop's CPU against the open loop's."""

from __future__ import annotations

import dataclasses
import multiprocessing
import multiprocessing.pool
import sys
import time

import mujoco
import numpy as np

from app.evaluation import BatchEvaluator, Job
from app.evaluation._frames import STATE_SPEC
from app.evaluation._lane_kit import LaneKit
from app.evaluation._processes import ProcessEvaluator
from app.sim.planning import FRAME_S, frame_steps
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import NOMINAL
from gait import GaitParams, Motion
from gait.params import LAW_GROUPS

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


def raw_replay(jobs: list[Job], frames: list[int]) -> tuple[int, float, float]:
    """Single thread: each run planned as the evaluator plans it (on its own varied model,
    latency, calibration and play included), then replayed by MuJoCo's C loop -- the control
    it ends each frame with, mj_step(nstep=20), no Python between steps -- from its start, for
    its number of frames.

    Returns (steps, wall seconds, CPU seconds of this process)."""
    planner = BatchEvaluator(threads=1)
    data, steps = mujoco.MjData(planner.model), planner.steps_per_frame
    planned = [planner._plan_run(job, n, data) for job, n in zip(jobs, frames, strict=True)]
    start, cpu_start = time.perf_counter(), time.process_time()
    for (robot, begin, ctrl), n in zip(planned, frames, strict=True):
        mujoco.mj_setState(robot.model, data, begin.state, STATE_SPEC)
        per_frame = ctrl[steps - 1 :: steps]
        for k in range(n):
            data.ctrl[:] = per_frame[k]
            mujoco.mj_step(robot.model, data, steps)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    return sum(frames) * steps, wall, cpu


def _raw_in_process(args: tuple[list[Job], list[int]]) -> tuple[int, float, float]:
    return raw_replay(*args)


def raw_pool(processes: int) -> multiprocessing.pool.Pool:
    """`processes` spawned processes, each with the project imported and the model loaded, to
    measure the ceiling with again and again (idle in between)."""
    pool = multiprocessing.get_context("spawn").Pool(processes)
    pool.map(_raw_in_process, [(walks(1), [2])] * processes)
    return pool


def concurrent_raw(
    jobs: list[Job],
    frames: list[int],
    processes: int,
    pool: multiprocessing.pool.Pool | None = None,
) -> tuple[float, float]:
    """The machine's ceiling for these runs: `processes` raw C loops at once, one per process,
    each replaying its share of the runs (every `processes`-th), each for its frames; in
    `pool` (`raw_pool(processes)`) if given, else in a pool made for the call.

    Returns (total steps/s, the sum of each process's own rate; steps per CPU second)."""
    own = pool is None
    pool = raw_pool(processes) if pool is None else pool
    try:
        shares = [(jobs[p::processes], frames[p::processes]) for p in range(processes)]
        done = pool.map(_raw_in_process, shares, chunksize=1)
    finally:
        if own:
            pool.close()
            pool.join()
    rate = sum(steps / wall for steps, wall, _cpu in done)
    per_cpu = sum(steps for steps, _w, _c in done) / sum(cpu for _s, _w, cpu in done)
    return rate, per_cpu


def bracketed(measured: float, before: float, after: float) -> float:
    """A measurement as a share of the ceiling around it: the mean of the one measured just
    before and the one just after."""
    return measured / (0.5 * (before + after))


def needed_frames(evaluator: BatchEvaluator, jobs: list[Job], seconds: float) -> list[int]:
    """The frames each run's measurement needs: all, or up to the frame it fell in."""
    metrics = evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    return [round(m["sim_s"] / FRAME_S) for m in metrics]


def batch_steps_per_s(
    evaluator: BatchEvaluator, jobs: list[Job], seconds: float, needed: list[int]
) -> tuple[float, float, float, float]:
    """One evaluate call: needed steps per wall second end to end and for the rollout alone,
    per CPU second of this process (all its threads) end to end, and the share of the call
    the lanes were busy (planning, rolling out or measuring; the rest is the call's tail)."""
    stages_before = sum(evaluator.stage_s.values())
    start, cpu_start = time.perf_counter(), time.process_time()
    metrics = evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    lanes = min(evaluator.threads, len(jobs))
    rollout_wall = sum(m["wall_s"] for m in metrics) / lanes  # wall_s: the run's own rollout
    busy = (sum(evaluator.stage_s.values()) - stages_before) / (lanes * wall)
    total = sum(needed) * evaluator.steps_per_frame
    return total / wall, total / rollout_wall, total / cpu, busy


def planning_alone_ms(jobs: list[Job], seconds: float) -> float:
    """Planning one run, ms, in one thread with nothing else running (against what it costs
    in a lane beside another, the stage seconds)."""
    evaluator, frames = BatchEvaluator(threads=1), round(seconds / FRAME_S)
    data = mujoco.MjData(evaluator.model)
    for job in jobs:  # the varied models are built outside the timing
        evaluator._varied(job.variation)
    start = time.perf_counter()
    for job in jobs:
        evaluator._plan_run(job, frames, data)
    return 1e3 * (time.perf_counter() - start) / len(jobs)


CLOSED_GOAL = 1.10  # a closed-loop run's CPU, of the same run's open loop


def with_laws(job: Job, groups: tuple[str, ...] = LAW_GROUPS) -> Job:
    """The job with the feedback laws of `groups` on at their default gains (all of them: the
    most a run can cost; those `robust` switches on: what the shipped loop costs)."""
    on = {g: dataclasses.replace(getattr(job.params, g), enabled=True) for g in groups}
    return dataclasses.replace(job, params=dataclasses.replace(job.params, **on))


def rollout_cpu_s(jobs: list[Job], frames: int, frames_per_call: int) -> float:
    """CPU seconds to roll the runs' open-loop control out, planned before, in `rollout` calls
    of `frames_per_call` frames each from the last call's state and warm start, as a lane does
    (one frame a call: what a closed loop pays for its calls alone, before any Python of its
    own). Runs that fall are rolled out to the end: both call sizes step the same."""
    evaluator = BatchEvaluator(threads=1)
    kit, steps = LaneKit(evaluator.model), evaluator.steps_per_frame
    planned = [evaluator._plan_run(job, frames, kit.data) for job in jobs]
    start = time.process_time()
    for robot, begin, control in planned:
        state, sensors = kit.output(control.shape[0])
        initial, warmstart = begin.state[None, :], None
        for first in range(0, frames, frames_per_call):
            part = slice(first * steps, min(first + frames_per_call, frames) * steps)
            kit.rollout.rollout(
                [robot.model], [kit.data], initial, control[None, part],
                initial_warmstart=warmstart, state=state[:, part], sensordata=sensors[:, part],
                nstep=part.stop - part.start, skip_checks=True,
            )  # fmt: skip
            initial, warmstart = state[:, part.stop - 1], kit.data.qacc_warmstart[None].copy()
    return time.process_time() - start


def cpu_s_per_sim_s(evaluator: BatchEvaluator, jobs: list[Job], seconds: float) -> float:
    """CPU seconds of this process (every lane) per simulated second, over one call."""
    start = time.process_time()
    metrics = evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    return (time.process_time() - start) / sum(m["sim_s"] for m in metrics)


def wall_s_per_sim_s(evaluator: ProcessEvaluator, jobs: list[Job], seconds: float) -> float:
    """Wall seconds per simulated second over one call (the worker processes' CPU is not this
    process's)."""
    start = time.perf_counter()
    metrics = evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    return (time.perf_counter() - start) / sum(m["sim_s"] for m in metrics)


def processes_steps_per_s(
    evaluator: ProcessEvaluator, jobs: list[Job], seconds: float, needed: list[int]
) -> float:
    """One evaluate call on worker processes: needed steps per wall second end to end."""
    start = time.perf_counter()
    evaluator.evaluate(jobs, duration_s=seconds, warmup_s=min(5.0, seconds / 2))
    steps = sum(needed) * frame_steps(evaluator.robot.model)
    return steps / (time.perf_counter() - start)


def say(what: str) -> None:
    """Progress on stderr (the figures go to stdout): a run takes ~14 minutes."""
    print(f"bench_batch: {what} ...", file=sys.stderr, flush=True)
