"""`artro bus`: the simulated robot's 12 leg servos as bus servos on a pseudo-terminal
(Dynamixel Protocol 2.0 or Feetech STS), the robot simulated in real time until SIGINT or
SIGTERM; the first line printed is the port's path (docs/BUS.md)."""

from __future__ import annotations

import argparse
import json
import signal
import sys
from typing import Any

from app.cli.options import add_robot_option, number, subcommand

EXAMPLES = """examples:
  artro bus                              Dynamixel XM430-W350s at 1 Mbaud, IDs 1-12 (or
                                         the robot's joints' bus_id)
  artro bus --protocol feetech           Feetech STS3215s
  artro bus --robot micro --baud 57600   another robot, another rate
  artro bus --torque-on                  the servos hold the standing pose from the start
  sudo artro bus --rt-priority 10        answers on time on a busy machine (SCHED_FIFO)
then open the printed port (e.g. /dev/pts/7) with your program, dynamixel-sdk or scservo_sdk"""

SWITCH_S = 0.0005  # Python's default 5 ms would hold an answer behind the simulation thread
PROTOCOL_HELP = "dynamixel: XM430-W350, Protocol 2.0; feetech: STS3215 (default: dynamixel)"


def add_parser(sub: Any) -> None:
    p = subcommand(
        sub,
        "bus",
        "the simulated robot's servos as bus servos on a pseudo-terminal, in real time",
        command,
        EXAMPLES,
    )
    p.description = (
        "Open a pseudo-terminal on which the simulated robot's 12 leg servos answer as bus "
        "servos do (IDs 1-12 in the gait's joint order, l_hip_yaw ... r_ankle_roll, unless "
        "the robot's joints set bus_id): PING, "
        "READ, WRITE, SYNC_READ, SYNC_WRITE, their control table's goal and present position, "
        "velocity, load, voltage, temperature and torque enable; each answer after the "
        "servo's return delay and its bytes' time at the baud rate. The first line printed is "
        "the port's path; on SIGINT or SIGTERM the bus closes and a JSON line says what it saw."
    )
    add_robot_option(p)
    p.add_argument(
        "--protocol", choices=("dynamixel", "feetech"), default="dynamixel", help=PROTOCOL_HELP
    )
    p.add_argument(
        "--baud",
        type=number(1, 4_500_000, integer=True, what="--baud"),
        default=1_000_000,
        help="the bus's rate, one the servos have (default: 1000000)",
    )
    p.add_argument(
        "--rt-priority",
        type=number(0, 99, integer=True, what="--rt-priority"),
        default=0,
        help="run the bus thread SCHED_FIFO at this priority, 1-99 (Linux, CAP_SYS_NICE): "
        "answers on time on a busy machine (default: 0, the normal scheduler)",
    )
    p.add_argument(
        "--torque-on",
        action="store_true",
        help="servos start with the torque on, holding the standing pose (default: off, limp, "
        "as a servo powers up)",
    )


def command(args: argparse.Namespace) -> int:
    from app.firmware.virtual_bus import TABLES, check_baud, start_bus

    check_baud(args.protocol, args.baud)
    table = TABLES[args.protocol]
    from app.robots.model import RobotModel

    robot = RobotModel.load(args.robot)
    sys.setswitchinterval(SWITCH_S)  # the bus thread gets the interpreter back soon to answer
    bus, sim, stop, threads = start_bus(
        robot,
        protocol=args.protocol,
        baud=args.baud,
        torque_on=args.torque_on,
        rt_priority=args.rt_priority,
    )

    def on_signal(_signum: int, _frame: Any) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        print(bus.port, flush=True)
        print(
            f"artro bus: {robot.name}, {table.model} x12 ({args.protocol}) at {args.baud} baud, "
            f"IDs {robot.description.bus_ids()} in joint order; Ctrl-C ends",
            file=sys.stderr,
            flush=True,
        )
        while not stop.wait(0.5):
            if not all(t.is_alive() for t in threads):
                stop.set()
        for t in threads:
            t.join(timeout=5)
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        bus.close()
    summary = {
        "port": bus.port,
        "packets": bus.stats.packets,
        "answers": bus.stats.answers,
        "answers_lost": bus.stats.answers_lost,
        "malformed": bus.stats.malformed,
        "unanswered": bus.stats.unanswered,
        "goal_writes": bus.stats.goal_writes,
        "answer_late_max_us": bus.stats.late_max_us,
        "sim_s": round(sim.stats.steps * float(sim.model.opt.timestep), 3),
        "real_time_factor": round(sim.real_time_factor, 4),
        "sim_lag_max_ms": round(sim.stats.lag_max_s * 1000, 2),
        "sim_debt_drops": sim.stats.drops,
    }
    print(json.dumps(summary), flush=True)
    return 0
