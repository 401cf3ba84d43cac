"""`artro link`: the dashboard's parameter set, live, to a robot's ATmega128 over its serial port.

Sends the whole set, follows every change (polling `GET /api/params`), switches the servos off on
every exit (Ctrl-C, SIGTERM, SIGHUP, an error); the same code drives the emulated robot on its pty
(hardware/firmware/PROTOCOL.md)."""

from __future__ import annotations

import argparse
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TextIO

import httpx

from app.core.mcu import protocol as proto
from app.core.mcu.link import SerialLink, SerialPort
from app.params.document import ParameterSet, load_parameter_set
from hardware.firmware.schema import FIRMWARE_ENGINE, schema_hash, values_from_document

DEFAULT_BAUD = 57600  # PROTOCOL.md: 57600 with U2X at 16 MHz, -0.8 %
POLL_S = 0.2  # how often the dashboard is asked for its parameter version


STOP_SIGNALS = ("SIGTERM", "SIGHUP")  # a kill, a closed terminal: the servos go off as on Ctrl-C


class LinkError(RuntimeError):
    """The robot did not answer, refused a set, or runs firmware of another schema."""


class LinkStopped(BaseException):
    """A signal asked the link to end (SIGTERM, SIGHUP); like KeyboardInterrupt, no `except
    Exception` on the way swallows it."""


class DryRunPort:
    """A port that writes each message as hex to a stream and never answers."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def write(self, data: bytes) -> int:
        known = len(data) > 2 and data[2] in {m.value for m in proto.Msg}
        name = proto.Msg(data[2]).name if known else "?"
        self.out.write(f"-> {name:13s} {data.hex(' ')}\n")
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    def close(self) -> None:
        pass


@dataclass
class RobotLink:
    """One robot: `send_set` a whole parameter set, `torque_off` at the end."""

    link: SerialLink
    dry_run: bool = False
    log: Callable[[str], None] = print

    def expect(self, message: bytes, what: str) -> proto.Reply | None:
        replies = self.link.request(message)
        if self.dry_run:
            return None
        if not replies:
            raise LinkError(f"{what}: no answer from the robot (wiring, baud rate, power?)")
        reply = replies[0]
        if isinstance(reply, proto.Nak):
            reason = getattr(reply.reason, "name", reply.reason)
            raise LinkError(f"{what}: the robot refused it ({reason}, detail {reply.detail})")
        return reply

    def hello(self) -> None:
        """PING; the robot's firmware must address parameters as this studio does."""
        info = self.expect(proto.encode(proto.Msg.PING), "ping")
        if info is None:
            return
        if not isinstance(info, proto.Info):
            raise LinkError(f"ping: expected INFO, got {info}")
        if info.schema_hash != schema_hash():
            raise LinkError(
                f"the robot's firmware has schema {info.schema_hash:08x}, this studio "
                f"{schema_hash():08x}: flash the firmware of this version (artro export "
                "--format firmware)"
            )
        self.log(
            f"robot: protocol {info.version}, {info.param_count} parameters, at frame {info.frame}"
        )

    def send_set(self, doc: dict[str, Any], version: int | None = None) -> int | None:
        """The whole set (motion, CA and every constant) in one SET_PARAMS; the frame it reaches.
        LinkError for a set the firmware refuses (another gait engine), also in a dry run."""
        engine = doc.get("gait", {}).get("engine", FIRMWARE_ENGINE)
        if engine != FIRMWARE_ENGINE:
            tag = "" if version is None else f" (dashboard version {version})"
            raise LinkError(
                f"the set{tag} names the {engine!r} gait engine; the robot's firmware runs only "
                f"{FIRMWARE_ENGINE!r} and would refuse it: choose engine {FIRMWARE_ENGINE}"
            )
        ack = self.expect(proto.set_params(values_from_document(doc)), "parameter set")
        frame = ack.effective_frame if isinstance(ack, proto.Ack) else None
        where = "" if frame is None else f" from frame {frame}"
        tag = "" if version is None else f" (dashboard version {version})"
        self.log(f"sent {doc.get('name') or 'the parameter set'}{tag}{where}")
        return frame

    def start(self) -> None:
        self.expect(proto.command(proto.Msg.START), "start")

    def torque_off(self) -> None:
        self.expect(proto.command(proto.Msg.TORQUE_OFF), "torque off")
        self.log("torque off")


