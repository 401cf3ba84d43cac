"""The firmware's closed loop emulated end to end (docs/DESIGN.md §15): the firmware drives the
simulated robot and reads its simulated sensors through its emulated IMU and ADC; the host's
model of the firmware (`model_closed_loop`), fed the counts it read (after a failed read, the
last good sample, as on the robot), plans the same pulses and computes the same law outputs."""

from __future__ import annotations

import dataclasses
import math
import struct
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware import protocol as proto
from app.firmware.build import wiring
from app.firmware.conformance import ANGLE_TOLERANCE_RAD, Comparison, ModelFrames, compare_frame
from app.firmware.emulator import CYCLES_PER_TICK, Mcu
from app.firmware.pulses import FirmwarePulses
from app.firmware.sensor_feed import RawSample, decoded
from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.frame_record import PinFrame
from app.sim.planning import FRAME_S, START_PHASE_RAD, plan_frames
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams, Motion, feedback, pi_cut
from hardware import HardwareSetup, frame_edges
from hardware.firmware.schema import param_specs, values_from_document

#: law outputs, firmware (float32, avr-libc's functions) against the model (numpy float32):
#: well below a tenth of a Timer tick's angle
LAW_TOLERANCE = 2e-5
#: laws.h `law_output_t`, member by member in its order (avr-gcc packs it): the field of
#: `feedback.Output` and of `LawFrame` it holds, its struct code and count. A law whose output
#: the firmware reports adds its member here, as laws.h does, and its field of `LawFrame`
LAW_OUTPUT_MEMBERS = (
    ("joint_delta_rad", "f", 12),
    ("a_y_delta", "f", 1),
    ("tilt_rad", "f", 2),
    ("cop_rad", "f", 2),
    ("support", "b", 1),
    ("attitude_rad", "f", 2),
    ("freq_delta_hz", "f", 1),
)
_LAW_OUTPUT = struct.Struct("<" + "".join(f"{n}{code}" for _, code, n in LAW_OUTPUT_MEMBERS))
_TDM_OVERRUN = 0x01  # tdm.h
#: the planning window of frame k+1 in frame k: from the guard of slot 3 to that of slot 7
PLAN_REQUEST_TICK, PLAN_LATCH_TICK = 19_900, 39_900


@dataclass(frozen=True)
class LawFrame:
    """What the firmware's laws made of one frame's sample (laws.h `law_output_t`)."""

    joint_delta_rad: NDArray[np.float32]
    a_y_delta: float
    tilt_rad: NDArray[np.float32]
    cop_rad: NDArray[np.float32]
    support: int
    attitude_rad: NDArray[np.float32]
    freq_delta_hz: float = 0.0


def read_law_output(mcu: Mcu) -> LawFrame:
    """The firmware's `g_law_output`, each member of `LAW_OUTPUT_MEMBERS` as its field."""
    values = iter(_LAW_OUTPUT.unpack(mcu.read_symbol("g_law_output")))
    fields: dict[str, Any] = {}
    for name, _, n in LAW_OUTPUT_MEMBERS:
        taken = [next(values) for _ in range(n)]
        fields[name] = np.array(taken, np.float32) if n > 1 else taken[0]
    return LawFrame(**fields)


def gyro_offset(mcu: Mcu) -> tuple[int, int, int]:
    """The firmware's gyro offsets from its calibration at boot, counts."""
    return struct.unpack("<3h", mcu.read_symbol("g_gyro_offset"))


def document_from_values(values: list[float]) -> dict[str, Any]:
    """The parameter-set document of the firmware's id-ordered values (`values_from_document`
    turned around)."""
    doc: dict[str, Any] = {"motion": {}, "gait": {}}
    for spec, value in zip(param_specs(), values, strict=True):
        where = doc["motion"] if spec.group == "motion" else doc["gait"].setdefault(spec.group, {})
        where[spec.name] = bool(value) if spec.is_switch else value
    return doc


def model_closed_loop(
    docs: list[dict[str, Any]],
    samples: list[RawSample],
    offset: tuple[int, ...],
    hardware: HardwareSetup,
    robot: RobotModel,
) -> tuple[ModelFrames, list[feedback.Output | None]]:
    """The firmware's frames 0..len(samples) as the host computes them: frame k in the set
    `docs[k]`; frame 0 open loop, frame k+1 planned with the laws' step on `samples[k]` (the
    counts the firmware used in frame k, decoded as it decodes them) and the motion the gait got
    in frame k; the walking clock advances by each frame's own frequency."""
    positions = robot.fsr_positions_m.astype(np.float32)
    state, motion_now, out = feedback.State(), Motion(**docs[0]["motion"]), None
    phase = START_PHASE_RAD
    phases, angles, ocrs, outs = [], [], [], []
    for k in range(len(samples) + 1):
        params = GaitParams.from_dict(docs[k]["gait"])
        motion = Motion(**docs[k]["motion"])
        if k > 0:
            reading = decoded(samples[k - 1], offset)
            state, out = feedback.step(
                params, state, reading, motion_now, positions, FRAME_S, phase_rad=phase
            )
        correct = feedback.any_law_on(params) and out is not None
        plan = plan_frames(
            params,
            motion,
            hardware,
            phase,
            1,
            10,
            0.002,
            motion_now=motion_now,
            geometry=robot.geometry,
            joint_delta_rad=out.joint_delta_rad if correct and out is not None else None,
            a_y_delta=float(out.a_y_delta) if correct and out is not None else 0.0,
        )
        motion_now = plan.motions[0]
        delta_hz = float(out.freq_delta_hz) if correct and out is not None else 0.0
        freq = params.clock.freq_hz + delta_hz
        phase = float(pi_cut(phase + 2.0 * math.pi * freq * FRAME_S))
        phases.append(plan.phase[0])
        angles.append(plan.angles[0])
        ocrs.append(plan.ocr[0])
        outs.append(out)
    return ModelFrames(np.array(phases), np.array(angles), np.array(ocrs)), outs


