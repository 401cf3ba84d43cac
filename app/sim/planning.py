"""The open-loop plan of consecutive 20 ms frames, in whole arrays: gait (either engine, the
motion ramp) -> joint angles -> pulses -> TDM-PWM frame -> the set-point each servo decodes and
the physics step its pulse's falling edge lets it act (docs/DESIGN.md §2, §4, §5)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import mujoco
import numpy as np
from numpy.typing import NDArray

from gait import (
    ARTRO_LEG,
    GaitParams,
    LegGeometry,
    Motion,
    joint_angles_with_flags,
    pi_cut,
    ramp_motion,
    startup_gain,
)
from hardware import (
    FRAME_TICKS,
    OCR_IDLE,
    SLOT_TICKS,
    TICK_US,
    HardwareSetup,
    angles_to_pulses_us,
    pulse_us_to_ocr,
    pulses_to_angles_rad,
    servo_falling_edge_ticks,
    servo_frame_ocr,
    servo_guard_violations,
)
from hardware.servo_bus import sync_write_substeps

FRAME_S = FRAME_TICKS * TICK_US * 1e-6  # 20 ms
START_PHASE_RAD = -0.5 * math.pi  # lateral shift passes through zero: both feet on the ground
A_Y_RANGE = next(
    (f.metadata["min"], f.metadata["max"]) for f in dataclasses.fields(Motion) if f.name == "a_y"
)


@dataclass
class FramePlan:
    """The pipeline evaluated for a block of consecutive frames (leading axis: frame)."""

    phase: NDArray[np.float64]  # (n,) phi_Trunk at each frame start
    angles: NDArray[np.float64]  # (n, 12) gait joint angles
    ocr: NDArray[np.int32]  # (n, 6, 8) timer compare values
    setpoint: NDArray[np.float64]  # (n, 12) angle decoded from the demultiplexed pulse
    substep: NDArray[np.int64]  # (n, 12) physics step of the frame at which it takes effect
    saturated: NDArray[np.bool_]  # (n, 12) servo angle or pulse limited
    gamma_clamped: NDArray[np.bool_]  # (n, 2)
    guard: NDArray[np.bool_]  # (n, 6, 8) select change while a line was high
    motions: list[Motion]  # (n,) the motion the gait got in each frame (after the ramp)
    next_index: int = 0

    # per-frame summaries, reduced once per block rather than once per frame, and only by a
    # reader that wants them (the frame loop's flags; not a closed loop's one-frame plans)
    @cached_property
    def any_saturated(self) -> list[bool]:
        return np.any(self.saturated, axis=-1).tolist()

    @cached_property
    def any_gamma_clamped(self) -> list[bool]:
        return np.any(self.gamma_clamped, axis=-1).tolist()

    @cached_property
    def any_guard(self) -> list[bool]:
        return np.any(self.guard, axis=(-2, -1)).tolist()

    def __len__(self) -> int:
        return len(self.phase)


def frame_motions(
    params: GaitParams, target: Motion, current: Motion, n_frames: int
) -> list[Motion]:
    """The motion the gait gets in each of `n_frames` frames: one ramp step per frame from
    `current` (the last frame's) toward `target`, then `target` itself."""
    out: list[Motion] = []
    motion = current
    while len(out) < n_frames and motion != target:
        motion = ramp_motion(motion, target, params, FRAME_S)
        out.append(motion)
    return out + [target] * (n_frames - len(out))


def _gait(
    params: GaitParams,
    motions: list[Motion],
    phase: NDArray[np.float64],
    startup: NDArray[np.float64],
    geometry: LegGeometry,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Joint angles and clamp flags of each frame; one vectorised call per run of equal motions
    (the whole block when nothing is ramping)."""
    angles, clamped = [], []
    start = 0
    while start < len(motions):
        end = start + 1
        while end < len(motions) and (
            motions[end] is motions[start] or motions[end] == motions[start]
        ):
            end += 1
        part = slice(start, end)
        out = joint_angles_with_flags(
            params, motions[start], phase[part], geometry, startup=startup[part]
        )
        angles.append(out.values)
        clamped.append(out.gamma_clamped)
        start = end
    if len(angles) == 1:
        return angles[0], clamped[0]
    return np.concatenate(angles), np.concatenate(clamped)


def with_a_y_delta(motion: Motion, delta: float) -> Motion:
    """`motion` with a_y moved by `delta` (the yaw-rate loop's), kept within a_y's range."""
    low, high = A_Y_RANGE
    return dataclasses.replace(motion, a_y=min(max(motion.a_y + float(delta), low), high))


def falling_edge_substeps(
    fall_ticks: NDArray[np.int64], steps_per_frame: int, timestep_s: float
) -> NDArray[np.int64]:
    """The physics step of the frame at which each set-point takes effect: the first starting at
    or after its pulse's falling edge (docs/DESIGN.md §2)."""
    edge_s = np.asarray(fall_ticks) * TICK_US * 1e-6
    substep = np.ceil(edge_s / timestep_s - 1e-9).astype(np.int64)
    return np.minimum(substep, steps_per_frame)


def plan_frames(
    params: GaitParams,
    motion: Motion,
    hardware: HardwareSetup,
    phase0: float,
    n_frames: int,
    steps_per_frame: int,
    timestep_s: float,
    *,
    motion_now: Motion | None = None,
    frame0: int = 0,
    geometry: LegGeometry = ARTRO_LEG,
    joint_delta_rad: NDArray[np.floating] | None = None,
    a_y_delta: float = 0.0,
) -> FramePlan:
    """Run gait and hardware model for n consecutive frames starting at phase0 (vectorised).

    Args:
        params, motion, hardware: the gait, the requested motion vector with CA, the servo
            set-up.
        phase0: phi_Trunk at the first frame's start, rad.
        n_frames: frames to plan; steps_per_frame, timestep_s: the physics steps of one frame.
        motion_now: the motion the gait got in the frame before; from it each frame takes one
            `ramp_motion` step toward `motion` (default: `motion`, nothing to ramp).
        frame0: the first frame's index since the reset (or the switch to this engine), for the
            pfs engine's start-up gain.
        geometry: the robot's leg (`RobotModel.geometry`) for the inverse kinematics.
        joint_delta_rad, a_y_delta: the feedback laws' corrections (`gait.feedback.Output`):
            added to every planned frame's joint angles (12,) and to the a_y its gait gets
            after the ramp (within a_y's range); none: the open-loop gait, to the bit.

    Returns:
        `FramePlan` with a leading frame axis; each set-point takes effect at the first physics
        step starting at or after its pulse's falling edge; `motions` is what the gait got.
    """
    step_rad = 2.0 * math.pi * params.clock.freq_hz * FRAME_S
    phase = pi_cut(phase0 + step_rad * np.arange(n_frames))
    motions = frame_motions(params, motion, motion if motion_now is None else motion_now, n_frames)
    startup = startup_gain(params, (frame0 + np.arange(n_frames)) * FRAME_S)
    walked = motions if a_y_delta == 0.0 else [with_a_y_delta(m, a_y_delta) for m in motions]
    angles, gamma_clamped = _gait(params, walked, phase, startup, geometry)
    if joint_delta_rad is not None:
        angles = angles + np.asarray(joint_delta_rad, dtype=np.float64)
    return _through_servos(
        phase, angles, gamma_clamped, motions, hardware, steps_per_frame, timestep_s
    )


class FrameOfRuns(NamedTuple):
    """One frame of K runs as a closed loop steps it: phi_Trunk at its start, the motion the
    runs' gait got (before the laws' a_y), and each servo's set-point (K, 12) and the physics
    step of the frame at which it takes effect (K, 12)."""

    phase: float | NDArray[np.float64]
    motion: Motion | MotionOfRuns
    setpoint: NDArray[np.float64]
    substep: NDArray[np.int64]


class MotionOfRuns(NamedTuple):
    """The motions of K runs that walk each its own motion vector and CA, a field (K,) each,
    as the gait and the laws take them (the gait along the legs' axis: `along_legs`)."""

    a_r: NDArray[np.float64]
    a_p: NDArray[np.float64]
    a_y: NDArray[np.float64]
    ca: NDArray[np.float64]

    @classmethod
    def of(cls, motions: Sequence[Motion]) -> MotionOfRuns:
        return cls(*(np.array([getattr(m, f) for m in motions]) for f in cls._fields))

    def take(self, runs: NDArray[np.bool_]) -> MotionOfRuns:
        """The motions of the runs `runs` selects."""
        return MotionOfRuns(*(field[runs] for field in self))

    def along_legs(self) -> MotionOfRuns:
        """The fields as (K, 1), against the gait's (K, 2) leg axis."""
        return MotionOfRuns(*(field[:, None] for field in self))


def plan_frame_of_runs(
    params: GaitParams,
    motion: Motion | MotionOfRuns,
    hardware: HardwareSetup,
    phase0: float | NDArray[np.float64],
    steps_per_frame: int,
    timestep_s: float,
    *,
    motion_now: Motion | MotionOfRuns,
    frame0: int,
    geometry: LegGeometry,
    joint_delta_rad: NDArray[np.floating],
    a_y_delta: NDArray[np.floating],
) -> FrameOfRuns:
    """One frame of K runs that walk the same gait from the same phase, each with its own laws'
    corrections (joint_delta_rad (K, 12), a_y_delta (K,)). They walk one `Motion` (its ramp
    from `motion_now`) or each its own (`MotionOfRuns`, which does not ramp: `motion_now` is
    `motion`). Each run's set-points and steps have the bits of `plan_frames(..., n_frames=1)`
    with its corrections (a test holds them equal): the gait is elementwise along the runs.
    `phase0` may be each run's own (K,), as the timing law makes them (`FrameOfRuns.phase`
    then is too)."""
    if np.ndim(phase0) and np.all(phase0 == np.asarray(phase0)[0]):
        phase0 = float(np.asarray(phase0)[0])
    own_phase = np.ndim(phase0) > 0
    phase = pi_cut(
        np.asarray(phase0) + 2.0 * math.pi * params.clock.freq_hz * FRAME_S * np.arange(1)
    )
    if isinstance(motion, MotionOfRuns):
        if motion_now is not motion:
            raise ValueError("the runs' own motions do not ramp: motion_now must be motion")
        walking: Motion | MotionOfRuns = motion
    elif isinstance(motion_now, MotionOfRuns):
        raise ValueError("one Motion ramps from one Motion: motion_now must be a Motion")
    else:
        (walking,) = frame_motions(params, motion, motion_now, 1)
    startup = startup_gain(params, (frame0 + np.arange(1)) * FRAME_S)
    delta = np.asarray(a_y_delta, dtype=np.float64)
    low, high = A_Y_RANGE
    moved = np.minimum(np.maximum(walking.a_y + delta, low), high)
    a_y = np.where(delta == 0.0, walking.a_y, moved)
    runs = len(delta)
    if not own_phase and isinstance(walking, Motion) and np.all(a_y == a_y[0]):  # one gait
        walked = walking if a_y[0] == walking.a_y else with_a_y_delta(walking, delta[0])
        one = joint_angles_with_flags(params, walked, phase, geometry, startup=startup)
        angles = np.repeat(one.values, runs, axis=0)
    else:
        if isinstance(walking, MotionOfRuns):
            own = walking._replace(a_y=a_y)
        else:
            a_r, a_p = (np.full(runs, f) for f in (walking.a_r, walking.a_p))
            own = MotionOfRuns(a_r, a_p, a_y, np.full(runs, walking.ca))
        # the gait reads a motion's four fields; a motion of runs holds them per run
        out = joint_angles_with_flags(
            params, own.along_legs(),  # type: ignore[arg-type]  # (K,) fields: numpy broadcasts
            phase if own_phase else np.repeat(phase, runs), geometry, startup=startup,
        )  # fmt: skip
        angles = out.values
    angles = angles + np.asarray(joint_delta_rad, dtype=np.float64)
    _ocr, _saturated, setpoint, substep = _servo_setpoints(
        angles, hardware, steps_per_frame, timestep_s
    )
    return FrameOfRuns(phase if own_phase else float(phase[0]), walking, setpoint, substep)


def _servo_setpoints(
    angles: NDArray[np.float64], hardware: HardwareSetup, steps_per_frame: int, timestep_s: float
) -> tuple[NDArray[np.int32], NDArray[np.bool_], NDArray[np.float64], NDArray[np.int64]]:
    """Joint angles (n, 12) -> pulses -> each servo's OCR, saturation, the set-point it decodes
    and the physics step of the frame at which it takes effect; on a robot of bus servos, the
    frame's sync write instead (no pulse: idle OCR; docs/BUS.md)."""
    if hardware.bus is not None:
        return _bus_setpoints(angles, hardware, steps_per_frame, timestep_s)
    pulse_us, saturated = angles_to_pulses_us(angles, hardware.calibration)
    servo_ocr = pulse_us_to_ocr(pulse_us)  # what frame_ocr places; no slot idle
    fall_ticks = servo_falling_edge_ticks(servo_ocr, hardware.tdm)
    slot = hardware.tdm.channel_map.slot_index
    received_us = (fall_ticks - slot * SLOT_TICKS) * TICK_US  # what the servo measured
    setpoint = pulses_to_angles_rad(received_us, hardware.calibration)
    substep = falling_edge_substeps(fall_ticks, steps_per_frame, timestep_s)
    return servo_ocr, saturated, setpoint, substep


def _bus_setpoints(
    angles: NDArray[np.float64], hardware: HardwareSetup, steps_per_frame: int, timestep_s: float
) -> tuple[NDArray[np.int32], NDArray[np.bool_], NDArray[np.float64], NDArray[np.int64]]:
    """The sync write of each frame's goals: held to the calibration's limits (saturated
    where they were), quantised to the bus's 4096 steps a turn, acting at the first physics
    step after the packet's last byte."""
    assert hardware.bus is not None
    cal = hardware.calibration
    lo, hi = np.asarray(cal.min_rad), np.asarray(cal.max_rad)
    held = np.clip(angles, lo, hi)
    setpoint, substep = sync_write_substeps(held, hardware.bus, round(timestep_s * 1e6))
    saturated = held != angles
    ocr = np.full(angles.shape, OCR_IDLE, dtype=np.int32)  # no pulse: the TDM lines stay low
    return ocr, saturated, setpoint, np.minimum(substep, steps_per_frame)


def _through_servos(
    phase: NDArray[np.float64],
    angles: NDArray[np.float64],
    gamma_clamped: NDArray[np.bool_],
    motions: list[Motion],
    hardware: HardwareSetup,
    steps_per_frame: int,
    timestep_s: float,
) -> FramePlan:
    """Joint angles (n, 12) -> pulses -> TDM-PWM frame -> set-points and their physics steps."""
    servo_ocr, saturated, setpoint, substep = _servo_setpoints(
        angles, hardware, steps_per_frame, timestep_s
    )
    return FramePlan(
        phase=phase,
        angles=angles,
        ocr=servo_frame_ocr(servo_ocr, hardware.tdm),
        setpoint=setpoint,
        substep=substep,
        saturated=saturated,
        gamma_clamped=gamma_clamped,
        guard=servo_guard_violations(servo_ocr, hardware.tdm),
        motions=motions,
    )


def frame_steps(model: mujoco.MjModel) -> int:
    """Physics steps per 20 ms frame; ValueError if the model's timestep does not divide it."""
    timestep_s = float(model.opt.timestep)
    steps = FRAME_S / timestep_s
    if abs(steps - round(steps)) > 1e-9:
        raise ValueError(f"model timestep {timestep_s} s must divide the 20 ms frame")
    return round(steps)
