"""The robot driven by bus servos (app/sim/bus_drive.py), stepped by hand: a goal acts from the
first 1 ms step starting at or after its packet's end, torque off is limp, and what the servos
measure is published after each advance; the bus thread's goals reach it through the handoff."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from app.assets import builtin_robots_dir
from app.firmware.virtual_bus import VirtualBus, start_bus
from app.robots import RobotError, load_description
from app.robots.model import RobotModel
from app.sim.bus_drive import BusSimulation, Goals
from gait import JOINT_NAMES
from hardware.servo_bus import Parser, angle_to_steps, dxl_packet, dxl_sync_write


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return RobotModel.load()


def _goals(effect_s: float, goal_rad: np.ndarray, on: bool = True) -> Goals:
    return Goals(effect_s, tuple(goal_rad.tolist()), (on,) * 12)


def test_a_goal_acts_from_the_first_step_that_starts_at_or_after_its_time(
    robot: RobotModel,
) -> None:
    sim = BusSimulation(robot, torque_on=True)
    sim.anchor_s = 100.0
    dt = sim.timestep_s
    assert dt == pytest.approx(0.001)
    knee = JOINT_NAMES.index("l_knee")
    goal = np.array(sim.pose)
    goal[knee] = -0.8
    act = robot.actuator_ids[knee]
    sim.handoff.put(_goals(100.0 + 3.5 * dt, goal))  # the packet ends 3.5 ms in
    sim.advance(4)  # steps 0..3 start before it
    assert sim.data.ctrl[act] == pytest.approx(sim.pose[knee], abs=0)
    sim.advance(5)  # step 4 starts at 4 ms: the goal is on
    assert sim.data.ctrl[act] == -0.8
    assert sim.stats.late_goals == 0
    measured = sim.handoff.measured
    assert measured.time_s == pytest.approx(5 * dt)
    assert measured.position_rad[knee] == sim.data.qpos[robot.qpos_adr[knee]]


def test_torque_off_is_limp_and_on_holds_the_goal(robot: RobotModel) -> None:
    sim = BusSimulation(robot, torque_on=False)
    act = robot.actuator_ids
    assert (sim.model.actuator_gainprm[act, 0] == 0).all()
    assert (robot.model.actuator_gainprm[act, 0] > 0).all()  # the robot's own model untouched
    sim.handoff.put(_goals(0.0, np.array(sim.pose), on=True))
    sim.advance(1)
    assert (sim.model.actuator_gainprm[act, 0] > 0).all()
    assert (sim.model.actuator_biasprm[act, 1] == -sim.model.actuator_gainprm[act, 0]).all()


def test_the_bus_threads_sync_write_reaches_the_simulation_at_its_last_byte(
    robot: RobotModel,
) -> None:
    """The bus's handling of a SYNC_WRITE, without the pty's threads: the goal handed over
    takes effect at arrival + the packet's wire time at the baud rate."""
    sim = BusSimulation(robot, torque_on=True)
    bus = VirtualBus("dynamixel", 1_000_000, sim.handoff, 6.0, list(range(1, 13)))
    try:
        steps = angle_to_steps(np.full(12, -0.25)).tolist()
        packet = dxl_sync_write(116, 4, dict(zip(range(1, 13), steps, strict=True)))
        (item,) = Parser("dynamixel").feed(packet)
        bus.handle(item, arrived_s=50.0)
        (goals,) = sim.handoff.take()
        assert goals.effect_s == pytest.approx(50.0 + len(packet) * 10e-6)  # 74 bytes, 740 µs
        assert goals.goal_rad == (steps_rad := (steps[0] - 2048) * 2 * math.pi / 4096,) * 12
        assert steps_rad == pytest.approx(-0.25, abs=math.pi / 4096)
        bus.handle(Parser("dynamixel").feed(dxl_packet(1, 0x01))[0], arrived_s=60.0)
        assert sim.handoff.take() == []  # a PING changes no goal
    finally:
        bus.close()


def test_a_real_time_priority_the_system_refuses_is_said_in_a_sentence(robot: RobotModel) -> None:
    with pytest.raises(OSError, match=r"--rt-priority 1000: the bus thread cannot run SCHED_FIFO"):
        start_bus(robot, rt_priority=1000)  # beyond SCHED_FIFO's 1..99: refused by the kernel


def test_a_robot_may_give_its_servos_bus_ids_each_its_own(tmp_path: Path) -> None:
    text = (builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8")
    text = text.replace("name: artro", "name: busbot", 1)

    def written(changed: str) -> Path:
        path = tmp_path / "busbot.yaml"
        path.write_text(changed, encoding="utf-8")
        return path

    assert load_description("artro").bus_ids() == list(range(1, 13))
    renumbered = text.replace("l_hip_yaw: {}", "l_hip_yaw: {bus_id: 21}")
    assert load_description(written(renumbered)).bus_ids() == [21, *range(2, 13)]
    clash = text.replace("r_hip_yaw: {}", "r_hip_yaw: {bus_id: 4}")  # l_knee's by default
    with pytest.raises(RobotError, match=r"joints\.r_hip_yaw\.bus_id: 4 is l_knee's ID"):
        load_description(written(clash))
