"""The frame loop: gait -> servo pulses -> TDM-PWM frame -> demultiplexed set-points -> MuJoCo.

One `FrameLoop.step_frame()` is one 20 ms TDM frame of the named gait engine and the hardware model;
set-points act at their pulses' falling edges (docs/DESIGN.md §2), motion changes via the ramp (§4).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.worlds.servo_path import ServoPath
from app.worlds.variations import NOMINAL, Variation, varied_robot
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
    SLOT_TICKS,
    TICK_US,
    FrameEdges,
    HardwareSetup,
    angles_to_pulses_us,
    demultiplex,
    falling_edge_ticks,
    frame_ocr,
    guard_violations,
    pulses_to_angles_rad,
)

FRAME_S = FRAME_TICKS * TICK_US * 1e-6  # 20 ms
START_PHASE_RAD = -0.5 * math.pi  # lateral shift passes through zero: both feet on the ground
FALL_HEIGHT_FRACTION = 0.6  # fallen: trunk below 60 % of its standing height ...
FALL_TILT_RAD = math.radians(50.0)  # ... or tilted more than 50 degrees
#: MuJoCo resets the state itself when it meets these; we report them as a blow-up.
BLOW_UP = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


def trunk_yaw(quat_wxyz: NDArray[np.float64]) -> float:
    """Heading of the trunk (counter-clockwise) from its orientation quaternion."""
    w, x, y, z = quat_wxyz
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def trunk_yaws(quats_wxyz: NDArray[np.float64]) -> list[float]:
    """`trunk_yaw` of each row of (n, 4) quaternions, to the bit: the same float arithmetic in
    whole arrays, then `math.atan2` per row."""
    w, x, y, z = quats_wxyz.T
    along = 2.0 * (w * z + x * y)
    across = 1.0 - 2.0 * (y * y + z * z)
    return list(map(math.atan2, along.tolist(), across.tolist()))


def has_fallen(qpos: NDArray[np.float64], standing_height_m: float) -> NDArray[np.bool_]:
    """Trunk below 60 % of its standing height, or tilted more than 50 degrees; qpos may be one
    state (nq,) or many (..., nq), with the same arithmetic either way."""
    up_z = 1.0 - 2.0 * (qpos[..., 4] ** 2 + qpos[..., 5] ** 2)  # trunk z axis, world z part
    return (qpos[..., 2] < FALL_HEIGHT_FRACTION * standing_height_m) | (
        up_z < math.cos(FALL_TILT_RAD)
    )


def planar_distance_m(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance in the ground plane between points (..., >= 2), elementwise arithmetic only, so
    one point pair and many give the same bits."""
    dx, dy = a[..., 0] - b[..., 0], a[..., 1] - b[..., 1]
    return np.sqrt(dx * dx + dy * dy)


def sole_distance_m(data: mujoco.MjData) -> float:
    """Distance between the sole centres in the ground plane (the differential drive's b), from
    the site positions MuJoCo last computed."""
    return float(planar_distance_m(data.site("l_sole").xpos, data.site("r_sole").xpos))


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

    def __post_init__(self) -> None:
        # per-frame summaries, reduced once per block rather than once per frame
        self.any_saturated = self.saturated.any(axis=-1).tolist()
        self.any_gamma_clamped = self.gamma_clamped.any(axis=-1).tolist()
        self.any_guard = self.guard.any(axis=(-2, -1)).tolist()

    def __len__(self) -> int:
        return len(self.phase)


@dataclass(frozen=True)
class FrameRecord:
    """What happened in one frame: the input to metrics, plots and the scope."""

    index: int
    time_s: float
    phase: float
    ocr: NDArray[np.int32]  # (6, 8)
    setpoint: NDArray[np.float64]  # (12,) angle each servo decodes from its pulse
    saturated_servos: NDArray[np.bool_]  # (12,)
    saturated: bool
    gamma_clamped: bool
    guard_violation: bool
    motion: Motion  # what the gait got: the requested motion, or a step of the ramp toward it
    pin_edges: FrameEdges | None = None  # the pins as recorded, when a PinFrame made the frame


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


def falling_edge_substeps(
    fall_ticks: NDArray[np.int64], steps_per_frame: int, timestep_s: float
) -> NDArray[np.int64]:
    """The physics step of the frame at which each set-point takes effect: the first starting at
    or after its pulse's falling edge (docs/DESIGN.md §2)."""
    edge_s = np.asarray(fall_ticks) * TICK_US * 1e-6
    substep = np.ceil(edge_s / timestep_s - 1e-9).astype(np.int64)
    return np.minimum(substep, steps_per_frame)