@dataclass
class ClosedLoopRun:
    """A closed-loop run of the emulated firmware against its model."""

    comparison: Comparison
    law_error_max: float = 0.0  # largest law output difference, firmware against model
    #: the same from the frame the robot fell on (the attitude estimate, tan(pitch) steep near
    #: its limit, then parts by float32 rounding): said, not judged; a fall ends every
    #: evaluator's run (decision 0026)
    law_error_max_fallen: float = 0.0
    fell_at: int | None = None  # the frame the robot fell on
    twi_transactions: list[int] = field(default_factory=list)  # per frame
    adc_conversions: list[int] = field(default_factory=list)  # per frame
    imu_stale_frames: list[int] = field(default_factory=list)  # frames whose IMU read failed
    imu_failures: int = 0  # the firmware's count
    gyro_offset: tuple[int, ...] = ()
    laws: list[LawFrame] = field(default_factory=list)  # the firmware's, frame k's sample
    model_laws: list[feedback.Output | None] = field(default_factory=list)
    ocr: list[NDArray[np.int32]] = field(default_factory=list)  # the firmware's pins, per frame
    fell: bool = False
    overrun: bool = False  # a plan was late and a frame repeated (the TDM's sticky flag)
    switch_frames: list[int] = field(default_factory=list)  # where a set sent took over
    #: with `profile`: per frame, cycles by part (`Mcu.profile_take`), and the tick of the frame
    #: at which the next frame's plan was ready (the window ends at PLAN_LATCH_TICK)
    part_cycles: list[NDArray[np.uint64]] = field(default_factory=list)
    plan_ready_ticks: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.failures()

    def failures(self) -> list[str]:
        """What differs from the model beyond its tolerance, in words ([] when it matches)."""
        said = self.comparison.failures()
        if self.law_error_max > LAW_TOLERANCE:
            said.append(
                f"the laws' outputs differ by up to {self.law_error_max:.3g} (tolerance "
                f"{LAW_TOLERANCE:g})" + ("" if self.fell_at is None else " before the fall")
            )
        if self.overrun:
            said.append("a plan was late and a frame repeated (the TDM's overrun flag)")
        return said

    def summary(self) -> dict[str, Any]:
        return {
            **self.comparison.summary(),
            "ok": self.ok,
            "law_error_max": self.law_error_max,
            "law_error_max_fallen": self.law_error_max_fallen,
            "fell_at_frame": self.fell_at,
            "twi_transactions_per_frame": _spread(self.twi_transactions),
            "adc_conversions_per_frame": _spread(self.adc_conversions),
            "imu_stale_frames": self.imu_stale_frames,
            "imu_failures": self.imu_failures,
            "gyro_offset_counts": list(self.gyro_offset),
            "overrun": self.overrun,
            "fell": self.fell,
        }


def _spread(values: list[int]) -> dict[str, float]:
    return {"min": min(values, default=0), "max": max(values, default=0),
            "mean": float(np.mean(values)) if values else 0.0}  # fmt: skip


def _law_error(got: LawFrame, want: feedback.Output) -> float:
    """The largest difference of a law output the firmware reports (`LAW_OUTPUT_MEMBERS`); inf
    where the support foot differs."""
    error = max(
        float(np.max(np.abs(np.float64(getattr(got, name)) - np.float64(getattr(want, name)))))
        for name, code, _ in LAW_OUTPUT_MEMBERS
        if code != "b"
    )
    return error if got.support == want.support else math.inf


