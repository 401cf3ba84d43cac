"""Benchmark: the batch evaluator's throughput against raw mj_step, nominal and with variations.

Prints, for the same 10 s walks (a_p = 0.07, CA spread over -0.1..0.1), once on the nominal
model and once with every walk on its own sampled variation:
  - the machine's ceiling: N processes (N = os.cpu_count()) at once, each replaying its share
    of the very same walks with MuJoCo's own C loop -- each walk on its own (varied) model, the
    control it ends each frame with written at the frame's start, mj_step(nstep=20), no Python
    between steps, up to the frame its measurement ends (a fall) -- in total, and raw's steps
    per CPU second;
  - BatchEvaluator.evaluate with N lanes, end to end (planning the gait + hardware for every
    step, the rollout, measuring), the rollout alone, and its steps per CPU second;
  - ProcessEvaluator.evaluate with N worker processes of one MuJoCo thread each, end to end;
  - the closed loop: --closed-runs varied walks (a study's call; a lane steps up to 128
    closed-loop runs of one gait in lockstep) with every law on and with `robust`'s laws, CPU
    per simulated second against the same walks open loop measured before and after (goal <=
    1.1), with `robust`'s laws also on the worker processes (wall time: a walk's runs go to them
    as whole groups), and its floor: the open loop's control rolled out a frame a `rollout` call
    against 50 frames a call;
  - the goals: end to end >= 0.95 of that ceiling, and >= 0.9 of raw's steps per CPU second,
    each measurement against the mean of the ceilings measured just before and just after it
    (ceiling, batch, ceiling, processes, ceiling: a machine whose speed drifts biases neither);
    and the CPU seconds per stage.
Steps are the steps the walks' measurements need (a walk that falls needs none after its fall;
the evaluator stops rolling it out at the end of that call, and the steps it rolls out beyond
the fall count as its loss); the share of all steps the falls spare is printed too.
The varied models are built once before (a robust study reuses each for every case). Raw
mj_step on one thread (4 nominal walks) shows what one core does. Steps per CPU second
stay meaningful when other processes compete for the cores (the wall-clock ratio then only
says how many were free).

A call of 64 walks (the default) leaves a lane idle at its end for under 1 % of the call;
`bench robust` and `tune` evaluate whole generations (hundreds of runs) in one call.

    python bench/bench_batch.py [--seconds 10] [--runs 64] [--repeats 6]   # ~14 min on 2 cores
        [--closed-runs 128] [--json PATH]

Writes every figure (per kind, nominal and varied: the ceiling, batch and processes, each
repeat's ratio to the ceilings around it, the stages) to bench/results/<bench>.json, or to
--json PATH (bench/results.py). The measurements themselves are bench/batch_measures.py's.
"""

from __future__ import annotations

import argparse
import os
import statistics

import results
from batch_measures import (
    CEILING_GOAL,
    CLOSED_GOAL,
    CPU_GOAL,
    batch_steps_per_s,
    bracketed,
    concurrent_raw,
    cpu_s_per_sim_s,
    cpu_times,
    needed_frames,
    planning_alone_ms,
    processes_steps_per_s,
    raw_pool,
    raw_replay,
    rollout_cpu_s,
    say,
    steal_share,
    walks,
    wall_s_per_sim_s,
    with_laws,
)

