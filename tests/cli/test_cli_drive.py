"""`artro drive` as a user runs it against `artro bus`: bad options refused in a sentence (exit 2),
a servo the bus lacks named before anything is sent, the torque off on SIGTERM (read back from
the bus), a Feetech bus driven too."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import termios
import tty

import pytest

from hardware.servo_bus import READ, dxl_packet, dxl_status
from tests.testing.bus_support import START_S, artro_bus, read_bytes

DRIVE = [sys.executable, "-m", "app.cli", "drive"]
#: `artro bus` runs at the normal scheduler on a shared machine: a stall of it is no lost servo
PATIENT = ["--lost-after", "50"]


def _drive(*args: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*DRIVE, *args], capture_output=True, text=True, timeout=timeout_s)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--bus", "/dev/null", "--ids", "1,2,3"], "--ids must be 12 different whole numbers"),
        (["--bus", "/dev/null", "--ids", ",".join(["1"] * 12)], "--ids must be 12 different"),
        (["--bus", "/dev/null", "--baud", "12345"], "--baud must be one of XM430-W350's rates"),
        (["--bus", "/dev/null", "--timeout-ms", "20"], "--timeout-ms must be a whole number"),
        (["--bus", "/dev/null", "--duration", "0"], "--duration must be > 0"),
        (["--bus", "/dev/null", "--protocol", "can"], "invalid choice: 'can'"),
        (["--bus", "/dev/null", "--rt-priority", "100"], "--rt-priority must be a whole number"),
        ([], "the following arguments are required: --bus"),
        (["--bus", "/"], "the port / is not a serial device (a folder)"),
    ],
)
def test_bad_options_are_refused_in_a_sentence(args: list[str], said: str) -> None:
    done = _drive(*args)
    assert done.returncode == 2, done.stderr
    assert said in done.stderr
    assert done.stdout == ""  # nothing driven, no summary


def _open(port: str) -> int:
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    termios.tcflush(fd, termios.TCIOFLUSH)
    return fd


def _torque(port: str) -> list[int]:
    """Each servo's torque enable (Dynamixel, address 64) read back over the bus."""
    fd = _open(port)
    try:
        values = []
        for servo_id in range(1, 13):
            os.write(fd, dxl_packet(servo_id, READ, (64).to_bytes(2, "little") + b"\x01\x00"))
            status = read_bytes(fd, 12)
            assert status[:-3] == dxl_status(servo_id, 0, b"\x00")[:-3], status
            values.append(status[-3])
        return values
    finally:
        os.close(fd)


def test_a_servo_the_bus_lacks_is_named_and_nothing_is_sent() -> None:
    with artro_bus() as bus:
        ids = ",".join(map(str, [*range(1, 12), 13]))  # the bus has 1-12
        done = _drive("--bus", bus.port, "--params", "paper", "--ids", ids)
        assert done.returncode == 2, done.stderr
        assert "no answer from servo ID 13 (r_ankle_roll) on the dynamixel bus" in done.stderr
        assert _torque(bus.port) == [0] * 12  # as they powered up
    assert bus.summary["goal_writes"] == 0


def test_sigterm_switches_the_torque_off_and_says_what_was_driven() -> None:
    with artro_bus("--torque-on") as bus:
        assert _torque(bus.port) == [1] * 12
        drive = subprocess.Popen(
            [*DRIVE, "--bus", bus.port, "--params", "paper", "--motion", "a_p=0.05", *PATIENT],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert drive.stderr is not None
        lines = []
        while not lines or lines[-1] != "artro drive: walking":
            ready, _, _ = select.select([drive.stderr], [], [], START_S)
            assert ready, f"artro drive did not start walking within {START_S} s: {lines}"
            lines.append(drive.stderr.readline().strip())
            assert lines[-1] or drive.poll() is None, lines
        drive.send_signal(signal.SIGTERM)
        out, err = drive.communicate(timeout=30)
        assert drive.returncode == 0, err
        summary = json.loads(out.strip().splitlines()[-1])
        assert summary["ended"] == "stopped" and summary["torque_off"] is True
        assert summary["torque_unconfirmed"] == [] and summary["lost"] is None
        assert summary["settle_frames"] == 50 and summary["frames"] >= 1
        assert _torque(bus.port) == [0] * 12
    assert bus.summary["goal_writes"] >= 50


def test_a_feetech_bus_is_driven_for_its_duration() -> None:
    with artro_bus("--protocol", "feetech", "--torque-on") as bus:
        done = _drive(
            "--bus", bus.port, "--protocol", "feetech", "--params", "paper",
            "--duration", "1", "--settle", "0.2", *PATIENT,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        summary = json.loads(done.stdout.strip().splitlines()[-1])
        assert summary["ended"] == "duration" and summary["frames"] == 50
        assert summary["settle_frames"] == 10 and summary["reads"] == 60
        assert summary["torque_off"] and summary["torque_unconfirmed"] == []
    assert bus.summary["malformed"] == {}
