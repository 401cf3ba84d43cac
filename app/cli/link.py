"""`artro link`: the dashboard's parameter set, live, to a robot's ATmega128 over its serial
port, and the robot's sensors back to the dashboard's Sensors panel; the servos are switched
off on every exit (Ctrl-C, SIGTERM, SIGHUP, an error)."""

from __future__ import annotations

import argparse
import os
import signal
import stat
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO
from urllib.parse import urlsplit

from app.cli.firmware_flash import add_board_option
from app.cli.options import (
    SETS_HELP,
    number,
    output_file_of,
    resolve_set,
    starting_set,
    subcommand,
)
from app.firmware.build import BOARD_BOOTLOADER_S
from app.firmware.link import SerialLink, SerialPort
from app.firmware.robot_link import DEFAULT_BAUD, DryRunPort, LinkError, RobotLink, follow
from app.robots import load_description
from app.robots.model import RobotModel

if TYPE_CHECKING:
    import serial

DEFAULT_SERVER = "http://127.0.0.1:8000"
RESTART_WAIT_S = 10.0  # a board that resets as its port opens: its firmware must answer by then
STOP_SIGNALS = ("SIGTERM", "SIGHUP")  # a kill, a closed terminal: the servos go off as on Ctrl-C
EXAMPLES = """examples:
  artro link --port /dev/ttyUSB0             follow the dashboard on http://127.0.0.1:8000,
                                             the robot's sensors in its Sensors panel
  artro link --port /dev/ttyUSB0 --no-sensors   follow it, the robot's sensors not asked for
  artro link --port /dev/pts/5 --params tuned   send one set (a preset's name or a file)
  artro link --port /dev/ttyACM0 --board mega2560-pca9685   an Arduino Mega: waits for its restart
  artro link --dry-run --params tuned        print the messages it would send
  artro link --dry-run                       the same, following the dashboard on :8000"""


def add_parser(sub: Any) -> None:
    p = subcommand(
        sub,
        "link",
        "send the dashboard's parameters to a robot over its serial port, live",
        command,
        EXAMPLES,
    )
    p.description = (
        "Send the dashboard's parameter set to a robot's ATmega128 over its serial port and "
        "follow every change. Meanwhile the robot streams its balance sensors (one SENSORS a "
        "frame: IMU attitude, gyro, foot forces, the laws' outputs), which go to the dashboard's "
        "Sensors panel beside the simulation's; a dashboard that stops answering for a while "
        "is said once, the robot walks on in the last set. The servos are switched off on "
        "every exit (Ctrl-C, SIGTERM, SIGHUP, an error)."
    )
    p.add_argument(
        "--port", help="serial device, e.g. /dev/ttyUSB0 (no default: needed unless --dry-run)"
    )
    p.add_argument(
        "--baud",
        type=number(1, 4_000_000, integer=True, what="--baud"),
        default=DEFAULT_BAUD,
        help=f"the firmware's rate (config.h UART_BAUD; default {DEFAULT_BAUD}): another one "
        "only for a firmware built with it",
    )
    p.add_argument(
        "--server",
        default=None,
        help="the dashboard to follow: http://HOST[:PORT] or https://HOST[:PORT] "
        f"(default: {DEFAULT_SERVER})",
    )
    p.add_argument(
        "--params",
        metavar="FILE|NAME",
        help=f"send this parameter set once instead of following: {SETS_HELP} "
        "(default: follow the dashboard)",
    )
    p.add_argument(
        "--robot",
        metavar="NAME|FILE",
        default=None,
        help="the robot the firmware on the port was built for (artro firmware build --robot); "
        "a set tuned for another is refused (default: artro)",
    )
    add_board_option(p)  # an Arduino Mega resets as its port opens: the link waits for it
    p.add_argument("--dry-run", action="store_true", help="print the messages, open no port")
    p.add_argument(
        "--no-sensors",
        dest="sensors",
        action="store_false",
        help="do not ask for the robot's sensors (the Sensors panel shows the simulation only)",
    )
    p.add_argument(
        "--script",
        choices=["identify"],
        default=None,
        help="play a fixed routine on the robot instead of following: identify, ~60 s of "
        "standing, weight shifts, steps and short walks, every law off (docs/FIT.md); with "
        "--record; the set: --params or the robot's default (default: none)",
    )
    p.add_argument(
        "--record",
        type=output_file_of((".json",), "a JSON recording"),
        default=None,
        metavar="REC.json",
        help="write the routine's recording here, for `artro fit` (default: none)",
    )


class LinkStopped(BaseException):
    """A signal asked the link to end (SIGTERM, SIGHUP); like KeyboardInterrupt, no `except
    Exception` on the way swallows it."""


