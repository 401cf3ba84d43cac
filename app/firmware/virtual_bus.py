"""The virtual servo bus (docs/BUS.md): a pseudo-terminal on which the simulated robot's 12 leg
servos answer as Dynamixel XM430-W350s or Feetech STS3215s do (`hardware.servo_bus`), a thread
that answers each packet at the modelled wire times, the robot in real time beside it
(`app.sim.bus_drive`); `start_bus` starts both, `port` is the path to open."""

from __future__ import annotations

import os
import select
import threading
import time
import tty
from collections import deque
from dataclasses import dataclass, field

from app.robots.model import RobotModel
from app.sim.bus_drive import BusSimulation, Goals, Handoff
from gait import JOINT_NAMES
from hardware.servo_bus import (
    TABLES,
    BusServo,
    Malformed,
    Packet,
    Parser,
    Present,
    ServoBus,
    angle_to_steps,
    answers_done_us,
    wire_us,
)

ARRIVALS_KEPT = 2000  # packets whose arrival times are kept (a rate over the last second)
QUIET_S = 0.05  # a partial packet the line leaves this long is dropped, as a servo's timeout


def check_baud(protocol: str, baud: int) -> None:
    """ValueError naming the servos' rates unless `baud` is one of them."""
    table = TABLES[protocol]
    if baud not in table.bauds.values():
        raise ValueError(
            f"--baud must be one of {table.model}'s rates, "
            f"{', '.join(map(str, sorted(table.bauds.values())))}; got {baud}"
        )


@dataclass
class BusStats:
    """What the bus saw: packets, malformed by reason, answers sent (and lost to a client that
    did not read), how late the latest answer went out against its modelled time (µs), goals
    handed over."""

    packets: int = 0
    malformed: dict[str, int] = field(default_factory=dict)
    unanswered: int = 0
    answers: int = 0
    answers_lost: int = 0
    goal_writes: int = 0
    late_max_us: int = 0
    last_packet_s: float = -1.0  # monotonic time the latest packet arrived (-1: none yet)


class VirtualBus:
    """The pty and its bus thread: `port` is the path a client opens; `serve(stop)` answers
    until `stop` is set. An instruction's answers go out together when the model says the last
    one's last byte would be through: its wire time, then per servo return delay and wire time."""

    def __init__(
        self, protocol: str, baud: int, handoff: Handoff, voltage_v: float, ids: list[int]
    ) -> None:
        self.protocol = protocol
        self.baud = baud
        self.bus = ServoBus(BusServo(protocol, i, baud) for i in ids)
        self.parser = Parser(protocol)
        self.handoff = handoff
        self.voltage_v = voltage_v
        self.stats = BusStats()
        self.arrivals: deque[float] = deque(maxlen=ARRIVALS_KEPT)  # the latest packets' times
        self._shown_s = -1.0
        self._line_free_s = 0.0  # monotonic time the last byte on the line is through
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # bytes as they are: no echo, no line editing
        tty.setraw(self._master)
        os.set_blocking(self._master, False)  # a client that never reads cannot stop the bus
        self.port = os.ttyname(self._slave)

    def _show_measured(self) -> None:
        m = self.handoff.measured
        if m.time_s == self._shown_s:
            return
        self._shown_s = m.time_s
        for joint, servo in enumerate(self.bus.servos[: len(JOINT_NAMES)]):
            servo.show(
                Present(
                    m.position_rad[joint], m.velocity_rad_s[joint], m.load[joint], self.voltage_v
                )
            )

    def _goals(self) -> tuple[tuple[float, ...], tuple[bool, ...]]:
        return (
            tuple(s.goal_rad for s in self.bus.servos),
            tuple(s.torque_on for s in self.bus.servos),
        )

    def handle(self, item: Packet | Malformed, arrived_s: float) -> None:
        """Answer one parsed item: it goes on the line when it arrived or the line fell quiet,
        ends `wire_us` later; a goal changed acts from then; the answers follow (see above)."""
        self._show_measured()
        before = self._goals()
        answers = self.bus.handle(item)
        self.stats.malformed = dict(self.bus.malformed)
        self.stats.unanswered = self.bus.unanswered
        if isinstance(item, Packet):
            self.stats.packets += 1
            self.stats.last_packet_s = arrived_s
            self.arrivals.append(arrived_s)
        start_s = max(arrived_s, self._line_free_s)  # the line carries one thing at a time
        end_s = start_s + wire_us(item.size, self.baud) * 1e-6
        self._line_free_s = end_s
        after = self._goals()
        if after != before:
            self.handoff.put(Goals(end_s, *after))
            self.stats.goal_writes += 1
        if not answers:
            return
        done_us = answers_done_us(
            0, [len(a.data) for a in answers], [a.return_delay_us for a in answers], self.baud
        )
        # the answers of one instruction go out together when the last one's last byte would
        # be through: never early, one wake-up however many servos answer
        wait = end_s + done_us[-1] * 1e-6 - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        else:
            self.stats.late_max_us = max(self.stats.late_max_us, round(-wait * 1e6))
        try:
            os.write(self._master, b"".join(a.data for a in answers))
            self.stats.answers += len(answers)
        except BlockingIOError:  # a client that never reads: its answers are lost, counted
            self.stats.answers_lost += len(answers)
        self._line_free_s = end_s + done_us[-1] * 1e-6

    def serve(self, stop: threading.Event) -> None:
        """Read, parse, answer until `stop`; a partial packet left for `QUIET_S` is dropped
        and counted. Nothing a client sends ends the thread."""
        last_s = time.monotonic()
        while not stop.is_set():
            ready, _, _ = select.select([self._master], [], [], QUIET_S / 2)
            now = time.monotonic()
            if not ready:
                if self.parser.buffer and now - last_s > QUIET_S:
                    dropped = self.parser.drop()
                    if dropped is not None:
                        self.bus.handle(dropped)
                        self.stats.malformed = dict(self.bus.malformed)
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:  # no client has the port open: wait for one
                stop.wait(QUIET_S)
                continue
            last_s = now
            for item in self.parser.feed(data):
                self.handle(item, now)

    def close(self) -> None:
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


