"""Headless runs: simulate a parameter set for a while and measure it (`artro run`)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.metrics import RunMetrics, Trace, compute_metrics
from app.sim.planning import FRAME_S
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams, Motion
from hardware import SAFETY_FACTOR, HardwareSetup, required_torque_from_loads


@dataclass
class RunResult:
    """A headless run: its metrics, trace and eq (1) torque per actuator (N·m, sf = 0.2)."""

    metrics: RunMetrics
    trace: Trace = field(repr=False)
    required_torque_nm: dict[str, float] = field(default_factory=dict)


def run(
    params: GaitParams,
    motion: Motion,
    *,
    duration_s: float = 30.0,
    warmup_s: float = 5.0,
    hardware: HardwareSetup | None = None,
    start_motion: Motion | None = None,
    robot: RobotModel | None = None,
    variation: Variation = NOMINAL,
) -> RunResult:
    """Simulate `duration_s` of walking (stopping early at a fall) and compute the run metrics.

    The first `warmup_s` seconds are left out of the motion metrics; `robot` defaults to the
    built-in one, varied by `variation` (docs/DESIGN.md §8), and `hardware` to the robot's
    servo set-up. The run starts in `motion`, or in
    `start_motion` and ramps from there to `motion`. ValueError if duration <= 0 or warm-up < 0.
    """
    if not duration_s > 0 or not warmup_s >= 0:
        raise ValueError("duration must be > 0 s and warm-up >= 0 s")
    sim = FrameLoop(
        robot,
        params=params,
        motion=motion,
        hardware=hardware,
        start_motion=start_motion,
        variation=variation,
    )
    trace = Trace()
    n_frames = math.ceil(duration_s / FRAME_S - 1e-9)
    flags = {"servo_saturated_frames": 0, "gamma_clamped_frames": 0, "guard_violation_frames": 0}
    peak_torque = np.zeros(12)
    force = sim.data.actuator_force
    actuators = sim.robot.actuator_ids
    wall_start = time.perf_counter()
    for _ in range(n_frames):
        record = sim.step_frame()
        flags["servo_saturated_frames"] += record.saturated
        flags["gamma_clamped_frames"] += record.gamma_clamped
        flags["guard_violation_frames"] += record.guard_violation
        np.maximum(peak_torque, np.abs(force[actuators]), out=peak_torque)
        trace.append(sim.time_s, sim.trunk_pose(), sim.gyro(), sim.feet_distance_m())
        if sim.fell:
            break
    wall_s = time.perf_counter() - wall_start
    metrics: RunMetrics = {"fell": sim.fell}
    if sim.fell:
        metrics["fall_time_s"] = round(sim.time_s, 3)
    metrics |= compute_metrics(trace, ca=motion.ca, freq_hz=params.clock.freq_hz, warmup_s=warmup_s)
    metrics |= {
        "sim_s": sim.time_s,
        "wall_s": wall_s,
        "rtf": sim.time_s / wall_s if wall_s else None,
    }
    metrics["flags"] = flags | {"blew_up": sim.blew_up}
    metrics["peak_torque_nm"] = peak_torque.tolist()
    required = required_torque_from_loads(peak_torque[None, :], SAFETY_FACTOR)
    names = [sim.model.actuator(int(i)).name for i in actuators]
    return RunResult(metrics, trace, dict(zip(names, map(float, required), strict=True)))