def _stop_on_signals() -> dict[int, Any]:
    """SIGTERM and SIGHUP end the link as Ctrl-C does (the servos go off); the handlers before
    (to put back). Only the main thread can take signals: elsewhere nothing changes."""

    def stop(signum: int, _frame: Any) -> None:
        for name in STOP_SIGNALS:  # a second signal must not cut the switching off short
            signal.signal(getattr(signal, name), signal.SIG_IGN)
        raise LinkStopped(signal.Signals(signum).name)

    previous: dict[int, Any] = {}
    if threading.current_thread() is not threading.main_thread():
        return previous
    for name in STOP_SIGNALS:
        number = getattr(signal, name, None)
        if number is not None:
            previous[number] = signal.signal(number, stop)
    return previous


def check_server(url: str) -> None:
    """ValueError unless `url` is an http or https address with a host (a dashboard's)."""
    allowed = "http://HOST[:PORT] or https://HOST[:PORT], e.g. http://127.0.0.1:8000"
    try:
        parts = urlsplit(url)
        _ = parts.port  # ValueError for a port that is not a number in 0..65535
    except ValueError as exc:
        raise ValueError(
            f"--server must be a dashboard's address, {allowed}; {url!r}: {exc}"
        ) from exc
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise ValueError(f"--server must be a dashboard's address, {allowed}; got {url!r}")


def open_port(name: str, baud: int) -> serial.Serial:
    """The robot's serial device, opened with pyserial; OSError naming it and what it is if it
    is not one (a folder, a regular file, /dev/null)."""
    import serial  # pyserial

    allowed = "give the robot's serial adapter, e.g. /dev/ttyUSB0, /dev/ttyACM0 or a pty"
    try:
        mode = os.stat(name).st_mode
    except OSError:
        mode = None  # pyserial says why (no such file, no permission)
    if mode is not None and not stat.S_ISCHR(mode):
        kind = (
            "a regular file" if stat.S_ISREG(mode) else "a folder" if stat.S_ISDIR(mode) else None
        )
        raise OSError(
            f"the port {name} is not a serial device ({kind or 'not a device'}): {allowed}"
        )
    try:
        return serial.Serial(name, baud, timeout=0.02)
    except serial.SerialException as exc:
        if exc.errno is not None:  # the open failed: pyserial repeats the errno in its text
            raise OSError(f"could not open the port {name}: {os.strerror(exc.errno)}") from exc
        cause = exc.__context__  # pyserial's text wraps termios.error(errno, text)
        why = cause.args[-1] if cause is not None and cause.args else exc
        raise OSError(
            f"the port {name} is not a serial device (it takes no line settings: {why}): {allowed}"
        ) from exc


class PasswordHidden:
    """A text stream that writes `out` with the password of `url` (http://USER:PASSWORD@HOST)
    hidden as ***: nothing the link says shows it."""

    def __init__(self, out: TextIO, url: str | None) -> None:
        self.out = out
        try:
            userinfo = urlsplit(url or "").netloc.rpartition("@")[0]
        except ValueError:  # an address that is no URL: check_server says so
            userinfo = ""
        user, colon, password = userinfo.partition(":")
        self.secret = f"{userinfo}@" if colon and password else None
        self.shown = f"{user}:***@"

    def hide(self, text: str) -> str:
        return text.replace(self.secret, self.shown) if self.secret else text

    def write(self, text: str) -> int:
        return self.out.write(self.hide(text))

    def flush(self) -> None:
        self.out.flush()


