"""Which single departure from the model breaks a gait (docs/DESIGN.md §8): each variation
field alone at the ends of its default range (the tilt downhill in four directions, the
calibration error on every joint at once, both signs), every case of `artro bench robust`, and
whether it passes by `bench robust`'s rule, with the run's figure as a share of the nominal one.

    python bench/robust_factors.py [--presets paper,tuned] [--duration 20] [--warmup 4]
        [--robot artro] [--json PATH]

The random draws of `bench robust` mix ten departures at once; this shows what each one alone
costs, which is where a robust gait has to give something up. Writes its figures (per preset
and departure: every case's figure, its share of the nominal one, pass or fall) to
bench/results/<bench>.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import results

from app.analysis.robust_cases import ROBUST_CASES, case_figure, passes
from app.evaluation import BatchEvaluator, Job
from app.evaluation.progress import progress_printer
from app.params.formats import load_parameter_set
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.worlds.sampling import VariationRanges
from app.worlds.variations import NOMINAL, PHYSICS_FIELDS, Variation
from gait import JOINT_NAMES


def one_factor_worlds(ranges: VariationRanges | None = None) -> list[Variation]:
    """Every field alone at each end of its range that departs from the model. The fields of the
    compiled model and the set-points only (docs/DESIGN.md §8): the sensors' errors and a push
    act on what the sensors read and on the trunk, not on the model."""
    ranges = ranges or VariationRanges()
    worlds = []
    for f in dataclasses.fields(Variation):
        if f.name not in PHYSICS_FIELDS:
            continue
        if f.name in ("tilt_direction_deg", "tilt_deg", "calibration_deg"):
            continue
        for end in getattr(ranges, f.name):
            if end != (0.7 if f.name == "friction" else f.default):
                worlds.append(dataclasses.replace(NOMINAL, **{f.name: end}))
    tilt = ranges.tilt_deg[1]
    worlds += [Variation(tilt_deg=tilt, tilt_direction_deg=d) for d in (0.0, 90.0, 180.0, 270.0)]
    for end in ranges.calibration_deg:
        worlds.append(Variation(calibration_deg=(end,) * len(JOINT_NAMES)))
    return worlds


def label(world: Variation) -> str:
    if world.imu_tilt_bias_deg:
        toward = {0.0: "ahead", 90.0: "left", 180.0: "behind", 270.0: "right"}
        return f"IMU tilted {world.imu_tilt_bias_deg:g}° {toward[world.imu_tilt_direction_deg]}"
    if world.tilt_deg:
        downhill = {0.0: "ahead", 90.0: "left", 180.0: "behind", 270.0: "right"}
        return f"tilt {world.tilt_deg:g}°, downhill {downhill[world.tilt_direction_deg]}"
    if any(world.calibration_deg):
        return f"calibration {world.calibration_deg[0]:+g}° on every joint"
    return world.to_text().replace("=", " ")


def main() -> None:
    measure("robust_factors", one_factor_worlds(), __doc__, "paper,tuned")


def measure(bench: str, worlds: list[Variation], doc: str, presets: str) -> None:
    """Every case of `bench robust` on each of `worlds` and the nominal model, for each of
    --presets, judged as `bench robust` judges; printed as a table, written as `bench`'s."""
    parser = argparse.ArgumentParser(description=doc.split("\n")[0])
    parser.add_argument("--presets", default=presets, help="built-in names or files")
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--warmup", type=float, default=4.0)
    parser.add_argument("--robot", default="artro", help="a built-in name or a description")
    args = results.parse_args(parser)
    shelf = builtin_presets()
    evaluator = BatchEvaluator(RobotModel.load(args.robot))
    short = ["spot", "fwd", "bwd", "side R", "side L", "turn CW", "turn CCW", "CA+", "CA-"]
    presets: dict[str, dict] = {}
    for name in [n.strip() for n in args.presets.split(",") if n.strip()]:
        gait = (shelf[name] if name in shelf else load_parameter_set(name)).gait
        jobs = [Job(gait, c.motion, variation=w) for w in [NOMINAL, *worlds] for c in ROBUST_CASES]
        progress = progress_printer(
            f"{bench}: {name}, {len(jobs)} runs of {args.duration:g} s ...",
            sys.stderr,
            label=bench,
        )
        metrics = evaluator.evaluate(
            jobs, duration_s=args.duration, warmup_s=args.warmup, progress=progress
        )
        n = len(ROBUST_CASES)
        nominal = metrics[:n]
        print(f"\n{name}: each departure alone; a cell is the run's figure as a share of the")
        print("nominal one (the spot: its drift in cm/s), x = does not pass, F = falls")
        print(f"{'':34s}" + "".join(f"{s:>9s}" for s in short) + "   pass")
        rows = []
        for k, world in enumerate(worlds):
            runs = metrics[(k + 1) * n : (k + 2) * n]
            cells, passed, data = [], 0, []
            for case, m, home in zip(ROBUST_CASES, runs, nominal, strict=True):
                ok = passes(case, m, home)
                passed += ok
                value, goal = case_figure(case, m), case_figure(case, home)
                share = None
                if m["fell"]:
                    cells.append("F")
                elif value is None or goal is None:
                    cells.append("-")
                elif case.kind == "spot":
                    cells.append(f"{value:.2f}" + ("" if ok else " x"))
                else:
                    share = value / goal
                    cells.append(f"{share:.2f}" + ("" if ok else " x"))
                data.append(
                    {
                        "case": case.name,
                        "kind": case.kind,
                        "figure": None if m["fell"] else value,  # cm/s or deg/s, by kind
                        "nominal_figure": goal,
                        "share_of_nominal": share,  # the spot: none, its figure is its drift
                        "passes": ok,
                        "fell": m["fell"],
                    }
                )
            print(f"{label(world):34s}" + "".join(f"{c:>9s}" for c in cells) + f"   {passed}/{n}")
            rows.append(
                {"departure": label(world), "variation": world.to_text(), "passed": passed,
                 "cases": data}
            )  # fmt: skip
        presets[name] = {
            "departures": rows,
            "passed": sum(r["passed"] for r in rows),
            "runs": n * len(rows),
            "departures_all_pass": sum(r["passed"] == n for r in rows),
        }
    figures = {"case_labels": short, "presets": presets}
    headline = {}
    for name, p in presets.items():
        headline[f"{name}: runs passing (of {p['runs']})"] = p["passed"]
        headline[f"{name}: departures passing every case (of {len(worlds)})"] = p[
            "departures_all_pass"
        ]
    results.write(bench, args, figures, headline)


if __name__ == "__main__":
    main()
