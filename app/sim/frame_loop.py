"""The frame loop: one `FrameLoop.step_frame()` is one 20 ms TDM frame of the planned gait and
hardware (`app.sim.planning`) applied to MuJoCo, set-points acting at their pulses' falling edges
(docs/DESIGN.md §2), or a frame of pulses made elsewhere (`step_pins`); its record
`app.sim.frame_record`, the fall test and `stand` `app.sim.robot_pose`."""

from __future__ import annotations

import dataclasses
import itertools
import math

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.sim.frame_record import FrameRecord, PinFrame, planned_record, pulseless_record
from app.sim.loop_sensing import LoopSensing
from app.sim.planning import (
    FRAME_S,
    START_PHASE_RAD,
    FramePlan,
    falling_edge_substeps,
    frame_steps,
    plan_frames,
)
from app.sim.robot_pose import has_fallen, sole_distance_m, stand, trunk_yaw
from app.sim.sensors import SensorReading, rest_accelerometers
from app.worlds.servo_path import ServoPath
from app.worlds.variations import NOMINAL, Variation, varied_robot
from gait import GaitParams, Motion, feedback
from hardware import (
    HardwareSetup,
    demultiplex,
    pulses_to_angles_rad,
)

#: MuJoCo resets the state itself when it meets these; we report them as a blow-up.
BLOW_UP = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)


def _varied(robot: RobotModel, variation: Variation) -> RobotModel:
    physics = variation.physics
    return robot if physics.is_nominal else varied_robot(robot, physics)


