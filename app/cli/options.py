"""What several `artro` commands share: argument types that say what is allowed, the `--robot`,
`--range`, `--vary` and `--motion` options, the robot and parameter set a command starts with
(a file or a preset's name), and the subcommand layout (help with defaults, examples, `handler`)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TextIO

from app.cli._motion import MOTION_HELP, MOTION_METAVAR, MotionChoice, motion_arg
from app.cli._sets import SETS_HELP, ChosenSet, preset_names, resolve_set, resolve_sets
from app.params.document import ParameterSet
from app.params.presets import (
    PresetStore,
    builtin_presets,
    default_data_dir,
    name_too_long,
    not_a_file,
)
from app.robots.model import RobotModel
from app.worlds.sampling import VariationRanges, parse_range
from app.worlds.variations import Variation, parse_variation
from gait import GaitParams, Motion
from gait.params import describe_fields, group_class

MAX_DURATION_S = 3600.0  # one simulated hour per run at most
MAX_SAMPLES = 100_000  # variations of a robust bench or of a robust tune's generation at most
ROBOT_HELP = "the robot: a built-in name (artro, ...) or a description .yaml (default: artro)"
_NUMBERS = re.compile(r"^-\d*\.?\d+(e[-+]?\d+)?(,[-+]?\d*\.?\d+(e[-+]?\d+)?)*$", re.IGNORECASE)

Handler = Callable[[argparse.Namespace], int]
__all__ = [  # from the private modules, for the commands
    "MOTION_HELP",
    "MOTION_METAVAR",
    "SETS_HELP",
    "ChosenSet",
    "MotionChoice",
    "motion_arg",
    "preset_names",
    "resolve_set",
    "resolve_sets",
]


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and examples as written; each option's help ends with its default unless
    the help already says it. A default that is not a plain value (None, an object) is for the
    help text to explain; flags are off and required options have none."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            not action.option_strings
            or "default" in text.lower()
            or default is argparse.SUPPRESS
            or action.required
            or isinstance(default, bool)
            or not isinstance(default, str | int | float | list)
        ):
            return text
        shown = "none" if default == [] else "%(default)s"
        return f"{text} (default: {shown})" if text else f"default: {shown}"


def use_help_formatter(parser: argparse.ArgumentParser) -> None:
    """`HelpFormatter` for `parser` and every subcommand and action parser below it."""
    parser.formatter_class = HelpFormatter
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                use_help_formatter(child)


def subcommand(
    sub: Any, name: str, help_text: str, handler: Handler, examples: str | None = None
) -> argparse.ArgumentParser:
    """A command of `artro`: its help, its examples under --help, and the `handler` `main`
    calls with the parsed arguments."""
    parser = sub.add_parser(
        name,
        help=help_text,
        description=help_text,
        epilog=examples,
        formatter_class=HelpFormatter,
    )
    parser.set_defaults(handler=handler)
    return parser


def action(sub: Any, name: str, help_text: str, examples: str) -> argparse.ArgumentParser:
    """An action of a command (`artro robot check`): its help as the description, and its
    examples under --help."""
    return sub.add_parser(
        name, help=help_text, description=help_text, epilog=examples, formatter_class=HelpFormatter
    )


def join_negative_values(argv: Sequence[str]) -> list[str]:
    """`--motion -0.1,0,0` -> `--motion=-0.1,0,0`: argparse would take the value for an option."""
    out: list[str] = []
    for token in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NUMBERS.match(token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def number(
    low: float, high: float, *, integer: bool = False, above: bool = False, what: str = "it"
) -> Any:
    """An argparse type: a finite number from `low` (exclusive if `above`) to `high`; the error
    says what is allowed (argparse exits with status 2)."""
    kind = "a whole number " if integer else ""
    lo, hi = (f"{int(low)}", f"{int(high)}") if integer else (f"{low:g}", f"{high:g}")
    allowed = f"> {lo} and at most {hi}" if above else f"{lo} to {hi}"

    def parse(text: str) -> float | int:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value > high or (value <= low if above else value < low):
            raise argparse.ArgumentTypeError(f"{what} must be {kind}{allowed}, got {text!r}")
        return value

    return parse


def nonempty(what: str) -> Callable[[str], str]:
    """An argparse type: any text but an empty one (which would mean the default unsaid)."""

    def parse(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"{what} is empty; leave it out for its default")
        return text

    return parse


def output_file(text: str) -> str:
    """An argparse type: a file to write, checked before the work (`output_problem`)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty file name; give the file to write")
    if text == "-":
        raise argparse.ArgumentTypeError(
            "- is not a file name here: leave the option out for its default (standard output, "
            "where that is the default), or write ./- for a file named -"
        )
    if problem := output_problem(Path(text)):
        raise argparse.ArgumentTypeError(f"{text} {problem}")
    return text