def start_bus(
    robot: RobotModel,
    *,
    protocol: str = "dynamixel",
    baud: int = 1_000_000,
    torque_on: bool = False,
    rt_priority: int = 0,
) -> tuple[VirtualBus, BusSimulation, threading.Event, list[threading.Thread]]:
    """The simulation and the bus on their threads, started; the servos' IDs the robot's
    (`bus_ids`: 1..12 in the gait's joint order unless it says otherwise); set the event to
    stop them. `rt_priority` > 0: the bus thread runs SCHED_FIFO at it, the simulation's one
    lower (neither spins; the simulation holding the interpreter's lock must not wait behind
    other programs); OSError in a sentence where that is not permitted."""
    sim = BusSimulation(robot, torque_on=torque_on)
    voltage_v = float(robot.description.supply_voltage_v)
    bus = VirtualBus(protocol, baud, sim.handoff, voltage_v, robot.description.bus_ids())
    for servo, steps in zip(bus.bus.servos, angle_to_steps(sim.goal_rad).tolist(), strict=True):
        servo.set("goal_position", steps)
        servo.set("torque_enable", int(torque_on))
    stop = threading.Event()
    threads = [
        threading.Thread(target=sim.serve, args=(stop,), name="bus-sim", daemon=True),
        threading.Thread(target=bus.serve, args=(stop,), name="bus-port", daemon=True),
    ]
    for t in threads:
        t.start()
    if rt_priority > 0:
        try:
            for thread, priority in zip(
                threads, (max(1, rt_priority - 1), rt_priority), strict=True
            ):
                assert thread.native_id is not None
                os.sched_setscheduler(thread.native_id, os.SCHED_FIFO, os.sched_param(priority))
        except OSError as exc:
            stop.set()
            for thread in threads:
                thread.join()
            bus.close()
            raise OSError(
                f"--rt-priority {rt_priority}: the bus thread cannot run SCHED_FIFO here "
                f"({exc.strerror}); it needs a priority of 1 to 99 and CAP_SYS_NICE (root, or "
                "an rtprio limit), or leave the option out"
            ) from None
    return bus, sim, stop, threads
