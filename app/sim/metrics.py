"""Run metrics of docs/DESIGN.md §6, computed from a recorded trunk trace.

Means over whole gait cycles after the warm-up in the trunk's ROS axes (§3); the prediction is
seed 004's differential drive, eqs (9), (12)–(13), with the measured V and b (`compute_metrics`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np
from numpy.typing import NDArray

from gait import Pose2D, predict_path, turn_rate_rad_s

#: What `compute_metrics` measures (docs/DESIGN.md §6), besides fell and the timing of the run.
MOTION_METRICS = (
    "forward_cm_s",
    "lateral_cm_s",
    "turn_deg_s",
    "predicted_turn_deg_s",
    "path_error_cm",
    "gyro_rms",
    "feet_distance_cm",
)


class MotionMetrics(TypedDict):
    """What `compute_metrics` measures; None where the run was too short to measure."""

    forward_cm_s: float | None  # mean body-frame velocity, forward +
    lateral_cm_s: float | None  # left +
    turn_deg_s: float | None  # counter-clockwise +
    predicted_turn_deg_s: float | None  # eq (13) with V = forward speed, b = feet distance
    path_error_cm: float | None  # RMS distance of the path from the differential-drive one
    gyro_rms: float | None  # RMS of |trunk angular velocity|, rad/s (seed 004's stability measure)
    feet_distance_cm: float | None  # mean distance between the sole centres


class RunFlags(TypedDict, total=False):
    servo_saturated_frames: int
    gamma_clamped_frames: int
    guard_violation_frames: int
    torque_limit_frames: int  # frames ending with a servo at >= 99 % of its torque limit
    blew_up: bool


class RunMetrics(MotionMetrics, total=False):
    """One run's metrics (docs/DESIGN.md §6): `artro run --json`, the batch evaluator, the bench.

    A JSON document, so it is a typed dict; `fall_time_s` only when it fell, `flags` from
    `artro run`, `blew_up` from the batch evaluator."""

    fell: bool
    fall_time_s: float
    sim_s: float
    wall_s: float
    rtf: float | None
    flags: RunFlags
    blew_up: bool
    peak_torque_nm: list[float]  # largest |torque| of each servo at the frames' ends (JOINT_NAMES)
    at_limit_share: list[float]  # share of the frames ending with each servo at its torque limit


@dataclass
class Trace:
    """Samples taken once per frame: time, trunk pose, gyro, distance between the feet."""

    t_s: list[float] = field(default_factory=list)
    x_m: list[float] = field(default_factory=list)
    y_m: list[float] = field(default_factory=list)
    yaw_rad: list[float] = field(default_factory=list)
    gyro_rad_s: list[NDArray[np.float64]] = field(default_factory=list)
    feet_distance_m: list[float] = field(default_factory=list)

    def append(
        self, t: float, pose: tuple[float, float, float], gyro: NDArray, feet_m: float
    ) -> None:
        """One sample: time s, trunk (x m, y m, yaw rad), gyro (3,) rad/s, feet distance m."""
        self.t_s.append(t)
        self.x_m.append(pose[0])
        self.y_m.append(pose[1])
        self.yaw_rad.append(pose[2])
        self.gyro_rad_s.append(gyro)
        self.feet_distance_m.append(feet_m)

    def arrays(self) -> dict[str, NDArray[np.float64]]:
        """t, x, y, yaw (unwrapped), feet as (n,) arrays; gyro as (n, 3)."""
        return {
            "t": np.asarray(self.t_s),
            "x": np.asarray(self.x_m),
            "y": np.asarray(self.y_m),
            "yaw": np.unwrap(np.asarray(self.yaw_rad)),
            "gyro": np.asarray(self.gyro_rad_s).reshape(-1, 3),
            "feet": np.asarray(self.feet_distance_m),
        }


def whole_cycles(t: NDArray[np.float64], start_s: float, freq_hz: float) -> slice:
    """Index range from the first sample at or after start_s spanning a whole number of cycles
    (all remaining samples if less than one cycle is left)."""
    first = int(np.searchsorted(t, start_s - 1e-9))
    if first >= len(t) - 1:
        return slice(first, first)
    span = t[-1] - t[first]
    cycles = math.floor(span * freq_hz + 1e-9)
    if cycles < 1:
        return slice(first, len(t))
    last = int(np.searchsorted(t, t[first] + cycles / freq_hz - 1e-9))
    return slice(first, min(last, len(t) - 1) + 1)


def mean_body_velocity(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    yaw: NDArray[np.float64],
    freq_hz: float,
) -> tuple[float, float, float]:
    """Mean (forward m/s, lateral m/s, turn rad/s) in the trunk frame; yaw must be unwrapped.

    t (s, increasing), x, y (m) and yaw (rad) are (n,) samples, n >= 2; freq_hz is the gait's.

    The trunk frame is taken per gait cycle: each cycle's displacement is rotated by that
    cycle's mean heading. Rotating every frame's step by the momentary heading instead would
    let the trunk's yaw wobble, which moves in step with its sideways sway, rectify part of the
    sway into forward speed. A part-cycle left at the end is measured in its own mean heading.
    """
    duration = t[-1] - t[0]
    bounds = np.searchsorted(t, np.arange(t[0], t[-1], 1.0 / freq_hz) - 1e-9)
    bounds = np.append(bounds[bounds < len(t) - 1], len(t) - 1)
    forward = lateral = 0.0
    for a, b in itertools.pairwise(bounds):
        span = slice(a, b + 1)
        heading = np.trapezoid(yaw[span], t[span]) / (t[b] - t[a])
        dx, dy = x[b] - x[a], y[b] - y[a]
        forward += math.cos(heading) * dx + math.sin(heading) * dy
        lateral += -math.sin(heading) * dx + math.cos(heading) * dy
    return forward / duration, lateral / duration, float((yaw[-1] - yaw[0]) / duration)


def compute_metrics(trace: Trace, *, ca: float, freq_hz: float, warmup_s: float) -> MotionMetrics:
    """The motion metrics over whole gait cycles after the warm-up; None where undefined.

    Velocities are in the trunk's axes (ROS: forward = +x, lateral = +y to the robot's left, turn
    counter-clockwise). `predicted_turn_deg_s` and `path_error_cm` come from the differential drive
    (`gait.steering`) with V = the measured forward speed and b = the measured mean distance between
    the feet, `feet_distance_cm`. `ca` is the run's CA, `freq_hz` its gait frequency, `warmup_s`
    the time left out; all None if under two samples remain.
    """
    a = trace.arrays()
    window = whole_cycles(a["t"], warmup_s, freq_hz)
    t, x, y, yaw = (a[k][window] for k in ("t", "x", "y", "yaw"))
    if len(t) < 2:
        return MotionMetrics(**dict.fromkeys(MOTION_METRICS))  # type: ignore[typeddict-item]  # its keys
    forward, lateral, turn = mean_body_velocity(t, x, y, yaw, freq_hz)
    axle = float(np.mean(a["feet"][window]))
    predicted_turn = float(turn_rate_rad_s(ca, forward, axle)) + 0.0  # no -0.0 in reports
    predicted = predict_path(Pose2D(x[0], y[0], yaw[0]), forward, ca, axle, t - t[0])
    path_error = np.sqrt(np.mean((predicted[:, 1] - x) ** 2 + (predicted[:, 2] - y) ** 2))
    gyro = a["gyro"][window]
    return MotionMetrics(
        forward_cm_s=100.0 * float(forward),
        lateral_cm_s=100.0 * float(lateral),
        turn_deg_s=math.degrees(turn),
        predicted_turn_deg_s=math.degrees(predicted_turn),
        path_error_cm=100.0 * float(path_error),
        gyro_rms=float(np.sqrt(np.mean(np.sum(gyro**2, axis=1)))),
        feet_distance_cm=100.0 * axle,
    )
