"""`artro bench paper|robust`: the papers' cases and seed 004's curve walks against what the
papers measured (tables, PNGs, results.json), or the paper's cases on N varied robots with the
pass share per case (docs/DESIGN.md §12). Not to be confused with `bench/`, the benchmarks."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from app.cli.options import (
    MAX_DURATION_S,
    MAX_SAMPLES,
    add_backend_options,
    add_cluster_options,
    add_range_option,
    add_robot_option,
    add_threads_option,
    backend_of,
    check_timing,
    cluster_of,
    nonempty,
    number,
    output_folder,
    ranges_from,
    resolve_sets,
    subcommand,
)

PAPER_OUT = Path("out/bench-paper")
ROBUST_OUT = Path("out/bench-robust")
ROBUST_DURATION_S = 20.0
ROBUST_SAMPLES = 200
EXAMPLES = """examples:
  artro bench paper                        paper, tuned and pfs, 60 s runs (~5 min on 2 cores)
  artro bench paper --quick --presets tuned
  artro bench robust --presets tuned --samples 100 --seed 1
  artro bench robust --presets tuned-artro,my_gait.json    a saved preset and a file"""


def add_parser(sub: Any) -> None:
    parser = subcommand(
        sub,
        "bench",
        "simulate what the papers measured and compare (tables, PNGs); or the paper's cases on "
        "varied robots",
        command,
        EXAMPLES,
    )
    parser.add_argument(
        "suite",
        choices=["paper", "robust"],
        help="which bench: 'paper' (the papers' figures, docs/DESIGN.md §12) or 'robust' (the "
        "paper's cases on model variations, §12)",
    )
    parser.add_argument(
        "--presets",
        type=nonempty("--presets"),
        default=None,
        metavar="NAME|FILE,...",
        help="parameter sets, each a built-in or saved preset's name or a parameter-set file "
        "(default: paper,tuned,pfs; robust: tuned)",
    )
    parser.add_argument(
        "--duration",
        type=number(0, MAX_DURATION_S, above=True, what="--duration"),
        metavar="S",
        help="simulated seconds per run (default: paper 60, --quick 10; robust 20)",
    )
    parser.add_argument(
        "--warmup",
        type=number(0, MAX_DURATION_S, what="--warmup"),
        metavar="S",
        help="seconds not measured (default: 5; --quick 2)",
    )
    robust = parser.add_argument_group("bench robust")
    robust.add_argument(
        "--samples",
        type=number(1, MAX_SAMPLES, integer=True, what="--samples"),
        default=None,
        metavar="N",
        help=f"variations (1 to {MAX_SAMPLES}; default {ROBUST_SAMPLES})",
    )
    robust.add_argument(
        "--seed",
        type=number(0, 2**32 - 1, integer=True, what="--seed"),
        default=None,
        help="of the variations drawn (default 0)",
    )
    add_range_option(robust, "")
    robust.add_argument("--json", action="store_true", help="print the report as one JSON object")

    parser.add_argument(
        "--out",
        type=output_folder,
        default=None,
        metavar="DIR",
        help=f"where the PNGs and results.json go (default {PAPER_OUT}, {ROBUST_OUT}; "
        f"another robot's robust report: {ROBUST_OUT}-ROBOT)",
    )
    add_threads_option(parser, "rollout threads", "all cores, <= 8")
    add_cluster_options(
        parser, "run on this Dask scheduler (docs/CLUSTER.md) instead of local threads"
    )
    add_backend_options(parser)
    parser.add_argument(
        "--quick", action="store_true", help="short runs and a coarse CA sweep (smoke test)"
    )
    add_robot_option(parser)


def command(args: argparse.Namespace) -> int:
    if args.suite == "robust":
        return robust(args)
    robust_only = {"--samples": args.samples, "--seed": args.seed, "--range": args.range or None,
                   "--json": args.json or None}  # fmt: skip
    if given := [name for name, value in robust_only.items() if value is not None]:
        raise ValueError(
            f"{', '.join(given)}: options of bench robust; bench paper runs the paper's cases "
            "on the model itself and writes its figures to --out (results.json)"
        )
    from app.study.paper_bench import run_paper_bench  # the studies load when run, not for --help
    from app.study.runs import QUICK, BenchConfig

    config = replace(QUICK if args.quick else BenchConfig(), **backend_of(args))
    if args.duration is not None:
        config = replace(config, duration_s=args.duration)
    if args.warmup is not None:
        config = replace(config, warmup_s=args.warmup)
    if args.robot is not None:
        config = replace(config, robot=args.robot)
    config = replace(config, **cluster_of(args))
    if args.threads is not None:
        config = replace(config, threads=args.threads)
    specs = preset_specs(args.presets, "paper,tuned,pfs", config.duration_s, config.warmup_s)
    run_paper_bench(specs, config, args.out or PAPER_OUT)
    return 0


def preset_specs(text: str | None, default: str, duration_s: float, warmup_s: float) -> list[str]:
    """`--presets` as the benches take them, each checked by `resolve_sets`: a built-in name as
    typed, a saved preset or a file as its path; ValueError names the presets there are, or a
    run that leaves one of them no whole gait cycle to measure after the warm-up."""
    chosen = resolve_sets(text or default)
    for c in chosen:
        check_timing((), c.pset.gait, duration_s, warmup_s)
    return [c.spec if c.builtin else str(c.path) for c in chosen]


def robust(args: argparse.Namespace) -> int:
    from app.analysis.robust_cases import ROBUST_CASES
    from app.analysis.robustness import run_robust
    from app.analysis.servo_advice import advised_robot
    from app.evaluation import close_evaluator, evaluator_for
    from app.evaluation.progress import progress_printer
    from app.robots.model import RobotModel
    from app.robots.swap import write_description
    from app.study.robust_report import render, write_plot
    from app.study.walks import resolve_presets

    duration = ROBUST_DURATION_S if args.duration is None else args.duration
    warmup = 5.0 if args.warmup is None else args.warmup
    args.samples = ROBUST_SAMPLES if args.samples is None else args.samples
    args.seed = 0 if args.seed is None else args.seed
    ranges = ranges_from(args.range, duration)
    specs = preset_specs(args.presets, "tuned", duration, warmup)
    presets, notes = resolve_presets(specs)
    if not presets:
        raise ValueError(f"no presets to run (asked for {specs}): {'; '.join(notes)}")
    robot = RobotModel.load(args.robot)
    evaluator = evaluator_for(
        robot,
        threads=args.threads,
        **cluster_of(args),
        **backend_of(args),
    )
    n_runs = len(presets) * (args.samples + 1) * len(ROBUST_CASES)
    progress = progress_printer(
        f"bench robust: {n_runs} runs of {duration:g} s ({', '.join(p.name for p in presets)} "
        f"on {args.samples} variation{'' if args.samples == 1 else 's'} of {robot.name}, "
        f"seed {args.seed}) ..."
        + (
            f"\n{robot.name} is fitted to a recording: the nominal runs walk its fit, the "
            "variations are drawn about it, narrowed to its uncertainty (docs/FIT.md)"
            if robot.description.fitted
            else ""
        ),
        sys.stderr,
        label="bench robust",
    )
    try:
        results = run_robust(
            [(p.name, p.params, p.name if p.name in specs else p.source) for p in presets],
            evaluator,
            samples=args.samples,
            seed=args.seed,
            ranges=ranges,
            duration_s=duration,
            warmup_s=warmup,
            progress=progress,
            robot_arg=None if args.robot is None else str(args.robot),
        )
    finally:
        close_evaluator(evaluator)
    # each robot's report a folder of its own: the next robot's would replace it
    default = ROBUST_OUT if robot.name == "artro" else Path(f"{ROBUST_OUT}-{robot.name}")
    out = args.out or default
    out.mkdir(parents=True, exist_ok=True)
    for report in results["presets"]:  # the robot with the servos the report advises
        advice = report["servo_advice"]
        swapped = None if advice is None else advised_robot(robot.description, advice)
        if swapped is None:
            continue
        path = write_description(swapped, out / f"{swapped.name}.yaml")
        advice["robot_file"] = str(path)
        advice["command"] = (
            f"artro bench robust --robot {path} --presets {','.join(specs)} "
            f"--samples {args.samples} --seed {args.seed}"
        )
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