@dataclass(frozen=True)
class PinFrame:
    """One frame of pulses made outside the model (the emulated firmware), as its pins carried
    them; the servos read their set-points off `edges` (docs/DESIGN.md §5)."""

    phase: float  # phi_Trunk the frame was made for
    ocr: NDArray[np.int32]  # (6, 8) decoded from the pins
    edges: FrameEdges
    saturated_servos: NDArray[np.bool_]  # (12,)
    gamma_clamped: bool
    motion: Motion  # the motion the maker of the pulses had


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
) -> FramePlan:
    """Run gait and hardware model for n consecutive frames starting at phase0 (vectorised).

    Args:
        params, motion, hardware: the gait, the requested motion vector with CA, the servo drive
            set-up.
        phase0: phi_Trunk at the first frame's start, rad.
        n_frames: frames to plan; steps_per_frame, timestep_s: the physics steps of one frame.
        motion_now: the motion the gait got in the frame before; from it each frame takes one
            `ramp_motion` step toward `motion` (default: `motion`, nothing to ramp).
        frame0: the first frame's index since the reset (or the switch to this engine), for the
            pfs engine's start-up gain.
        geometry: the robot's leg (`RobotModel.geometry`) for the inverse kinematics.

    Returns:
        `FramePlan` with a leading frame axis; each set-point takes effect at the first physics
        step starting at or after its pulse's falling edge; `motions` is what the gait got.
    """
    step_rad = 2.0 * math.pi * params.clock.freq_hz * FRAME_S
    phase = pi_cut(phase0 + step_rad * np.arange(n_frames))
    motions = frame_motions(params, motion, motion if motion_now is None else motion_now, n_frames)
    startup = startup_gain(params, (frame0 + np.arange(n_frames)) * FRAME_S)
    angles, gamma_clamped = _gait(params, motions, phase, startup, geometry)
    pulse_us, saturated = angles_to_pulses_us(angles, hardware.calibration)
    ocr = frame_ocr(pulse_us, hardware.tdm)
    fall_ticks = falling_edge_ticks(ocr, hardware.tdm)
    slot = np.asarray(hardware.tdm.channel_map.slot_index)
    received_us = (fall_ticks - slot * SLOT_TICKS) * TICK_US  # what the servo measured
    setpoint = pulses_to_angles_rad(received_us, hardware.calibration)
    substep = falling_edge_substeps(fall_ticks, steps_per_frame, timestep_s)
    return FramePlan(
        phase=phase,
        angles=angles,
        ocr=ocr,
        setpoint=setpoint,
        substep=substep,
        saturated=saturated,
        gamma_clamped=gamma_clamped,
        guard=guard_violations(ocr, hardware.tdm),
        motions=motions,
    )


def frame_steps(model: mujoco.MjModel) -> int:
    """Physics steps per 20 ms frame; ValueError if the model's timestep does not divide it."""
    timestep_s = float(model.opt.timestep)
    steps = FRAME_S / timestep_s
    if abs(steps - round(steps)) > 1e-9:
        raise ValueError(f"model timestep {timestep_s} s must divide the 20 ms frame")
    return round(steps)


def stand(
    robot: RobotModel, data: mujoco.MjData, params: GaitParams, motion: Motion, phase: float
) -> NDArray[np.float64]:
    """Reset `data` and stand the robot on the floor in the gait's pose of `motion` at `phase`
    (start-up gain at time 0), feet flat, at rest, each servo's set-point on its angle; returns
    the pose. `data` is the scratch for the standing height first: no MjData is made."""
    pose = joint_angles_with_flags(
        params, motion, phase, robot.geometry, startup=startup_gain(params, 0.0)
    ).values
    height = robot.standing_height_m(pose, scratch=data)
    mujoco.mj_resetData(robot.model, data)
    data.qpos[robot.qpos_adr] = pose
    data.qpos[2] = height + 1e-4
    data.ctrl[robot.actuator_ids] = pose
    mujoco.mj_forward(robot.model, data)
    return pose


def _varied(robot: RobotModel, variation: Variation) -> RobotModel:
    return robot if variation.is_nominal else varied_robot(robot, variation)


