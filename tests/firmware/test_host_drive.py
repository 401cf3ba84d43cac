"""`artro drive`'s loop (app/firmware/host_drive.py) against the virtual bus in this process: the
host's gait sends `artro run`'s goals to the bit, the simulated robot walks as `artro run` walks
it (forward speed within 5 %), and a servo that stops answering is named with the torque off."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator

import mujoco
import numpy as np
import pytest
import serial

from app.firmware.host_drive import DriveOptions, GaitFrames, drive, lost_sentence
from app.firmware.virtual_bus import VirtualBus, start_bus
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.bus_drive import BusSimulation
from app.sim.frame_loop import FrameLoop, stand
from app.sim.headless import run
from app.sim.metrics import Trace, mean_body_velocity, whole_cycles
from app.sim.planning import START_PHASE_RAD
from gait import Motion
from hardware.servo_bus import bus_frame
from tests.testing.bus_support import bus_robot_file

PAPER = builtin_presets()["paper"].gait  # no balance law: a bus robot has no IMU on the bus
FORWARD = Motion(a_p=0.07)


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> RobotModel:
    return RobotModel.load(bus_robot_file(tmp_path_factory.mktemp("bus-robot")))


@pytest.fixture
def virtual_bus(robot: RobotModel) -> Iterator[tuple[VirtualBus, BusSimulation]]:
    """The robot on the virtual bus, its servos holding their pose (torque on), in real time."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(0.0005)  # as `artro bus` runs: the bus thread answers soon
    bus, sim, stop, threads = start_bus(robot, torque_on=True)
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
    robot: RobotModel, virtual_bus: tuple[VirtualBus, BusSimulation]
) -> None:
    bus, sim = virtual_bus
    walk_s, warmup_s = 20.0, 5.0
    trace = Trace()

    def on_frame(_k: int) -> None:  # where the simulated trunk is as each frame goes out
        m = sim.handoff.measured
        trace.append(m.time_s, m.trunk, np.zeros(3), 0.0)

    # lost_after 50 (1 s): the virtual bus shares this process and a loaded machine, and a
    # stall of its thread is no lost servo
    with serial.Serial(bus.port, 1_000_000, timeout=0.015) as port:
        report = drive(
            port, robot, PAPER, FORWARD, DriveOptions(duration_s=walk_s, lost_after=50),
            threading.Event(), on_frame,
        )  # fmt: skip
    assert report.ended == "duration" and report.torque_off
    if sim.stats.drops:  # the machine starved the simulation thread: not the same physics
        pytest.skip(f"the simulation fell {sim.stats.dropped_s:.2f} s behind real time")
    assert report.frames == 1000 and report.settle_frames == 50
    a = trace.arrays()
    t = a["t"] - a["t"][0]  # from the first walking frame, as `artro run` counts
    window = whole_cycles(t, warmup_s, PAPER.clock.freq_hz)
    speed = mean_body_velocity(t[window], *(a[k][window] for k in ("x", "y", "yaw")),
                               PAPER.clock.freq_hz)[0]  # fmt: skip
    ref = run(PAPER, FORWARD, duration_s=walk_s, warmup_s=warmup_s, start_motion=Motion(),
              robot=robot).metrics  # fmt: skip
    assert not ref["fell"] and ref["forward_cm_s"] > 2.0
    assert 100 * speed == pytest.approx(ref["forward_cm_s"], rel=0.05), (
        report.summary(), sim.real_time_factor,
    )  # fmt: skip
    assert all(s.torque_on is False for s in bus.bus.servos)  # read back off the bus


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
