"""`artro firmware build|run|flash`: a firmware folder for a parameter set and a board, the
firmware emulated on simavr and compared with the Python model pin for pin -- with a feedback law
on, closed loop through its emulated sensors on the simulated robot (docs/DESIGN.md §15) -- or
served on a pseudo-terminal (docs/DESIGN.md §5); a board programmed by avrdude (docs/BOARDS.md)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import shlex
import sys
from pathlib import Path
from typing import Any

from app.cli.firmware_flash import (
    add_board_option,
    add_flash_parser,
    board_of,
    flash,
    upload_command,
)
from app.cli.options import (
    action,
    add_motion_option,
    add_params_option,
    check_pushed_variation,
    motion_number,
    number,
    output_file,
    output_folder,
    set_named,
    starting_set,
    subcommand,
    variation,
    warn_if_other_robot,
)
from app.firmware.build import (
    BOARD_BOOTLOADER_S,
    DEFAULT_BOARD,
    build_firmware,
    export_firmware_folder,
    wiring,
)
from app.firmware.closed_loop import run_closed_loop
from app.firmware.conformance import check_firmware
from app.firmware.emulator import Mcu
from app.params.document import ParameterSet
from app.robots.model import RobotModel
from app.sim.planning import FRAME_S
from app.worlds.variations import NOMINAL
from gait import GaitParams, Motion, feedback

FRAMES, MIN_FRAMES, MAX_FRAMES = 250, 2, 15_000  # 5 s by default, 5 min at most
COMPARISON_ONLY = ("frames", "json", "vcd")  # options of the comparison run, not of --pty

EXAMPLES = """examples:
  artro firmware build -o artro_fw          then: make -C artro_fw && make -C artro_fw flash
  artro firmware run --motion a_p=0.07 --frames 250 --json
                                           the robot's default preset (ArtRo's robust: laws on)
  artro firmware run --params tuned --motion a_p=0.07,ca=0.1 --vcd walk.vcd
                                           an open-loop set: its output lines as VCD
  artro firmware run --vary imu_tilt_bias_deg=1,gyro_noise_deg_s=0.1
                                           the laws on the MCU against a varied robot
  artro firmware run --pty                 the emulated robot on a serial pseudo-terminal
  artro firmware build --board mega2560-pca9685 -o mega_fw   an Arduino Mega and a PCA9685
  artro firmware flash --port /dev/ttyACM0 --board mega2560-pca9685   build it and upload it"""


def add_parser(sub: Any) -> None:
    fw = subcommand(
        sub,
        "firmware",
        "the firmware: build it, run it emulated against the model, flash it",
        command,
        EXAMPLES,
    )
    sub = fw.add_subparsers(dest="firmware_command", required=True, metavar="ACTION")
    build = action(
        sub,
        "build",
        "write and build a firmware folder",
        """examples:
  artro firmware build -o artro_fw          the robot's default preset; then:
                                           make -C artro_fw && make -C artro_fw flash
  artro firmware build --robot micro -o micro_fw   micro's default preset, micro-robust""",
    )
    add_params_option(build)
    build.add_argument(
        "-o",
        "--output",
        type=output_folder,
        metavar="DIR",
        default="artro_firmware",
        help="the firmware folder",
    )
    build.add_argument("--robot", metavar="NAME|FILE", help="the robot (default: artro)")
    add_board_option(build)
    run = action(
        sub,
        "run",
        "emulate on simavr and compare with the model",
        """examples:
  artro firmware run --frames 250 --json   closed loop (ArtRo's default preset has laws on)
  artro firmware run --params tuned --vcd walk.vcd   open loop, pin for pin; its lines as VCD
  artro firmware run --pty                 the emulated robot on a serial pseudo-terminal""",
    )
    add_params_option(run)
    add_motion_option(run)
    run.add_argument(
        "--ca", type=motion_number("ca", "--ca"), help="curve amount (default: the motion's)"
    )
    run.add_argument(
        "--frames",
        type=number(MIN_FRAMES, MAX_FRAMES, integer=True, what="--frames"),
        default=None,
        metavar="N",
        help=f"20 ms frames, {MIN_FRAMES} to {MAX_FRAMES} (default {FRAMES})",
    )
    run.add_argument("--robot", metavar="NAME|FILE", help="the robot (default: artro)")
    add_board_option(run)
    run.add_argument(
        "--vcd",
        type=output_file,
        metavar="FILE",
        help="write the nine output lines as VCD (default: no VCD)",
    )
    run.add_argument(
        "--vary",
        type=variation,
        default=NOMINAL,
        metavar="KEY=VALUE,...",
        help="closed loop (a feedback law on; a mega2560-pca9685 run always is): the simulated "
        "robot and its sensors varied, e.g. "
        "imu_tilt_bias_deg=1,gyro_bias_deg_s=0.5,fsr_gain=1.1 (docs/DESIGN.md §8) "
        "(default: none, the nominal model)",
    )
    run.add_argument("--json", action="store_true", help="print one JSON object")
    run.add_argument(
        "--pty",
        action="store_true",
        help="instead: serve the emulated robot's UART on a pseudo-terminal in real time until "
        "Ctrl-C (57600 baud, PROTOCOL.md); the Mega board resets as the port opens and its "
        "bootloader answers nothing for 1 s, as a real Mega's USB port does",
    )
    add_flash_parser(sub)


