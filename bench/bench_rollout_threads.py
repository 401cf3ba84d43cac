"""Benchmark: where the batch evaluator loses against the machine's ceiling (docs/DESIGN.md §14).

The same planned walks (a_p = 0.07, CA spread over -0.1..0.1, 10 s) are stepped, interleaved
in each repeat, by:
  - raw mj_step in a C loop, 1 process, and in N processes at once (the ceiling);
  - `mujoco.rollout` alone (no planning, no measuring), with 1 thread and with N threads, the
    latter once into fresh output arrays and once into arrays kept from call to call (as
    `BatchEvaluator` does since session 8).
Each repeat prints rollout / raw side by side, so a machine whose speed drifts between repeats
shows as spread rather than as a bias.

    python bench/bench_rollout_threads.py [--repeats 5] [--runs 8]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import mujoco
from bench_batch import concurrent_raw_steps_per_s, raw_steps_per_s, walks
from mujoco import rollout

from app.core.batch import BatchEvaluator

FRAMES = 500  # 10 s


def rollout_steps_per_s(
    evaluator: BatchEvaluator, runs: int, threads: int, reuse: bool = False
) -> float:
    """Steps/s of one rollout call of `runs` planned walks on `threads` threads, into fresh
    output arrays or (`reuse`) the evaluator's kept ones."""
    _sims, _starts, controls, initial, models = evaluator._plan(walks(runs), FRAMES)
    datas = [mujoco.MjData(evaluator.model) for _ in range(threads)]
    state, sensors = evaluator._output(0, runs, controls.shape[1]) if reuse else (None, None)
    start = time.perf_counter()
    rollout.rollout(models, datas, initial, controls, state=state, sensordata=sensors)
    return runs * controls.shape[1] / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=8, help="walks per rollout call")
    args = parser.parse_args()
    n = os.cpu_count() or 1
    evaluator, job = BatchEvaluator(threads=n), walks(1)[0]
    reused = f"{n} threads, kept output arrays"
    ratios: dict[str, list[float]] = {"1 thread": [], f"{n} threads": [], reused: []}
    rollout_steps_per_s(evaluator, args.runs, n, reuse=True)  # the kept arrays exist from here
    for _ in range(args.repeats):
        one = raw_steps_per_s(job, FRAMES, max(1, args.runs // n))[0]
        ratios["1 thread"].append(rollout_steps_per_s(evaluator, max(1, args.runs // n), 1) / one)
        ceiling = concurrent_raw_steps_per_s(job, FRAMES, n, max(1, args.runs // n))
        ratios[f"{n} threads"].append(rollout_steps_per_s(evaluator, args.runs, n) / ceiling)
        ratios[reused].append(rollout_steps_per_s(evaluator, args.runs, n, reuse=True) / ceiling)
    print(
        f"{args.runs} walks of 10 s, {args.repeats} repeats, load average {os.getloadavg()[0]:.2f}"
    )
    for label, values in ratios.items():
        spread = ", ".join(f"{v:.3f}" for v in values)
        against = "raw, 1 process" if label == "1 thread" else f"raw, {n} processes at once"
        median = statistics.median(values)
        print(f"rollout alone, {label}: median {median:.3f} of {against} ({spread})")


if __name__ == "__main__":
    main()