def output_file_of(suffixes: Sequence[str], what: str) -> Callable[[str], str]:
    """An argparse type: an `output_file` whose name ends in one of `suffixes`, as what is
    written there (`what`, e.g. "a YAML description") is."""

    def parse(text: str) -> str:
        output_file(text)
        if Path(text).suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(
                f"{text}: this writes {what}; give a file ending in {' or '.join(suffixes)}"
            )
        return text

    return parse


def output_problem(path: Path, *, folder: bool = False, devices: bool = False) -> str | None:
    """Why nothing can be written at `path`, or None: the one check, before the work, of every
    option that names a file (or with `folder` a folder) to write. A name the file system
    refuses for its length; a folder where a file is meant, a file where a folder is; a device,
    pipe or socket unless `devices` (a temporary file renamed over one would replace it); a
    folder above that is a file; a read-only file (root would write over it); a place that
    cannot be looked at."""
    try:
        if problem := name_too_long(path):
            return problem
        if folder and path.exists() and not path.is_dir():
            return "is a file, not a folder"
        if not folder and path.is_dir():
            return "is a folder; give the file to write"
        if not (folder or devices) and (problem := not_a_file(path)):
            return f"{problem}; give the file to write"
        if inside_a_file(path):
            return "is inside a file, not a folder"
        if not folder and path.is_file() and _read_only(path):
            return "is a read-only file: give another file, or make it writable first"
    except OSError as exc:  # a folder above that cannot be searched
        return f"cannot be looked at ({exc.strerror or exc}); give a file in a folder of yours"
    return None


def _read_only(path: Path) -> bool:
    """Whether `path` is not to be written: no write permission for anyone, or none for this
    user (root may write anything, so the mode alone counts for it)."""
    return not (path.stat().st_mode & 0o222) or not os.access(path, os.W_OK)


def inside_a_file(path: Path) -> bool:
    """Whether a folder above `path` is a file, so nothing can be written there."""
    return any(up.exists() and not up.is_dir() for up in path.parents)


def host_name(text: str) -> str:
    """An argparse type: an address to listen on, not empty (uvicorn would take every
    interface)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty address; 0.0.0.0 listens on every interface")
    return text


def output_folder(text: str) -> Path:
    """An argparse type: a folder to write into, checked before the work (`output_problem`)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty folder name; give the folder to write into")
    path = Path(text)
    if problem := output_problem(path, folder=True):
        raise argparse.ArgumentTypeError(f"{text} {problem}")
    return path


def motion_number(name: str, option: str) -> Any:
    """An argparse type: a number in the range of the motion vector's field `name`
    (`gait.Motion`), the error naming `option` and that range."""
    meta = next(f.metadata for f in dataclasses.fields(Motion) if f.name == name)
    return number(meta["min"], meta["max"], what=option)


def add_threads_option(
    parser: Any, what: str = "simulation threads", default: str = "all cores"
) -> None:
    """`--threads N`: how many threads step the physics on this machine."""
    parser.add_argument(
        "--threads",
        type=number(1, 1024, integer=True, what="--threads"),
        default=None,
        metavar="N",
        help=f"{what} (default: {default})",
    )


