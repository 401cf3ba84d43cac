"""`artro bus` as a subprocess for the tests: started, its port read from its first line, ended
with a signal and its closing JSON line read back; a robot of bus servos written to a folder."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

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
