"""`artro bus`: its refusals, and the port answering raw packets as the servos would (the
hardware model's bytes), a malformed packet answered or not and counted, never a crash."""

from __future__ import annotations

import os
import subprocess
import sys
import termios
import tty

from hardware.servo_bus import (
    ERR_CRC,
    PING,
    READ,
    dxl_packet,
    dxl_status,
    sts_packet,
    sts_status,
)
from tests.testing.bus_support import artro_bus, read_bytes


def test_a_baud_no_servo_has_is_refused_naming_the_rates() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "bus", "--baud", "12345"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "--baud must be one of XM430-W350's rates" in done.stderr
    assert "1000000" in done.stderr


def _open(port: str) -> int:
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    termios.tcflush(fd, termios.TCIOFLUSH)
    return fd


def test_dynamixel_servos_answer_raw_packets_and_count_the_malformed() -> None:
    with artro_bus() as bus:
        fd = _open(bus.port)
        try:
            os.write(fd, dxl_packet(12, PING))
            assert read_bytes(fd, 14) == dxl_status(12, 0, (1020).to_bytes(2, "little") + b"\x34")
            os.write(fd, dxl_packet(3, READ, (64).to_bytes(2, "little") + b"\x01\x00"))
            assert read_bytes(fd, 12) == dxl_status(3, 0, b"\x00")  # torque off at power-on
            bad = bytearray(dxl_packet(5, PING))
            bad[-1] ^= 0x55
            os.write(fd, b"\x13\x37" + bytes(bad))  # noise, then a bad CRC: CRC error from ID 5
            assert read_bytes(fd, 11) == dxl_status(5, ERR_CRC)
            os.write(fd, dxl_packet(40, PING))  # nobody: silence
            assert read_bytes(fd, 1, timeout_s=0.3) == b""
            os.write(fd, dxl_packet(1, PING))  # the bus goes on
            assert read_bytes(fd, 14)[:5] == b"\xff\xff\xfd\x00\x01"
            os.write(fd, dxl_packet(2, PING)[:6])  # half a packet, then the line falls quiet
            assert read_bytes(fd, 1, timeout_s=1.0) == b""  # well past the 50 ms a servo waits
            os.write(fd, dxl_packet(2, PING))  # dropped: this one is whole again
            assert read_bytes(fd, 14)[:5] == b"\xff\xff\xfd\x00\x02"
        finally:
            os.close(fd)
    assert bus.summary["malformed"] == {"noise": 1, "crc": 1, "partial": 1}
    assert bus.summary["unanswered"] == 1
    assert bus.summary["packets"] == 5


def test_feetech_servos_answer_and_stay_silent_on_a_bad_checksum() -> None:
    with artro_bus("--protocol", "feetech", "--baud", "500000") as bus:
        fd = _open(bus.port)
        try:
            os.write(fd, sts_packet(7, PING))
            assert read_bytes(fd, 6) == sts_status(7, 0)
            os.write(fd, sts_packet(7, READ, bytes([3, 2])))
            assert read_bytes(fd, 8) == sts_status(7, 0, (777).to_bytes(2, "little"))
            bad = bytearray(sts_packet(7, PING))
            bad[-1] ^= 1
            os.write(fd, bytes(bad))
            assert read_bytes(fd, 1, timeout_s=0.3) == b""
        finally:
            os.close(fd)
    assert bus.summary["malformed"] == {"checksum": 1}