def follow(
    robot: RobotLink,
    server: str,
    stop: threading.Event,
    *,
    max_updates: int | None = None,
) -> int:
    """Send the dashboard's set, then each new version until `stop` (or `max_updates` sets
    after the first). Returns how many sets were sent."""
    sent = 0
    last = None
    with httpx.Client(base_url=server, timeout=5) as http:
        while not stop.is_set():
            doc = http.get("/api/params").raise_for_status().json()
            if doc.get("version") != last:
                last = doc.get("version")
                robot.send_set(_plain(doc), last)
                if sent == 0:
                    robot.start()
                sent += 1
                if max_updates is not None and sent > max_updates:
                    break
            stop.wait(POLL_S)
    return sent


def _plain(doc: dict[str, Any]) -> dict[str, Any]:
    """The parameter-set document of an API answer (validated by the schema)."""
    return ParameterSet.from_dict({"motion": doc["motion"], "gait": doc["gait"]}).to_dict() | {
        "name": doc.get("name") or "dashboard"
    }


def add_link_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser(
        "link",
        help="send the dashboard's parameters to a robot over its serial port, live",
        description="Send the dashboard's parameter set to a robot's ATmega128 over its serial "
        "port and follow every change; the servos are switched off on every exit (Ctrl-C, "
        "SIGTERM, SIGHUP, an error).",
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--port", help="serial device, e.g. /dev/ttyUSB0 (not needed with --dry-run)")
    p.add_argument("--baud", type=int, default=DEFAULT_BAUD, help=f"(default {DEFAULT_BAUD})")
    p.add_argument("--server", default="http://127.0.0.1:8000", help="the dashboard to follow")
    p.add_argument("--params", metavar="FILE", help="send this file once instead of following")
    p.add_argument("--dry-run", action="store_true", help="print the messages, open no port")


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


def cmd_link(args: argparse.Namespace, out: TextIO) -> int:
    if not args.dry_run and not args.port:
        raise ValueError("--port is needed (e.g. /dev/ttyUSB0), or --dry-run to print the messages")
    if args.baud <= 0:
        raise ValueError(f"--baud must be a positive rate such as {DEFAULT_BAUD}, got {args.baud}")
    port: SerialPort
    if args.dry_run:
        port = DryRunPort(out)
    else:
        import serial  # pyserial

        port = serial.Serial(args.port, args.baud, timeout=0.02)
    robot = RobotLink(SerialLink(port), dry_run=args.dry_run, log=lambda s: print(s, file=out))
    stop = threading.Event()
    previous = _stop_on_signals()
    try:
        robot.hello()
        if args.params:
            robot.send_set(load_parameter_set(args.params).to_dict())
            robot.start()
            return 0
        print(f"following {args.server} (Ctrl-C stops and switches the servos off)", file=out)
        follow(robot, args.server, stop, max_updates=0 if args.dry_run else None)
        return 0
    except KeyboardInterrupt:
        return 0
    except LinkStopped as exc:
        print(f"{exc}: stopping", file=out)
        return 0
    except httpx.HTTPError as exc:
        raise LinkError(f"the dashboard at {args.server} did not answer: {exc}") from exc
    finally:
        stop.set()
        for number in previous:  # nothing cuts the switching off short
            signal.signal(number, signal.SIG_IGN)
        try:
            robot.torque_off()
        except LinkError as exc:  # say so, but do not hide why the link ended
            print(f"could not switch the servos off: {exc}", file=out)
        finally:
            robot.link.close()
            for number, handler in previous.items():
                signal.signal(number, handler)
