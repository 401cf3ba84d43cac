"""`artro calibrate-ca`: fit the steering term K (`steer.yaw_per_ca`, walking forward and
backward) and the effective axle b_eff of a gait from short curve walks (docs/DESIGN.md §4)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import Any

from app.analysis.axle_fit import MIN_A_P, walking_amplitude
from app.analysis.ca_calibration import CalibrationError, calibrate_ca, with_k
from app.cli.options import (
    MAX_DURATION_S,
    add_backend_options,
    add_cluster_options,
    add_params_option,
    add_robot_option,
    add_threads_option,
    backend_of,
    check_timing,
    cluster_of,
    number,
    output_file,
    robot_and_set,
    subcommand,
)
from app.evaluation import close_evaluator, evaluator_for
from app.params.formats import export_text
from gait import ENGINES

EXAMPLES = """examples:
  artro calibrate-ca                       the robot's default preset, both ways at |a_p| 0.07
  artro calibrate-ca --params tuned -o tuned_steered.json"""


def add_parser(sub: Any) -> None:
    c = subcommand(
        sub,
        "calibrate-ca",
        "fit the steering term K (steer.yaw_per_ca) and the effective axle b_eff from curve walks",
        command,
        EXAMPLES,
    )
    add_params_option(c)
    add_robot_option(c)
    c.add_argument(
        "--engine",
        choices=ENGINES,
        default=None,
        help="gait engine to calibrate (default: the parameter set's)",
    )
    c.add_argument(
        "--a-p",
        type=number(-1, 1, what="--a-p"),
        default=None,
        help=f"sagittal amplitude to walk at, |a_p| >= {MIN_A_P:g}; its sign names the direction "
        f"(default: the set's, or 0.07 where the set walks slower than {MIN_A_P:g})",
    )
    c.add_argument(
        "--duration",
        type=number(0, MAX_DURATION_S, above=True, what="--duration"),
        default=20.0,
        metavar="S",
        help="seconds per walk; at least one gait cycle longer than --warmup",
    )
    c.add_argument(
        "--warmup",
        type=number(0, MAX_DURATION_S, what="--warmup"),
        default=4.0,
        metavar="S",
        help="seconds not measured",
    )
    c.add_argument(
        "--iterations",
        type=number(1, 20, integer=True, what="--iterations"),
        default=2,
        help="checks of a fitted K (default 2)",
    )
    c.add_argument(
        "--direction",
        choices=("forward", "backward", "both"),
        default="both",
        help="which K to fit: walking forward (steer.yaw_per_ca), backward "
        "(steer.yaw_per_ca_backward), or both (default; a given --a-p picks its own)",
    )
    add_threads_option(c)
    add_cluster_options(c, "evaluate on this Dask scheduler (docs/CLUSTER.md)")
    add_backend_options(c)
    c.add_argument(
        "-o",
        "--output",
        type=output_file,
        metavar="FILE",
        help="write the parameter set with K here (default: nothing written)",
    )
    c.add_argument("--json", action="store_true", help="print the result as one JSON object")


def command(args: argparse.Namespace) -> int:
    if args.a_p is not None and abs(args.a_p) < MIN_A_P:
        raise ValueError(
            f"--a-p {args.a_p:g} is too short a step to steer with: allowed |a_p| >= {MIN_A_P:g}"
        )
    wanted = {"forward": 1.0, "backward": -1.0}.get(args.direction)
    if args.a_p is not None and wanted is not None and args.a_p * wanted < 0:
        raise ValueError(
            f"--a-p {args.a_p:g} walks the other way than --direction {args.direction}: give "
            "the amplitude's size, or its sign alone (without --direction)"
        )
    robot, pset = robot_and_set(args)
    gait = pset.gait if args.engine is None else dataclasses.replace(pset.gait, engine=args.engine)
    check_timing((), gait, args.duration, args.warmup)  # a whole cycle to measure
    motion = pset.motion if args.a_p is None else dataclasses.replace(pset.motion, a_p=args.a_p)
    size = abs(walking_amplitude(motion))
    signs = {"forward": (1.0,), "backward": (-1.0,), "both": (1.0, -1.0)}[args.direction]
    if args.a_p is not None and args.direction == "both":
        signs = (1.0 if args.a_p >= 0 else -1.0,)  # a given a_p names its direction
    log = sys.stderr if args.json else sys.stdout
    if gait.yaw_rate.enabled:  # the fit still holds, but K is not what makes CA steer here
        print(
            f"note: {pset.name!r} has the yaw-rate loop on: it turns a_y and CA into turn-rate "
            "commands (CA's by eq (13)) and steers to them itself, so K is a feed-forward under "
            "the loop and matters little; calibrate with yaw_rate off to fit the open-loop gait",
            file=log,
        )
    evaluator = evaluator_for(
        robot,
        threads=args.threads,
        **cluster_of(args),
        **backend_of(args),
    )
    results, failed = {}, {}
    try:
        for sign in signs:
            a_p, direction = sign * size, "forward" if sign > 0 else "backward"
            try:
                result = calibrate_ca(
                    gait,
                    dataclasses.replace(motion, a_p=a_p),
                    evaluator,
                    duration_s=args.duration,
                    warmup_s=args.warmup,
                    iterations=args.iterations,
                    say=lambda line: print(line, file=log, flush=True),
                )
            except CalibrationError as exc:
                if len(signs) == 1:
                    raise
                failed[direction] = str(exc)  # the other direction may still calibrate
                print(f"{direction}: no calibration, K left as it was: {exc}", file=log, flush=True)
                continue
            gait = with_k(gait, a_p, result.yaw_per_ca)
            results[direction] = result
    finally:
        close_evaluator(evaluator)
    if not results:
        raise CalibrationError("; ".join(f"{d}: {e}" for d, e in failed.items()))
    if args.output:
        out = dataclasses.replace(pset, gait=gait, created="", project_version="")
        text, _media, _name = export_text(out, "json")
        Path(args.output).write_text(text, encoding="utf-8")
    if args.json:
        document = {d: r.to_dict() for d, r in results.items()}
        document |= {d: {"error": e} for d, e in failed.items()}
        print(json.dumps(document, allow_nan=False))
        return 0

    def cm(m: float | None) -> str:
        if m is None:
            return "none (CA does not turn it)"
        return f"{100 * m:.1f} cm" + (" (CA turns it the other way)" if m < 0 else "")

    for direction, result in results.items():
        print(
            f"{direction}: steer.{result.field} = K = {result.yaw_per_ca:+.4f} for {pset.name!r} "
            f"({gait.engine}) at a_p = {result.a_p:+.3f}: CA turns it at "
            f"{100 * result.gain:.0f} % of eq (13)"
            + ("" if result.converged else " (not within 10 %)")
        )
        print(
            f"  b_eff = {cm(result.axle_eff_m)} with K (feet {100 * result.feet_m:.1f} cm apart; "
            f"without K: {cm(result.axle_eff_without_m)}), V = {100 * result.speed_m_s:.2f} cm/s, "
            f"{result.sim_s:.0f} s simulated"
        )
    if args.output:
        print(f"wrote {args.output}")
    return 0
