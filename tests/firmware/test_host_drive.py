"""`artro drive` (app/firmware/host_drive.py) against the virtual bus in this process: the host's
gait sends `artro run`'s goals to the bit, the simulated robot walks as `artro run` walks it
(forward speed within 5 %), and a servo that stops answering is named with the torque off."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest
import serial

from app.firmware.host_drive import DriveOptions, GaitFrames, drive, lost_sentence
from app.firmware.virtual_bus import VirtualBus, start_bus
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.bus_drive import BusSimulation
from app.sim.frame_loop import FrameLoop
from app.sim.headless import run
from app.sim.planning import START_PHASE_RAD
from app.sim.robot_pose import stand
from gait import Motion
from hardware.servo_bus import bus_frame
from tests.testing.bus_support import (
    RT_PRIORITY,
    bus_robot_file,
    drive_and_measure,
    rt_permitted,
)

PAPER = builtin_presets()["paper"].gait  # no balance law: a bus robot has no IMU on the bus
FORWARD = Motion(a_p=0.07)
STARVED_MS = 100.0  # a frame this late: the machine held the drive back (five frames)


@pytest.fixture(scope="module")
def robot_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return bus_robot_file(tmp_path_factory.mktemp("bus-robot"))


@pytest.fixture(scope="module")
def robot(robot_file: Path) -> RobotModel:
    return RobotModel.load(robot_file)


@pytest.fixture
def virtual_bus(robot: RobotModel) -> Iterator[tuple[VirtualBus, BusSimulation]]:
    """The robot on the virtual bus, its servos holding their pose (torque on), in real time;
    its threads SCHED_FIFO where the machine permits (as `artro bus --rt-priority 10`)."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.0005)  # as `artro bus` runs: the bus thread answers soon
    priority = RT_PRIORITY if rt_permitted() else 0
    bus, sim, stop, threads = start_bus(robot, torque_on=True, rt_priority=priority)
    try:
        yield bus, sim
    finally:
        stop.set()
        for thread in threads:
            thread.join()
        bus.close()
        sys.setswitchinterval(interval)


def test_the_host_sends_the_goals_artro_run_gives_its_servos_to_the_bit(robot: RobotModel) -> None:
    gait = GaitFrames(robot, PAPER, FORWARD, start_motion=Motion())
    loop = FrameLoop(robot, params=PAPER, motion=FORWARD, start_motion=Motion())
    pose = stand(robot, mujoco.MjData(robot.model), PAPER, Motion(), START_PHASE_RAD)
    np.testing.assert_array_equal(gait.start_pose, np.clip(pose, gait.low, gait.high))
    for k in range(120):  # the ramp and beyond a block of 50
        sent = bus_frame(k, gait.next(), protocol="dynamixel", ids=range(1, 13))
        assert sent.goal_rad == tuple(loop.step_frame().setpoint.tolist()), k


@pytest.mark.slow
def test_against_the_virtual_bus_the_robot_walks_as_artro_run_walks_it(
    robot_file: Path, robot: RobotModel, virtual_bus: tuple[VirtualBus, BusSimulation]
) -> None:
    bus, sim = virtual_bus
    walk_s, warmup_s = 20.0, 5.0
    # --lost-after 50 (1 s): the virtual bus shares a loaded machine, and a stall of its
    # thread is no lost servo
    args = ["--robot", str(robot_file), "--params", "paper", "--motion", "a_p=0.07"]
    walk = drive_and_measure(
        sim, bus.port, [*args, "--lost-after", "50"], walk_s, warmup_s, PAPER.clock.freq_hz
    )
    assert walk.returncode == 0, walk.summary
    assert walk.summary["ended"] == "duration" and walk.summary["frames"] == 1000
    assert walk.summary["torque_off"] and walk.summary["torque_unconfirmed"] == []
    assert all(s.torque_on is False for s in bus.bus.servos)  # read back off the bus
    ref = run(PAPER, FORWARD, duration_s=walk_s, warmup_s=warmup_s, start_motion=Motion(),
              robot=robot).metrics  # fmt: skip
    assert not ref["fell"] and ref["forward_cm_s"] > 2.0
    assert walk.forward_cm_s is not None
    near = walk.forward_cm_s == pytest.approx(ref["forward_cm_s"], rel=0.05)
    late_ms = walk.summary["late_max_ms"]
    if not near and (sim.stats.drops or late_ms > STARVED_MS):  # the machine starved one of
        pytest.skip(  # the real-time parts: not the walk `artro run` steps
            f"{walk.forward_cm_s:.3f} cm/s against {ref['forward_cm_s']:.3f}, but the "
            f"simulation dropped {sim.stats.dropped_s:.2f} s behind real time and a frame "
            f"went out {late_ms:.0f} ms late"
        )
    assert near, (walk.forward_cm_s, ref["forward_cm_s"], late_ms, walk.summary)


def test_a_servo_that_stops_answering_is_named_and_the_torque_switched_off(
    robot: RobotModel, virtual_bus: tuple[VirtualBus, BusSimulation]
) -> None:
    bus, _sim = virtual_bus
    knee = bus.bus.by_id(10)  # r_knee
    assert knee is not None

    def on_frame(k: int) -> None:
        if k == 10:
            knee.set("id", 40)  # no longer answers to its ID: as if its cable came loose

    options = DriveOptions(duration_s=5.0, settle_s=0.1, lost_after=3)
    with serial.Serial(bus.port, 1_000_000, timeout=0.015) as port:
        report = drive(port, robot, PAPER, FORWARD, options, threading.Event(), on_frame)
    assert report.ended == "lost" and report.lost == (10, "r_knee")
    assert report.frames == 11 + 2  # lost at the third sync read it missed
    assert report.torque_off
    others = [s for s in bus.bus.servos if s is not knee]
    assert not any(s.torque_on for s in others)
    sentence = lost_sentence(report, options)
    assert sentence.startswith("servo ID 10 (r_knee) gave no status to 3 sync reads in a row")
    assert "the torque was switched off (not read back as off from ID 10 (r_knee))" in sentence
