"""Benchmark: `mujoco.rollout` alone against the machine's ceiling (docs/DESIGN.md §9).

The same planned walks (a_p = 0.07, CA spread over -0.1..0.1, 10 s) are stepped, interleaved
in each repeat, by:
  - raw mj_step in a C loop, 1 process, and in N processes at once (the ceiling);
  - one rollout call of all walks on 1 thread, and on N threads (MuJoCo's pool: a barrier at
    the call's end, where the thread that finished first waits for the other);
  - N lanes: N Python threads, each rolling out one walk per call (the GIL released) and taking
    the next, as `BatchEvaluator` does since session 9.
Each repeat prints rollout / raw side by side, so a machine whose speed drifts between repeats
shows as spread rather than as a bias.

    python bench/bench_rollout_threads.py [--repeats 5] [--runs 8] [--json PATH]

Writes the ratios (per way: the median and every repeat's) to
bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import os
import queue
import statistics
import threading
import time

import mujoco
import numpy as np
import results
from bench_batch import concurrent_raw, raw_replay, walks
from mujoco import rollout

from app.evaluation import BatchEvaluator
from app.evaluation._frames import STATE_SPEC

FRAMES = 500  # 10 s


def one_call(evaluator: BatchEvaluator, planned: tuple, threads: int) -> float:
    """Steps/s of one rollout call of the planned walks on `threads` MuJoCo threads."""
    _starts, controls, initial, models = planned
    datas = [mujoco.MjData(evaluator.model) for _ in range(threads)]
    start = time.perf_counter()
    rollout.rollout(models, datas, initial, controls)
    return controls.shape[0] * controls.shape[1] / (time.perf_counter() - start)


def lanes(evaluator: BatchEvaluator, planned: tuple, threads: int) -> float:
    """Steps/s of `threads` Python threads taking one walk per rollout call from a queue."""
    _starts, controls, initial, _models = planned
    todo: queue.SimpleQueue[int] = queue.SimpleQueue()
    for i in range(len(controls)):
        todo.put(i)

    def lane() -> None:
        data = mujoco.MjData(evaluator.model)
        out = np.empty((1, controls.shape[1], mujoco.mj_stateSize(evaluator.model, STATE_SPEC)))
        sensors = np.empty((1, controls.shape[1], evaluator.model.nsensordata))
        while True:
            try:
                i = todo.get_nowait()
            except queue.Empty:
                return
            rollout.rollout(
                evaluator.model, data, initial[i : i + 1], controls[i : i + 1],
                state=out, sensordata=sensors,
            )  # fmt: skip

    workers = [threading.Thread(target=lane) for _ in range(threads)]
    start = time.perf_counter()
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    return controls.shape[0] * controls.shape[1] / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=8, help="walks per rollout call")
    args = results.parse_args(parser)
    n = os.cpu_count() or 1
    evaluator, jobs = BatchEvaluator(threads=n), walks(args.runs)
    planned = evaluator._plan(jobs, FRAMES)
    ratios: dict[str, list[float]] = {"1 thread": [], f"{n} threads": [], f"{n} lanes": []}
    one_core = jobs[: max(1, args.runs // n)]
    share = evaluator._plan(one_core, FRAMES)
    for _ in range(args.repeats):
        steps, wall, _cpu = raw_replay(one_core, [FRAMES] * len(one_core))
        ratios["1 thread"].append(one_call(evaluator, share, 1) / (steps / wall))
        ceiling, _per_cpu = concurrent_raw(jobs, [FRAMES] * len(jobs), n)
        ratios[f"{n} threads"].append(one_call(evaluator, planned, n) / ceiling)
        ratios[f"{n} lanes"].append(lanes(evaluator, planned, n) / ceiling)
    load = os.getloadavg()[0]
    print(f"{args.runs} walks of 10 s, {args.repeats} repeats, load average {load:.2f}")
    ways = []
    for label, values in ratios.items():
        spread = ", ".join(f"{v:.3f}" for v in values)
        against = "raw, 1 process" if label == "1 thread" else f"raw, {n} processes at once"
        median = statistics.median(values)
        print(f"rollout alone, {label}: median {median:.3f} of {against} ({spread})")
        ways.append({"way": label, "against": against, "median": median, "repeats": values})
    figures = {"threads": n, "walk_s": FRAMES * 0.02, "load_average_after": load, "ratios": ways}
    headline = {f"rollout alone, {w['way']}, of {w['against']}": w["median"] for w in ways}
    results.write("bench_rollout_threads", args, figures, headline)


if __name__ == "__main__":
    main()
