"""`artro tune`'s options and their defaults: the start's recipe without `--base`, the classic
search with it (`app.cli.tune` runs the tune)."""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path
from typing import Any

from app.analysis.robot_start import START_RECIPE
from app.cli.options import (
    MAX_DURATION_S,
    MAX_SAMPLES,
    SETS_HELP,
    add_backend_options,
    add_cluster_options,
    add_range_option,
    add_robot_option,
    add_threads_option,
    nonempty,
    number,
    output_file,
    output_problem,
    study_location,
    subcommand,
)
from app.study.tune_space import DEFAULT_NAMES, tunable_fields

EXAMPLES = """examples:
  artro tune --robot my.yaml       the start for my.yaml, tuned to walk; saved as tuned-my
  artro tune --base paper --tune swing.v,short.amp_base --generations 4 --popsize 6
  artro tune --base paper --set leg.paper_signs=false --select passing --name unsigned
  artro tune --base my_gait.json --robot my.yaml       a file; the result: tuned-ROBOT
  artro tune --base tuned --robust 8 --tune tilt.ki_per_s,yaw_rate.kp,swing.v (gains, gait)"""
DEFAULT_OUT = "out/tune/NAME.json"
#: the values of the search options left out when `--base` is given (before issue 32 item 4,
#: always); without `--base` they are START_RECIPE's
CLASSIC = {
    "tune": ",".join(DEFAULT_NAMES),
    "generations": 30,
    "popsize": 10,
    "sigma": 0.12,
    "duration": 20.0,
    "warmup": 4.0,
    "band_weight": 0.0,
    "select": "best",
}
RECIPE = {
    "tune": ",".join(START_RECIPE.names),
    "generations": START_RECIPE.generations,
    "popsize": START_RECIPE.popsize,
    "sigma": START_RECIPE.sigma,
    "duration": START_RECIPE.duration_s,
    "warmup": START_RECIPE.warmup_s,
    "band_weight": START_RECIPE.band_weight,
    "select": START_RECIPE.select,
}


def defaults_help(key: str) -> str:
    """How an option's default reads in --help: the recipe's without --base, else the classic."""
    return f"(default: {RECIPE[key]} without --base, the start's recipe; {CLASSIC[key]} with it)"


def tunable_help() -> str:
    """The epilog's list of what `--tune` accepts, one group a line."""
    lines = ["what --tune accepts (GROUP.FIELD; each within its schema range):"]
    for group, fields in tunable_fields().items():
        lines += textwrap.wrap(
            ", ".join(fields),
            width=78,
            initial_indent=f"  {group + ':':10s}",
            subsequent_indent=" " * 12,
        )
    return "\n".join(lines)


