"""`artro export`: a parameter set as JSON, YAML, the firmware's C header, or a whole firmware
folder to build and flash."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from app.cli.options import (
    add_params_option,
    add_robot_option,
    nonempty,
    robot_and_set,
    subcommand,
)
from app.firmware.build import export_firmware_folder, wiring
from app.params.formats import FORMATS, export_text

EXAMPLES = """examples:
  artro export --format c -o artro_params.h              the firmware header
  artro export --format yaml --params my_gait.json
  artro export --format c --params tuned -o tuned.h      a preset by name
  artro export --format firmware --params my_gait.json -o my_robot   then: make -C my_robot"""


def add_parser(sub: Any) -> None:
    e = subcommand(
        sub,
        "export",
        "write a parameter set as JSON, YAML or a firmware C header",
        command,
        EXAMPLES,
    )
    e.add_argument(
        "--format",
        required=True,
        choices=(*FORMATS, "firmware"),
        help="output format; firmware: a folder with the C sources, this set's header and a "
        "Makefile (make, make flash) -- needs -o DIR",
    )
    add_params_option(e)
    add_robot_option(e)
    e.add_argument(
        "-o", "--output", type=nonempty("-o"), metavar="FILE",
        help="write here (default: standard output)",
    )  # fmt: skip


def command(args: argparse.Namespace) -> int:
    robot, pset = robot_and_set(args)
    if args.format == "firmware":
        if not args.output:
            raise ValueError("--format firmware writes a folder: give it with -o DIR")
        try:
            folder = export_firmware_folder(pset.to_dict(), Path(args.output), **wiring(robot))
        except OSError as exc:
            why = _why(exc, args.output)
            raise OSError(f"cannot write the firmware folder {args.output}: {why}") from exc
        print(f"{folder}: the firmware for {pset.name or 'the paper set'}; `make` builds it")
        return 0
    text, _media_type, _filename = export_text(pset, args.format)
    if args.output:
        try:
            Path(args.output).write_text(text, encoding="utf-8")
        except OSError as exc:
            raise OSError(f"cannot write {args.output}: {_why(exc, args.output)}") from exc
    else:
        sys.stdout.write(text)
    return 0


def _why(exc: OSError, output: str) -> str:
    """What went wrong in words, with the path it happened at when that is not `output`."""
    where = f" ({exc.filename})" if exc.filename and str(exc.filename) != output else ""
    return f"{exc.strerror or exc}{where}"
