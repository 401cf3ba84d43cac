"""The servo set-up of one robot: each servo's calibration and the TDM-PWM channel map, or the
serial bus its servos sit on (docs/DESIGN.md §5, docs/BUS.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

from hardware.servo import ServoCalibration
from hardware.servo_bus import BusLink
from hardware.tdm import TdmConfig


@dataclass(frozen=True)
class HardwareSetup:
    """What the firmware needs to know about the wiring: calibration and channel map.

    Attributes:
        calibration: the 12 servos' calibration in SERVO_NAMES order (default: uncalibrated).
        tdm: channel map and select-change tick (default: `ChannelMap.default()`, 4900 ticks).
        bus: the serial bus of a robot whose servos are bus servos (a sync write of goal
            positions per frame instead of TDM-PWM pulses); None: TDM-PWM.
    """

    calibration: ServoCalibration = field(default_factory=ServoCalibration.default)
    tdm: TdmConfig = field(default_factory=TdmConfig)
    bus: BusLink | None = None