def command(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """The link (`link`), with a password in --server hidden in all it says, errors too."""
    hidden = PasswordHidden(out or sys.stdout, getattr(args, "server", None))
    try:
        return link(args, hidden)  # type: ignore[arg-type]  # a TextIO to print to
    except (ValueError, OSError, RuntimeError) as exc:
        text = hidden.hide(str(exc))
        if text == str(exc):
            raise
        raise LinkError(text) if isinstance(exc, RuntimeError) else ValueError(text) from None


def link(args: argparse.Namespace, out: TextIO) -> int:
    import httpx  # ~0.5 s: only to follow a dashboard

    if not args.dry_run and not args.port:
        raise ValueError("--port is needed (e.g. /dev/ttyUSB0), or --dry-run to print the messages")
    if args.dry_run and args.port:
        raise ValueError(f"--dry-run opens no port: leave --port {args.port} out, or --dry-run")
    script = getattr(args, "script", None)
    if (script is None) != (getattr(args, "record", None) is None):
        raise ValueError("--script and --record go together: --script identify --record REC.json")
    if script is not None and (args.server or args.dry_run):
        raise ValueError("--script plays a routine on the robot: leave out --server and --dry-run")
    if args.params and args.server:
        raise ValueError(
            f"--params sends one set and follows no dashboard: leave --server {args.server} out"
        )
    args.server = args.server or DEFAULT_SERVER
    if args.baud != DEFAULT_BAUD:  # the firmware's rate is config.h's, a build-time choice
        print(
            f"warning: --baud {args.baud}: the ArtRo firmware talks at {DEFAULT_BAUD} "
            "(hardware/firmware/src/config.h UART_BAUD); another rate reaches only a firmware "
            "built with it",
            file=out,
        )
    # the set and the dashboard first: a bad name, file or address is said before a port is opened
    description = load_description(getattr(args, "robot", None))
    firmware_robot = description.name
    board = getattr(args, "board", None) or description.board
    one_set = resolve_set(args.params, "--params").pset if args.params else None
    if script is not None and one_set is None:
        one_set = starting_set(RobotModel.load(getattr(args, "robot", None)), None, out)
    if one_set is None:
        check_server(args.server)
    elif one_set.robot != firmware_robot:
        raise ValueError(
            f"--params {args.params}: the set {one_set.name!r} is tuned for the robot "
            f"{one_set.robot!r}; the firmware on the port is built for {firmware_robot!r} "
            f"(--robot): give a set tuned for {firmware_robot}, or --robot {one_set.robot} if the "
            "firmware was built for it"
        )
    port: SerialPort = DryRunPort(out) if args.dry_run else open_port(args.port, args.baud)
    robot = RobotLink(SerialLink(port), dry_run=args.dry_run, log=lambda s: print(s, file=out))
    stop = threading.Event()
    previous = _stop_on_signals()
    try:
        if board in BOARD_BOOTLOADER_S and not args.dry_run:
            print(f"waiting for the {board} to restart: opening its port resets it (DTR) and its "
                  f"bootloader runs ~1-2 s; asking it with PING for up to {RESTART_WAIT_S:g} s",
                  file=out, flush=True)  # fmt: skip
            pings = robot.wait_for_firmware(RESTART_WAIT_S)
            print(f"the {board} answered after {pings} PINGs", file=out)
        robot.hello()
        if script is not None and one_set is not None:
            record_to(robot, one_set, args, stop, out)
        elif one_set is not None:
            robot.send_set(one_set.to_dict())
            robot.start()
        else:
            said = (
                f"the messages that would follow {args.server}: its set once, then stop"
                if args.dry_run
                else f"following {args.server} (Ctrl-C stops and switches the servos off)"
            )
            print(said, file=out)
            sensors = getattr(args, "sensors", True)
            dry = args.dry_run
            follow(robot, args.server, stop, max_updates=0 if dry else None, sensors=sensors,
                   firmware_robot=firmware_robot)  # fmt: skip
    except KeyboardInterrupt:
        pass
    except LinkStopped as exc:
        print(f"{exc}: stopping", file=out)
    except httpx.HTTPError as exc:
        raise LinkError(f"the dashboard at {args.server} did not answer: {exc}") from exc
    finally:
        servos_off = _switch_off(robot, stop, previous, out)
    return 0 if servos_off else 2  # a stop asked for, but the servos may still be on


def record_to(robot: RobotLink, pset: Any, args: argparse.Namespace, stop: threading.Event,
              out: TextIO) -> None:  # fmt: skip
    """Play the identify routine and write its recording (docs/FIT.md)."""
    from app.analysis import identify_record
    from app.firmware.identify_link import record_identify

    model = RobotModel.load(getattr(args, "robot", None))
    recording = record_identify(robot, model, pset, stop, lambda s: print(s, file=out))
    identify_record.write(recording, Path(args.record))
    print(f"recorded {len(recording.frames.frame)} frames: {args.record} (artro fit "
          f"{args.record} --robot {model.name})", file=out)  # fmt: skip


def _switch_off(
    robot: RobotLink, stop: threading.Event, previous: dict[int, Any], out: TextIO
) -> bool:
    """The servos off, or said why not (without hiding why the link ended); the port closed
    and the signal handlers put back. Whether the servos are off."""
    stop.set()
    for signum in previous:  # nothing cuts the switching off short
        signal.signal(signum, signal.SIG_IGN)
    try:
        robot.torque_off()
        return True
    except (LinkError, OSError) as exc:  # pyserial's SerialException is an OSError
        print(f"could not switch the servos off: {exc}", file=out)
        return False
    finally:
        try:
            robot.link.close()
        except OSError:
            pass  # a port that failed may fail its closing too
        for number, handler in previous.items():
            signal.signal(number, handler)
