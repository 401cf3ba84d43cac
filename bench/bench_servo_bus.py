"""Benchmark: the virtual servo bus (`artro bus`, docs/BUS.md) driven by ROBOTIS's dynamixel-sdk
as a builder's program drives 12 servos: at 100 Hz a SYNC_WRITE of the goal positions and a
SYNC_READ of the present positions, for `--seconds`. The round trip is the time from the write's
call to the read's return; the goal is a median under 5 ms with the simulation in real time.

    python bench/bench_servo_bus.py [--seconds 10] [--rate-hz 100] [--rt-priorities 0,10]

Each servo's return delay is written first (as such programs do; the factory's is 500 µs),
then the torque switched on. A case per `artro bus --rt-priority` (0: the normal scheduler; 10:
the bus thread SCHED_FIFO, where the machine permits it). The figures per case: the round
trip's median, p95 and worst, cycles that started late, failed transfers, the wire time the bus
model gives the same exchange, the load average, and what `artro bus` said at its end: the
simulation's real-time factor and largest lag, how late the latest answer went out.
Writes bench/results/bench_servo_bus.json, or --json PATH.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import time
from typing import Any

import dynamixel_sdk as dxl
import numpy as np
import results

from hardware.servo_bus import (
    BROADCAST_ID,
    SYNC_READ,
    angle_to_steps,
    answers_done_us,
    dxl_packet,
    dxl_status,
    dxl_sync_write,
    wire_us,
)

IDS = list(range(1, 13))
GOAL_MS = 5.0
SWING_RAD = 0.05  # each joint swings this much about where it started, at 0.5 Hz


def modelled_round_trip_us(baud: int, return_delay_us: int) -> int:
    """Wire time of one cycle on a real bus: the sync write, the sync read, 12 answers."""
    write = dxl_sync_write(116, 4, dict.fromkeys(IDS, 2048))
    read = dxl_packet(BROADCAST_ID, SYNC_READ, bytes([132, 0, 4, 0, *IDS]))
    status = dxl_status(1, 0, bytes(4))
    end = wire_us(len(write), baud) + wire_us(len(read), baud)
    return answers_done_us(end, [len(status)] * 12, [return_delay_us] * 12, baud)[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="how long (default: 10)")
    parser.add_argument("--rate-hz", type=float, default=100.0, help="cycles a second (100)")
    parser.add_argument("--baud", type=int, default=1_000_000, help="bus rate (1000000)")
    parser.add_argument(
        "--return-delay-us", type=int, default=0, help="each servo's return delay (default: 0)"
    )
    parser.add_argument("--robot", default="artro", help="the robot (default: artro)")
    parser.add_argument(
        "--rt-priorities",
        default="0,10",
        help="artro bus --rt-priority per case, 0 the normal scheduler (default: 0,10; a case "
        "the machine does not permit is skipped and said)",
    )
    args = results.parse_args(parser)
    cases, skipped = {}, {}
    for priority in (int(p) for p in args.rt_priorities.split(",")):
        name = "normal scheduler" if priority == 0 else f"bus thread SCHED_FIFO {priority}"
        try:
            cases[name] = run_case(args, priority)
        except CaseRefused as exc:
            skipped[name] = str(exc)
            print(f"{name}: skipped: {exc}")
            continue
        f = cases[name]
        rtt, bus = f["round_trip_ms"], f["bus"]
        print(
            f"{name}: {f['cycles']} cycles at {args.rate_hz:g} Hz: round trip median "
            f"{rtt['median']:.2f} ms, p95 {rtt['p95']:.2f} ms, max {rtt['max']:.2f} ms (wire time "
            f"{f['modelled_wire_ms']:.2f} ms); {f['failed_cycles']} failed, {f['late_cycles']} "
            f"started late; simulation real-time factor {bus['real_time_factor']}, largest lag "
            f"{bus['sim_lag_max_ms']} ms; load average {f['load_average_1min']:.1f}"
        )
    headline: dict[str, float] = {}
    for name, f in cases.items():
        headline[f"{name}: round trip median, ms (goal < {GOAL_MS:g})"] = f["round_trip_ms"][
            "median"
        ]
        headline[f"{name}: round trip p95, ms"] = f["round_trip_ms"]["p95"]
        headline[f"{name}: simulation real-time factor (goal 1)"] = f["bus"]["real_time_factor"]
    headline["wire time the bus model gives, ms"] = (
        modelled_round_trip_us(args.baud, args.return_delay_us) / 1000
    )
    results.write("bench_servo_bus", args, {"cases": cases, "skipped": skipped}, headline)


class CaseRefused(RuntimeError):
    """`artro bus` refused the case (its --rt-priority not permitted here)."""


def run_case(args: argparse.Namespace, rt_priority: int) -> dict[str, Any]:
    """One run of `artro bus` driven at `args.rate_hz` for `args.seconds`: its figures."""
    command = [sys.executable, "-m", "app.cli", "bus", "--robot", args.robot]
    command += ["--baud", str(args.baud), "--rt-priority", str(rt_priority)]
    bus = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert bus.stdout is not None and bus.stderr is not None
    port_name = bus.stdout.readline().strip()
    if not port_name:
        raise CaseRefused(bus.stderr.read().strip().splitlines()[-1])
    port = dxl.PortHandler(port_name)
    packets = dxl.PacketHandler(2.0)
    if not (port.openPort() and port.setBaudRate(args.baud)):
        raise SystemExit(f"cannot open {port_name} at {args.baud}")
    for servo_id in IDS:
        result, error = packets.write1ByteTxRx(port, servo_id, 9, args.return_delay_us // 2)
        assert (result, error) == (dxl.COMM_SUCCESS, 0), (servo_id, result, error)
    torque = dxl.GroupSyncWrite(port, packets, 64, 1)
    for servo_id in IDS:
        torque.addParam(servo_id, [1])
    torque.txPacket()
    read = dxl.GroupSyncRead(port, packets, 132, 4)
    for servo_id in IDS:
        read.addParam(servo_id)
    assert read.txRxPacket() == dxl.COMM_SUCCESS
    start_steps = np.array([read.getData(i, 132, 4) for i in IDS])
    start_rad = (start_steps - 2048) * 2 * math.pi / 4096
    write = dxl.GroupSyncWrite(port, packets, 116, 4)
    for servo_id in IDS:
        write.addParam(servo_id, [0, 8, 0, 0])

    period_s = 1.0 / args.rate_hz
    cycles = round(args.seconds * args.rate_hz)
    round_trip_ms, failed, late = [], 0, 0
    t_start = time.perf_counter()
    for k in range(cycles):
        due = t_start + k * period_s
        now = time.perf_counter()
        if now < due:
            time.sleep(due - now)
        else:
            late += now - due > 0.001  # the cycle before ran past this one's start
        goal = angle_to_steps(start_rad + SWING_RAD * math.sin(2 * math.pi * 0.5 * k * period_s))
        for servo_id, steps in zip(IDS, goal.tolist(), strict=True):
            write.changeParam(servo_id, list(int(steps).to_bytes(4, "little")))
        t0 = time.perf_counter()
        ok = write.txPacket() == dxl.COMM_SUCCESS and read.txRxPacket() == dxl.COMM_SUCCESS
        round_trip_ms.append((time.perf_counter() - t0) * 1000)
        failed += not ok
    wall_s = time.perf_counter() - t_start
    load = os.getloadavg()[0]
    port.closePort()
    bus.send_signal(signal.SIGTERM)
    out, _ = bus.communicate(timeout=30)
    rtt = np.array(round_trip_ms)
    return {
        "rt_priority": rt_priority,
        "cycles": cycles,
        "wall_s": wall_s,
        "round_trip_ms": {
            "median": float(np.median(rtt)),
            "p95": float(np.percentile(rtt, 95)),
            "max": float(rtt.max()),
            "min": float(rtt.min()),
        },
        "modelled_wire_ms": modelled_round_trip_us(args.baud, args.return_delay_us) / 1000,
        "failed_cycles": failed,
        "late_cycles": late,
        "load_average_1min": load,
        "bus": json.loads(out.strip().splitlines()[-1]),
    }


if __name__ == "__main__":
    main()
