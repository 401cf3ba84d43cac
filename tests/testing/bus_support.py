"""`artro bus` as a subprocess for the tests: started, its port read from its first line, ended
with a signal and its closing JSON line read back; a robot of bus servos written to a folder;
`artro drive` run against a virtual bus in this process, the simulated trunk's speed measured."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.sim.bus_drive import BusSimulation
from app.sim.metrics import Trace, mean_body_velocity, whole_cycles

START_S = 60.0  # loading MuJoCo and the robot on a busy machine


@dataclass
class BusProcess:
    process: subprocess.Popen[str]
    port: str
    summary: dict[str, Any] = field(default_factory=dict)


@contextmanager
def artro_bus(*args: str) -> Iterator[BusProcess]:
    """`artro bus ARGS` running; on leaving, SIGTERM, its exit status checked (0) and its
    summary line kept in `.summary`."""
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "bus", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    ready, _, _ = select.select([process.stdout], [], [], START_S)
    if not ready:
        process.kill()
        raise AssertionError(f"artro bus printed no port within {START_S} s")
    port = process.stdout.readline().strip()
    assert port.startswith("/dev/"), (port, process.stderr.read() if process.stderr else "")
    bus = BusProcess(process, port)
    try:
        yield bus
    finally:
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=30)
        assert process.returncode == 0, err
        bus.summary = json.loads(out.strip().splitlines()[-1])


def read_bytes(fd: int, n: int, timeout_s: float = 2.0) -> bytes:
    """Up to `n` bytes from `fd`, waiting at most `timeout_s` for them (fewer on a timeout)."""
    got = b""
    end = time.monotonic() + timeout_s
    while len(got) < n:
        left = end - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            break
        got += os.read(fd, n - len(got))
    return got


def bus_robot_file(folder: Path) -> Path:
    """A robot of bus servos in `folder`: the built-in ArtRo exported as a CAD file's MJCF and
    imported with Dynamixel XM430-W350s (`artro robot import --servo`), its description's
    path; it walks the paper's gait in `artro run`."""
    from app.robots.cad_import import import_robot, write_import
    from tests.testing.cad_support import artro_mjcf

    source, target = folder / "artro-cad.xml", folder / "artro-bus.yaml"
    source.write_text(artro_mjcf(), encoding="utf-8")
    imported = import_robot(source, output=target, name="artro-bus", servo="XM430-W350")
    write_import(imported, target, "tests.testing.bus_support")
    return target


@dataclass
class DrivenWalk:
    """`artro drive`'s walk as the simulation saw it: the trunk's forward speed (cm/s) over whole
    cycles after the warm-up, the drive's closing JSON line, its exit status."""

    forward_cm_s: float | None
    summary: dict[str, Any]
    returncode: int


RT_PRIORITY = 10  # SCHED_FIFO for the real-time parts where the machine permits it


def rt_permitted(priority: int = RT_PRIORITY) -> bool:
    """Whether a thread of this process may run SCHED_FIFO at `priority` (tried on a thread that
    then ends)."""
    permitted: list[bool] = []

    def probe() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
            permitted.append(True)
        except (OSError, AttributeError):
            permitted.append(False)

    thread = threading.Thread(target=probe)
    thread.start()
    thread.join()
    return permitted[0]


@contextmanager
def sampled_at_priority(priority: int) -> Iterator[None]:
    """The calling thread SCHED_FIFO at `priority` (0: as it is) until the block ends. A thread
    that samples the virtual bus's simulation shares the interpreter's lock with the bus's
    SCHED_FIFO threads: preempted by other programs while it holds the lock, it would hold them
    back (priority inversion); at a real-time priority it is never preempted by them."""
    if priority <= 0:
        yield
        return
    before = os.sched_getscheduler(0), os.sched_getparam(0)
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    try:
        yield
    finally:
        os.sched_setscheduler(0, before[0], before[1])


def drive_and_measure(
    sim: BusSimulation, port: str, args: list[str], walk_s: float, warmup_s: float, freq_hz: float
) -> DrivenWalk:
    """Run `artro drive --bus PORT ARGS --duration WALK_S` (its own process, as a user runs it;
    `--rt-priority` where permitted) against the virtual bus whose simulation `sim` is in this
    process; the trunk is sampled as the simulation publishes it, from the drive's first walking
    frame on (its "walking" line)."""
    command = [sys.executable, "-m", "app.cli", "drive", "--bus", port, *args]
    if rt_permitted():
        command += ["--rt-priority", str(RT_PRIORITY)]
    drive = subprocess.Popen(
        [*command, "--duration", f"{walk_s:g}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert drive.stderr is not None
    said: list[str] = []
    while not said or said[-1] != "artro drive: walking":
        ready, _, _ = select.select([drive.stderr], [], [], START_S)
        line = drive.stderr.readline() if ready else ""
        if not line:
            drive.kill()
            raise AssertionError(f"artro drive did not start walking: {said}")
        said.append(line.strip())
    start_s = sim.handoff.measured.time_s  # frame 0 has just gone out
    trace = Trace()
    # below the bus's threads (RT_PRIORITY and one less), above every other program
    with sampled_at_priority(RT_PRIORITY - 2 if rt_permitted() else 0):
        while True:  # a sample per frame or so: each carries the simulated time it was taken at
            m = sim.handoff.measured
            if m.time_s <= start_s + walk_s and (not trace.t_s or m.time_s > trace.t_s[-1]):
                trace.append(m.time_s - start_s, m.trunk, np.zeros(3), 0.0)
            try:
                drive.wait(timeout=0.01)
                break
            except subprocess.TimeoutExpired:
                continue
    out, err = drive.communicate(timeout=30)
    summary = json.loads(out.strip().splitlines()[-1]) if out.strip() else {"stderr": err}
    forward = None
    if summary.get("ended") == "duration":
        a = trace.arrays()
        window = whole_cycles(a["t"], warmup_s, freq_hz)
        t, x, y, yaw = (a[k][window] for k in ("t", "x", "y", "yaw"))
        forward = 100 * mean_body_velocity(t, x, y, yaw, freq_hz)[0]
    return DrivenWalk(forward, summary, drive.returncode)
