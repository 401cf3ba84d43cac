"""The servo set-up of one robot: each servo's calibration and the TDM-PWM channel map."""

from __future__ import annotations

from dataclasses import dataclass, field

from hardware.servo import ServoCalibration
from hardware.tdm import TdmConfig


@dataclass(frozen=True)
class HardwareSetup:
    """What the firmware needs to know about the wiring: calibration and channel map.

    Attributes:
        calibration: the 12 servos' calibration in SERVO_NAMES order (default: uncalibrated).
        tdm: channel map and select-change tick (default: `ChannelMap.default()`, 4900 ticks).
    """

    calibration: ServoCalibration = field(default_factory=ServoCalibration.default)
    tdm: TdmConfig = field(default_factory=TdmConfig)
