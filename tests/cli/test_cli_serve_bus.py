"""`artro serve --servo-bus pty` as a user starts it: the port's path printed at the start and
a program can ping a servo there; a value the option does not take exits 2 saying which do."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hardware.servo_bus import dxl_packet
from tests.testing.bus_support import read_bytes
from tests.testing.server_harness import free_port

START_S = 60.0  # loading MuJoCo and the robot on a busy machine
PREFIX = "artro serve: the servo bus is on "


@pytest.mark.slow
def test_serve_prints_the_bus_port_and_its_servos_answer(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "app.cli", "serve", "--servo-bus", "pty", "--no-viewer"]
    command += ["--port", str(free_port()), "--data-dir", str(tmp_path)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout is not None
    try:
        lines: list[str] = []
        while not any(line.startswith(PREFIX) for line in lines):
            ready, _, _ = select.select([process.stdout], [], [], START_S)
            assert ready, f"no servo bus line within {START_S} s: {lines}"
            line = process.stdout.readline()
            assert line, f"artro serve ended: {lines}, {process.stderr.read()}"  # type: ignore[union-attr]
            lines.append(line)
        port = next(line for line in lines if line.startswith(PREFIX))[len(PREFIX) :].strip()
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
        try:
            os.write(fd, dxl_packet(1, 0x01))  # PING of ID 1
            answer = read_bytes(fd, 14, timeout_s=10.0)
        finally:
            os.close(fd)
        assert answer[:5] == bytes([0xFF, 0xFF, 0xFD, 0x00, 1]) and answer[7] == 0x55
        assert answer[8] == 0 and int.from_bytes(answer[9:11], "little") == 1020  # XM430-W350
    finally:
        process.send_signal(signal.SIGINT)
        process.communicate(timeout=30)


def test_a_servo_bus_other_than_pty_is_refused(tmp_path: Path) -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "serve",
            "--servo-bus",
            "usb",
            "--data-dir",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "--servo-bus: invalid choice: 'usb'" in done.stderr
    assert "'pty'" in done.stderr