def variation(text: str) -> Variation:
    """An argparse type: a variation's `key=value,...` text, not empty (leave it out for the
    nominal model)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty variation; leave it out for the nominal model")
    try:
        return parse_variation(text)
    except (ValueError, TypeError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cluster_address(text: str) -> str:
    """An argparse type: a Dask scheduler's tcp://HOST:PORT (or HOST:PORT), as tcp://HOST:PORT."""
    from app.evaluation._dask import ClusterError, check_address

    try:
        return check_address(text)
    except ClusterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def study_location(text: str) -> str:
    """An argparse type: a study journal file or an RDB URL of a known scheme (the form only)."""
    from app.study.study_store import check_location

    try:
        return check_location(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_cluster_options(parser: Any, purpose: str, *, wait: bool = True) -> None:
    """`--cluster tcp://HOST:PORT` (checked as it is parsed) and, with `wait`, `--wait-workers`."""
    parser.add_argument(
        "--cluster",
        type=cluster_address,
        metavar="tcp://HOST:PORT",
        help=f"{purpose} (default: none, this machine)",
    )
    if wait:
        parser.add_argument(
            "--wait-workers",
            type=number(0, 86_400, what="--wait-workers"),
            default=None,
            metavar="S",
            help="with --cluster: how long to wait for a worker when the scheduler has none "
            "(default 60 s; it says so at once), then give up with exit status 2",
        )


def add_backend_options(parser: Any) -> None:
    """`--backend cpu|warp|auto` and `--device cpu|cuda` (docs/GPU.md), read by `backend_of`;
    argparse refuses another value, naming those allowed (exit status 2)."""
    from app.evaluation import BACKENDS, DEVICES

    parser.add_argument(
        "--backend",
        choices=BACKENDS,
        default="cpu",
        help="who steps the physics: cpu (MuJoCo's threads, processes or --cluster; default), "
        "warp (every run of a call a world of one MuJoCo Warp batch; the gpu extra, "
        "docs/GPU.md) or auto (warp when a CUDA device and the extra are there)",
    )
    parser.add_argument(
        "--device",
        choices=DEVICES,
        default=None,
        help="with --backend warp: cuda (default) or cpu (Warp's CPU device: slow, for checks)",
    )


def cluster_of(args: argparse.Namespace) -> dict[str, Any]:
    """`--cluster` and `--wait-workers` as the evaluator's `cluster` and `wait_workers_s`;
    ValueError for --wait-workers without a cluster to wait for."""
    wait = getattr(args, "wait_workers", None)
    if wait is not None and args.cluster is None:
        raise ValueError("--wait-workers is how long to wait for a --cluster's workers; give both")
    return {"cluster": args.cluster, "wait_workers_s": wait}


def backend_of(args: argparse.Namespace) -> dict[str, Any]:
    """`evaluator_for`'s backend and device from `add_backend_options`' options; ValueError for
    --device without a backend that uses it."""
    if args.device is not None and args.backend == "cpu":
        raise ValueError(f"--device {args.device} is for --backend warp or auto, not cpu")
    if args.backend == "warp" and getattr(args, "cluster", None) is not None:
        raise ValueError("--backend warp runs in this process: leave out --cluster")
    return {"backend": args.backend, "device": args.device}


def add_range_option(parser: Any, purpose: str) -> None:
    """`--range NAME=LOW:HIGH` (repeatable), read by `ranges_from`."""
    parser.add_argument(
        "--range",
        action="append",
        default=[],
        metavar="NAME=LOW:HIGH",
        help=f"narrow or widen one variation range{purpose}, e.g. friction=0.3:0.6 (repeatable)",
    )


def ranges_from(texts: list[str], duration_s: float | None = None) -> VariationRanges:
    """The `--range` options as ranges; ValueError for a field given twice (as `--vary`), or
    for pushes that may be drawn after the end of runs of `duration_s` (`check_push_time`)."""
    ranges, seen = VariationRanges(), set()
    for text in texts:
        name, low, high = parse_range(text)
        if name in seen:
            raise ValueError(f"--range {name} given twice; give each field once")
        seen.add(name)
        ranges = ranges.with_range(name, low, high)
    low, high = ranges.push_time_s
    if duration_s is not None and ranges.push_n_s[1] > 0:
        given = "" if "push_time_s" in seen else f" (its default {low:g}:{high:g})"
        check_push_time(
            high, duration_s, f"--range push_time_s reaches {high:g} s{given}", "--range"
        )
    return ranges


def check_push_time(push_time_s: float, duration_s: float, what: str, option: str) -> None:
    """ValueError if a push at `push_time_s` comes at or after the end of a run of
    `duration_s`: it would never act, and the run would be taken for one that withstood it."""
    if push_time_s >= duration_s:
        raise ValueError(
            f"{what}: a push then comes after the run's end ({duration_s:g} s) and would never "
            f"act; allowed: {option} push_time_s below {duration_s:g} s, or longer runs"
        )


def check_pushed_variation(variation: Variation, duration_s: float, runs: str) -> None:
    """`check_push_time` for `--vary`'s push in a run of `duration_s` (`runs`: what sets it)."""
    if variation.push_n_s > 0:
        check_push_time(
            variation.push_time_s,
            duration_s,
            f"--vary push_time_s={variation.push_time_s:g} in a run of {runs}",
            "--vary",
        )


def add_params_option(
    parser: Any,
    default: str = "the --robot's default preset, or its newest tune where that preset was "
    "tuned for another robot: as the dashboard starts it",
) -> None:
    """`--params FILE|NAME`, read by `resolve_set` (or `robot_and_set`)."""
    parser.add_argument(
        "--params",
        type=nonempty("--params"),
        metavar="FILE|NAME",
        default=None,
        help=f"the parameter set: {SETS_HELP} (e.g. tuned) (default: {default})",
    )


def add_motion_option(parser: Any, default: str = "the parameter set's") -> None:
    """`--motion KEY=VALUE,...|AR,AP,AY` as a `MotionChoice`; `MotionChoice.applied` uses it."""
    parser.add_argument(
        "--motion",
        type=motion_arg,
        default=None,
        metavar=MOTION_METAVAR,
        help=f"{MOTION_HELP} (default: {default})",
    )


def add_robot_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", metavar="NAME|FILE", default=None, help=ROBOT_HELP)


def check_timing(
    names: Sequence[str], base: GaitParams, duration_s: float, warmup_s: float
) -> None:
    """Each run must leave at least one whole gait cycle after the warm-up (the metrics are
    measured over whole cycles): of the slowest clock the search may try (`names` are the
    parameters a tune varies). ValueError otherwise."""
    slowest, which = base.clock.freq_hz, "the clock"
    if "clock.freq_hz" in names:
        slowest = next(
            m["min"] for f, _d, m in describe_fields(group_class("clock")) if f == "freq_hz"
        )
        which = "the slowest clock the search may try (clock.freq_hz is tuned)"
    need = warmup_s + 1.0 / slowest
    if duration_s < need:
        raise ValueError(
            f"--duration {duration_s:g} leaves no whole gait cycle after --warmup {warmup_s:g}: "
            f"the runs are measured over whole cycles after the warm-up, and a cycle of {which}, "
            f"{slowest:g} Hz, takes {1.0 / slowest:g} s; allowed: --duration of at least {need:g}"
        )


def starting_set(robot: RobotModel, params: str | None, say: TextIO | None = None) -> ParameterSet:
    """The parameter set a command starts with: `params` (a file, or a built-in or saved
    preset's name: `resolve_set`), else the one the dashboard starts the robot in: its default
    preset (`robust` for ArtRo; the paper's values are `--params paper`), or the newest set
    saved for it where that preset was tuned for another robot (`PresetStore.start_for`). A set
    chosen so is named on `say` (standard error), with why it was chosen."""
    if params:
        return resolve_set(params, "--params").pset
    presets = builtin_presets()
    name = robot.description.default_preset
    if name not in presets:
        raise ValueError(f"robot {robot.name!r} names the preset {name!r}, which is not built in")
    from app.analysis.robot_start import start_set

    chosen = start_set(
        robot.description, PresetStore(default_data_dir(), presets).start_for(robot.name, name)
    )
    default = presets[name]
    why = (
        f"{robot.name}'s default preset"
        if (chosen.name, chosen.robot) == (default.name, default.robot)
        else f"the newest set saved for {robot.name} (its default preset {name!r} was tuned "
        f"for {default.robot})"
    )
    print(
        f"no --params: the parameter set {set_named(chosen)}, {why}; --params NAME|FILE "
        "chooses another",
        file=say or sys.stderr,
    )
    return chosen


def set_named(pset: ParameterSet) -> str:
    """A parameter set as the commands name it: its name, the robot it was tuned for, when it
    was made and by which version of artro (where the set says)."""
    made = [f"made {pset.created}"] if pset.created else []
    made += [f"artro {pset.project_version}"] if pset.project_version else []
    return f"{pset.name or 'unnamed'!r} (robot {pset.robot}{''.join(', ' + m for m in made)})"


def warn_if_other_robot(
    pset: ParameterSet, robot: RobotModel, out: TextIO = sys.stderr, scaled: bool = False
) -> None:
    if pset.robot != robot.name:
        how = (
            f", scaled to its legs (clock {pset.gait.clock.freq_hz:g} Hz, the yaw-rate loop's "
            "axle and speed; as `artro tune` starts it)"
            if scaled
            else ""
        )
        print(
            f"warning: parameter set {pset.name!r} was tuned for the robot {pset.robot!r}, "
            f"not {robot.name!r}{how}",
            file=out,
        )


def robot_and_set(args: argparse.Namespace) -> tuple[RobotModel, ParameterSet]:
    """The `--robot` and the `--params` a command starts with (a warning if they do not match)."""
    robot = RobotModel.load(args.robot)
    pset = starting_set(robot, args.params)
    scaled = not args.params and pset.gait != builtin_presets().get(pset.name, pset).gait
    warn_if_other_robot(pset, robot, scaled=scaled)
    return robot, pset
