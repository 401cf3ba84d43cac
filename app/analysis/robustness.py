"""Will a gait walk on the real robot (`artro bench robust`, the dashboard's robustness job)?
Each preset walks the paper's cases and CA = ±0.1 forward on N model variations drawn with a seed;
per case the share that passes with its 95 % interval, the parameter failures depend on most,
and the worst variations, each repeatable with `artro run --vary` (docs/DESIGN.md §12)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from app.analysis.failure_dependence import dependence, wilson
from app.analysis.robust_cases import (
    PASS_RULE,
    ROBUST_CASES,
    case_figure,
    figure_metric,
    nominal_walks,
    passes,
)
from app.analysis.servo_advice import servo_advice, torque_bound
from app.evaluation import Evaluator, Job
from app.worlds.fitted import fitted_ranges, fitted_variation
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import FIELDS, NOMINAL, Variation
from gait import GaitParams

WORST = 5  # the worst variations a report names, each with its command


def jobs_for(
    gait: GaitParams, variations: Sequence[Variation], base: Variation = NOMINAL
) -> list[Job]:
    """The nominal runs of every case (on a fitted robot: its fit, `base`), then every
    variation's, case by case."""
    nominal = [Job(gait, c.motion, variation=base) for c in ROBUST_CASES]
    return nominal + [Job(gait, c.motion, variation=v) for v in variations for c in ROBUST_CASES]


def summarise(
    name: str,
    variations: Sequence[Variation],
    metrics: Sequence[Mapping[str, Any]],
    *,
    repeat: str = "artro run",
    stall_nm: Sequence[float] | None = None,
) -> dict[str, Any]:
    """One preset's report from its `jobs_for` metrics; `repeat` starts the command that
    repeats a worst variation's first failed case. With each servo's stall torque `stall_nm`
    (JOINT_NAMES order), each case says which servos' torque holds its failures back
    (`torque_bound`)."""
    n_cases = len(ROBUST_CASES)
    nominal, varied = metrics[:n_cases], metrics[n_cases:]
    grid = [varied[i * n_cases : (i + 1) * n_cases] for i in range(len(variations))]
    cases = []
    shortfall = np.zeros(len(variations))
    failures = np.zeros(len(variations), dtype=int)
    for k, case in enumerate(ROBUST_CASES):
        ok = [passes(case, row[k], nominal[k]) for row in grid]
        failures += ~np.array(ok, dtype=bool)
        goal = case_figure(case, nominal[k]) or 0.0
        for i, row in enumerate(grid):
            value = case_figure(case, row[k])
            if row[k]["fell"] or value is None:
                shortfall[i] += 2.0
            elif case.kind != "spot" and goal:
                shortfall[i] += max(0.0, 1.0 - value / goal)
        lo, hi = wilson(sum(ok), len(ok))
        cases.append(
            {
                "case": case.name,
                "motion": f"{case.motion.a_r:g},{case.motion.a_p:g},{case.motion.a_y:g}",
                "ca": case.motion.ca,
                "metric": figure_metric(case),
                "nominal": case_figure(case, nominal[k]),
                "nominal_fell": nominal[k]["fell"],
                "nominal_walks": nominal_walks(case, nominal[k]),
                "passed": sum(ok),
                "runs": len(ok),
                "share": sum(ok) / len(ok) if ok else 0.0,
                "interval": [lo, hi],
                "falls": sum(row[k]["fell"] for row in grid),
                "depends_on": dependence(variations, [not o for o in ok]),
                "torque": torque_bound(
                    [row[k] for row, o in zip(grid, ok, strict=True) if not o],
                    [row[k] for row, o in zip(grid, ok, strict=True) if o],
                    nominal[k],
                    stall_nm,
                    [v.torque_scale for v, o in zip(variations, ok, strict=True) if not o],
                ),
            }
        )
    order = sorted(range(len(variations)), key=lambda i: (-failures[i], -shortfall[i], i))
    worst = []
    for i in order[:WORST]:
        failed = [c for k, c in enumerate(ROBUST_CASES) if not passes(c, grid[i][k], nominal[k])]
        if not failed:
            continue
        m = failed[0].motion
        worst.append(
            {
                "variation": variations[i].name,
                "failed_cases": len(failed),
                "failed": [c.name for c in failed],
                "motion": {"a_r": m.a_r, "a_p": m.a_p, "a_y": m.a_y, "ca": m.ca},  # the first's
                "command": f"{repeat} --motion a_p={m.a_p:g},a_r={m.a_r:g},a_y={m.a_y:g},"
                f"ca={m.ca:g} --vary {variations[i].name}",
            }
        )
    every = sum(c["passed"] for c in cases) / max(1, sum(c["runs"] for c in cases))
    return {"preset": name, "cases": cases, "worst": worst, "overall_share": every}


def run_robust(
    presets: Sequence[tuple[str, GaitParams, str]],
    evaluator: Evaluator,
    *,
    samples: int,
    seed: int,
    ranges: VariationRanges,
    duration_s: float,
    warmup_s: float,
    progress: Callable[[int, int], None] | None = None,
    cancel: threading.Event | None = None,
    robot_arg: str | None = None,
) -> dict[str, Any]:
    """Every preset (name, gait, file) on the same `samples` variations (one evaluation call, so
    the threads or workers stay busy); the report as a JSON-ready dict, the same to the bit for a
    seed. `robot_arg` is the robot as the worst runs' `artro run --robot` gets it (default its
    name; the description's path for a robot from a file)."""
    base = fitted_variation(evaluator.robot)  # a fitted robot: ranges centred on its fit
    drawn = fitted_ranges(evaluator.robot, ranges)
    variations = sample(drawn, samples, seed)
    all_jobs: list[Job] = []
    for _, gait, _ in presets:
        all_jobs += jobs_for(gait, variations, base)
    metrics = evaluator.evaluate(
        all_jobs, duration_s=duration_s, warmup_s=warmup_s, progress=progress, cancel=cancel
    )
    per = len(all_jobs) // max(1, len(presets))
    robot = evaluator.robot
    stall = np.abs(robot.model.actuator_forcerange[robot.actuator_ids, 1]).tolist()
    reports = [
        summarise(
            name,
            variations,
            metrics[i * per : (i + 1) * per],
            repeat=f"artro run --robot {robot_arg or robot.name} --params {source} "
            f"--duration {duration_s:g} --warmup {warmup_s:g}",
            stall_nm=stall,
        )
        for i, (name, _, source) in enumerate(presets)
    ]
    for report in reports:
        report["servo_advice"] = servo_advice(report, robot.description, stall)
    return {
        "robot": evaluator.robot.name,
        "samples": samples,
        "seed": seed,
        "duration_s": duration_s,
        "warmup_s": warmup_s,
        "ranges": {f: list(getattr(drawn, f)) for f in FIELDS},
        "fitted": base.to_text() if evaluator.robot.description.fitted else None,
        "pass_rule": PASS_RULE,
        "presets": reports,
    }
