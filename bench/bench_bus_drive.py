"""Benchmark: `artro drive`'s loop (app/firmware/host_drive.py) against the virtual servo bus.

    python bench/bench_bus_drive.py [--seconds 20] [--repeats 3] [--rate-hz 100] [--rt-seconds 10]

Two cases. **walk**: the ArtRo imported with Dynamixel XM430-W350s (tests/testing/bus_support.py)
on the virtual bus in this process (torque on, the factory's 500 µs return delay; its threads
SCHED_FIFO 10 where permitted), driven by `artro drive` (its own process, `--rt-priority 10`
where permitted) for `--seconds` of the
paper's gait at a_p = 0.07 after 1 s of settling; per repeat the
simulated trunk's forward speed over whole cycles after 5 s against `artro run --from-rest`'s
(the ratio; goal within 5 %), frames late, the sync write + sync read round trip at 50 Hz.
**round trip**: `artro bus` as its own process, our `BusClient` at `--rate-hz` a SYNC_WRITE of 12
goals and a SYNC_READ of the present positions, each servo's return delay written to 0 first (as
bench/bench_servo_bus.py does with dynamixel-sdk): median, p95, worst, late and failed cycles.
Writes bench/results/bench_bus_drive.json, or --json PATH.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import results
import serial

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the tests' bus robot
from app.firmware.bus_client import BusClient
from app.firmware.virtual_bus import start_bus
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.headless import run
from gait import Motion
from hardware.servo_bus import steps_to_angle
from tests.testing.bus_support import RT_PRIORITY, bus_robot_file, drive_and_measure, rt_permitted

PAPER = builtin_presets()["paper"].gait
FORWARD = Motion(a_p=0.07)
WARMUP_S = 5.0
IDS = list(range(1, 13))
STARVED_MS = 100.0  # a frame this late: the machine held the drive back (as the walk test)
#: sync reads a servo may miss in a row (1 s): the virtual bus shares the machine, and a stall
#: of its thread is no lost servo (`artro drive` ends after 5 by default)
LOST = 50


def walk_case(robot: RobotModel, robot_file: Path, seconds: float) -> dict[str, Any]:
    """`artro drive` for `seconds` against the virtual bus in this process: its figures."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.0005)  # as `artro bus` runs
    priority = RT_PRIORITY if rt_permitted() else 0
    bus, sim, stop, threads = start_bus(robot, torque_on=True, rt_priority=priority)
    args = ["--robot", str(robot_file), "--params", "paper", "--motion", "a_p=0.07"]
    try:
        walk = drive_and_measure(
            sim, bus.port, [*args, "--lost-after", str(LOST)], seconds, WARMUP_S,
            PAPER.clock.freq_hz,
        )  # fmt: skip
    finally:
        stop.set()
        for thread in threads:
            thread.join()
        bus.close()
        sys.setswitchinterval(interval)
    return {
        "forward_cm_s": walk.forward_cm_s,
        "drive": walk.summary,
        "sim_real_time_factor": sim.real_time_factor,
        "sim_lag_max_ms": sim.stats.lag_max_s * 1e3,
        "sim_late_goals": sim.stats.late_goals,
        "sim_kept_real_time": sim.stats.drops == 0,  # no debt dropped: the same physics
        "rt_priority": priority,
        "load_average_1min": os.getloadavg()[0],
    }


