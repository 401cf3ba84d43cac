"""Benchmark: the same robust study (`artro bench robust`'s jobs: every case on the nominal robot
and on N sampled variations) on the lanes of threads and as the worlds of one MuJoCo Warp batch,
side by side (docs/GPU.md, decision 0042).

Prints and writes, for each executor: wall seconds, physics steps per second (the steps each
stepped: the lanes stop a run after the call it fell in, a Warp batch steps every world until
the last is done) and runs per second; for Warp also the seconds its first step took (the
kernels compiled, or loaded from the cache) and the steady step rate without it; the agreement
of the two on every run (per metric, the median and largest difference over the runs that
walked on both; falls that differ; `bench robust`'s pass verdicts that differ); the device
(GPU model and memory, or "cpu device") and the CPU cores.

    python bench/bench_gpu.py --device cpu --samples 1 --duration 2 --warmup 0.5 --cold
        # Warp's CPU device, ~75 s on 2 cores: a check
    python bench/bench_gpu.py --device cuda --samples 200 --duration 20 --warmup 5 --cache DIR
        # one GPU: 1 809 worlds, ~4 min on an H200 with 16 cores (docs/GPU.md "Speed")

`--cold` compiles the kernels into an empty cache (a temporary folder) so the compile time is
measured, not a cached load; `--cache DIR` names the cache (cold when it is empty), for a second
run that loads what the first compiled. `--skip-lanes` runs Warp alone (a scaling figure, no
agreement). "compiled" figures leave out the first step (the compile), which a cache saves.
Writes bench/results/<bench>.json, or --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import numpy as np
import results

from app.analysis.robust_cases import ROBUST_CASES, passes
from app.analysis.robustness import jobs_for
from app.evaluation import BatchEvaluator
from app.evaluation._warp import AGREEMENT, WarpEvaluator
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.metrics import RunMetrics
from app.worlds.sampling import VariationRanges, sample


def verdicts(metrics: list[RunMetrics]) -> list[bool]:
    """`bench robust`'s pass verdict of every run against its case's nominal run."""
    n = len(ROBUST_CASES)
    return [passes(ROBUST_CASES[i % n], m, metrics[i % n]) for i, m in enumerate(metrics)]


def agreement(warp: list[RunMetrics], lanes: list[RunMetrics]) -> dict:
    """Per metric of AGREEMENT the median and largest |warp - lanes| over the runs that walked
    on both (sim_s and fall_time_s over all), how many exceed the stated tolerance, and the
    runs whose fall or pass verdict differs."""
    pairs = list(enumerate(zip(warp, lanes, strict=True)))
    walked = [i for i, (w, c) in pairs if not (w["fell"] or c["fell"])]
    per_metric = {}
    for key, tolerance in AGREEMENT.items():
        rows = range(len(warp)) if key in ("sim_s", "fall_time_s") else walked
        diffs = [
            float(np.max(np.abs(np.subtract(warp[i][key], lanes[i][key]))))
            for i in rows
            if key in warp[i] and key in lanes[i]
        ]
        per_metric[key] = {
            "tolerance": tolerance,
            "median": statistics.median(diffs) if diffs else None,
            "max": max(diffs) if diffs else None,
            "beyond_tolerance": sum(d > tolerance for d in diffs),
            "runs": len(diffs),
        }
    falls = [i for i, (w, c) in pairs if w["fell"] != c["fell"]]
    vw, vc = verdicts(warp), verdicts(lanes)
    return {
        "runs": len(warp),
        "walked_on_both": len(walked),
        "metrics": per_metric,
        "falls_differ": falls,
        "verdicts_differ": [i for i, (a, b) in enumerate(zip(vw, vc, strict=True)) if a != b],
        "passing": {"warp": sum(vw), "lanes": sum(vc)},
    }


def device_info(evaluator: WarpEvaluator) -> dict:
    device = evaluator.device
    if not device.is_cuda:
        return {"device": "cpu device", "gpu": None, "gpu_memory_gib": None}
    return {
        "device": str(device),
        "gpu": device.name,
        "gpu_memory_gib": round(device.total_memory / 2**30, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cuda", help="cuda (default), cuda:N or cpu")
    parser.add_argument("--samples", type=int, default=400, help="variations (worlds: 9 x (N+1))")
    parser.add_argument("--duration", type=float, default=20.0, metavar="S")
    parser.add_argument("--warmup", type=float, default=5.0, metavar="S")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--preset", default="tuned", help="a built-in preset's name")
    parser.add_argument("--threads", type=int, default=None, help="lanes (default: the cores)")
    parser.add_argument("--cold", action="store_true", help="an empty kernel cache first")
    parser.add_argument(
        "--cache", metavar="DIR", help="Warp's kernel cache folder (cold when empty or new)"
    )
    parser.add_argument(
        "--skip-lanes", action="store_true", help="Warp alone (no lanes, no agreement): scaling"
    )
    args = results.parse_args(parser)
    # read when Warp initialises, which no import above has done
    if args.cold:
        os.environ["WARP_CACHE_PATH"] = tempfile.mkdtemp(prefix="artro-warp-cache-")
    elif args.cache:
        os.environ["WARP_CACHE_PATH"] = args.cache
    cache = os.environ.get("WARP_CACHE_PATH")
    cold = args.cold or bool(cache and not (os.path.isdir(cache) and os.listdir(cache)))
    robot = RobotModel.load()
    gait = builtin_presets()[args.preset].gait
    jobs = jobs_for(gait, sample(VariationRanges(), args.samples, args.seed))
    timestep_s = float(robot.model.opt.timestep)
    print(f"{len(jobs)} runs of {args.duration:g} s ({args.preset}, {args.samples} variations)")

    lanes_figures, lanes = None, None
    if not args.skip_lanes:
        lanes_evaluator = BatchEvaluator(robot, threads=args.threads)
        t0 = time.perf_counter()
        lanes = lanes_evaluator.evaluate(jobs, duration_s=args.duration, warmup_s=args.warmup)
        lanes_s = time.perf_counter() - t0
        lanes_steps = lanes_evaluator.frames_rolled * lanes_evaluator.steps_per_frame
        print(f"lanes ({lanes_evaluator.threads} threads): {lanes_s:.1f} s")
        lanes_figures = {
            "threads": lanes_evaluator.threads,
            "wall_s": lanes_s,
            "steps": lanes_steps,
            "steps_per_s": lanes_steps / lanes_s,
            "runs_per_s": len(jobs) / lanes_s,
        }

    warp_evaluator = WarpEvaluator(robot, device=args.device)
    t0 = time.perf_counter()
    warp = warp_evaluator.evaluate(jobs, duration_s=args.duration, warmup_s=args.warmup)
    warp_s = time.perf_counter() - t0
    compile_s = warp_evaluator.compile_s or 0.0
    warp_steps = warp_evaluator.world_steps
    steady_s = warp_evaluator.stage_s["step"] - compile_s
    print(f"warp ({args.device}): {warp_s:.1f} s, of which the first step {compile_s:.1f} s")
    if warp_evaluator.graph_error:
        print(f"warp: frames stepped by hand, not replayed: {warp_evaluator.graph_error}")

    agree = agreement(warp, lanes) if lanes is not None else None
    figures = {
        "runs": len(jobs),
        "sim_s_per_run": args.duration,
        "timestep_s": timestep_s,
        "cpu_cores": os.cpu_count(),
        **device_info(warp_evaluator),
        "lanes": lanes_figures,
        "warp": {
            "wall_s": warp_s,
            "first_step_s": compile_s,
            "cold_cache": cold,
            "frame_graph": warp_evaluator.graph_error is None and warp_evaluator.device.is_cuda,
            "graph_error": warp_evaluator.graph_error,
            "steps": warp_steps,
            "steps_per_s": warp_steps / warp_s,
            "end_to_end_s_compiled": warp_s - compile_s,
            "end_to_end_steps_per_s_compiled": warp_steps / (warp_s - compile_s),
            "steady_steps_per_s": warp_steps / steady_s if steady_s > 0 else None,
            "runs_per_s": len(jobs) / warp_s,
            "stage_s": warp_evaluator.stage_s,
        },
        "agreement": agree,
    }
    if agree is not None:
        for key, row in agree["metrics"].items():
            tolerance = row["tolerance"]
            print(f"  {key}: median {row['median']}, max {row['max']} (tolerance {tolerance})")
        print(f"falls differ: {agree['falls_differ']}; verdicts differ: {agree['verdicts_differ']}")
    headline = {
        "worlds": len(jobs),
        "warp wall s": warp_s,
        "warp s (end to end, compiled)": warp_s - compile_s,
        "warp steps/s (end to end, compiled)": figures["warp"]["end_to_end_steps_per_s_compiled"],
        "warp steps/s (steady)": figures["warp"]["steady_steps_per_s"],
        "lanes steps/s": lanes_figures["steps_per_s"] if lanes_figures else None,
        "warp first step s": compile_s,
        "pass verdicts differing": len(agree["verdicts_differ"]) if agree else None,
    }
    results.write("bench_gpu", args, figures, headline)


if __name__ == "__main__":
    main()
