"""`artro drive`: the gait run on the host and sent to a robot's bus servos (Dynamixel 2.0 or
Feetech STS) on a serial port, one sync write per 20 ms frame, open loop; the torque off on
Ctrl-C, SIGTERM, the end, and a servo lost (docs/BUS.md, "Driving a robot from the host")."""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import threading
from typing import Any

from app.cli.link import open_port
from app.cli.options import (
    MAX_DURATION_S,
    add_motion_option,
    add_params_option,
    add_robot_option,
    number,
    robot_and_set,
    subcommand,
)

EXAMPLES = """examples:
  artro bus --robot op3.yaml --torque-on &           a virtual bus (its first line: the port)
  artro drive --bus /dev/pts/7 --robot op3.yaml --params paper --motion a_p=0.07 --duration 30
  artro drive --bus /dev/ttyUSB0 --protocol feetech --baud 1000000 --robot my.yaml
  artro drive --bus /dev/ttyUSB0 --ids 11,12,13,14,15,16,21,22,23,24,25,26 --no-read
  sudo artro drive --bus /dev/ttyUSB0 --robot my.yaml --rt-priority 10   frames on time

exit status: 0 the walk ended (its time, Ctrl-C or SIGTERM), 1 a servo was lost or the port
failed (the torque switched off, the servo named), 2 bad input or a servo missing at the start;
a JSON line on standard output says what the drive did (frames, late ones, round trips)"""

PROTOCOL_HELP = (
    "dynamixel: Protocol 2.0 (XM430 control table); feetech: STS (default: the robot's bus "
    "servos' maker, else dynamixel)"
)
MAX_ID = 252


def servo_ids(text: str) -> tuple[int, ...]:
    """An argparse type: 12 different IDs, 0-252, comma-separated, in the gait's joint order."""
    try:
        ids = tuple(int(part) for part in text.split(","))
    except ValueError:
        ids = ()
    if len(ids) != 12 or len(set(ids)) != 12 or not all(0 <= i <= MAX_ID for i in ids):
        raise argparse.ArgumentTypeError(
            f"--ids must be 12 different whole numbers 0-{MAX_ID}, comma-separated, one per "
            f"joint in the gait's order (l_hip_yaw ... r_ankle_roll); got {text!r}"
        )
    return ids