def round_trip_case(robot_file: Path, rate_hz: float, seconds: float) -> dict[str, Any]:
    """`artro bus` driven by `BusClient` at `rate_hz`: sync write + sync read round trips."""
    command = [sys.executable, "-m", "app.cli", "bus", "--robot", str(robot_file)]
    bus = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert bus.stdout is not None
    port_name = bus.stdout.readline().strip()
    with serial.Serial(port_name, 1_000_000, timeout=0.015) as port:
        client = BusClient(port, protocol="dynamixel", baud=1_000_000, ids=IDS, timeout_s=0.015)
        assert all(client.write(i, "return_delay_time", 0) for i in IDS)
        client.torque(True)
        start_rad = steps_to_angle([client.sync_read("present_position")[i] for i in IDS])
        period_s = 1.0 / rate_hz
        cycles = round(seconds * rate_hz)
        rtt, failed, late = [], 0, 0
        t_start = time.monotonic()
        for k in range(cycles):
            due = t_start + k * period_s
            now = time.monotonic()
            if now < due:
                time.sleep(due - now)
            else:
                late += now - due > 0.001
            goal = start_rad + 0.05 * math.sin(2 * math.pi * 0.5 * k * period_s)
            t0 = time.monotonic()
            client.goals(k, goal)
            got = client.sync_read("present_position")
            rtt.append((time.monotonic() - t0) * 1e3)
            failed += len(got) < len(IDS)
        client.torque(False)
    load = os.getloadavg()[0]
    bus.send_signal(signal.SIGTERM)
    out, _ = bus.communicate(timeout=30)
    ms = np.asarray(rtt)
    return {
        "cycles": cycles,
        "round_trip_ms": {
            "median": float(np.median(ms)),
            "p95": float(np.percentile(ms, 95)),
            "max": float(ms.max()),
            "min": float(ms.min()),
        },
        "late_cycles": late,
        "failed_cycles": failed,
        "load_average_1min": load,
        "bus": json.loads(out.strip().splitlines()[-1]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="walk per repeat (20)")
    parser.add_argument("--repeats", type=int, default=3, help="walks (default: 3)")
    parser.add_argument("--rate-hz", type=float, default=100.0, help="round trips a second (100)")
    parser.add_argument("--rt-seconds", type=float, default=10.0, help="round-trip case (10 s)")
    args = results.parse_args(parser)
    with tempfile.TemporaryDirectory() as folder:
        robot_file = bus_robot_file(Path(folder))
        robot = RobotModel.load(robot_file)
        ref = run(PAPER, FORWARD, duration_s=args.seconds, warmup_s=WARMUP_S,
                  start_motion=Motion(), robot=robot).metrics  # fmt: skip
        walks = []
        for k in range(args.repeats):
            walk = walk_case(robot, robot_file, args.seconds)
            d = walk["drive"]
            if walk["forward_cm_s"] is None:
                print(f"walk {k + 1}: ended early ({d['ended']}): {d}")
                continue
            walk["speed_ratio"] = walk["forward_cm_s"] / ref["forward_cm_s"]
            walks.append(walk)
            print(
                f"walk {k + 1}: {walk['forward_cm_s']:.3f} cm/s, artro run "
                f"{ref['forward_cm_s']:.3f} cm/s, ratio {walk['speed_ratio']:.4f}; "
                f"{d['late_frames']} of {d['frames'] + d['settle_frames']} frames late (worst "
                f"{d['late_max_ms']:.1f} ms); round trip median {d['round_trip_ms_median']} ms, "
                f"p95 {d['round_trip_ms_p95']} ms; {d['statuses_missed']} statuses missed; "
                f"simulation real-time factor {walk['sim_real_time_factor']:.4f}; load average "
                f"{walk['load_average_1min']:.1f}"
            )
        trip = round_trip_case(robot_file, args.rate_hz, args.rt_seconds)
    r = trip["round_trip_ms"]
    print(
        f"round trip at {args.rate_hz:g} Hz, return delay 0: median {r['median']:.2f} ms, p95 "
        f"{r['p95']:.2f} ms, max {r['max']:.2f} ms; {trip['late_cycles']} late, "
        f"{trip['failed_cycles']} failed of {trip['cycles']}; load average "
        f"{trip['load_average_1min']:.1f}"
    )
    ratios = [w["speed_ratio"] for w in walks] or [math.nan]
    kept = [  # both real-time parts kept their time: the simulation, the host's frames
        w["speed_ratio"]
        for w in walks
        if w["sim_kept_real_time"] and w["drive"]["late_max_ms"] <= STARVED_MS
    ] or [math.nan]
    headline = {
        "walk: repeats that walked their whole time": len(walks),
        "walk: repeats that kept real time (simulation, frames ≤ 100 ms late)": len(kept)
        - math.isnan(kept[0]),
        "walk: speed ratio to artro run, median (goal 1 ± 0.05)": float(np.median(ratios)),
        "walk: speed ratio, lowest": min(ratios),
        "walk: speed ratio, highest": max(ratios),
        "walk: speed ratio where real time was kept, lowest": min(kept),
        "walk: speed ratio where real time was kept, highest": max(kept),
        "walk: frames late, most of a repeat": max(
            (w["drive"]["late_frames"] for w in walks), default=math.nan
        ),
        "walk: round trip at 50 Hz, 500 µs return delay, median ms": float(
            np.median([w["drive"]["round_trip_ms_median"] for w in walks] or [math.nan])
        ),
        f"round trip at {args.rate_hz:g} Hz, return delay 0: median ms (goal < 5)": r["median"],
        f"round trip at {args.rate_hz:g} Hz, return delay 0: p95 ms": r["p95"],
        "load average (1 min) at the end": trip["load_average_1min"],
    }
    figures = {"artro_run": ref, "walks": walks, "round_trip": trip}
    results.write("bench_bus_drive", args, figures, headline)


if __name__ == "__main__":
    main()
