"""`artro drive`'s loop (docs/BUS.md, "Driving a robot from the host"): the gait of `artro run`
(its engine, parameter set and motion ramp from standing, planned as `FrameLoop` plans it) on
the host, each 20 ms frame's goals one sync write paced by a monotonic clock, a sync read of the
present positions; open loop (a bus has no IMU here); the torque off at every end, a servo that
stops answering named."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware.bus_client import BusClient, SerialPort
from app.robots.model import RobotModel
from app.sim.planning import FRAME_S, START_PHASE_RAD, FramePlan, frame_steps, plan_frames
from gait import JOINT_NAMES, GaitParams, Motion, joint_angles_with_flags, startup_gain
from hardware.servo_bus import steps_to_angle

BLOCK_FRAMES = 50  # planned at once, as `FrameLoop` plans (the same bits)
LATE_S = 0.002  # a frame sent this much after its time is counted late

#: times the torque-off is read back before a servo is said not to have taken it (a bus
#: drops an answer now and then: a loaded host, noise on the line)
CONFIRM_TRIES = 3
#: how long each read-back waits for the answers: the walk is over, so the drive waits longer
#: than a frame's exchange may (a host busy with other programs answers late, not never)
CONFIRM_TIMEOUT_S = 0.25


class GaitFrames:
    """The joint angles of `artro run`'s frames for `robot`: from standing in `start_motion`'s
    pose at the start phase, one ramp step per frame toward `motion`, each held to the servos'
    limits (as the simulation's bus holds them, `app/sim/planning.py`)."""

    def __init__(
        self, robot: RobotModel, params: GaitParams, motion: Motion, start_motion: Motion
    ) -> None:
        self.robot, self.params, self.motion = robot, params, motion
        self.hardware = robot.hardware()
        cal = self.hardware.calibration
        self.low, self.high = np.asarray(cal.min_rad), np.asarray(cal.max_rad)
        self.phase = START_PHASE_RAD
        self.motion_now = start_motion
        self.frame_index = 0
        self._plan: FramePlan | None = None
        self.start_pose = self.held(
            joint_angles_with_flags(
                params,
                start_motion,
                START_PHASE_RAD,
                robot.geometry,
                startup=startup_gain(params, 0.0),
            ).values
        )

    def held(self, angles: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.clip(angles, self.low, self.high)

    def next(self) -> NDArray[np.float64]:
        """The next frame's angles (12,), rad, joint order, held to the limits."""
        plan = self._plan
        if plan is None or plan.next_index >= len(plan):
            plan = self._plan = plan_frames(
                self.params, self.motion, self.hardware, self.phase, BLOCK_FRAMES,
                frame_steps(self.robot.model), float(self.robot.model.opt.timestep),
                motion_now=self.motion_now, frame0=self.frame_index,
                geometry=self.robot.geometry,
            )  # fmt: skip
        k = plan.next_index
        plan.next_index += 1
        self.motion_now = plan.motions[k]
        self.frame_index += 1
        next_phase = float(plan.phase[k]) + 2.0 * math.pi * self.params.clock.freq_hz * FRAME_S
        self.phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi  # as FrameLoop's
        return self.held(plan.angles[k])


class ServoMissing(ValueError):
    """Servos of the robot that did not answer at the start (nothing was sent to any)."""


@dataclass(frozen=True)
class DriveOptions:
    """The bus and the run: protocol, baud, the servos' IDs (joint order); seconds of walking
    (None: until stopped); seconds to move from the present pose to the gait's first; a sync
    read each frame or not; the status timeout (s); misses in a row that lose a servo."""

    protocol: str = "dynamixel"
    baud: int = 1_000_000
    ids: tuple[int, ...] = tuple(range(1, 13))
    duration_s: float | None = None
    settle_s: float = 1.0
    read_present: bool = True
    timeout_s: float = 0.015
    lost_after: int = 5


@dataclass
class DriveReport:
    """What the drive did: frames sent (settling, walking), late ones and the latest (ms), the
    sync write + sync read round trips (ms), statuses missed, the largest |goal − present| of
    the frame before (deg), how it ended, the servo lost (ID, joint), the torque switched off
    and the IDs that did not read back as off."""

    settle_frames: int = 0
    frames: int = 0
    late_frames: int = 0
    late_max_ms: float = 0.0
    round_trip_ms: list[float] = field(default_factory=list, repr=False)
    statuses_missed: int = 0
    present_error_deg_max: float = 0.0
    ended: str = "duration"  # "duration", "stopped" (a signal), "lost" (a servo), "port"
    lost: tuple[int, str] | None = None
    port_error: str | None = None
    torque_off: bool = False
    torque_unconfirmed: list[int] = field(default_factory=list)  # not read back as off

    def summary(self) -> dict[str, Any]:
        """The report as one JSON object (round trips as median and 95th percentile)."""
        rt = np.asarray(self.round_trip_ms)
        out = {k: v for k, v in vars(self).items() if k != "round_trip_ms"}
        out["lost"] = None if self.lost is None else {"id": self.lost[0], "joint": self.lost[1]}
        out["reads"] = int(rt.size)
        for name, q in (("median", 50), ("p95", 95)):
            out[f"round_trip_ms_{name}"] = (
                round(float(np.percentile(rt, q)), 3) if rt.size else None
            )
        out["late_max_ms"] = round(self.late_max_ms, 3)
        out["present_error_deg_max"] = round(self.present_error_deg_max, 3)
        return out


def joint_of(ids: tuple[int, ...], servo_id: int) -> str:
    return JOINT_NAMES[ids.index(servo_id)]


def drive(
    port: SerialPort,
    robot: RobotModel,
    params: GaitParams,
    motion: Motion,
    options: DriveOptions,
    stop: threading.Event,
    on_frame: Callable[[int], None] | None = None,
) -> DriveReport:
    """Ping the 12 servos (`ServoMissing` naming those that do not answer, nothing sent to
    any), take their present pose as their goal, torque on, move to the gait's first pose over
    `settle_s`, then walk `artro run`'s frames until `duration_s`, `stop` or a lost servo; the
    torque is switched off at every end (also on an exception). `on_frame(k)` is called after
    walking frame k was sent (and read)."""
    bus = BusClient(
        port, protocol=options.protocol, baud=options.baud, ids=options.ids,
        timeout_s=options.timeout_s,
    )  # fmt: skip
    missing = bus.missing()
    if not missing:  # each answered a PING: each must give its position too
        present = bus.sync_read("present_position")
        missing = [i for i in options.ids if i not in present]
    if missing:
        named = ", ".join(f"ID {i} ({joint_of(options.ids, i)})" for i in missing)
        raise ServoMissing(
            f"no answer from servo {named} on the {options.protocol} bus at {options.baud} "
            f"baud: check its ID, cable, power and baud rate (the robot's servos are IDs "
            f"{list(options.ids)} in joint order)"
        )
    gait = GaitFrames(robot, params, motion, start_motion=Motion())
    start = np.array([present[i] for i in options.ids])
    report = DriveReport()
    try:
        bus.sync_write("goal_position", start.tolist())  # torque on holds where they are
        bus.torque(True)
        _walk(bus, gait, steps_to_angle(start), options, stop, on_frame, report)
    except OSError as exc:  # the adapter unplugged, the other end of a pty closed
        report.ended, report.port_error = "port", str(exc)
    finally:
        try:
            bus.torque(False)
            report.torque_off = True
            report.torque_unconfirmed = list(options.ids)
            bus.port.timeout = max(options.timeout_s, CONFIRM_TIMEOUT_S)
            for _ in range(CONFIRM_TRIES):  # read back: also waits till it was taken
                off = bus.sync_read("torque_enable")
                report.torque_unconfirmed = [i for i in options.ids if off.get(i) != 0]
                if not report.torque_unconfirmed:
                    break
        except OSError as exc:
            report.port_error = report.port_error or str(exc)
    return report


def _walk(
    bus: BusClient,
    gait: GaitFrames,
    present_rad: NDArray[np.float64],
    options: DriveOptions,
    stop: threading.Event,
    on_frame: Callable[[int], None] | None,
    report: DriveReport,
) -> None:
    """The frames, each at its time on the monotonic clock (a late one is sent at once and
    counted: no drift builds up): the settling ones, then the gait's."""
    settle = max(0, round(options.settle_s / FRAME_S))
    walk = None if options.duration_s is None else round(options.duration_s / FRAME_S)
    misses = dict.fromkeys(options.ids, 0)
    goal = present_rad
    start_s = time.monotonic()
    k = 0
    while walk is None or k < settle + walk:
        wait = start_s + k * FRAME_S - time.monotonic()
        if (wait > 0 and stop.wait(wait)) or stop.is_set():
            report.ended = "stopped"
            return
        if -wait > LATE_S:
            report.late_frames += 1
            report.late_max_ms = max(report.late_max_ms, -wait * 1e3)
        previous = goal
        if k < settle:
            goal = present_rad + (gait.start_pose - present_rad) * (k + 1) / settle
        else:
            goal = gait.next()
        sent_s = time.monotonic()
        bus.goals(k, goal)
        if options.read_present:
            got = bus.sync_read("present_position")
            report.round_trip_ms.append((time.monotonic() - sent_s) * 1e3)
            if lost := _count_misses(got, misses, options, report):
                report.ended, report.lost = "lost", lost
                return
            error = [
                abs(steps_to_angle(v) - previous[options.ids.index(i)]) for i, v in got.items()
            ]
            if error:
                report.present_error_deg_max = max(
                    report.present_error_deg_max, math.degrees(float(max(error)))
                )
        if k < settle:
            report.settle_frames += 1
        else:
            report.frames += 1
            if on_frame is not None:
                on_frame(k - settle)
        k += 1


def _count_misses(
    got: dict[int, int], misses: dict[int, int], options: DriveOptions, report: DriveReport
) -> tuple[int, str] | None:
    """Count each servo's statuses missed in a row; the first to reach `lost_after`: lost."""
    for i in options.ids:
        if i in got:
            misses[i] = 0
            continue
        misses[i] += 1
        report.statuses_missed += 1
        if misses[i] >= options.lost_after:
            return i, joint_of(options.ids, i)
    return None


def lost_sentence(report: DriveReport, options: DriveOptions) -> str:
    """What a lost servo or a failed port means, in a sentence."""
    if not report.torque_off:
        torque = "the torque could not be switched off"
    else:
        torque = "the torque was switched off"
    if report.torque_off and report.torque_unconfirmed:
        named = ", ".join(f"ID {i} ({joint_of(options.ids, i)})" for i in report.torque_unconfirmed)
        torque += f" (not read back as off from {named})"
    if report.lost is not None:
        servo_id, joint = report.lost
        return (
            f"servo ID {servo_id} ({joint}) gave no status to {options.lost_after} sync reads in "
            f"a row ({options.timeout_s * 1e3:g} ms each): {torque}; check its cable and power"
        )
    return f"the bus's port failed ({report.port_error}): {torque}"


__all__ = [
    "DriveOptions",
    "DriveReport",
    "GaitFrames",
    "ServoMissing",
    "drive",
    "lost_sentence",
]
