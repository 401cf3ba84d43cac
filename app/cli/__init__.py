"""The `artro` command line: one module per command, each adding its parser and its `handler`;
the options several share are `app.cli.options` (`artro COMMAND --help` for each). The commands
load inside `main`, so a Ctrl-C while they load (~2 s) ends in one line too."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from collections.abc import Sequence


def build_parser() -> argparse.ArgumentParser:
    from app.cli import (
        bench,
        bus,
        calibrate_ca,
        drive,
        export,
        firmware,
        fit,
        link,
        robot,
        run,
        serve,
        tune,
    )
    from app.cli.options import use_help_formatter
    from app.params.document import project_version

    parser = argparse.ArgumentParser(
        prog="artro",
        description="ArtRo Gait Studio: tune the ArtRo biped's gait in a MuJoCo simulation.",
        epilog="Directions: a_p > 0 walks forward, a_r > 0 steps to the right, a_y > 0 and "
        "CA > 0 turn clockwise.",
    )
    parser.add_argument(
        "--version", action="version", version=f"artro-gait-studio {project_version()}"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in (
        serve, run, export, calibrate_ca, bench, tune, fit, firmware, link, robot, bus, drive,
    ):  # fmt: skip
        command.add_parser(sub)
    use_help_formatter(parser)  # the action parsers too (firmware run, robot check, ...)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        from app.cli.options import join_negative_values

        parser = build_parser()
    except KeyboardInterrupt:  # Ctrl-C while the commands load: a line, not a traceback
        print("artro: interrupted", file=sys.stderr)
        return 130
    args, unknown = parser.parse_known_args(
        join_negative_values(sys.argv[1:] if argv is None else argv)
    )
    if unknown:  # said by the command's own parser: its usage, not artro's
        innermost(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    from app.robots.mujoco_warnings import keep_warnings_out_of_the_folder

    keep_warnings_out_of_the_folder()  # no MUJOCO_LOG.TXT where a run blew up
    try:
        return args.handler(args)
    except BrokenPipeError:  # `artro run | head -1`: the reader took what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
        return 128 + signal.SIGPIPE  # as a shell reports a process its pipe ended
    # RuntimeError: BuildError, EmulatorError, LinkError, CalibrationError, ExecutorError
    except (ValueError, OSError, RuntimeError) as exc:
        parser.exit(2, f"artro {args.command}: error: {exc}\n")
    except KeyboardInterrupt:  # Ctrl-C: said in a line, not a traceback
        parser.exit(130, f"artro {args.command}: interrupted\n")
    return 1


def innermost(parser: argparse.ArgumentParser, args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the command (and action: `firmware build`) that `args` were parsed for."""
    for act in parser._actions:
        if isinstance(act, argparse._SubParsersAction):
            chosen = act.choices.get(getattr(args, act.dest, None) or "")
            if chosen is not None:
                return innermost(chosen, args)
    return parser
