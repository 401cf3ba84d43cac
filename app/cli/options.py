"""What several `artro` commands share, the one module they import it from: the subcommand layout
(help with defaults, examples, `handler`), the `--robot`, `--params` and `--motion` options, the
robot and parameter set a command starts with (a file or a preset's name); the argument types,
output paths, compute and variation options of the private modules beside it (docs/DESIGN.md §2)."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from typing import Any, TextIO

from app.cli._arg_types import (
    cluster_address,
    host_name,
    motion_number,
    nonempty,
    number,
    study_location,
)
from app.cli._compute_options import (
    add_backend_options,
    add_cluster_options,
    add_threads_option,
    backend_of,
    cluster_of,
)
from app.cli._motion import MOTION_HELP, MOTION_METAVAR, MotionChoice, motion_arg
from app.cli._output_paths import (
    inside_a_file,
    output_file,
    output_file_of,
    output_folder,
    output_problem,
)
from app.cli._sets import SETS_HELP, ChosenSet, preset_names, resolve_set, resolve_sets
from app.cli._variation_options import (
    add_range_option,
    check_push_time,
    check_pushed_variation,
    ranges_from,
    variation,
)
from app.params.document import ParameterSet
from app.params.presets import PresetStore, builtin_presets, default_data_dir
from app.robots.model import RobotModel
from gait import GaitParams
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
    "add_backend_options",
    "add_cluster_options",
    "add_range_option",
    "add_threads_option",
    "backend_of",
    "check_push_time",
    "check_pushed_variation",
    "cluster_address",
    "cluster_of",
    "host_name",
    "inside_a_file",
    "motion_arg",
    "motion_number",
    "nonempty",
    "number",
    "output_file",
    "output_file_of",
    "output_folder",
    "output_problem",
    "preset_names",
    "ranges_from",
    "resolve_set",
    "resolve_sets",
    "study_location",
    "variation",
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
