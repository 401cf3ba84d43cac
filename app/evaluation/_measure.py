"""A run's metrics from its frame-end samples, as `FrameLoop` measures it: the fall test after
each frame, the trunk trace, `compute_metrics` and the servos' peak torques. Every executor
measures through here, whatever stepped the physics (docs/DESIGN.md §9)."""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

from app.evaluation._api import Job
from app.evaluation._frames import Start
from app.robots.model import RobotModel
from app.sim.headless import AT_LIMIT
from app.sim.metrics import RunMetrics, Trace, compute_metrics
from app.sim.planning import FRAME_S
from app.sim.robot_pose import has_fallen, planar_distance_m, trunk_yaws


def fallen(qpos: np.ndarray, start: Start) -> np.ndarray:
    """(frames,) bool: the frame-end states `qpos` (frames, nq) that `FrameLoop` calls fallen."""
    return has_fallen(qpos, start.standing_height_m)


def not_finite(qpos: np.ndarray) -> np.ndarray:
    """(...) bool: the frame-end states `qpos` (..., nq) that blew up to inf or NaN."""
    return ~np.all(np.isfinite(qpos), axis=-1)


class FrameEnds(NamedTuple):
    """Frames' last physics steps: their rows in the run's states, qpos, blown up, fallen."""

    rows: np.ndarray
    qpos: np.ndarray
    bad: np.ndarray
    down: np.ndarray


def end_checks(
    model: mujoco.MjModel,
    ends: np.ndarray,
    rows: np.ndarray | int,
    start_s: float | np.ndarray,
    standing_height_m: float | np.ndarray,
) -> FrameEnds:
    """Frame-end states `ends` (n, state size) -- each the state after physics step `rows`
    of its run, which started at `start_s` standing `standing_height_m` high (each a number
    or one per state) -- as `FrameLoop` checks them: blown up (not finite, or MuJoCo reset
    it: time restarts at 0) or fallen."""
    qpos = ends[:, 1 : 1 + model.nq]
    expected_time = start_s + (np.asarray(rows) + 1) * model.opt.timestep
    bad = not_finite(qpos) | (np.abs(ends[:, 0] - expected_time) > 1e-6)
    return FrameEnds(np.asarray(rows), qpos, bad, has_fallen(qpos, standing_height_m))


def measure_frames(
    robot: RobotModel,
    job: Job,
    qpos: np.ndarray,
    sensors: np.ndarray,
    bad: np.ndarray,
    down: np.ndarray,
    warmup_s: float,
) -> tuple[RunMetrics, Trace]:
    """Metrics and trunk trace of a run's frames: `qpos` (frames, nq) the state after each
    frame's last physics step, `sensors` (frames, nsensordata) that step's sensordata, `bad`
    and `down` (frames,) each frame blown up or fallen. The frame it fell in is still sampled,
    a blown-up frame is not; the trace keeps views of `sensors` (pass a copy)."""
    n_frames = len(qpos)
    first_bad = int(np.argmax(bad)) if bad.any() else n_frames
    down = down[:first_bad]
    if down.any():
        fell, blew_up = True, False
        samples = frames_done = int(np.argmax(down)) + 1
    elif first_bad < n_frames:
        fell = blew_up = True
        samples, frames_done = first_bad, first_bad + 1
    else:
        fell = blew_up = False
        samples = frames_done = n_frames
    qpos, sens = qpos[:samples], sensors[:samples]
    gyro, (left, right) = robot.gyro_adr, robot.sole_adr
    trace = Trace(
        t_s=(np.arange(1, samples + 1) * FRAME_S).tolist(),
        x_m=qpos[:, 0].tolist(),
        y_m=qpos[:, 1].tolist(),
        yaw_rad=trunk_yaws(qpos[:, 3:7]),
        gyro_rad_s=list(sens[:, gyro : gyro + 3]),
        feet_distance_m=planar_distance_m(
            sens[:, left : left + 3], sens[:, right : right + 3]
        ).tolist(),
    )
    metrics: RunMetrics = {"fell": fell}  # type: ignore[typeddict-item]  # the rest below
    if fell:
        metrics["fall_time_s"] = round(frames_done * FRAME_S, 3)
    metrics |= compute_metrics(
        trace, ca=job.motion.ca, freq_hz=job.params.clock.freq_hz, warmup_s=warmup_s
    )
    metrics["sim_s"] = frames_done * FRAME_S
    metrics["blew_up"] = blew_up
    torque = np.abs(sens[:, robot.torque_adr])
    metrics["peak_torque_nm"] = (torque.max(axis=0) if samples else np.zeros(12)).tolist()
    # the run's own servos: the described force limit times its torque_scale, as varied_robot
    stall = np.abs(robot.model.actuator_forcerange[robot.actuator_ids, 1])
    at_limit = torque >= AT_LIMIT * (stall * job.variation.torque_scale)
    metrics["at_limit_share"] = (at_limit.mean(axis=0) if samples else np.zeros(12)).tolist()
    return metrics, trace