def run_closed_loop(
    doc: dict[str, Any],
    frames: int,
    robot: RobotModel | None = None,
    variation: Variation = NOMINAL,
    *,
    faults: dict[int, tuple[int, int]] | None = None,
    samples: list[RawSample] | None = None,
    changes: dict[int, dict[str, Any]] | None = None,
    profile: bool = False,
) -> ClosedLoopRun:
    """Walk the simulated `robot` (varied by `variation`, its sensor errors included) for
    `frames` frames with the firmware built for `doc` making the pulses from the sensors it
    reads; then compare its pins, angles and law outputs with the model fed the same counts.

    Args:
        faults: {frame: (nack, short_after)} corrupts the IMU read of that frame
            (`Mcu.imu_fault`).
        samples: instead of the simulation, what the sensors show in each frame (no physics).
        changes: {frame: document} a whole set sent over the UART at the start of that frame;
            the model takes it from the frame its last ACK names.
        profile: count each frame's cycles by part and when its next plan was ready
            (`Mcu.profile`; slower).
    """
    robot = robot or RobotModel.load()
    hardware = robot.hardware()
    params, motion = GaitParams.from_dict(doc["gait"]), Motion(**doc["motion"])
    drive = FirmwarePulses(doc, **wiring(robot))
    loop = FrameLoop(robot, params, motion, hardware=hardware, variation=variation)
    loop.watch_sensors = True
    run = ClosedLoopRun(Comparison())
    used: list[RawSample] = []
    fw_frames = []
    switches: list[tuple[int, int, list[float]]] = []  # (first frame, first id, values)
    pending: list[tuple[list[float], int, int]] = []  # messages sent: (set, first id, count)
    mcu = drive.mcu
    try:
        run.gyro_offset = gyro_offset(mcu)
        if profile:
            mcu.profile()
            mcu.profile_take()
        last_good_imu = drive.raw
        for k in range(frames):
            served = drive.raw if samples is None else drive.show(samples[k])
            if faults and k in faults:
                nack, short_after = faults[k]
                mcu.imu_fault(nack=nack, short_after=short_after)
            if changes and k in changes:
                values = values_from_document(changes[k])
                drive.send_parameters(changes[k])
                pending += [(values, first, n) for first, n in proto.param_parts(len(values))]
            before = mcu.sensor_counts()
            frame = drive.next_frame()  # frame k: its sample read in slot 3, frame k+1 planned
            after = mcu.sensor_counts()
            if profile:
                bins, rose = mcu.profile_take()
                run.part_cycles.append(bins)
                run.plan_ready_ticks.append((rose - mcu.frame_start(k)) // CYCLES_PER_TICK)
            for reply in frame.replies:
                if pending and isinstance(reply, proto.Ack | proto.Nak):
                    values, first, count = pending.pop(0)
                    if isinstance(reply, proto.Ack):
                        part = values[first : first + count]
                        switches.append((reply.effective_frame, first, part))
            run.twi_transactions.append(after.twi_transactions - before.twi_transactions)
            run.adc_conversions.append(after.adc_conversions - before.adc_conversions)
            status = mcu.read_symbol("g_sensor_status")[0]
            if status & proto.IMU_STALE:
                run.imu_stale_frames.append(k)
                served = dataclasses.replace(
                    served, accel=last_good_imu.accel, gyro=last_good_imu.gyro
                )
            last_good_imu = served
            used.append(served)
            run.laws.append(read_law_output(mcu))
            run.ocr.append(frame.ocr)
            fw_frames.append(frame)
            if samples is not None:
                continue
            pins = PinFrame(
                frame.phase_rad, frame.ocr, frame.edges, frame.saturated, frame.gamma_clamped,
                motion,
            )  # fmt: skip
            record = loop.step_pins(pins)
            if loop.fell and not run.fell:
                run.fell, run.fell_at = True, k
            assert record.reading is not None  # watch_sensors
            drive.feed(record.reading)
        run.imu_failures = mcu.read_symbol("g_imu_failures")[0]
        run.overrun = bool(mcu.read_symbol("g_tdm_flags")[0] & _TDM_OVERRUN)
    finally:
        drive.close()
    per_frame = [values_from_document(doc) for _ in range(frames + 1)]
    for frame_from, first, part in switches:  # each message from the frame its ACK names
        for held in per_frame[frame_from:]:
            held[first : first + len(part)] = part
    docs = [document_from_values(v) for v in per_frame]
    model, run.model_laws = model_closed_loop(docs, used, run.gyro_offset, hardware, robot)
    result = run.comparison
    for k, frame in enumerate(fw_frames):
        want = frame_edges(model.ocr[k], hardware.tdm)
        compare_frame(frame.edges, want, k, result, hardware.tdm.select_change_ticks)
        error = float(np.max(np.abs(np.float64(frame.angles_rad) - model.angles[k])))
        result.max_angle_error_rad = max(result.max_angle_error_rad, error)
        result.busy_cycles.append(frame.busy_cycles)
        law = run.model_laws[k + 1]
        if law is None:
            continue
        error = _law_error(run.laws[k], law)
        if run.fell_at is not None and k >= run.fell_at:
            run.law_error_max_fallen = max(run.law_error_max_fallen, error)
        else:
            run.law_error_max = max(run.law_error_max, error)
    result.frames = len(fw_frames)
    run.switch_frames = [frame_from for frame_from, _, _ in switches]
    return run


__all__ = [
    "ANGLE_TOLERANCE_RAD",
    "LAW_TOLERANCE",
    "ClosedLoopRun",
    "LawFrame",
    "gyro_offset",
    "model_closed_loop",
    "read_law_output",
    "run_closed_loop",
]