class FrameLoop:
    """The ArtRo simulation, advanced one TDM frame at a time.

    The open-loop gait is planned for a block of `block_frames` frames at once; a change of
    parameters, motion or hardware discards the rest of the block. A `FrameLoop` and its `MjData`
    belong to one thread (docs/DESIGN.md §10). ValueError if the model's timestep does not divide
    the 20 ms frame. Defaults: the built-in robot, `GaitParams()`, `Motion()`, and the robot's
    servo drive (`RobotModel.hardware()`); the gait uses the robot's leg geometry.

    `motion` is the requested motion vector and CA. The run starts in it, or in `start_motion`;
    from then on the gait gets one `ramp_motion` step toward the requested motion per frame
    (`motion_now`, docs/DESIGN.md §4), so `set_gait(motion=...)` is ramped too.
    """

    def __init__(
        self,
        robot: RobotModel | None = None,
        params: GaitParams | None = None,
        motion: Motion | None = None,
        hardware: HardwareSetup | None = None,
        block_frames: int = 50,
        start_motion: Motion | None = None,
        variation: Variation = NOMINAL,
    ) -> None:
        self.nominal_robot = robot or RobotModel.load()
        self.variation = variation
        self.robot = _varied(self.nominal_robot, variation)
        self.model = self.robot.model
        self.data = mujoco.MjData(self.model)
        self.params = params or GaitParams()
        self.motion = motion or Motion()
        self.hardware = hardware or self.robot.hardware()
        self.block_frames = block_frames
        self.timestep_s = float(self.model.opt.timestep)
        self.steps_per_frame = frame_steps(self.model)
        self._plan: FramePlan | None = None
        self.reset(start_motion=start_motion)

    # --- control -----------------------------------------------------------------------------

    def reset(self, phase: float = START_PHASE_RAD, *, start_motion: Motion | None = None) -> None:
        """Stand the robot on the floor in the gait's pose at `phase`, feet flat, at rest: the
        pose of `start_motion` (default: the requested motion), from which the ramp starts."""
        self.phase = float(phase)
        self.frame_index = 0
        self.engine_start_frame = 0  # the start-up gain counts from here (reset, engine switch)
        self.fell = False
        self.blew_up = False
        self.motion_now = self.motion if start_motion is None else start_motion
        pose = stand(self.robot, self.data, self.params, self.motion_now, self.phase)
        self.standing_height_m = float(self.data.qpos[2])
        self._plan = None
        self._new_path(pose)

    def _new_path(self, setpoint: NDArray[np.float64]) -> None:
        """The set-points sent so far end at `setpoint`; a varied robot's servos act on them
        through a new `ServoPath` from there (docs/DESIGN.md §8)."""
        self._sent = np.array(setpoint, dtype=np.float64)
        nominal = self.variation.is_nominal
        self._path = None if nominal else ServoPath(self.variation, self.timestep_s, self._sent)

    def set_variation(self, variation: Variation) -> None:
        """Walk on with the robot varied by `variation` (nominal: as described), from the next
        frame on; the state carries over, the set-point path starts anew."""
        self.variation = variation
        self.robot = _varied(self.nominal_robot, variation)
        self.model = self.robot.model
        self._new_path(self._sent)

    def set_gait(self, params: GaitParams | None = None, motion: Motion | None = None) -> None:
        """New parameters or motion vector: they reach the servos from the next frame on, a new
        motion through the ramp (`ramp` parameters). A switch of engine starts that engine's
        start-up phase (pfs: the oscillation grows from the mean pose)."""
        if params is not None:
            if params.engine != self.params.engine:
                self.engine_start_frame = self.frame_index
            self.params = params
        if motion is not None:
            self.motion = motion
        self._plan = None

    def set_hardware(self, hardware: HardwareSetup) -> None:
        """New calibration or channel map: in effect from the next frame on."""
        self.hardware = hardware
        self._plan = None

    # --- the loop ----------------------------------------------------------------------------

    def step_frame(self) -> FrameRecord:
        """Simulate the next 20 ms frame; returns its record. Sets `fell` / `blew_up` when so."""
        plan = self._plan
        if plan is None or plan.next_index >= len(plan):
            plan = self._plan = plan_frames(
                self.params,
                self.motion,
                self.hardware,
                self.phase,
                self.block_frames,
                self.steps_per_frame,
                self.timestep_s,
                motion_now=self.motion_now,
                frame0=self.frame_index - self.engine_start_frame,
                geometry=self.robot.geometry,
            )
        k = plan.next_index
        plan.next_index += 1
        self._apply_frame(plan.substep[k], plan.setpoint[k])
        record = FrameRecord(
            index=self.frame_index,
            time_s=self.frame_index * FRAME_S,
            phase=float(plan.phase[k]),
            ocr=plan.ocr[k],
            setpoint=plan.setpoint[k],
            saturated_servos=plan.saturated[k],
            saturated=plan.any_saturated[k],
            gamma_clamped=plan.any_gamma_clamped[k],
            guard_violation=plan.any_guard[k],
            motion=plan.motions[k],
        )
        self.motion_now = plan.motions[k]
        self.frame_index += 1
        next_phase = float(plan.phase[k]) + 2.0 * math.pi * self.params.clock.freq_hz * FRAME_S
        self.phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi  # piCut, in floats
        self._check_state()
        return record

    def step_pins(self, pins: PinFrame) -> FrameRecord:
        """Simulate the next 20 ms frame with pulses made outside the model: each servo takes
        the pulse its demultiplexed output carried, at its falling edge; a servo whose output
        carried nothing keeps its set-point. The loop's phase follows the pins' maker."""
        demux = demultiplex(pins.edges, self.hardware.tdm)
        received = ~np.isnan(demux.pulse_us)
        decoded = pulses_to_angles_rad(demux.pulse_us, self.hardware.calibration)
        setpoint = np.where(received, decoded, self._sent)
        substep = falling_edge_substeps(
            np.where(received, demux.fall_ticks, 0), self.steps_per_frame, self.timestep_s
        )
        self._apply_frame(substep, setpoint)
        record = FrameRecord(
            index=self.frame_index,
            time_s=self.frame_index * FRAME_S,
            phase=pins.phase,
            ocr=pins.ocr,
            setpoint=setpoint,
            saturated_servos=pins.saturated_servos,
            saturated=bool(pins.saturated_servos.any()),
            gamma_clamped=pins.gamma_clamped,
            guard_violation=bool(demux.cut.any() or demux.glitch.any()),
            motion=pins.motion,
            pin_edges=pins.edges,
        )
        self.motion_now = pins.motion
        self.frame_index += 1
        self._plan = None  # the model's plan no longer continues this phase
        next_phase = pins.phase + 2.0 * math.pi * self.params.clock.freq_hz * FRAME_S
        self.phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi
        self._check_state()
        return record

    def _apply_frame(self, substep: NDArray[np.int64], setpoint: NDArray[np.float64]) -> None:
        """Step physics through one frame, switching each servo's set-point at its falling edge
        (through the variation's set-point path when the robot is varied)."""
        if self._path is not None:
            self._apply_varied_frame(substep, setpoint)
            return
        self._sent = np.array(setpoint, dtype=np.float64)
        model, data = self.model, self.data
        order = np.argsort(substep, kind="stable")
        ctrl = data.ctrl
        done = 0
        for s, actuator, value in zip(
            substep[order].tolist(),
            self.robot.actuator_ids[order].tolist(),
            setpoint[order].tolist(),
            strict=True,
        ):
            if s > done:
                mujoco.mj_step(model, data, s - done)
                done = s
            ctrl[actuator] = value
        if done < self.steps_per_frame:
            mujoco.mj_step(model, data, self.steps_per_frame - done)

    def _apply_varied_frame(
        self, substep: NDArray[np.int64], setpoint: NDArray[np.float64]
    ) -> None:
        """The frame's set-points per physics step through the path (the step-level input
        `servo_path.acting_setpoints` never builds); physics steps between the steps where what
        the servos act on changes."""
        assert self._path is not None
        steps = np.arange(self.steps_per_frame)[:, None]
        sent = np.where(steps >= substep[None, :], setpoint[None, :], self._sent[None, :])
        self._sent = np.array(setpoint, dtype=np.float64)
        acting = self._path(sent)  # (steps, 12)
        changes = np.flatnonzero(np.any(np.diff(acting, axis=0) != 0.0, axis=1)) + 1
        model, data, act = self.model, self.data, self.robot.actuator_ids
        bounds = [0, *changes.tolist(), self.steps_per_frame]
        for start, end in itertools.pairwise(bounds):
            data.ctrl[act] = acting[start]
            mujoco.mj_step(model, data, end - start)

    def _check_state(self) -> None:
        data = self.data
        # MuJoCo checks qpos, qvel and qacc every step and counts what it finds
        if any(data.warning[w].number for w in BLOW_UP) or not math.isfinite(data.qpos[2]):
            self.blew_up = True
            self.fell = True
            return
        if has_fallen(data.qpos, self.standing_height_m):
            self.fell = True

    # --- readings ----------------------------------------------------------------------------

    @property
    def time_s(self) -> float:
        """Simulated time since the last reset, s (whole frames)."""
        return self.frame_index * FRAME_S

    def trunk_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the trunk in the world frame, yaw counter-clockwise."""
        qpos = self.data.qpos
        return float(qpos[0]), float(qpos[1]), trunk_yaw(qpos[3:7])

    def gyro(self) -> NDArray[np.float64]:
        """The trunk gyro's angular velocity (3,), rad/s, in the IMU's frame."""
        adr = self.robot.gyro_adr
        return self.data.sensordata[adr : adr + 3].copy()

    def feet_distance_m(self) -> float:
        """Distance between the sole centres in the ground plane, m (the drive's axle b)."""
        return sole_distance_m(self.data)
