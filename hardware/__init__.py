"""ArtRo's servo drive hardware, seed 000 §2–3 and eq (1): pure numpy models (docs/DESIGN.md §5).

joint angle -> servo pulse (servo) -> timer OCR ticks (timer) -> TDM-PWM frame of six lines and
three shared select lines (tdm) -> wire edges and demultiplexed pulses (demux); eq (1) (torque).
"""

from hardware.demux import (
    DemuxResult,
    FrameEdges,
    Pulse,
    demultiplex,
    frame_edges,
)
from hardware.drive import HardwareSetup
from hardware.servo import (
    PERIOD_US,
    PULSE_CENTER_US,
    PULSE_MAX_US,
    PULSE_MIN_US,
    US_PER_DEG,
    ServoCalibration,
    angles_to_pulses_us,
    pulses_to_angles_rad,
)
from hardware.tdm import (
    CHANNELS,
    DEFAULT_SELECT_CHANGE_TICKS,
    SELECT_LINES,
    SERVO_NAMES,
    ChannelMap,
    TdmConfig,
    check_ocr,
    falling_edge_ticks,
    frame_ocr,
    guard_violations,
    select_value,
)
from hardware.timer import (
    F_CPU_HZ,
    FRAME_TICKS,
    ICR_TOP,
    OCR_IDLE,
    OCR_MAX,
    PRESCALER,
    SLOT_TICKS,
    SLOTS_PER_FRAME,
    SLOTS_USED,
    TICK_US,
    ocr_to_pulse_us,
    pulse_us_to_ocr,
    timer_registers,
)
from hardware.torque import max_sin, required_torque_from_loads, required_torque_nm

__all__ = [
    "CHANNELS",
    "DEFAULT_SELECT_CHANGE_TICKS",
    "FRAME_TICKS",
    "F_CPU_HZ",
    "ICR_TOP",
    "OCR_IDLE",
    "OCR_MAX",
    "PERIOD_US",
    "PRESCALER",
    "PULSE_CENTER_US",
    "PULSE_MAX_US",
    "PULSE_MIN_US",
    "SELECT_LINES",
    "SERVO_NAMES",
    "SLOTS_PER_FRAME",
    "SLOTS_USED",
    "SLOT_TICKS",
    "TICK_US",
    "US_PER_DEG",
    "ChannelMap",
    "DemuxResult",
    "FrameEdges",
    "HardwareSetup",
    "Pulse",
    "ServoCalibration",
    "TdmConfig",
    "angles_to_pulses_us",
    "check_ocr",
    "demultiplex",
    "falling_edge_ticks",
    "frame_edges",
    "frame_ocr",
    "guard_violations",
    "max_sin",
    "ocr_to_pulse_us",
    "pulse_us_to_ocr",
    "pulses_to_angles_rad",
    "required_torque_from_loads",
    "required_torque_nm",
    "select_value",
    "timer_registers",
]
