"""Headless runs: simulate a parameter set for a while and measure it (`artro run`)."""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.metrics import RunFlags, RunMetrics, Trace, compute_metrics
from app.sim.planning import FRAME_S
from app.worlds.variations import NOMINAL, Variation
from gait import JOINT_NAMES, GaitParams, Motion
from hardware import SAFETY_FACTOR, HardwareSetup, required_torque_from_loads

AT_LIMIT = 0.99  # a servo's force this close to its limit (frame ends): it sat at its torque limit
LAST_S = 1.0  # a fall's diagnosis looks at this last stretch


@dataclass
class RunResult:
    """A headless run: its metrics, trace and eq (1) torque per actuator (N·m, sf = 0.2)."""

    metrics: RunMetrics
    trace: Trace = field(repr=False)
    required_torque_nm: dict[str, float] = field(default_factory=dict)
    #: a run that fell: when, toward which side, which servos sat at their torque limit
    diagnosis: str | None = None
    #: those servos' joints, most frames at the limit first
    stuck: tuple[str, ...] = ()


def fall_side(quat: np.ndarray) -> tuple[str, float]:
    """Toward which side of itself the trunk (quaternion w, x, y, z) leans, and by how many
    degrees from upright: "front", "back", "left" or "right", by the larger part."""
    w, x, y, z = (float(q) for q in quat)
    up = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
    heading = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    ahead = up[0] * math.cos(heading) + up[1] * math.sin(heading)
    left = -up[0] * math.sin(heading) + up[1] * math.cos(heading)
    side = ("front" if ahead > 0 else "back") if abs(ahead) >= abs(left) else (
        "left" if left > 0 else "right")  # fmt: skip
    return side, math.degrees(math.acos(max(-1.0, min(1.0, up[2]))))


#: a servo held the fall at its torque when in the last LAST_S it sat at its limit for at least
#: this many frames and HELD_TIMES times as many as its share of the frames before would give
#: (the knees sit there at each step of a walk: that is no cause)
HELD_FRAMES, HELD_TIMES = 5, 2.0


def stuck_joints(at_limit: np.ndarray, before: np.ndarray | None = None) -> tuple[str, ...]:
    """The joints whose servos sat at their torque limit in the frames `at_limit` (frames x
    12), most frames first; with `before` (each joint's share of the frames before those at
    its limit) only those that sat there for HELD_FRAMES and HELD_TIMES their usual share."""
    counts = at_limit.sum(axis=0)
    held = counts > 0
    if before is not None:
        usual = np.asarray(before) * len(at_limit)
        held = (counts >= HELD_FRAMES) & (counts >= HELD_TIMES * usual)
    return tuple(JOINT_NAMES[i] for i in np.argsort(-counts, kind="stable") if held[i])


def diagnose(
    time_s: float, quat: np.ndarray, at_limit: np.ndarray, before: np.ndarray | None = None
) -> str:
    """One line on a fall: when, toward which side, and which servos sat at their torque limit
    in the frames of the last second (`at_limit`: frames x 12; with `before`, as
    `stuck_joints` takes it, only those held there beyond their usual share). What to try
    depends on the robot and the gait: the command's (`app/cli/run.py` `fall_advice`)."""
    side, tilt = fall_side(quat)
    counts = dict(zip(JOINT_NAMES, at_limit.sum(axis=0), strict=True))
    stuck = [f"{joint} {int(counts[joint])}" for joint in stuck_joints(at_limit, before)]
    head = f"fell at {time_s:.2f} s toward its {side} ({tilt:.0f}° from upright)"
    if not stuck:
        usual = "" if before is None else " beyond a walk's usual share"
        return f"{head}; no servo at its torque limit{usual} in the last {LAST_S:g} s"
    beyond = "" if before is None else " beyond a walk's usual share"
    return (
        f"{head}; servos at their torque limit{beyond} in the last {LAST_S:g} s "
        f"({len(at_limit)} frames): {', '.join(stuck[:4])}"
    )


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
    flags: RunFlags = {
        "servo_saturated_frames": 0,
        "gamma_clamped_frames": 0,
        "guard_violation_frames": 0,
    }
    flags["torque_limit_frames"] = 0  # a servo's force at AT_LIMIT of its limit at a frame's end
    peak_torque = np.zeros(12)
    at_limit_frames = np.zeros(12)
    force = sim.data.actuator_force
    actuators = sim.robot.actuator_ids
    limit = AT_LIMIT * np.abs(sim.model.actuator_forcerange[actuators, 1])
    recent: deque[np.ndarray] = deque(maxlen=round(LAST_S / FRAME_S))
    wall_start = time.perf_counter()
    for _ in range(n_frames):
        record = sim.step_frame()
        flags["servo_saturated_frames"] += record.saturated
        flags["gamma_clamped_frames"] += record.gamma_clamped
        flags["guard_violation_frames"] += record.guard_violation
        torque = np.abs(force[actuators])
        np.maximum(peak_torque, torque, out=peak_torque)
        recent.append(torque >= limit)
        at_limit_frames += recent[-1]
        flags["torque_limit_frames"] += bool(recent[-1].any())
        trace.append(sim.time_s, sim.trunk_pose(), sim.gyro(), sim.feet_distance_m())
        if sim.fell:
            break
    wall_s = time.perf_counter() - wall_start
    metrics: RunMetrics = {"fell": sim.fell}  # type: ignore[typeddict-item]  # the rest below
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
    metrics["at_limit_share"] = (at_limit_frames / max(1, len(trace.t_s))).tolist()
    required = required_torque_from_loads(peak_torque[None, :], SAFETY_FACTOR)
    names = [sim.model.actuator(int(i)).name for i in actuators]
    diagnosis = None
    stuck: tuple[str, ...] = ()
    if sim.fell and not sim.blew_up:
        last = np.array(recent)
        earlier = len(trace.t_s) - len(last)
        before = (at_limit_frames - last.sum(axis=0)) / max(1, earlier)
        diagnosis = diagnose(sim.time_s, sim.data.qpos[3:7], last, before)
        stuck = stuck_joints(last, before)
    torques = dict(zip(names, map(float, required), strict=True))
    return RunResult(metrics, trace, torques, diagnosis, stuck)
