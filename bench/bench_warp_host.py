"""Benchmark: the Warp executor's work on the host for a robust study, without a GPU: what
stays on the CPU beside the stepping (docs/GPU.md "Where the time goes", decision 0042).

For `bench robust`'s jobs (every case on the nominal robot and on N sampled variations, runs
of --duration s) it times, per stage and per world:
  - plan: the varied robots, the starts, the gait plans (one per case, cached) and every
    step's controls into the batch's (worlds, steps, nu) array, as `WarpEvaluator` does;
  - per-world fields: the model fields the worlds differ in, read from their MjModels after
    two models are put on the device (`per_world_fields`), against putting every model
    (`_per_world_fields_put`, the way before);
  - segment copies: the controls of every segment into the upload buffer, as one contiguous
    block per world, against stacking them step-major per segment (the way before);
  - measure: one world's metrics from its frame ends (`measure_frames`), from a real rollout.
On the H200 (bench/results/bench_gpu.json, 1809 worlds) planning took 5.2 ms a world and the
upload stage 9.1 s before these changes.

    python bench/bench_warp_host.py [--samples 200] [--duration 20]   # ~1 min on 2 cores

Writes bench/results/<bench>.json, or --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import math
import time

import mujoco
import numpy as np
import results
from mujoco import rollout

from app.analysis.robustness import jobs_for
from app.evaluation._measure import fallen, measure_frames, not_finite
from app.evaluation._warp import SEGMENT_FRAMES, WarpEvaluator, _Batch
from app.evaluation._warp_model import _per_world_fields_put, per_world_fields
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.planning import FRAME_S
from app.worlds.sampling import VariationRanges, sample


def timed(work) -> float:
    t0 = time.perf_counter()
    work()
    return time.perf_counter() - t0


def segment_copies(batch: _Batch, steps: int, contiguous: bool) -> None:
    """Every segment's controls into an upload buffer: world-major (now) or step-major."""
    worlds, total, nu = batch.control.shape
    per = SEGMENT_FRAMES * steps
    if contiguous:
        buffer = np.zeros((worlds, per, nu), np.float32)
        for first in range(0, total, per):
            rows = slice(first, min(first + per, total))
            buffer[:, : rows.stop - rows.start] = batch.control[:, rows]
    else:
        rows_of = [batch.control[w] for w in range(worlds)]
        for first in range(0, total, per):
            rows = slice(first, min(first + per, total))
            np.stack([c[rows] for c in rows_of], axis=1)


def measure_one(robot: RobotModel, batch: _Batch, repeats: int) -> float:
    """Seconds to measure world 0 from its frame ends (a real rollout of its controls)."""
    job, start = batch.jobs[0], batch.starts[0]
    data = mujoco.MjData(robot.model)
    control = batch.control[0].astype(np.float64)
    states, sensors = rollout.rollout(robot.model, data, start.state, control)
    steps = len(control) // batch.n_frames
    ends = np.arange(steps - 1, len(control), steps)
    size = mujoco.mj_stateSize(robot.model, mujoco.mjtState.mjSTATE_TIME)
    qpos = states[0, ends, size : size + robot.model.nq]
    sens = sensors[0, ends]
    bad, down = not_finite(qpos), fallen(qpos, start)
    t0 = time.perf_counter()
    for _ in range(repeats):
        measure_frames(robot, job, qpos, sens.copy(), bad, down, 5.0)
    return (time.perf_counter() - t0) / repeats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=200, help="variations (worlds: 9 x (N+1))")
    parser.add_argument("--duration", type=float, default=20.0, metavar="S")
    args = results.parse_args(parser)
    robot = RobotModel.load()
    gait = builtin_presets()["tuned"].gait
    jobs = jobs_for(gait, sample(VariationRanges(), args.samples, 0))
    evaluator = WarpEvaluator(robot, device="cpu")
    n_frames = math.ceil(args.duration / FRAME_S - 1e-9)
    steps = evaluator.steps_per_frame
    holder: dict[str, _Batch] = {}
    plan_s = timed(lambda: holder.setdefault("batch", _Batch(evaluator, jobs, n_frames)))
    batch = holder["batch"]
    models = [r.model for r in batch.robots]
    fields_s = timed(lambda: per_world_fields(models))
    fields_put_s = timed(lambda: _per_world_fields_put(models))
    copies_s = timed(lambda: segment_copies(batch, steps, contiguous=True))
    stack_s = timed(lambda: segment_copies(batch, steps, contiguous=False))
    measure_s = measure_one(robot, batch, repeats=20)
    worlds = len(jobs)
    figures = {
        "worlds": worlds,
        "variations": args.samples,
        "frames": n_frames,
        "control_bytes": batch.control.nbytes,
        "plan": {"s": plan_s, "ms_per_world": plan_s / worlds * 1e3},
        "per_world_fields": {"s": fields_s, "put_every_model_s": fields_put_s},
        "segment_copies": {"world_major_s": copies_s, "step_major_stack_s": stack_s},
        "measure": {"ms_per_world": measure_s * 1e3, "s_all_worlds": measure_s * worlds},
    }
    print(f"{worlds} worlds, {n_frames} frames each")
    print(f"plan: {plan_s:.1f} s ({plan_s / worlds * 1e3:.2f} ms a world)")
    print(f"per-world fields: {fields_s:.2f} s (putting every model: {fields_put_s:.1f} s)")
    print(f"segment copies: {copies_s:.2f} s (stacked step-major: {stack_s:.2f} s)")
    print(f"measure: {measure_s * 1e3:.2f} ms a world ({measure_s * worlds:.1f} s for all)")
    headline = {
        "worlds": worlds,
        "plan ms/world": plan_s / worlds * 1e3,
        "per-world fields s": fields_s,
        "per-world fields, every model put, s": fields_put_s,
        "segment copies s": copies_s,
        "segment stacks (before) s": stack_s,
        "measure ms/world": measure_s * 1e3,
    }
    results.write("bench_warp_host", args, figures, headline)


if __name__ == "__main__":
    main()
