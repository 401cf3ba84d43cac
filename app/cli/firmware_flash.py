"""`artro firmware flash` and the `--board` option of `artro firmware`: a build programmed with
avrdude -- the Mega 2560 through its bootloader (STK500v2, `-c wiring`, 115200 baud), ArtRo's
ATmega128 through an ISP programmer (docs/BOARDS.md)."""

from __future__ import annotations

import argparse
import shlex
import shutil
import stat
import subprocess
import sys
from pathlib import Path
from typing import Any

from app.cli.options import action, add_params_option
from app.firmware.build import BOARDS, DEFAULT_BOARD, build_firmware, wiring
from app.robots.model import RobotModel

#: avrdude's part and programmer options per board
AVRDUDE = {
    "artro-atmega128": ("-p", "m128", "-c", "usbasp"),
    "mega2560-pca9685": ("-p", "atmega2560", "-c", "wiring"),
}
_AFTER_PORT = {"artro-atmega128": (), "mega2560-pca9685": ("-b", "115200", "-D")}


def board_name(text: str) -> str:
    if text not in BOARDS:
        raise argparse.ArgumentTypeError(
            f"--board must be one of {', '.join(BOARDS)}, got {text!r}"
        )
    return text


def add_board_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--board",
        type=board_name,
        metavar="BOARD",
        help=f"the controller: {' or '.join(BOARDS)} (default: the robot's `board`, else "
        f"{DEFAULT_BOARD})",
    )


def board_of(args: argparse.Namespace, robot: RobotModel) -> str:
    return getattr(args, "board", None) or robot.description.board


def upload_command(hex_file: Path | str, port: str, board: str = "mega2560-pca9685") -> list[str]:
    """avrdude's command line that programs `hex_file` on `port`."""
    return ["avrdude", *AVRDUDE[board], "-P", port, *_AFTER_PORT[board],
            "-U", f"flash:w:{hex_file}:i"]  # fmt: skip


def hex_file(text: str) -> str:
    path = Path(text)
    if path.suffix.lower() != ".hex" or not path.is_file():
        raise argparse.ArgumentTypeError(
            f"--hex must be an Intel HEX file (.hex) that exists, got {text!r}"
        )
    return text


def add_flash_parser(sub: Any) -> None:
    flash = action(
        sub,
        "flash",
        "build the firmware and program a board with avrdude",
        """examples:
  artro firmware flash --port /dev/ttyACM0 --board mega2560-pca9685   the Mega's bootloader
  artro firmware flash --port /dev/ttyACM0 --hex mega_fw/build/artro.hex --board mega2560-pca9685
  artro firmware flash --port usb            ArtRo's ATmega128 through a USBasp""",
    )
    add_params_option(flash)
    flash.add_argument("--port", required=True, metavar="PORT",
                       help="the board's serial port, the Mega's /dev/ttyACM0 or /dev/ttyUSB0 "
                       "(required, no default)")  # fmt: skip
    flash.add_argument("--robot", metavar="NAME|FILE", help="the robot (default: artro)")
    add_board_option(flash)
    flash.add_argument(
        "--hex",
        type=hex_file,
        metavar="FILE",
        help="a .hex built before (artro firmware build) (default: build the parameter set now)",
    )


def flash(args: argparse.Namespace, doc: dict[str, Any], robot: RobotModel, board: str) -> int:
    """Run avrdude; its exit status. RuntimeError if avrdude is not installed."""
    if shutil.which("avrdude") is None:
        raise RuntimeError("avrdude is not installed (Debian: apt-get install avrdude; "
                           "scripts/setup.sh installs it)")  # fmt: skip
    port = Path(args.port)
    if board != DEFAULT_BOARD and not (port.exists() and stat.S_ISCHR(port.stat().st_mode)):
        raise ValueError(
            f"--port {args.port}: no serial port there; give the Mega's port (/dev/ttyACM0, "
            "/dev/ttyUSB0: `ls /dev/tty*` with the board plugged in)"
        )
    hex_path = Path(args.hex) if args.hex else build_firmware(doc, board=board, **wiring(robot)).hex
    command = upload_command(hex_path, args.port, board)
    print(shlex.join(command), flush=True)
    code = subprocess.run(command, check=False).returncode
    if code:
        print(f"artro firmware flash: avrdude could not program the {board} on {args.port} "
              f"(exit {code}); is the board on that port, and no other program holding it?",
              file=sys.stderr)  # fmt: skip
    return code
