"""`artro serve --servo-bus pty` (docs/BUS.md): a real server whose live robot's 12 leg servos
answer on a pseudo-terminal; ROBOTIS's `dynamixel_sdk` pings them, sync-writes goals and the
robot's joints follow (GET /api/bus); the scope shows the goals' sync write; a malformed packet
is counted, never a crash; when the goal writes stop, the gait drives again."""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from pathlib import Path

import dynamixel_sdk as dxl
import pytest

from gait import JOINT_NAMES
from hardware.servo_bus import angle_to_steps, dxl_packet, sts_packet
from tests.testing.server_harness import client, running_server, wait_for

IDS = list(range(1, 13))
KNEE = JOINT_NAMES.index("l_knee")
#: a crouch the robot stands in: hip pitch, knee, ankle pitch bent, in the gait's joint order
CROUCH_RAD = [0.0, 0.0, 0.3, -0.6, 0.3, 0.0] * 2
TOLERANCE_RAD = 0.1  # the knees sag under the robot's weight (a position servo's stiffness)
ANSWER_MS = 2000  # how long a bare read waits for a status (a loaded 2-core machine)
TRIES = 5  # an SDK call that timed out is tried again (a loaded 2-core machine, as a real bus)

pytestmark = pytest.mark.slow


def _tried(call: Callable[[], tuple], port: object, timeout: int = dxl.COMM_RX_TIMEOUT) -> tuple:
    """`call()` (an SDK call whose second item is its result) until it did not time out (the
    SDK's `timeout` result), the port's input cleared before each new try."""
    for _ in range(TRIES - 1):
        answer = call()
        if answer[1] != timeout:
            return answer
        port.clearPort()  # type: ignore[attr-defined]
    return call()


