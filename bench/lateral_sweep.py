"""Experiment: the lateral settings of decision 0061 on the sideways cases alone (quick).

Walks `robust` and variants of it (each --variant a list of GROUP.FIELD=VALUE, comma separated,
on top of the preset) through `bench robust`'s two sideways cases on the same variations of the
stock robot, judged by its pass rule (`app.analysis.robust_cases.passes`), and prints each
variant's pass share per way, the nominal model's speed, and its falls.

    python bench/lateral_sweep.py [--preset robust] [--samples 20] [--seed 0] \
        [--variant timing.enabled=true,timing.swing_rad=0.074 ...] [--json PATH]

Writes the shares to bench/results/lateral_sweep.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse

import results

from app.analysis.robust_cases import MAX_TURN_DEG_S, PASS_SHARE, ROBUST_CASES, passes
from app.evaluation import BatchEvaluator, Job
from app.robots.model import RobotModel
from app.study.walks import resolve_presets
from app.worlds.sampling import VariationRanges, sample
from gait.params import merge, parse_settings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="robust", help="preset name or file (default robust)")
    parser.add_argument("--samples", type=int, default=20, help="variations (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="of the variations (default 0)")
    parser.add_argument("--duration", type=float, default=20.0, help="seconds a run (default 20)")
    parser.add_argument(
        "--variant", action="append", default=[],
        help="GROUP.FIELD=VALUE,... on top of the preset (repeatable; default: none)",
    )  # fmt: skip
    args = results.parse_args(parser)
    (preset,), _notes = resolve_presets([args.preset])
    cases = [c for c in ROBUST_CASES if c.kind == "lateral"]
    variations = sample(VariationRanges(), args.samples, args.seed)
    variants = {"(preset)": preset.params}
    for text in args.variant:
        variants[text] = merge(preset.params, parse_settings(text.split(",")))
    jobs = []
    for gait in variants.values():
        jobs += [Job(gait, c.motion) for c in cases]
        jobs += [Job(gait, c.motion, variation=v) for v in variations for c in cases]
    metrics = BatchEvaluator(RobotModel.load(), threads=2).evaluate(
        jobs, duration_s=args.duration, warmup_s=5.0
    )
    per = len(cases) * (1 + len(variations))
    figures = {}
    for i, name in enumerate(variants):
        block = metrics[i * per : (i + 1) * per]
        nominal, varied = block[: len(cases)], block[len(cases) :]
        row = {}
        for k, case in enumerate(cases):
            runs = varied[k :: len(cases)]
            ok = sum(passes(case, m, nominal[k]) for m in runs)
            goal = abs(nominal[k]["lateral_cm_s"])
            way = 1.0 if nominal[k]["lateral_cm_s"] > 0 else -1.0
            walked = [m for m in runs if not m["fell"]]
            row[case.name] = {
                "pass_share": ok / len(runs), "falls": sum(m["fell"] for m in runs),
                "nominal_cm_s": nominal[k].get("lateral_cm_s"),
                # why the others failed: too slow sideways, or turning on the way
                "slow": sum(m["lateral_cm_s"] * way < PASS_SHARE * goal for m in walked),
                "turning": sum(abs(m["turn_deg_s"]) > MAX_TURN_DEG_S for m in walked),
            }  # fmt: skip
        figures[name] = row
        text = "  ".join(
            f"{c}: {r['pass_share']:.0%} ({r['falls']} falls, {r['slow']} slow, "
            f"{r['turning']} turning; nominal {r['nominal_cm_s']:+.2f} cm/s)"
            for c, r in row.items()
        )
        print(f"{name}: {text}")
    headline = {
        f"{name} {case} pass": r["pass_share"]
        for name, row in figures.items()
        for case, r in row.items()
    }
    results.write("lateral_sweep", args, figures, headline)


if __name__ == "__main__":
    main()