from app.evaluation import BatchEvaluator
from app.evaluation._lanes import SEGMENT_FRAMES
from app.evaluation._processes import ProcessEvaluator
from app.params.presets import builtin_presets
from app.sim.planning import FRAME_S
from gait import feedback
from gait.params import LAW_GROUPS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per walk")
    parser.add_argument("--runs", type=int, default=64, help="walks per evaluate call")
    parser.add_argument("--repeats", type=int, default=6)
    parser.add_argument(
        "--closed-runs", type=int, default=128,
        help="varied walks per evaluate call for the closed loop against the open (a study's "
        "call: a lane steps up to 128 closed-loop runs of one gait at once; 128 on two lanes: "
        "two groups of 64)",
    )  # fmt: skip
    args = results.parse_args(parser)
    n_threads = os.cpu_count() or 1
    kinds = {"nominal": walks(args.runs), "varied": walks(args.runs, varied=True)}
    frames = round(args.seconds / FRAME_S)
    load_before, counters_before = os.getloadavg()[0], cpu_times()
    single: list[tuple[int, float, float]] = []
    evaluators = {k: BatchEvaluator(threads=n_threads) for k in kinds}
    batch: dict[str, list[tuple[float, float, float, float]]] = {k: [] for k in kinds}
    in_processes: dict[str, list[float]] = {k: [] for k in kinds}
    workers = ProcessEvaluator(processes=n_threads)
    workers.evaluate(kinds["varied"][:n_threads], duration_s=0.5, warmup_s=0.2)  # start, load
    needed: dict[str, list[int]] = {}
    for kind, jobs in kinds.items():  # builds the varied models once (a study reuses each)
        needed[kind] = needed_frames(evaluators[kind], jobs, args.seconds)
        evaluators[kind].stage_s = dict.fromkeys(evaluators[kind].stage_s, 0.0)
        evaluators[kind].frames_rolled = 0
    #: per kind and repeat: the ceilings (steps/s, per CPU s) before the batch, between the
    #: batch and the processes, and after the processes
    ceilings: dict[str, list[list[tuple[float, float]]]] = {k: [] for k in kinds}
    pool = raw_pool(n_threads)
    for repeat in range(args.repeats):  # interleaved, so machine load affects all alike
        say(f"throughput, repeat {repeat + 1} of {args.repeats}")
        one_core = kinds["nominal"][:4]
        single.append(raw_replay(one_core, [frames] * len(one_core)))
        for kind, jobs in kinds.items():  # the ceiling replays the very runs around them
            need = needed[kind]
            around = [concurrent_raw(jobs, need, n_threads, pool)]
            batch[kind].append(batch_steps_per_s(evaluators[kind], jobs, args.seconds, need))
            around.append(concurrent_raw(jobs, need, n_threads, pool))
            in_processes[kind].append(processes_steps_per_s(workers, jobs, args.seconds, need))
            around.append(concurrent_raw(jobs, need, n_threads, pool))
            ceilings[kind].append(around)
    pool.close()
    pool.join()
    steal = steal_share(counters_before, cpu_times())

    print(
        f"model: artro (generated), timestep {evaluators['nominal'].model.opt.timestep * 1e3:g} ms"
    )
    print(
        f"{args.runs} walks of {args.seconds:g} s (a_p = 0.07, CA -0.1..0.1), "
        f"{args.repeats} repeats, medians; {n_threads} CPU(s), load average before "
        f"{load_before:.2f}, after {os.getloadavg()[0]:.2f}"
        + ("" if steal is None else f"; CPU time stolen by the hypervisor {100 * steal:.1f} %")
    )
    wall_rate = statistics.median(steps / wall for steps, wall, _cpu in single)
    cpu_rate = statistics.median(steps / cpu for steps, _wall, cpu in single)
    figures: dict = {
        "threads": n_threads,
        "timestep_ms": evaluators["nominal"].model.opt.timestep * 1e3,
        "load_average_before": load_before,
        "load_average_after": os.getloadavg()[0],
        "cpu_stolen_pct": None if steal is None else 100 * steal,
        "goals": {"of_ceiling": CEILING_GOAL, "of_raw_per_cpu_s": CPU_GOAL},
        "raw_one_thread": {
            "walks": 4,
            "steps_per_s": wall_rate,
            "steps_per_cpu_s": cpu_rate,
        },
        "kinds": {},
    }
    print(
        f"raw mj_step, 1 thread (C loop), 4 nominal walks: {wall_rate:8.0f} steps/s wall, "
        f"{cpu_rate:8.0f} per CPU s"
    )
    for kind, measured in batch.items():
        ceiling = statistics.median(c[0] for around in ceilings[kind] for c in around)
        raw_cpu = statistics.median(c[1] for around in ceilings[kind] for c in around)
        falls = sum(n < frames for n in needed[kind])
        rolled = evaluators[kind].frames_rolled / (args.repeats * sum(needed[kind]))
        print(
            f"{kind:7s}: {falls} of {len(needed[kind])} walks fall, their measurements need "
            f"{100 * sum(needed[kind]) / (frames * len(needed[kind])):.1f} % of all steps; the "
            f"evaluator rolls out {rolled:.3f} times that (a fall's call runs to its end)"
        )
        print(
            f"raw mj_step, {kind:7s}, the same walks in {n_threads} processes at once (the "
            f"ceiling): {ceiling:8.0f} steps/s, {raw_cpu:8.0f} per CPU s"
        )
        e2e, roll, per_cpu, busy = (statistics.median(r[i] for r in measured) for i in range(4))
        # side by side: each repeat's batch against the ceilings measured around it
        pairs = sorted(
            bracketed(r[0], c[0][0], c[1][0]) for r, c in zip(measured, ceilings[kind], strict=True)
        )
        cpu_pairs = sorted(
            bracketed(r[2], c[0][1], c[1][1]) for r, c in zip(measured, ceilings[kind], strict=True)
        )
        runs = args.repeats * len(kinds[kind])
        per_run = ", ".join(
            f"{k} {1e3 * v / runs:.1f} ms" for k, v in evaluators[kind].stage_s.items()
        )
        planning_ms = planning_alone_ms(kinds[kind], args.seconds)
        print(
            f"batch, {kind:7s}, {n_threads} threads: {e2e:8.0f} steps/s end to end = "
            f"{statistics.median(pairs):.3f} of the ceiling (repeats {pairs[0]:.3f}…"
            f"{pairs[-1]:.3f}; goal >= {CEILING_GOAL}), rollout alone {roll:8.0f}; "
            f"{per_cpu:8.0f} per CPU s = {statistics.median(cpu_pairs):.3f} of raw's (repeats "
            f"{cpu_pairs[0]:.3f}…{cpu_pairs[-1]:.3f}; goal >= {CPU_GOAL}); per run in a lane: "
            f"{per_run}; planning alone {planning_ms:.1f} ms; "
            f"lanes busy {100 * busy:.1f} % of the call"
        )
        batch_figures = {
            "steps_per_s": e2e,
            "of_ceiling": statistics.median(pairs),
            "of_ceiling_repeats": pairs,
            "rollout_steps_per_s": roll,
            "steps_per_cpu_s": per_cpu,
            "of_raw_per_cpu_s": statistics.median(cpu_pairs),
            "of_raw_per_cpu_s_repeats": cpu_pairs,
            "stage_ms_per_run": {k: 1e3 * v / runs for k, v in evaluators[kind].stage_s.items()},
            "planning_alone_ms": planning_ms,
            "lanes_busy_pct": 100 * busy,
        }
        pairs = sorted(
            bracketed(p, c[1][0], c[2][0])
            for p, c in zip(in_processes[kind], ceilings[kind], strict=True)
        )
        figures["kinds"][kind] = {
            "walks": len(needed[kind]),
            "falls": falls,
            "needed_steps_pct": 100 * sum(needed[kind]) / (frames * len(needed[kind])),
            "rolled_of_needed": rolled,
            "ceiling": {"processes": n_threads, "steps_per_s": ceiling, "steps_per_cpu_s": raw_cpu},
            "batch": batch_figures,
            "processes": {
                "workers": n_threads,
                "steps_per_s": statistics.median(in_processes[kind]),
                "of_ceiling": statistics.median(pairs),
                "of_ceiling_repeats": pairs,
            },
        }
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
    # the closed loop: --closed-runs varied walks with every law on, and with `robust`'s laws,
    # against the same walks open loop, CPU per simulated second (a run that falls stops: per
    # second keeps them comparable); and its floor, the open loop's control rolled out a frame
    # a call
    robust_laws = tuple(feedback.laws_on(builtin_presets()["robust"].gait))
    loops = {"every law": LAW_GROUPS, "robust's laws": robust_laws}
    open_jobs = walks(args.closed_runs, varied=True)
    closed_jobs = {
        name: [with_laws(j, groups) for j in open_jobs] for name, groups in loops.items()
    }
    ratios: dict[str, list[float]] = {name: [] for name in loops}
    floors = []
    # each closed-loop measurement against the mean of the open loop's measured just before and
    # just after it (open, closed..., open, closed..., open): a machine whose speed drifts
    # biases neither
    open_cpu = cpu_s_per_sim_s(evaluators["varied"], open_jobs, args.seconds)
    in_workers: list[float] = []
    open_wall = wall_s_per_sim_s(workers, open_jobs, args.seconds)
    for repeat in range(args.repeats):
        say(f"closed loop against open, repeat {repeat + 1} of {args.repeats}")
        closed_cpu = {
            name: cpu_s_per_sim_s(evaluators["varied"], jobs, args.seconds)
            for name, jobs in closed_jobs.items()
        }
        open_after = cpu_s_per_sim_s(evaluators["varied"], open_jobs, args.seconds)
        for name, cpu in closed_cpu.items():
            ratios[name].append(cpu / (0.5 * (open_cpu + open_after)))
        open_cpu = open_after
        # on worker processes (their CPU is not this process's: wall time, both cores busy),
        # `robust`'s laws against the open loop before and after, as above
        closed_wall = wall_s_per_sim_s(workers, closed_jobs["robust's laws"], args.seconds)
        open_wall_after = wall_s_per_sim_s(workers, open_jobs, args.seconds)
        in_workers.append(closed_wall / (0.5 * (open_wall + open_wall_after)))
        open_wall = open_wall_after
        floor_jobs = kinds["varied"][: max(2, len(kinds["varied"]) // 8)]
        floors.append(
            rollout_cpu_s(floor_jobs, frames, 1) / rollout_cpu_s(floor_jobs, frames, SEGMENT_FRAMES)
        )
    workers.close()
    figures["closed_loop"] = {
        "walks": len(open_jobs),
        "laws": {name: list(groups) for name, groups in loops.items()},
        "of_open": {name: statistics.median(r) for name, r in ratios.items()},
        "of_open_repeats": {name: sorted(r) for name, r in ratios.items()},
        "processes_robust_laws_wall_of_open": statistics.median(in_workers),
        "processes_robust_laws_wall_of_open_repeats": sorted(in_workers),
        "floor_one_frame_per_call_of_open": statistics.median(floors),
        "floor_repeats": sorted(floors),
        "goal_of_open_max": CLOSED_GOAL,
    }
    for name, r in ratios.items():
        print(
            f"closed loop, varied, {name} on: CPU per simulated s {statistics.median(r):.2f} "
            f"of the open loop's (repeats {min(r):.2f}…{max(r):.2f}; goal ≤ {CLOSED_GOAL})"
        )
    print(
        f"closed loop, varied, robust's laws on, {n_threads} worker processes: wall time per "
        f"simulated s {statistics.median(in_workers):.2f} of the open loop's (repeats "
        f"{min(in_workers):.2f}…{max(in_workers):.2f}; a walk's runs go as whole groups)"
    )
    print(
        f"closed loop's floor, the open loop's control a frame a rollout call: "
        f"{statistics.median(floors):.3f} of {SEGMENT_FRAMES} frames a call (repeats "
        f"{min(floors):.3f}…{max(floors):.3f}): what is left of the goal for the Python per frame"
    )
    headline = {}
    for name in loops:
        headline[f"closed loop, {name}: CPU of the open loop's (goal ≤ {CLOSED_GOAL})"] = figures[
            "closed_loop"
        ]["of_open"][name]
    headline["closed loop on worker processes, robust's laws: wall of the open loop's"] = figures[
        "closed_loop"
    ]["processes_robust_laws_wall_of_open"]
    headline["closed loop's floor: a frame a rollout call, CPU of the open loop's"] = figures[
        "closed_loop"
    ]["floor_one_frame_per_call_of_open"]
    for kind, k in figures["kinds"].items():
        headline[f"{kind}: batch end to end, of the ceiling (goal ≥ {CEILING_GOAL})"] = k["batch"][
            "of_ceiling"
        ]
        headline[f"{kind}: batch per CPU s, of raw's (goal ≥ {CPU_GOAL})"] = k["batch"][
            "of_raw_per_cpu_s"
        ]
        headline[f"{kind}: ceiling (steps/s)"] = k["ceiling"]["steps_per_s"]
    results.write("bench_batch", args, figures, headline)


if __name__ == "__main__":
    main()
