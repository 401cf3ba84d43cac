"""`artro fit REC.json --robot R`: fit the model to a recording of the identification routine
(docs/FIT.md): each field with its uncertainty, what the recording cannot tell, the residual
against the sensors' noise; writes the fitted robot and a report, and says how to tune on it."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from app.cli._compute_options import add_cluster_options, cluster_of
from app.cli.options import add_robot_option, number, output_file_of, subcommand
from app.evaluation.progress import about

EXAMPLES = """examples:
  artro run --script identify --record rec.json --vary latency_ms=20,kp_scale=0.9
                                          a simulated recording whose truth you know
  artro fit rec.json                      fit it on artro: rec-fitted.yaml, rec-fit/report.md
  artro fit rec.json --fix trunk_mass_scale=1.05      a field you measured, held
  artro fit rec.json --fields latency_ms,kp_scale --budget 60   fewer fields, a quicker fit
  artro fit rec.json --cluster tcp://10.0.0.5:8786   the replays on a Dask cluster
  artro tune --robot rec-fitted.yaml      then tune on the fitted robot

exit status: 0 fitted, 1 the fit did not converge (the nominal kept, the report written),
2 bad input (a recording that cannot be fitted says why)"""


def add_parser(sub: Any) -> None:
    from app.study.fit_space import DEFAULT_FIELDS, FIELDS

    p = subcommand(
        sub,
        "fit",
        "fit the model to a recording of your robot (artro link --script identify)",
        command,
        EXAMPLES,
    )
    p.add_argument("recording", metavar="REC.json", help="a recording of the identify routine")
    add_robot_option(p)
    p.add_argument(
        "-o",
        "--output",
        type=output_file_of((".yaml", ".yml"), "a robot description"),
        default=None,
        metavar="FITTED.yaml",
        help="the fitted robot: the description with its fitted variation (default: REC-fitted.yaml"
        " beside the recording)",
    )
    p.add_argument(
        "--fields",
        default=",".join(DEFAULT_FIELDS),
        metavar="F,...",
        help=f"the fields to fit, of {', '.join(FIELDS)} (default: %(default)s)",
    )
    p.add_argument(
        "--fix",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="hold a field you know at its value, e.g. trunk_mass_scale=1.05 (repeatable; "
        "default: none)",
    )
    p.add_argument(
        "--budget",
        type=number(10, 5000, integer=True, what="budget"),
        default=160,
        help="replays of the routine the search may take (default: %(default)s)",
    )
    p.add_argument(
        "--workers",
        type=number(1, 64, integer=True, what="workers"),
        default=min(4, os.cpu_count() or 1),
        help="processes replaying at once (default: the cores, at most 4; with --cluster the "
        "cluster's workers instead)",
    )
    add_cluster_options(p, "replay on this Dask scheduler's workers (docs/CLUSTER.md)")
    p.add_argument(
        "--seed",
        type=number(0, 2**31 - 1, integer=True, what="seed"),
        default=1,
        help="CMA-ES's seed: one seed, one fit (default: %(default)s)",
    )
    p.add_argument("--json", action="store_true", help="print the fit as one JSON object")


def command(args: argparse.Namespace) -> int:
    from app.analysis import identify_record
    from app.robots.model import RobotModel
    from app.study import fit_space
    from app.study.fit import fit
    from app.study.fit_report import fitted_robot, summary, write_report

    fields = fit_space.parse_fields(args.fields)
    fixed = fit_space.parse_fixed(args.fix)
    held = {c for f in fixed.departures() for c in fit_space.FIELDS.get(_field_of(f), ())}
    fields = tuple(f for f in fields if not set(fit_space.FIELDS[f]) & held)
    path = Path(args.recording)
    recording = identify_record.read(path)
    robot = RobotModel.load(args.robot)
    identify_record.check_robot(recording, robot.name, robot.total_mass_kg(), str(path))
    out = Path(args.output) if args.output else path.with_name(path.stem + "-fitted.yaml")
    report_dir = out.with_name(out.stem.removesuffix("-fitted") + "-fit")
    start = time.monotonic()

    def progress(done: float, total: float, loss: float) -> None:
        left = (time.monotonic() - start) / max(done, 1e-9) * (total - done)
        print(
            f"fit: {100 * done / total:.0f} % of the search, best loss {loss:.4f}, "
            f"{about(left)} left",
            file=sys.stderr,
            flush=True,
        )

    result = fit(
        recording,
        args.robot or "artro",
        fields=fields,
        fixed=fixed,
        budget=args.budget,
        workers=args.workers,
        seed=args.seed,
        progress=progress,
        **cluster_of(args),
    )
    fitted_robot(robot, result, recording, path, out)
    report = write_report(result, recording, report_dir, robot.name, out)
    if args.json:
        print(json.dumps(summary(result, recording) | {"fitted": str(out), "report": str(report)}))
    else:
        print(report.read_text(encoding="utf-8").split("\n## ", 2)[1].split("\n", 1)[1])
        print(f"fitted robot: {out}\nreport: {report}\ntune on it: artro tune --robot {out}")
    return 0 if result.converged else 1


def _field_of(name: str) -> str:
    """The --fields name a variation field belongs to."""
    return {
        "tilt_deg": "tilt",
        "tilt_direction_deg": "tilt",
        "imu_tilt_bias_deg": "imu_tilt_bias",
        "imu_tilt_direction_deg": "imu_tilt_bias",
    }.get(name, name)
