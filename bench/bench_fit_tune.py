"""Benchmark: does a gait tuned on a fitted robot pass more on the hidden robot than the same
tune on the nominal one (docs/FIT.md §5)? A hidden robot (its variation the fit is not told)
records the identify routine; `artro fit` fits it; `artro tune --robust` runs twice from the
same base with the same budget and seed, once on the fitted robot (ranges centred on the fit)
and once on the nominal (the default ranges); then `artro bench robust` walks both tuned sets
and the base on the hidden robot (its variation as a description's fit, ranges narrowed to the
fit's goal precision around it) and counts the runs that pass. Every step is the command a
builder would type.

    python bench/bench_fit_tune.py [--robust 4] [--generations 4] [--popsize 6] [--samples 20]

Writes bench/results/bench_fit_tune.json (or --json PATH); keeps its files in --work.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import results

from app.robots.fitted import Fitted, write_fitted
from app.robots.model import RobotModel

#: a robot the `robust` preset is not made for: weak slow servos, a heavy trunk, a floor
#: tilted sideways (each inside the default ranges, docs/DESIGN.md §8)
HIDDEN = (
    "latency_ms=35,kp_scale=0.85,torque_scale=0.8,trunk_mass_scale=1.15,tilt_deg=2.5,"
    "tilt_direction_deg=90,imu_tilt_bias_deg=0.4,imu_tilt_direction_deg=30,"
    "gyro_bias_deg_s=0.2,gyro_noise_deg_s=0.1"
)
ARTRO = [sys.executable, "-m", "app.cli"]


def artro(*args: str, ok: tuple[int, ...] = (0,)) -> str:
    """Run `artro ARGS` and return its standard output (its progress shown as it goes)."""
    print("$ artro " + shlex.join(args), flush=True)
    done = subprocess.run([*ARTRO, *args], stdout=subprocess.PIPE, text=True, check=False)
    if done.returncode not in ok:
        raise SystemExit(f"artro {args[0]} exited {done.returncode}")
    return done.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--hidden", default=HIDDEN, help="the hidden variation (default: HIDDEN)")
    parser.add_argument("--base", default="robust", help="the tunes' start (default: robust)")
    parser.add_argument("--budget", type=int, default=160, help="the fit's (default: 160)")
    parser.add_argument("--robust", type=int, default=4, help="variations a tune (default: 4)")
    parser.add_argument("--generations", type=int, default=4, help="a tune's (default: 4)")
    parser.add_argument("--popsize", type=int, default=6, help="a tune's (default: 6)")
    parser.add_argument("--samples", type=int, default=20, help="bench robust's (default: 20)")
    parser.add_argument("--seed", type=int, default=1, help="tunes' and bench's (default: 1)")
    parser.add_argument(
        "--work", default="out/bench-fit-tune", help="its files (default: out/bench-fit-tune)"
    )
    args = results.parse_args(parser)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rec, fitted, hidden = work / "rec.json", work / "rec-fitted.yaml", work / "hidden.yaml"
    seconds: dict[str, float] = {}

    def timed(step: str, *command: str, ok: tuple[int, ...] = (0,)) -> str:
        start = time.perf_counter()
        out = artro(*command, ok=ok)
        seconds[step] = time.perf_counter() - start
        return out

    timed("record", "run", "--script", "identify", "--record", str(rec), "--vary", args.hidden)
    summary = json.loads(
        timed("fit", "fit", str(rec), "-o", str(fitted), "--budget", str(args.budget),
              "--json", ok=(0, 1)).splitlines()[-1]
    )  # fmt: skip
    robot = RobotModel.load()
    write_fitted(robot.description, Fitted(variation=args.hidden, routine="truth"), hidden)
    tune = ["--base", args.base, "--robust", str(args.robust), "--seed", str(args.seed),
            "--generations", str(args.generations), "--popsize", str(args.popsize)]  # fmt: skip
    sets = {"on_fit": work / "tuned-on-fit.json", "on_nominal": work / "tuned-on-nominal.json"}
    timed("tune_on_fit", "tune", *tune, "--robot", str(fitted), "-o", str(sets["on_fit"]))
    timed("tune_on_nominal", "tune", *tune, "-o", str(sets["on_nominal"]))
    presets = [str(sets["on_fit"]), str(sets["on_nominal"]), args.base]
    report = json.loads(
        timed("bench", "bench", "robust", "--robot", str(hidden), "--presets", ",".join(presets),
              "--samples", str(args.samples), "--seed", str(args.seed), "--json", ok=(0, 1))
    )  # fmt: skip
    # the report's presets come in the order asked
    passed = {name: tally(entry) for name, entry in zip(
        ("on_fit", "on_nominal", "base"), report["presets"], strict=True)}  # fmt: skip
    for name, row in passed.items():
        print(f"{name}: {row['passed']} of {row['runs']} runs pass on the hidden robot", flush=True)
    figures = {
        "hidden": args.hidden,
        "fit": {k: summary.get(k) for k in ("converged", "fields", "replays", "why_not")},
        "passed": passed,
        "seconds": seconds,
        "cpus": os.cpu_count(),
    }
    headline = {
        "tuned_on_fit_passed": passed["on_fit"]["passed"],
        "tuned_on_nominal_passed": passed["on_nominal"]["passed"],
        "base_passed": passed["base"]["passed"],
        "runs": passed["base"]["runs"],
        "fit_converged": bool(summary.get("converged")),
    }
    results.write("bench_fit_tune", args, figures, headline)


def tally(entry: dict[str, Any]) -> dict[str, Any]:
    """A preset's passing runs in a `bench robust --json` report, in all and per case."""
    cases = {c["case"]: c["passed"] for c in entry["cases"]}
    runs = sum(c["runs"] for c in entry["cases"])
    return {"passed": sum(cases.values()), "runs": runs, "cases": cases, "name": entry["preset"]}


if __name__ == "__main__":
    main()
