"""What one frame of the frame loop did (`FrameRecord`: the input to metrics, plots, the scope
and the Sensors trace) and a frame of pulses made outside the model (`PinFrame`, the emulated
firmware's), docs/DESIGN.md §2, §5."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from app.sim.planning import FRAME_S, FramePlan
from app.sim.sensors import SensorReading
from gait import Motion, feedback
from hardware import CHANNELS, OCR_IDLE, SLOTS_PER_FRAME, FrameEdges


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
    reading: SensorReading | None = None  # what the sensors read before it (closed loop)
    feedback: feedback.Output | None = None  # what the laws made of it


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


def planned_record(plan: FramePlan, k: int, index: int) -> FrameRecord:
    """The record of frame `index`, the plan's k-th frame."""
    return FrameRecord(
        index=index,
        time_s=index * FRAME_S,
        phase=float(plan.phase[k]),
        ocr=plan.ocr[k],
        setpoint=plan.setpoint[k],
        saturated_servos=plan.saturated[k],
        saturated=plan.any_saturated[k],
        gamma_clamped=plan.any_gamma_clamped[k],
        guard_violation=plan.any_guard[k],
        motion=plan.motions[k],
    )


def pulseless_record(
    index: int, phase: float, setpoint: NDArray[np.float64], motion: Motion
) -> FrameRecord:
    """The record of frame `index` whose set-points came from outside with no pulses (a servo
    bus's goals): the TDM's outputs idle, nothing saturated or clamped."""
    return FrameRecord(
        index=index,
        time_s=index * FRAME_S,
        phase=phase,
        ocr=np.full((len(CHANNELS), SLOTS_PER_FRAME), OCR_IDLE, dtype=np.int32),
        setpoint=setpoint,
        saturated_servos=np.zeros(len(setpoint), dtype=bool),
        saturated=False,
        gamma_clamped=False,
        guard_violation=False,
        motion=motion,
    )
