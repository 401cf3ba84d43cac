"""Benchmark: the Warp executor's work on the host for a robust study, without a GPU: what
stays on the CPU beside the stepping (docs/GPU.md "Where the time goes", decision 0056).

For `bench robust`'s jobs (every case on the nominal robot and on N sampled variations, runs
of --duration s) it times, per stage and per world:
  - plan: the varied robots, the starts, the gait plans (one per case, cached) and every
    step's controls into the batch's (worlds, steps, nu) array, as `WarpEvaluator` does;
  - per-world fields: the model fields the worlds differ in, read from their MjModels after
    two models are put on the device (`per_world_fields`), against putting every model
    (`_per_world_fields_put`, the way before);
  - segment copies: the controls of every segment into the upload buffer, as one contiguous
    block per world, against stacking them step-major per segment (the way before);
  - measure: one world's metrics from its frame ends (`measure_frames`), from a real rollout;
  - host processes: the planning of every world, and the measuring of as many worlds (world
    0's frame ends, as `bench robust` measures: no traces), in this process and over a pool of
    --processes spawned workers (`HostPool`: the controls written into shared memory), the
    pool's start timed apart and the pool's controls checked equal to this process's;
  - the closed loop: the same study with `robust` (its laws on), the worlds' loops between
    frames (`WorldLoops`: the sensors, laws and next frame of every world, one host thread), fed
    each frame the sensor rows of a robot standing (the laws are elementwise: their cost does
    not depend on the values), per world and frame.
On the H200 (bench/results/bench_gpu.json, 1809 worlds) planning took 5.2 ms a world and the
upload stage 9.1 s before these changes.

    python bench/bench_warp_host.py [--samples 200] [--duration 20] [--processes N]  # ~1.5 min

Writes bench/results/<bench>.json, or --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import math
import os
import time

import mujoco
import numpy as np
import results
from mujoco import rollout

from app.analysis.robustness import jobs_for
from app.evaluation._frames import STATE_SPEC
from app.evaluation._measure import fallen, measure_frames, not_finite
from app.evaluation._warp import SEGMENT_FRAMES, import_warp, warp_device
from app.evaluation._warp_host import Planned, plan_batch
from app.evaluation._warp_model import _per_world_fields_put, per_world_fields
from app.evaluation._warp_pool import HostArray, HostPool, measure_world
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.planning import FRAME_S, frame_steps
from app.worlds.sampling import VariationRanges, sample


def timed(work) -> float:
    t0 = time.perf_counter()
    work()
    return time.perf_counter() - t0


def segment_copies(control: np.ndarray, steps: int, contiguous: bool) -> None:
    """Every segment's controls into an upload buffer: world-major (now) or step-major."""
    worlds, total, nu = control.shape
    per = SEGMENT_FRAMES * steps
    if contiguous:
        buffer = np.zeros((worlds, per, nu), np.float32)
        for first in range(0, total, per):
            rows = slice(first, min(first + per, total))
            buffer[:, : rows.stop - rows.start] = control[:, rows]
    else:
        rows_of = [control[w] for w in range(worlds)]
        for first in range(0, total, per):
            rows = slice(first, min(first + per, total))
            np.stack([c[rows] for c in rows_of], axis=1)


#: frames the closed loop's host work is timed over
CLOSED_LOOP_FRAMES = 50