class FrameLoop:
    """The ArtRo simulation, advanced one TDM frame at a time.

    The open-loop gait is planned for a block of `block_frames` frames at once; a change of
    parameters, motion or hardware discards the rest of the block. A `FrameLoop` and its `MjData`
    belong to one thread (docs/DESIGN.md §10). ValueError if the model's timestep does not divide
    the 20 ms frame. Defaults: the built-in robot, `GaitParams()`, `Motion()`, and the robot's
    servo set-up (`RobotModel.hardware()`); the gait uses the robot's leg geometry.

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
        #: read the sensors and estimate the attitude every frame also with every law off (the
        #: dashboard's Sensors panel); what the robot does stays the same to the bit
        self.watch_sensors = False
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
        self.steps_done = 0  # physics steps since the reset (the push counts them)
        self._new_sensors(None)

    def _new_sensors(self, state: feedback.State | None) -> None:
        """The variation's sensors and push, from here; the laws' `state` carried (None: anew)."""
        self.sensing = LoopSensing(self.robot, self.variation, self.data, state)
        self._push_step, self._push_force = self.variation.push(self.timestep_s)

    def _new_path(self, setpoint: NDArray[np.float64]) -> None:
        """The set-points sent so far end at `setpoint`; a varied robot's servos act on them
        through a new `ServoPath` from there (docs/DESIGN.md §8)."""
        self._sent = np.array(setpoint, dtype=np.float64)
        nominal = self.variation.physics.is_nominal
        self._path = None if nominal else ServoPath(self.variation, self.timestep_s, self._sent)

    def set_variation(self, variation: Variation) -> None:
        """Walk on with the robot varied by `variation` (nominal: as described), from the next
        frame on; the state carries over, the set-point path starts anew."""
        self.variation = variation
        self.robot = _varied(self.nominal_robot, variation)
        self.model = self.robot.model
        self._new_path(self._sent)
        self._new_sensors(self.sensing.state)

    def set_gait(self, params: GaitParams | None = None, motion: Motion | None = None) -> None:
        """New parameters or motion vector: they reach the servos from the next frame on, a new
        motion through the ramp (`ramp` parameters). A switch of engine starts that engine's
        start-up phase (pfs: the oscillation grows from the mean pose)."""
        if params is not None:
            if params.engine != self.params.engine:
                self.engine_start_frame = self.frame_index
            if feedback.laws_on(params) != feedback.laws_on(self.params):
                # the estimate is current where a law was on or the sensors watched
                self.sensing.restart(feedback.any_law_on(self.params) or self.watch_sensors)
            self.params = params
        if motion is not None:
            self.motion = motion
        self._plan = None

    def placed(self) -> None:
        """The robot was put where `data.qpos` says (forward kinematics done): the sensors'
        rows read it at rest there, the floor's tilt in its pose (`rest_accelerometers`)."""
        rest_accelerometers(self.model, self.data)
        self.sensing.rows_as_now()

    def set_hardware(self, hardware: HardwareSetup) -> None:
        """New calibration or channel map: in effect from the next frame on."""
        self.hardware = hardware
        self._plan = None

    # --- the loop ----------------------------------------------------------------------------

    def step_frame(self) -> FrameRecord:
        """Simulate the next 20 ms frame; returns its record. Sets `fell` / `blew_up` when so.
        With a feedback law on (`params`), the frame is planned alone, after the laws have
        read the sensors (docs/DESIGN.md §15); another set of laws starts them anew."""
        if feedback.any_law_on(self.params):
            return self._step_closed_loop()
        plan = self._plan
        if plan is None or plan.next_index >= len(plan):
            plan = self._plan = self._plan_from_here(self.block_frames)
        return self._watched(self._step_planned(plan))

    def _watched(self, record: FrameRecord) -> FrameRecord:
        """`record` with what the sensors read after it and the attitude estimated from them
        (every law off: no correction), when `watch_sensors`."""
        if not self.watch_sensors:
            return record
        reading, out = self._read_and_step_laws()
        return dataclasses.replace(record, reading=reading, feedback=out)

    def _read_and_step_laws(self) -> tuple[SensorReading, feedback.Output]:
        """The sensors read now, and the laws' step on that reading (their state carried on)."""
        return self.sensing.read_and_step(
            self.params, self.motion_now, self.fsr_positions_m, self.phase
        )

    def push_now(self, impulse_n_s: float, direction_deg: float) -> tuple[float, float] | None:
        """Push the trunk in the next physics step (the dashboard's Push): impulse_n_s, level,
        toward direction_deg counter-clockwise from where the trunk faces (0: forward, 90: to
        its left). Takes the place of the world's push if that is still to come; a push already
        due in that step adds to it (two in one frame both act): then the impulse of the two,
        N·s along the world's x and y, is returned (else None)."""
        heading = self.trunk_pose()[2] + math.radians(direction_deg)
        force = impulse_n_s / self.timestep_s
        fx, fy = force * math.cos(heading), force * math.sin(heading)
        summed = self._push_step == self.steps_done  # another push acts in this step: they add
        if summed:
            fx, fy = fx + self._push_force[0], fy + self._push_force[1]
        self._push_step = self.steps_done
        self._push_force = (fx, fy, 0.0)
        return (fx * self.timestep_s, fy * self.timestep_s) if summed else None

    def _plan_from_here(
        self, n_frames: int, correction: feedback.Output | None = None
    ) -> FramePlan:
        """The next `n_frames` frames planned from the loop's phase and motion, with the laws'
        corrections when given."""
        return plan_frames(
            self.params,
            self.motion,
            self.hardware,
            self.phase,
            n_frames,
            self.steps_per_frame,
            self.timestep_s,
            motion_now=self.motion_now,
            frame0=self.frame_index - self.engine_start_frame,
            geometry=self.robot.geometry,
            joint_delta_rad=None if correction is None else correction.joint_delta_rad,
            a_y_delta=0.0 if correction is None else float(correction.a_y_delta),
        )

    def _step_planned(self, plan: FramePlan, freq_delta_hz: float = 0.0) -> FrameRecord:
        """The plan's next frame through the servos and the physics; the clock then advances at
        the gait's frequency plus `freq_delta_hz` (the timing law's)."""
        k = plan.next_index
        plan.next_index += 1
        self._apply_frame(plan.substep[k], plan.setpoint[k])
        record = planned_record(plan, k, self.frame_index)
        self.motion_now = plan.motions[k]
        self.frame_index += 1
        freq = self.params.clock.freq_hz + freq_delta_hz  # + 0.0: the same bits
        next_phase = float(plan.phase[k]) + 2.0 * math.pi * freq * FRAME_S
        self.phase = (next_phase + math.pi) % (2.0 * math.pi) - math.pi  # piCut, in floats
        self._check_state()
        return record

    def _step_closed_loop(self) -> FrameRecord:
        """Sensors -> laws -> a plan of this one frame with their corrections -> physics."""
        reading, out = self._read_and_step_laws()
        self._plan = self._plan_from_here(1, out)
        record = self._step_planned(self._plan, float(out.freq_delta_hz))
        self._plan = None  # the next frame is planned after the next reading
        return dataclasses.replace(record, reading=reading, feedback=out)

    @property
    def _law_state(self) -> feedback.State:
        """The laws' state carried to the next frame (`sensing.state`; the tests read it)."""
        return self.sensing.state

    @property
    def fsr_positions_m(self) -> NDArray[np.float32]:
        return self.robot.fsr_positions_m.astype(np.float32)

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
        return self._watched(record)

    def step_goals(self, setpoint: NDArray[np.float64], substep: int = 0) -> FrameRecord:
        """Simulate the next 20 ms frame with each servo's set-point given from outside (a
        servo bus's goals, docs/BUS.md), acting from the frame's step `substep`; no pulses (the
        TDM lines stay low). The gait plans anew from here once it drives again."""
        setpoint = np.array(setpoint, dtype=np.float64)
        self._apply_frame(np.full(len(setpoint), substep, dtype=np.int64), setpoint)
        record = pulseless_record(self.frame_index, self.phase, setpoint, self.motion_now)
        self.frame_index += 1
        self._plan = None
        self._check_state()
        return self._watched(record)

    def _apply_frame(self, substep: NDArray[np.int64], setpoint: NDArray[np.float64]) -> None:
        """Step physics through one frame, switching each servo's set-point at its falling edge
        (through the variation's set-point path when the robot is varied)."""
        if self._path is not None:
            self._apply_varied_frame(substep, setpoint)
            return
        self._sent = np.array(setpoint, dtype=np.float64)
        data = self.data
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
                self._advance(s - done)
                done = s
            ctrl[actuator] = value
        if done < self.steps_per_frame:
            self._advance(self.steps_per_frame - done)

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
        data, act = self.data, self.robot.actuator_ids
        bounds = [0, *changes.tolist(), self.steps_per_frame]
        for start, end in itertools.pairwise(bounds):
            data.ctrl[act] = acting[start]
            self._advance(end - start)

    def _advance(self, n: int) -> None:
        """n physics steps; one at a time where each step's sensor rows are needed (a law is
        on) or the push falls among them, in one call otherwise (the same bits either way)."""
        first = self.steps_done
        self.steps_done += n
        push_here = first <= self._push_step < self.steps_done
        if not (feedback.any_law_on(self.params) or push_here or self.watch_sensors):
            mujoco.mj_step(self.model, self.data, n)
            return
        data, trunk = self.data, self.robot.trunk_id
        for step in range(first, self.steps_done):
            if step == self._push_step:
                data.xfrc_applied[trunk, :3] = self._push_force
            mujoco.mj_step(self.model, data)
            if step == self._push_step:
                data.xfrc_applied[trunk, :3] = 0.0
            self.sensing.keep_row()

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
