"""`artro run --script identify --record REC.json`: the identification routine played in
simulation on a robot varied by `--vary` (the truth a fit is tested against) and written as a
recording (docs/FIT.md)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from app.analysis import identify_record
from app.analysis.identify_replay import play
from app.analysis.identify_routine import ROUTINES, open_loop, total_frames
from app.params.document import ParameterSet
from app.robots.model import RobotModel


def add_script_options(parser: Any, output: Any) -> None:
    parser.add_argument(
        "--script",
        choices=sorted(ROUTINES),
        default=None,
        help="play a fixed routine instead of one motion: identify, ~60 s of standing, weight "
        "shifts, steps on the spot and short walks (docs/FIT.md); with --record (default: none)",
    )
    parser.add_argument(
        "--record",
        type=output,
        default=None,
        metavar="REC.json",
        help="write the routine's recording here, marked simulated, with --vary as its truth "
        "(default: none)",
    )


def check_script(args: argparse.Namespace, parser_error: Any) -> None:
    """--script and --record come together, and without --motion (the routine has its own)."""
    if (args.script is None) != (args.record is None):
        parser_error("--script and --record go together: --script identify --record REC.json")
    if args.script is not None and (args.motion is not None or args.ca is not None):
        parser_error("--script plays the routine's own motions: leave out --motion and --ca")


def record_script(args: argparse.Namespace, robot: RobotModel, pset: ParameterSet) -> int:
    """Play the routine, write it; 1 when the robot fell in it (the file is written all the same:
    a fit needs a recording where it stands)."""
    routine = ROUTINES[args.script]
    gait = open_loop(pset.gait)
    traces = play(robot, gait, routine, args.vary)
    recording = identify_record.to_recording(
        traces,
        routine=args.script,
        source="simulation",
        robot=robot.name,
        robot_mass_kg=robot.total_mass_kg(),
        params=gait.to_dict(),
        truth=args.vary.to_text(),
        present=robot.bus() is not None,
    )
    identify_record.write(recording, Path(args.record))
    seconds = total_frames(routine) * 0.02
    truth = args.vary.name
    print(
        f"recorded {args.script} ({seconds:g} s, {traces.frames} frames) on {robot.name!r}, "
        f"varied {truth}: {args.record}"
    )
    if traces.fell_frame is not None:
        print(
            f"the robot fell at {traces.fell_frame * 0.02:.2f} s: a fit needs a routine "
            "it stands through",
            flush=True,
        )
        return 1
    return 0
