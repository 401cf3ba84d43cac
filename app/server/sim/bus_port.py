"""`artro serve --servo-bus pty` (docs/BUS.md): the live robot's 12 leg servos answer on a
pseudo-terminal as bus servos (`app.firmware.virtual_bus`); while goal writes arrive the robot
is driven by the bus. The bus thread hands goals over (`Handoff`); the simulation thread alone
takes them, steps the robot and publishes what the servos measure."""

from __future__ import annotations

import statistics
import threading
import time
from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.firmware.virtual_bus import VirtualBus
from app.robots.model import RobotModel
from app.sim.bus_drive import Handoff, Measured, measured_of
from hardware.servo_bus import BusLink, angle_to_steps

HOLD_S = 1.0  # after a goal write, the bus drives while a packet came within this long
RATE_WINDOW_S = 1.0  # the packet rate is counted over this long
LATENCIES_KEPT = 100  # goal writes whose latency the status summarises


@dataclass(frozen=True)
class BusPortStatus:
    """What the page shows: the port, whether the bus drives, its packets (total and per second
    over the last second), errors (malformed packets by reason, packets to no servo), answers,
    how late the latest answer went out (µs), goal writes and their latency (ms: from the
    packet's last byte to the frame that took it, median and largest of the last 100); what
    the servos measure (each joint's angle, rad, the gait's joint order) at sim time `time_s`."""

    port: str
    protocol: str
    baud: int
    ids: tuple[int, ...]
    driving: bool
    packets: int
    packet_rate_hz: float
    malformed: dict[str, int]
    errors: int
    unanswered: int
    answers: int
    answer_late_max_us: int
    goal_writes: int
    goal_latency_ms_median: float | None
    goal_latency_ms_max: float | None
    time_s: float
    present_rad: tuple[float, ...]


class BusPort:
    """The pty and its bus thread beside the dashboard's simulation thread: `take` and
    `publish` are the simulation thread's; `status` any thread's; `start`, `stop` the
    server's."""

    def __init__(self, robot: RobotModel, protocol: str = "dynamixel", baud: int = 1_000_000):
        self.handoff = Handoff(Measured(0.0, (0.0,) * 12, (0.0,) * 12, (0.0,) * 12))
        ids = robot.description.bus_ids()
        voltage_v = float(robot.description.supply_voltage_v)
        self.bus = VirtualBus(protocol, baud, self.handoff, voltage_v, ids)
        centre = angle_to_steps(np.zeros(len(ids))).tolist()
        for servo, steps in zip(self.bus.bus.servos, centre, strict=True):
            servo.set("goal_position", steps)
            servo.set("torque_enable", 1)  # the dashboard's robot stands on its servos
        self.link = BusLink(protocol, baud, tuple(ids))
        self._goal_rad: NDArray[np.float64] | None = None
        self._latencies_s: deque[float] = deque(maxlen=LATENCIES_KEPT)
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self.bus.serve, args=(self._stop,), name="servo-bus", daemon=True
        )

    @property
    def port(self) -> str:
        return self.bus.port

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(5.0)
        self.bus.close()

    @property
    def driving(self) -> bool:
        """A goal was written and the latest packet came within `HOLD_S`."""
        last_s = self.bus.stats.last_packet_s
        return self._goal_rad is not None and time.monotonic() - last_s < HOLD_S

    def take(self, now_s: float) -> NDArray[np.float64] | None:
        """(simulation thread) The goals (rad, the gait's joint order) the next frame's servos
        take; None before the first goal write and once the bus was quiet for `HOLD_S` (the
        gait drives)."""
        goals = self.handoff.take()  # only goals that changed are handed over
        for g in goals:
            self._latencies_s.append(max(0.0, now_s - g.effect_s))
        if goals:
            self._goal_rad = np.array(goals[-1].goal_rad[:12], dtype=np.float64)
        return self._goal_rad if self.driving else None

    def publish(self, robot: RobotModel, data: mujoco.MjData) -> None:
        """(simulation thread) What the servos measure now, for the bus thread's answers."""
        stall_nm = np.abs(robot.model.actuator_forcerange[robot.actuator_ids, 1])
        self.handoff.measured = measured_of(robot, data, stall_nm)

    def status(self) -> BusPortStatus:
        stats = self.bus.stats
        now_s = time.monotonic()
        rate = sum(now_s - t < RATE_WINDOW_S for t in list(self.bus.arrivals)) / RATE_WINDOW_S
        latencies_ms = [s * 1e3 for s in list(self._latencies_s)]
        malformed = dict(stats.malformed)
        measured = self.handoff.measured
        return BusPortStatus(
            port=self.port,
            protocol=self.link.protocol,
            baud=self.link.baud,
            ids=self.link.ids,
            driving=self.driving,
            packets=stats.packets,
            packet_rate_hz=round(rate, 1),
            malformed=malformed,
            errors=sum(malformed.values()),
            unanswered=stats.unanswered,
            answers=stats.answers,
            answer_late_max_us=stats.late_max_us,
            goal_writes=stats.goal_writes,
            goal_latency_ms_median=round(statistics.median(latencies_ms), 2)
            if latencies_ms
            else None,
            goal_latency_ms_max=round(max(latencies_ms), 2) if latencies_ms else None,
            time_s=measured.time_s,
            present_rad=measured.position_rad,
        )