def add_parser(sub: Any, command: Any) -> None:
    """`artro tune`'s options, `command` its handler (`app.cli.tune.command`)."""
    parser = subcommand(
        sub,
        "tune",
        "CMA-ES over gait parameters toward the paper's walking",
        command,
        f"{EXAMPLES}\n\n{tunable_help()}",
    )
    parser.add_argument(
        "--base",
        default=None,
        metavar="FILE|NAME",
        help=f"the set to start from: {SETS_HELP} (default: the built-in preset nearest the "
        "robot's leg length, its clock scaled by sqrt(L_ref/L), tuned by the start's recipe, "
        "saved among the presets; docs/DESIGN.md §12)",
    )
    add_robot_option(parser)
    parser.add_argument(
        "--cases",
        type=nonempty("--cases"),
        default=None,
        metavar="NAME,...",
        help="judge only these paper cases (e.g. forward,backward) and the CA pairs at their "
        "speed; default: all of them",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="GROUP.FIELD=VALUE",
        help="change the base before tuning, e.g. leg.paper_signs=false or engine=pfs (repeatable)",
    )
    parser.add_argument(
        "--tune",
        default=None,
        metavar="GROUP.FIELD,...",
        help=f"comma-separated parameters to tune (the list below) {defaults_help('tune')}",
    )
    whole = {"integer": True}
    parser.add_argument(
        "--generations",
        type=number(1, 100_000, **whole, what="generations"),
        default=None,
        help=f"CMA-ES generations {defaults_help('generations')}",
    )
    parser.add_argument(
        "--popsize",
        type=number(2, 1000, **whole, what="popsize"),
        default=None,
        help=f"candidates per generation (CMA-ES needs 2 or more) {defaults_help('popsize')}",
    )
    parser.add_argument(
        "--sigma",
        type=number(0, 1, above=True, what="sigma"),
        default=None,
        help=f"initial step, share of range {defaults_help('sigma')}",
    )
    parser.add_argument(
        "--duration",
        type=number(0, MAX_DURATION_S, above=True, what="duration"),
        default=None,
        help="simulated s per case; at least one gait cycle longer than --warmup "
        f"{defaults_help('duration')}",
    )
    parser.add_argument(
        "--warmup",
        type=number(0, MAX_DURATION_S, what="warmup"),
        default=None,
        help=f"simulated s per case not measured {defaults_help('warmup')}",
    )
    parser.add_argument(
        "--seed",
        type=number(0, 2**32 - 1, **whole, what="seed"),
        default=1,
        help="of CMA-ES and of the --robust variations",
    )
    parser.add_argument(
        "--band-weight",
        type=number(0, 1000, what="band weight"),
        default=None,
        help="extra penalty per case for errors beyond 20 %% (the tolerance is 25 %%) "
        f"{defaults_help('band_weight')}",
    )
    parser.add_argument(
        "--steering-weight",
        type=number(0, 1000, what="steering weight"),
        default=1.0,
        help="scale of the CA steering terms (gain toward eq (13), bend) in the loss",
    )
    parser.add_argument(
        "--cross-talk-weight",
        type=number(0, 1000, what="cross-talk weight"),
        default=0.2,
        help="weight of unwanted rotation while translating and translation while turning",
    )
    add_threads_option(parser)
    parser.add_argument(
        "--study",
        type=study_location,
        default="out/tune/study.log",
        metavar="FILE|URL",
        help="the study store: an Optuna journal file (default out/tune/study.log) or an RDB URL "
        "such as sqlite:///tune.db; an interrupted study resumes from it, optuna-dashboard opens "
        "it; one tune writes it at a time (docs/DESIGN.md §12)",
    )
    parser.add_argument(
        "--study-name",
        default=None,
        help="the study within the store (default: tune-ROBOT-DIGEST of the options: the same "
        "command resumes it, a tune of another size or robot starts its own)",
    )
    parser.add_argument(
        "--robust",
        type=number(0, MAX_SAMPLES, integer=True, what="--robust"),
        default=0,
        metavar="N",
        help="also score each candidate on N model variations, the same for a whole generation "
        "and drawn anew each generation; the loss adds the worst family's (spot, "
        "forward/backward, sideways, turning, curves) missed passes and worst quarter of pass "
        "margins (default 0: none)",
    )
    parser.add_argument(
        "--robust-weight",
        type=number(0, 1000, what="--robust-weight"),
        default=1.0,
        help="weight of that term (default 1.0)",
    )
    parser.add_argument(
        "--keep-base",
        type=number(0, 1000, what="--keep-base"),
        default=0.0,
        metavar="W",
        help="with --robust, also walk the base set in each generation's worlds and add W times "
        "how far each case family's pass share falls below the base's there, summed: a gain "
        "in the worst family cannot buy a loss in another (default 0: not walked; decision "
        "0070)",
    )
    parser.add_argument(
        "--torque-weight",
        type=number(0, 1000, what="--torque-weight"),
        default=0.5,
        help="with --robust, weight of eq (1)'s torque margin on the nominal runs: a gait whose "
        "servos ask more than stall / 1.2, or sit at their limit, costs more (default 0.5; "
        "decision 0062)",
    )
    add_range_option(parser, " for --robust")
    add_cluster_options(parser, "evaluate on this Dask scheduler (docs/CLUSTER.md)")
    add_backend_options(parser)
    parser.add_argument(
        "-o",
        "--out",
        type=output_file,
        default=None,
        metavar="FILE",
        help=f"the chosen set, as a preset file (default: {DEFAULT_OUT} with --base; without "
        "it, saved among the presets only)",
    )
    parser.add_argument(
        "--name",
        default=None,
        help="the name the chosen set is given, never a built-in's (read-only) "
        "(default: tuned-ROBOT, e.g. tuned-artro)",
    )
    parser.add_argument(
        "--select",
        choices=("best", "passing", "steering", "walking"),
        default=None,
        help="save the lowest loss; the lowest loss that meets every paper criterion; or of "
        "those, the one CA steers most (forward); or the lowest loss that never fell "
        f"{defaults_help('select')}",
    )
    parser.add_argument(
        "--events",
        type=events_file,
        default=None,
        metavar="FILE|-",
        help="also write what happens as JSON lines to FILE ('-': standard output): start, "
        "runs, each trial with the best loss so far, the result with its figures (the "
        'dashboard\'s "Tune for this robot" reads them; default: none)',
    )


def events_file(text: str) -> str:
    """An argparse type: `-` (standard output) or a file to write the events to, checked before
    the work; a device or a pipe is written as it is (line by line, never replaced)."""
    if text == "-":
        return text
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty file name; give the file to write, or -")
    if problem := output_problem(Path(text), devices=True):
        raise argparse.ArgumentTypeError(f"{text} {problem}")
    return text