def _document(args: argparse.Namespace, robot: RobotModel) -> dict[str, Any]:
    """The parameter-set document the firmware is built with: `--params`, else the robot's
    starting set as every command's (`starting_set`), with `--motion` and `--ca` applied."""
    pset = starting_set(robot, args.params)
    warn_if_other_robot(pset, robot)
    doc = pset.to_dict()
    motion = Motion(**doc["motion"])
    ca = getattr(args, "ca", None)
    if getattr(args, "motion", None) is not None:
        motion = args.motion.applied(motion, ca)
    elif ca is not None:
        motion = dataclasses.replace(motion, ca=ca)  # validated
    doc["motion"] = dataclasses.asdict(motion)
    return doc


def _serve_pty(doc: dict[str, Any], robot: RobotModel, board: str = DEFAULT_BOARD) -> int:
    import threading

    from app.firmware.pty_bridge import PtyBridge

    elf = build_firmware(doc, board=board, **wiring(robot)).elf
    bootloader_s = BOARD_BOOTLOADER_S.get(board)
    with Mcu(elf, board=board) as mcu:
        if bootloader_s is None:
            bridge = PtyBridge(mcu)
            resets = ""
        else:  # as a Mega's USB port: opening it resets the board (DTR)
            bridge = PtyBridge(mcu, restart=lambda: Mcu(elf, board=board),
                               bootloader_s=bootloader_s)  # fmt: skip
            resets = (f"; it resets as the port opens, its bootloader answering nothing for "
                      f"{bootloader_s:g} s")  # fmt: skip
        print(f"emulated robot on {bridge.port} (57600 8N1{resets}); Ctrl-C ends", flush=True)
        try:
            bridge.serve(threading.Event())
        except KeyboardInterrupt:
            pass
        finally:
            bridge.close()
    return 0


def _run_mega(args: argparse.Namespace, doc: dict[str, Any], robot: RobotModel) -> int:
    """The Mega build closed loop, every PCA9685 pulse against the model (docs/BOARDS.md)."""
    from app.firmware.mega import run_mega_closed_loop

    frames = FRAMES if args.frames is None else args.frames
    # always closed loop (the robot simulated, its IMU read): --vary with or without a law on
    check_pushed_variation(args.vary, frames * FRAME_S, f"{frames} frames of {FRAME_S:g} s")
    run = run_mega_closed_loop(doc, frames, robot, args.vary, trace=bool(args.vcd))
    if args.vcd:
        Path(args.vcd).write_text(run.vcd, encoding="ascii")
    summary = {**run.summary(), "robot": robot.name, "variation": args.vary.name}
    if args.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            if key != "failures":
                print(f"{key:26s} {value}")
    for failure in summary["failures"]:
        print(f"artro firmware run: the firmware differs from its model: {failure}",
              file=sys.stderr)  # fmt: skip
    return 1 if summary["failures"] else 0


def command(args: argparse.Namespace) -> int:
    robot = RobotModel.load(getattr(args, "robot", None))
    doc = _document(args, robot)
    board = board_of(args, robot)
    if args.firmware_command == "flash":
        return flash(args, doc, robot, board)
    if args.firmware_command == "build":
        folder = export_firmware_folder(doc, Path(args.output), board=board, **wiring(robot))
        build = build_firmware(doc, out_dir=folder, board=board, **wiring(robot))
        hex_file = build.hex.resolve().relative_to(folder.resolve())  # -o may be relative
        named = set_named(ParameterSet.from_dict(doc))
        print(
            f"{folder}: {hex_file} built from the parameter set {named}; for the {board}: "
            f"flash {build.flash_bytes} B of {build.flash_size}, SRAM {build.sram_bytes} B of "
            f"{build.sram_size} (without the stack); `make -C {folder} flash` programs it"
        )
        if board != DEFAULT_BOARD:
            command = shlex.join(upload_command(build.hex.resolve(), "PORT"))
            print(f"upload through the Mega's bootloader: {command}")
        return 0
    if board != DEFAULT_BOARD and not args.pty:
        return _run_mega(args, doc, robot)
    if args.pty:
        given = [
            f"--{name}" for name in COMPARISON_ONLY if getattr(args, name) not in (None, False)
        ]
        if given:
            raise ValueError(
                f"--pty serves the emulated robot on a pseudo-terminal until Ctrl-C; "
                f"{', '.join(given)} belong{'s' if len(given) == 1 else ''} to the comparison "
                f"run (without --pty): leave {'it' if len(given) == 1 else 'them'} out "
                "(--params, --motion and --ca apply)"
            )
        return _serve_pty(doc, robot, board)
    frames = FRAMES if args.frames is None else args.frames  # its range checked as parsed
    closed = feedback.any_law_on(GaitParams.from_dict(doc["gait"]))
    if closed and args.vcd:
        raise ValueError("--vcd writes the open-loop comparison's lines; leave it out here")
    if not closed and not args.vary.is_nominal:
        raise ValueError(
            "--vary varies the simulated robot the firmware walks closed loop: it needs a set "
            "with a feedback law on (gait.tilt, yaw_rate, damping or cop enabled)"
        )
    if closed:
        check_pushed_variation(args.vary, frames * FRAME_S, f"{frames} frames of {FRAME_S:g} s")
        run = run_closed_loop(doc, frames, robot, args.vary)
        failures = run.failures()
        build = build_firmware(doc, **wiring(robot))  # the run's own build, from the cache
        summary = {**run.summary(), "robot": robot.name, "variation": args.vary.name,
                   "flash_bytes": build.flash_bytes, "sram_bytes": build.sram_bytes}  # fmt: skip
        summary["failures"] = failures
    else:
        summary = check_firmware(doc, frames, args.vcd, robot)
        failures = summary["failures"]
    if args.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            if key != "failures":
                print(f"{key:24s} {value}")
    for failure in failures:  # what the exit status 1 stands for
        print(f"artro firmware run: the firmware differs from its model: {failure}",
              file=sys.stderr)  # fmt: skip
    return 1 if failures else 0
