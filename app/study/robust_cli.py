"""`artro bench robust` on the command line: presets, robot, variations and where to run them
in; the report to the terminal (or JSON), results.json, report.md and robust.png in --out."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from app.core.evaluation import evaluator_for
from app.core.robot import RobotModel
from app.core.robustness import ROBUST_CASES, run_robust
from app.core.variations import VariationRanges, parse_range
from app.study.bench import progress_printer
from app.study.robust_report import render, write_plot
from app.study.runs import resolve_presets

DEFAULT_OUT = Path("out/bench-robust")
DURATION_S = 20.0


def add_range_option(parser: Any, purpose: str) -> None:
    """`--range NAME=LOW:HIGH` (repeatable), read by `ranges_from`."""
    parser.add_argument(
        "--range",
        action="append",
        default=[],
        metavar="NAME=LOW:HIGH",
        help=f"narrow or widen one variation range{purpose}, e.g. friction=0.3:0.6 (repeatable)",
    )


def ranges_from(texts: list[str]) -> VariationRanges:
    ranges = VariationRanges()
    for text in texts:
        ranges = ranges.with_range(*parse_range(text))
    return ranges


def cmd_robust(args: argparse.Namespace) -> int:
    if args.samples < 1:
        raise ValueError(f"--samples must be >= 1, got {args.samples}")
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    duration = DURATION_S if args.duration is None else args.duration
    warmup = 5.0 if args.warmup is None else args.warmup
    if not duration > warmup >= 0:
        raise ValueError(f"need duration > warm-up >= 0 s, got {duration:g} and {warmup:g}")
    ranges = ranges_from(args.range)
    specs = [s.strip() for s in (args.presets or "tuned").split(",") if s.strip()]
    presets, notes = resolve_presets(specs)
    if not presets:
        raise ValueError(f"no presets to run (asked for {specs}): {'; '.join(notes)}")
    robot = RobotModel.load(args.robot)
    evaluator = evaluator_for(robot, cluster=args.cluster, threads=args.threads)
    n_runs = len(presets) * (args.samples + 1) * len(ROBUST_CASES)
    progress = progress_printer(
        f"bench robust: {n_runs} runs of {duration:g} s ({', '.join(p.name for p in presets)} "
        f"on {args.samples} variations of {robot.name}, seed {args.seed}) ...",
        sys.stderr,
        label="bench robust",
    )
    results = run_robust(
        [(p.name, p.params, p.name if p.name in specs else p.source) for p in presets],
        evaluator,
        samples=args.samples,
        seed=args.seed,
        ranges=ranges,
        duration_s=duration,
        warmup_s=warmup,
        progress=progress,
    )
    out = args.out or DEFAULT_OUT
    out.mkdir(parents=True, exist_ok=True)
    text = json.dumps(results, indent=1, allow_nan=False)
    (out / "results.json").write_text(text + "\n", encoding="utf-8")
    (out / "report.md").write_text(render(results, markdown=True) + "\n", encoding="utf-8")
    plot = write_plot(results, out / "robust.png")
    if args.json:
        print(json.dumps(results, allow_nan=False))
    else:
        print(render(results))
        print(f"\nwritten to {out}: results.json, report.md, {plot.name}")
    return 0