def real_time(priority: int) -> None:
    """This process SCHED_FIFO at `priority` (its loop sleeps between frames, never spins);
    OSError in a sentence where the system does not permit it."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError) as exc:
        why = getattr(exc, "strerror", None) or "not on this system"
        raise OSError(
            f"--rt-priority {priority}: the frame loop cannot run SCHED_FIFO here ({why}); it "
            "needs Linux and CAP_SYS_NICE (root, or an rtprio limit), or leave the option out"
        ) from None


def add_parser(sub: Any) -> None:
    p = subcommand(
        sub,
        "drive",
        "walk a robot of bus servos from the host: the gait's goals by sync write, 50 Hz",
        command,
        EXAMPLES,
    )
    p.description = (
        "Run the gait on this computer (the engine, parameter set and motion ramp of `artro "
        "run --from-rest`) and send each 20 ms frame's goal positions to the robot's 12 bus "
        "servos as one SYNC_WRITE, paced by the clock. First each servo is pinged (one that "
        "does not answer is named, and nothing is sent), their present pose is read and held, "
        "the torque switched on, and the robot moved to the gait's first pose over --settle. "
        "Open loop: a bus robot has no IMU on the bus here, so the balance laws of a parameter "
        "set are not run. The torque is switched off on Ctrl-C, SIGTERM, at the end, and when a "
        "servo stops answering the sync reads (named by ID and joint)."
    )
    p.add_argument(
        "--bus",
        required=True,
        metavar="PORT",
        help="the bus's serial port, e.g. /dev/ttyUSB0, or the pty `artro bus` printed",
    )
    p.add_argument("--protocol", choices=("dynamixel", "feetech"), default=None, help=PROTOCOL_HELP)
    p.add_argument(
        "--baud",
        type=number(1, 4_500_000, integer=True, what="--baud"),
        default=1_000_000,
        help="the bus's rate, one the servos have (default: 1000000)",
    )
    add_robot_option(p)
    add_params_option(p)
    add_motion_option(p)
    p.add_argument(
        "--duration",
        type=number(0, MAX_DURATION_S, above=True, what="--duration"),
        default=None,
        metavar="S",
        help="seconds of walking after the settling (default: until Ctrl-C or SIGTERM)",
    )
    p.add_argument(
        "--ids",
        type=servo_ids,
        default=None,
        metavar="ID,...",
        help="the 12 servos' IDs in the gait's joint order, l_hip_yaw ... r_ankle_roll "
        "(default: the robot's joints' bus_id, else 1-12)",
    )
    p.add_argument(
        "--settle",
        type=number(0, 60, what="--settle"),
        default=1.0,
        metavar="S",
        help="seconds to move from the present pose to the gait's first (default: 1)",
    )
    p.add_argument(
        "--timeout-ms",
        type=number(1, 15, integer=True, what="--timeout-ms"),
        default=15,
        help="how long a sync read waits for the statuses, 1-15 ms of the 20 ms frame; 12 "
        "servos at the factory's 500 µs return delay take about 9 ms at 1 Mbaud (default: 15)",
    )
    p.add_argument(
        "--lost-after",
        type=number(1, 50, integer=True, what="--lost-after"),
        default=5,
        help="sync reads in a row a servo leaves unanswered before it counts as lost and the "
        "drive ends (default: 5)",
    )
    p.add_argument(
        "--rt-priority",
        type=number(0, 99, integer=True, what="--rt-priority"),
        default=0,
        help="run the frame loop SCHED_FIFO at this priority, 1-99 (Linux, CAP_SYS_NICE): "
        "frames on time on a busy machine (default: 0, the normal scheduler)",
    )
    p.add_argument(
        "--no-read",
        action="store_true",
        help="send the goals only, no sync read of the present positions: faster, but a lost "
        "servo goes unnoticed",
    )


def command(args: argparse.Namespace) -> int:
    from app.firmware.host_drive import DriveOptions, drive, lost_sentence
    from app.firmware.virtual_bus import check_baud
    from gait import feedback

    robot, pset = robot_and_set(args)
    link = robot.hardware().bus
    protocol = args.protocol or (link.protocol if link is not None else "dynamixel")
    check_baud(protocol, args.baud)
    motion = pset.motion if args.motion is None else args.motion.applied(pset.motion)
    options = DriveOptions(
        protocol=protocol,
        baud=args.baud,
        ids=args.ids or tuple(robot.description.bus_ids()),
        duration_s=args.duration,
        settle_s=args.settle,
        read_present=not args.no_read,
        timeout_s=args.timeout_ms / 1000,
        lost_after=args.lost_after,
    )
    if args.rt_priority > 0:
        real_time(args.rt_priority)
    port = open_port(args.bus, args.baud)
    stop = threading.Event()

    def on_signal(_signum: int, _frame: Any) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    laws = " (its balance laws not run)" if feedback.any_law_on(pset.gait) else ""
    print(
        f"artro drive: {robot.name}, parameter set {pset.name!r}{laws}, motion "
        f"a_r={motion.a_r} a_p={motion.a_p} a_y={motion.a_y} CA={motion.ca}, on {args.bus}: "
        f"{protocol} at {args.baud} baud, IDs {list(options.ids)}; open loop (no IMU on the "
        "bus); Ctrl-C ends",
        file=sys.stderr,
        flush=True,
    )

    def on_frame(k: int) -> None:
        if k == 0:
            print("artro drive: walking", file=sys.stderr, flush=True)

    try:
        report = drive(port, robot, pset.gait, motion, options, stop, on_frame)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        port.close()
    summary = {"port": args.bus, "protocol": protocol, "baud": args.baud, **report.summary()}
    print(json.dumps(summary), flush=True)
    if report.ended in ("lost", "port"):
        print(f"artro drive: {lost_sentence(report, options)}", file=sys.stderr, flush=True)
        return 1
    return 0