def frame_ends(robot: RobotModel, batch: Planned, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """World 0's frame-end qpos and sensordata (frames, ...) float64, from a real rollout of its
    controls."""
    data = mujoco.MjData(robot.model)
    control = batch.controls.array[0].astype(np.float64)
    states, sensors = rollout.rollout(robot.model, data, batch.starts[0].state, control)
    steps = len(control) // n_frames
    ends = np.arange(steps - 1, len(control), steps)
    size = mujoco.mj_stateSize(robot.model, mujoco.mjtState.mjSTATE_TIME)
    return states[0, ends, size : size + robot.model.nq], sensors[0, ends]


def measure_one(robot: RobotModel, job, start, qpos, sens, repeats: int) -> float:
    """Seconds to measure world 0 from its frame ends (`measure_frames`)."""
    bad, down = not_finite(qpos), fallen(qpos, start)
    t0 = time.perf_counter()
    for _ in range(repeats):
        measure_frames(robot, job, qpos, sens.copy(), bad, down, 5.0)
    return (time.perf_counter() - t0) / repeats


def host_processes(
    robot: RobotModel, jobs, n_frames: int, alone: Planned, item: tuple, processes: int
) -> dict:
    """Planning every world and measuring as many copies of `item` (job, start, qpos, sensors)
    over a pool of `processes` workers, the frame ends in shared memory as `WorldEnds` holds
    them, against this process (`alone`'s planning; the items measured here first): seconds
    and ms a world."""
    worlds, steps = len(jobs), frame_steps(robot.model)
    job, start, qpos, sens = item
    here_measure_s = timed(lambda: [measure_world(robot, *item, 5.0) for _ in range(worlds)])
    pool = HostPool(robot, processes)
    ends = [HostArray((len(a), worlds, a.shape[1]), shared=True) for a in (qpos, sens)]
    try:
        start_s = timed(  # the workers spawned and the project imported, one small task each
            lambda: plan_batch(robot, jobs[:processes], 1, steps, pool, None).controls.release()
        )
        holder: dict[str, Planned] = {}
        plan_s = timed(
            lambda: holder.setdefault("batch", plan_batch(robot, jobs, n_frames, steps, pool, None))
        )
        pooled = holder["batch"]
        try:
            same = bool(np.array_equal(pooled.controls.array, alone.controls.array))
            same = same and all(
                np.array_equal(pooled.initial[k], v) for k, v in alone.initial.items()
            )
        finally:
            pooled.controls.release()
        for shared, a in zip(ends, (qpos, sens), strict=True):
            shared.array[:] = a[:, None, :]
        items = [(job, start, w, len(qpos)) for w in range(worlds)]
        measure_s = timed(lambda: pool.measure(ends, items, 5.0, with_traces=False))
    finally:
        pool.close()
        for shared in ends:
            shared.release()
    return {
        "processes": processes,
        "pool_start_s": start_s,
        "same_controls_and_initial_rows": same,
        "plan": {"s": plan_s, "ms_per_world": plan_s / worlds * 1e3},
        "measure": {"s": measure_s, "ms_per_world": measure_s / worlds * 1e3},
        "measure_here": {"s": here_measure_s, "ms_per_world": here_measure_s / worlds * 1e3},
    }


def closed_loop(robot: RobotModel, samples: int, frames: int) -> dict:
    """The host's work between two frames of a closed-loop batch (`WorldLoops.record` of the
    frame's sensor rows, then `plan` of the next frame) for `robust` on `samples` variations:
    ms a frame and µs a world and frame, over `frames` frames."""
    jobs = jobs_for(builtin_presets()["robust"].gait, sample(VariationRanges(), samples, 0))
    steps = frame_steps(robot.model)
    batch = plan_batch(robot, jobs, frames + 1, steps, None, None)
    try:
        data = mujoco.MjData(robot.model)
        mujoco.mj_setState(robot.model, data, batch.starts[0].state, STATE_SPEC)
        mujoco.mj_forward(robot.model, data)
        worlds, shape = len(jobs), (len(jobs), steps, robot.model.nsensordata)
        rows = np.broadcast_to(data.sensordata.astype(np.float32), shape).copy()
        counting = np.ones(worlds, bool)
        out = np.empty((worlds, steps, robot.model.nu), np.float32)
        record_s = plan_s = 0.0
        for frame in range(1, frames + 1):
            t0 = time.perf_counter()
            batch.loops.record(rows, counting)
            t1 = time.perf_counter()
            batch.loops.plan(frame, counting, out)
            record_s, plan_s = record_s + t1 - t0, plan_s + time.perf_counter() - t1
    finally:
        batch.controls.release()
    return {
        "worlds": worlds,
        "frames": frames,
        "groups": len(batch.loops.groups),
        "record_ms_per_frame": record_s / frames * 1e3,
        "plan_ms_per_frame": plan_s / frames * 1e3,
        "us_per_world_frame": (record_s + plan_s) / (frames * worlds) * 1e6,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=200, help="variations (worlds: 9 x (N+1))")
    parser.add_argument("--duration", type=float, default=20.0, metavar="S")
    parser.add_argument(
        "--processes",
        type=int,
        default=os.cpu_count() or 1,
        metavar="N",
        help="host processes to plan and measure over (default: every core)",
    )
    args = results.parse_args(parser)
    wp, _mjw = import_warp()
    warp_device(wp, "cpu")  # Warp loaded and started before any timing, as WarpEvaluator does
    robot = RobotModel.load()
    gait = builtin_presets()["tuned"].gait
    jobs = jobs_for(gait, sample(VariationRanges(), args.samples, 0))
    n_frames = math.ceil(args.duration / FRAME_S - 1e-9)
    steps = frame_steps(robot.model)
    holder: dict[str, Planned] = {}
    plan_s = timed(
        lambda: holder.setdefault("batch", plan_batch(robot, jobs, n_frames, steps, None, None))
    )
    batch = holder["batch"]
    control = batch.controls.array
    models = [r.model for r in batch.robots]
    fields_s = timed(lambda: per_world_fields(models))
    fields_put_s = timed(lambda: _per_world_fields_put(models))
    copies_s = timed(lambda: segment_copies(control, steps, contiguous=True))
    stack_s = timed(lambda: segment_copies(control, steps, contiguous=False))
    qpos, sens = frame_ends(robot, batch, n_frames)
    measure_s = measure_one(robot, jobs[0], batch.starts[0], qpos, sens, repeats=20)
    worlds = len(jobs)
    item = (jobs[0], batch.starts[0], qpos.astype(np.float32), sens.astype(np.float32))
    pool = host_processes(robot, jobs, n_frames, batch, item, args.processes)
    closed = closed_loop(robot, args.samples, CLOSED_LOOP_FRAMES)
    figures = {
        "worlds": worlds,
        "variations": args.samples,
        "frames": n_frames,
        "control_bytes": control.nbytes,
        "plan": {"s": plan_s, "ms_per_world": plan_s / worlds * 1e3},
        "per_world_fields": {"s": fields_s, "put_every_model_s": fields_put_s},
        "segment_copies": {"world_major_s": copies_s, "step_major_stack_s": stack_s},
        "measure": {"ms_per_world": measure_s * 1e3, "s_all_worlds": measure_s * worlds},
        "host_processes": pool,
        "closed_loop": closed,
    }
    n = args.processes
    print(f"{worlds} worlds, {n_frames} frames each")
    print(f"plan: {plan_s:.1f} s ({plan_s / worlds * 1e3:.2f} ms a world)")
    print(f"per-world fields: {fields_s:.2f} s (putting every model: {fields_put_s:.1f} s)")
    print(f"segment copies: {copies_s:.2f} s (stacked step-major: {stack_s:.2f} s)")
    print(f"measure: {measure_s * 1e3:.2f} ms a world ({measure_s * worlds:.1f} s for all)")
    print(
        f"{n} host processes (started in {pool['pool_start_s']:.1f} s): plan "
        f"{pool['plan']['ms_per_world']:.2f} ms a world (1: {plan_s / worlds * 1e3:.2f}), "
        f"measure {pool['measure']['ms_per_world']:.2f} ms a world "
        f"(1: {pool['measure_here']['ms_per_world']:.2f}); the same controls: "
        f"{pool['same_controls_and_initial_rows']}"
    )
    print(
        f"closed loop (robust, {closed['worlds']} worlds in {closed['groups']} group(s)): "
        f"{closed['record_ms_per_frame']:.2f} ms recording and {closed['plan_ms_per_frame']:.2f} "
        f"ms planning a frame, {closed['us_per_world_frame']:.1f} µs a world and frame"
    )
    headline = {
        "worlds": worlds,
        "plan ms/world": plan_s / worlds * 1e3,
        "per-world fields s": fields_s,
        "per-world fields, every model put, s": fields_put_s,
        "segment copies s": copies_s,
        "segment stacks (before) s": stack_s,
        "measure ms/world": measure_s * 1e3,
        "host processes": n,
        f"plan ms/world, {n} processes": pool["plan"]["ms_per_world"],
        "measure_world ms/world, 1 process": pool["measure_here"]["ms_per_world"],
        f"measure_world ms/world, {n} processes": pool["measure"]["ms_per_world"],
        "host pool start s": pool["pool_start_s"],
        "closed loop µs/world-frame": closed["us_per_world_frame"],
    }
    batch.controls.release()
    results.write("bench_warp_host", args, figures, headline)


if __name__ == "__main__":
    main()
