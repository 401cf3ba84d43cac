"""`artro bus` driven by the vendors' own Python packages, as a builder's program drives real
servos: ROBOTIS's `dynamixel_sdk` (Protocol 2.0) and Feetech's `scservo_sdk` (STS): PING every
ID, torque on, SYNC_WRITE goals, SYNC_READ present positions until the simulated joint got
there; a malformed packet is counted and the bus goes on (docs/BUS.md)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import dynamixel_sdk as dxl
import pytest
import scservo_sdk as scs

from app.robots import load_description
from gait import JOINT_NAMES
from hardware.servo_bus import angle_to_steps, dxl_packet, sts_packet
from tests.testing.bus_support import artro_bus

IDS = list(range(1, 13))
KNEE_ID = JOINT_NAMES.index("l_knee") + 1
KNEE_GOAL_RAD = -0.6
STEP_RAD = 2 * math.pi / 4096
MOVE_S = 10.0  # wall time the joint has to get there (real time; a loaded machine is slower)


#: an SDK call that timed out is tried again this often: on a loaded 2-core machine the bus
#: thread may miss the SDK's ~34 ms packet timeout, as a real bus may drop an answer; a
#: builder's program retries (the round trip's figures are `bench/bench_servo_bus.py`'s)
TRIES = 5


@pytest.fixture(autouse=True)
def slow_adapter(monkeypatch: pytest.MonkeyPatch) -> None:
    """Both SDKs size an answer's timeout for a USB adapter's 16 ms latency timer (~34 ms in
    all); a loaded 2-core machine can starve the bus thread longer, as a slow adapter would
    delay its bytes: the SDKs wait here as for a 100 ms latency timer (their own constant)."""
    monkeypatch.setattr(dxl.port_handler, "LATENCY_TIMER", 100)
    monkeypatch.setattr(scs.port_handler, "LATENCY_TIMER", 100)


def _tried(call: Callable[[], tuple], timeout: int, port: object) -> tuple:
    """`call()` (an SDK call whose second item is its result) until it is not `timeout`, the
    port's input cleared before each new try (a late answer is not the next call's)."""
    for _ in range(TRIES - 1):
        answer = call()
        if answer[1] != timeout:
            return answer
        port.clearPort()  # type: ignore[attr-defined]
    return call()


def _until(read: Callable[[], float], goal: float, tolerance: float) -> list[float]:
    """Read (each read waits for the servos' answers) until within `tolerance` of `goal` or
    `MOVE_S` passed; the readings."""
    seen = [read()]
    end = time.monotonic() + MOVE_S
    while abs(seen[-1] - goal) > tolerance and time.monotonic() < end:
        seen.append(read())
    return seen


def test_dynamixel_sdk_pings_writes_and_reads_the_simulated_servos() -> None:
    with artro_bus("--robot", "artro") as bus:
        port = dxl.PortHandler(bus.port)
        packets = dxl.PacketHandler(2.0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            for servo_id in IDS:
                model, result, error = _tried(
                    lambda i=servo_id: packets.ping(port, i), dxl.COMM_RX_TIMEOUT, port
                )
                assert (model, result, error) == (1020, dxl.COMM_SUCCESS, 0), servo_id
            voltage, result, _ = _tried(
                lambda: packets.read2ByteTxRx(port, 1, 144), dxl.COMM_RX_TIMEOUT, port
            )
            supply_v = load_description("artro").supply_voltage_v
            assert result == dxl.COMM_SUCCESS and voltage == round(supply_v * 10)  # 0.1 V
            torque = dxl.GroupSyncWrite(port, packets, 64, 1)
            for servo_id in IDS:
                torque.addParam(servo_id, [1])
            assert torque.txPacket() == dxl.COMM_SUCCESS
            present = dxl.GroupSyncRead(port, packets, 132, 4)
            for servo_id in IDS:
                assert present.addParam(servo_id)

            def positions() -> dict[int, int]:
                result = _tried(lambda: (None, present.txRxPacket()), dxl.COMM_RX_TIMEOUT, port)[1]
                assert result == dxl.COMM_SUCCESS
                return {i: present.getData(i, 132, 4) for i in IDS}

            goals = positions()  # hold every joint where it is, the knee to its goal
            goals[KNEE_ID] = int(angle_to_steps(KNEE_GOAL_RAD))
            write = dxl.GroupSyncWrite(port, packets, 116, 4)
            for servo_id, steps in goals.items():
                write.addParam(servo_id, list(steps.to_bytes(4, "little")))
            assert write.txPacket() == dxl.COMM_SUCCESS

            def knee_rad() -> float:
                return (positions()[KNEE_ID] - 2048) * STEP_RAD

            seen = _until(knee_rad, KNEE_GOAL_RAD, 0.05)
            assert abs(seen[-1] - KNEE_GOAL_RAD) <= 0.05, seen[:: max(1, len(seen) // 10)]
            # a bad CRC from the SDK's own port: the servo answers "CRC error", the bus goes on
            bad = bytearray(dxl_packet(3, dxl.INST_PING))
            bad[-2] ^= 0xFF
            port.writePort(list(bad))
            port.setPacketTimeoutMillis(1000)  # the raw read's own wait, as a program sets it
            reply, result = packets.rxPacket(port, False)
            assert result == dxl.COMM_SUCCESS and reply[8] == 0x03  # error 3: CRC
            assert (
                _tried(lambda: packets.ping(port, 3), dxl.COMM_RX_TIMEOUT, port)[1]
                == dxl.COMM_SUCCESS
            )
        finally:
            port.closePort()
    assert bus.summary["malformed"] == {"crc": 1}
    assert bus.summary["goal_writes"] == 2  # torque on, then the goals


def test_feetech_sdk_pings_writes_and_reads_the_simulated_servos() -> None:
    with artro_bus("--protocol", "feetech") as bus:
        port = scs.PortHandler(bus.port)
        packets = scs.PacketHandler(0)  # STS: little-endian
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            for servo_id in IDS:
                model, result, error = _tried(
                    lambda i=servo_id: packets.ping(port, i), scs.COMM_RX_TIMEOUT, port
                )
                assert (model, result, error) == (777, scs.COMM_SUCCESS, 0), servo_id
            torque = scs.GroupSyncWrite(port, packets, 40, 1)
            for servo_id in IDS:
                torque.addParam(servo_id, [1])
            assert torque.txPacket() == scs.COMM_SUCCESS
            present = scs.GroupSyncRead(port, packets, 56, 2)
            for servo_id in IDS:
                assert present.addParam(servo_id)

            def positions() -> dict[int, int]:
                result = _tried(lambda: (None, present.txRxPacket()), scs.COMM_RX_TIMEOUT, port)[1]
                assert result == scs.COMM_SUCCESS
                return {i: present.getData(i, 56, 2) for i in IDS}

            goals = positions()
            goals[KNEE_ID] = int(angle_to_steps(KNEE_GOAL_RAD))
            write = scs.GroupSyncWrite(port, packets, 42, 2)
            for servo_id, steps in goals.items():
                write.addParam(servo_id, list(steps.to_bytes(2, "little")))
            assert write.txPacket() == scs.COMM_SUCCESS

            def knee_rad() -> float:
                return (positions()[KNEE_ID] - 2048) * STEP_RAD

            seen = _until(knee_rad, KNEE_GOAL_RAD, 0.05)
            assert abs(seen[-1] - KNEE_GOAL_RAD) <= 0.05, seen[:: max(1, len(seen) // 10)]
            bad = bytearray(sts_packet(3, 0x01))
            bad[-1] ^= 0xFF
            port.writePort(bad)  # an STS stays silent on a bad checksum; the bus goes on
            assert (
                _tried(lambda: packets.ping(port, 3), scs.COMM_RX_TIMEOUT, port)[1]
                == scs.COMM_SUCCESS
            )
        finally:
            port.closePort()
    assert bus.summary["malformed"] == {"checksum": 1}


@pytest.mark.parametrize("sdk", ["dynamixel_sdk", "scservo_sdk"])
def test_the_vendors_packages_are_the_real_ones(sdk: str) -> None:
    """No stand-in: the modules come from the installed distributions the lock pins."""
    from importlib import metadata

    dists = metadata.packages_distributions()[sdk]
    assert dists in (["dynamixel-sdk"], ["dynamixel_sdk"], ["feetech-servo-sdk"])
