"""Benchmark: the same robust study locally (threads) and on local Dask clusters of 1 and 2
worker processes (a real `dask scheduler` and `dask worker`s on loopback, started here).

Prints runs/s of each, the speed-up over 1 worker, and the efficiency against local threads
(goal for 2 workers against 2 threads on a 2-core machine: >= 0.85), and checks the results are
the same to the bit. Each evaluation is warmed once first (workers import and build the model).

    python bench/bench_cluster.py [--samples 12] [--seconds 10] [--runs-per-task 8] [--json PATH]

Writes the figures (runs/s locally and per cluster size, speed-ups, efficiencies, whether the
results are the same to the bit) to bench/results/<bench>.json, or to --json PATH
(bench/results.py).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import results

from app.analysis.robustness import jobs_for
from app.evaluation import BatchEvaluator, same_results
from app.evaluation._dask import ClusterEvaluator
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.worlds.sampling import VariationRanges, sample

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the tests' loopback cluster
from tests.testing.cluster_support import LoopbackCluster

GOAL = 0.85


def timed(evaluator, jobs, seconds: float) -> tuple[float, list]:
    evaluator.evaluate(jobs[:4], duration_s=seconds, warmup_s=1.0)  # warm: imports, models
    start = time.perf_counter()
    metrics = evaluator.evaluate(jobs, duration_s=seconds, warmup_s=1.0)
    return len(jobs) / (time.perf_counter() - start), metrics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=12, help="variations (x 9 cases + 9)")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per run")
    parser.add_argument("--runs-per-task", type=int, default=8)
    args = results.parse_args(parser)
    robot = RobotModel.load()
    jobs = jobs_for(builtin_presets()["tuned"].gait, sample(VariationRanges(), args.samples, 0))
    threads = os.cpu_count() or 1
    print(
        f"robust study: {len(jobs)} runs of {args.seconds:g} s (tuned, {args.samples} "
        f"variations), {threads} CPU(s), load average {os.getloadavg()[0]:.2f}"
    )
    local_rate, local = timed(BatchEvaluator(robot, threads=threads), jobs, args.seconds)
    print(f"local threads ({threads}): {local_rate:6.2f} runs/s")
    rates = {}
    clusters = []
    for workers in (1, 2):
        with LoopbackCluster(workers) as cluster:
            evaluator = ClusterEvaluator(cluster.address, robot, runs_per_task=args.runs_per_task)
            evaluator.client.wait_for_workers(workers, timeout=120)
            rate, remote = timed(evaluator, jobs, args.seconds)
            evaluator.close()
        rates[workers] = rate
        identical = same_results(remote, local)
        same = "same results to the bit" if identical else "RESULTS DIFFER"
        efficiency = rate / local_rate * threads / workers
        clusters.append(
            {"workers": workers, "runs_per_s": rate, "speed_up_over_1_worker": rate / rates[1],
             "efficiency_against_local_threads": efficiency, "same_results": identical}
        )  # fmt: skip
        print(
            f"Dask, {workers} worker process(es): {rate:6.2f} runs/s, speed-up over 1 worker "
            f"{rate / rates[1]:.2f}, efficiency against {threads} local threads "
            f"{efficiency:.3f}; {same}"
        )
    print(
        f"2 workers against {threads} local threads: {rates[2] / local_rate:.3f} "
        f"(goal >= {GOAL} for 2 workers on 2 cores)"
    )
    load = os.getloadavg()[0]
    if load > 0.5 + threads:
        print("note: the machine was busy; the ratios then say how many cores were free")
    figures = {
        "runs": len(jobs),
        "threads": threads,
        "load_average_after": load,
        "local_runs_per_s": local_rate,
        "clusters": clusters,
        "two_workers_of_local_threads": rates[2] / local_rate,
        "goal_two_workers_of_local_threads": GOAL,
    }
    headline = {
        f"2 Dask workers, of {threads} local threads (goal ≥ {GOAL})": rates[2] / local_rate,
        "local threads (runs/s)": local_rate,
        "every cluster's results the same to the bit": all(c["same_results"] for c in clusters),
    }
    results.write("bench_cluster", args, figures, headline)


if __name__ == "__main__":
    main()