def test_dynamixel_sdk_drives_the_dashboards_robot(tmp_path: Path) -> None:
    with running_server(tmp_path / "data", servo_bus="pty") as (url, _app), client(url) as http:
        status = http.get("/api/bus").json()
        assert status["protocol"] == "dynamixel" and status["ids"] == IDS
        assert status["port"].startswith("/dev/pts/") and not status["driving"]
        port = dxl.PortHandler(status["port"])
        packets = dxl.PacketHandler(2.0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            for servo_id in IDS:
                answer = _tried(lambda i=servo_id: packets.ping(port, i), port)
                assert answer == (1020, dxl.COMM_SUCCESS, 0), servo_id
            goals = [int(s) for s in angle_to_steps(CROUCH_RAD)]
            write = dxl.GroupSyncWrite(port, packets, 116, 4)
            for servo_id, steps in zip(IDS, goals, strict=True):
                write.addParam(servo_id, list(steps.to_bytes(4, "little")))

            def crouched() -> dict | None:
                assert write.txPacket() == dxl.COMM_SUCCESS  # a program drives on, frame by frame
                now = http.get("/api/bus").json()
                off = [abs(a - b) for a, b in zip(now["present_rad"], CROUCH_RAD, strict=True)]
                return now if now["driving"] and max(off) < TOLERANCE_RAD else None

            streak: list[dict] = []

            def held() -> dict | None:  # at the goals in 5 polls in a row, not passing by
                now = crouched()
                streak[:] = [*streak, now] if now else []
                return (
                    now if len(streak) >= 5 and streak[-1]["time_s"] > streak[0]["time_s"] else None
                )

            driven = wait_for(held, "the joints held at the bus's goals")
            assert driven["goal_writes"] >= 1 and driven["packets"] >= 13
            assert driven["goal_latency_ms_median"] is not None
            assert http.get("/api/state").json()["fell"] is False
            write.txPacket()

            def bus_frame() -> dict | None:
                frame = http.get("/api/scope?frames=1").json()["frames"][-1]
                return frame.get("bus")

            shown = wait_for(bus_frame, "a scope frame the bus drove")
            assert [g["steps"] for g in shown["goals"]] == goals  # the goals' sync write
            # the SDK reads the same joint as the route
            steps, result, _ = _tried(lambda: packets.read4ByteTxRx(port, KNEE + 1, 132), port)
            assert result == dxl.COMM_SUCCESS
            assert abs((steps - 2048) * 2 * math.pi / 4096 - CROUCH_RAD[KNEE]) < TOLERANCE_RAD
            # a bad CRC: the servo answers "CRC error", counted; the bus and the server go on
            bad = bytearray(dxl_packet(3, dxl.INST_PING))
            bad[-2] ^= 0xFF
            port.clearPort()
            port.writePort(list(bad))
            port.setPacketTimeoutMillis(ANSWER_MS)  # the SDK times its reads from its own sends
            errors = []
            for _ in range(TRIES):  # a late answer to a retried read may come first
                reply, result = packets.rxPacket(port, False)
                if result != dxl.COMM_SUCCESS or reply[8] == 0x03:
                    break
                errors.append(reply[8])
            assert result == dxl.COMM_SUCCESS and reply[8] == 0x03, (result, errors)  # error 3: CRC
            assert _tried(lambda: packets.ping(port, 3), port)[1] == dxl.COMM_SUCCESS
            after = http.get("/api/bus").json()
            assert after["malformed"] == {"crc": 1} and after["errors"] == 1
            # noise on the line (seeded): counted, the bus goes on answering
            port.writePort(list(random.Random(54).randbytes(300)))
            assert _tried(lambda: packets.ping(port, 5), port)[1] == dxl.COMM_SUCCESS
            assert http.get("/api/bus").json()["errors"] > 1
            # the goal writes stop: the gait drives again within a second or so
            wait_for(lambda: not http.get("/api/bus").json()["driving"], "the gait back")
            assert http.get("/api/health").status_code == 200
        finally:
            port.closePort()


def test_without_a_servo_bus_the_route_says_so(http) -> None:
    answer = http.get("/api/bus")
    assert answer.status_code == 404 and "--servo-bus pty" in answer.json()["message"]


def test_feetech_sdk_drives_the_dashboards_robot(tmp_path: Path) -> None:
    """`--bus-protocol feetech`: Feetech's `scservo_sdk` pings the 12 STS3215s and its sync
    writes crouch the robot; a bad checksum is counted, the servo stays silent."""
    import scservo_sdk as scs

    config = {"servo_bus": "pty", "bus_protocol": "feetech"}
    with running_server(tmp_path / "data", **config) as (url, _app), client(url) as http:
        status = http.get("/api/bus").json()
        assert status["protocol"] == "feetech"
        port = scs.PortHandler(status["port"])
        packets = scs.PacketHandler(0)  # STS: little-endian
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            for servo_id in IDS:
                answer = _tried(lambda i=servo_id: packets.ping(port, i), port, scs.COMM_RX_TIMEOUT)
                assert answer == (777, scs.COMM_SUCCESS, 0), servo_id
            write = scs.GroupSyncWrite(port, packets, 42, 2)
            for servo_id, steps in zip(IDS, angle_to_steps(CROUCH_RAD).tolist(), strict=True):
                write.addParam(servo_id, list(int(steps).to_bytes(2, "little")))

            def crouched() -> dict | None:
                assert write.txPacket() == scs.COMM_SUCCESS
                now = http.get("/api/bus").json()
                off = [abs(a - b) for a, b in zip(now["present_rad"], CROUCH_RAD, strict=True)]
                return now if now["driving"] and max(off) < TOLERANCE_RAD else None

            wait_for(crouched, "the joints at the bus's goals")
            bad = bytearray(sts_packet(3, 0x01))
            bad[-1] ^= 0xFF
            port.writePort(bad)
            assert (
                _tried(lambda: packets.ping(port, 3), port, scs.COMM_RX_TIMEOUT)[1]
                == scs.COMM_SUCCESS
            )
            assert http.get("/api/bus").json()["malformed"] == {"checksum": 1}
        finally:
            port.closePort()
