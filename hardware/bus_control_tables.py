"""The control tables of the two bus servos the studio emulates, the XM430-W350 (Dynamixel
Protocol 2.0) and the STS3215 (Feetech): each field's address and size, what a WRITE may change,
the power-on values and the baud rates (docs/BUS.md, docs/DESIGN.md §5)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from hardware.bus_timing import CENTER_STEPS, RAD_PER_STEP


@dataclass(frozen=True)
class ControlTable:
    """A servo model's control table: name -> (address, bytes), little-endian; what a WRITE may
    change; the power-on values; the baud rates by the baud field's value."""

    model: str
    model_number: int
    size: int
    fields: dict[str, tuple[int, int]]
    writable: frozenset[str]
    eeprom_end: int  # addresses below: written only with the torque off
    defaults: dict[str, int]
    bauds: dict[int, int]
    velocity_unit_rad_s: float
    load_unit: float  # fraction of the stall torque per count
    signed: str  # "twos" (Dynamixel) or "magnitude" (Feetech: a sign bit above the value)

    def baud_code(self, baud: int) -> int:
        for code, rate in self.bauds.items():
            if rate == baud:
                return code
        raise ValueError(f"{self.model} runs at {sorted(self.bauds.values())} baud, got {baud}")


XM430_W350 = ControlTable(
    model="XM430-W350",
    model_number=1020,
    size=148,
    fields={
        "model_number": (0, 2),
        "firmware_version": (6, 1),
        "id": (7, 1),
        "baud_rate": (8, 1),
        "return_delay_time": (9, 1),
        "operating_mode": (11, 1),
        "torque_enable": (64, 1),
        "led": (65, 1),
        "status_return_level": (68, 1),
        "hardware_error_status": (70, 1),
        "goal_velocity": (104, 4),
        "profile_acceleration": (108, 4),
        "profile_velocity": (112, 4),
        "goal_position": (116, 4),
        "moving": (122, 1),
        "present_load": (126, 2),
        "present_velocity": (128, 4),
        "present_position": (132, 4),
        "present_input_voltage": (144, 2),
        "present_temperature": (146, 1),
    },
    writable=frozenset(
        {
            "id",
            "baud_rate",
            "return_delay_time",
            "operating_mode",
            "torque_enable",
            "led",
            "status_return_level",
            "goal_velocity",
            "profile_acceleration",
            "profile_velocity",
            "goal_position",
        }
    ),
    eeprom_end=64,
    defaults={
        "firmware_version": 52,
        "baud_rate": 3,
        "return_delay_time": 250,
        "operating_mode": 3,
        "status_return_level": 2,
        "goal_position": CENTER_STEPS,
        "present_position": CENTER_STEPS,
        "present_temperature": 25,
    },
    bauds={
        0: 9600,
        1: 57_600,
        2: 115_200,
        3: 1_000_000,
        4: 2_000_000,
        5: 3_000_000,
        6: 4_000_000,
        7: 4_500_000,
    },
    velocity_unit_rad_s=0.229 * 2.0 * math.pi / 60.0,  # 0.229 rev/min
    load_unit=0.001,  # 0.1 %
    signed="twos",
)

STS3215 = ControlTable(
    model="STS3215",
    model_number=777,
    size=71,
    fields={
        "firmware_version": (0, 1),
        "model_number": (3, 2),
        "id": (5, 1),
        "baud_rate": (6, 1),
        "return_delay_time": (7, 1),
        "torque_enable": (40, 1),
        "acceleration": (41, 1),
        "goal_position": (42, 2),
        "goal_time": (44, 2),
        "goal_speed": (46, 2),
        "lock": (55, 1),
        "present_position": (56, 2),
        "present_speed": (58, 2),
        "present_load": (60, 2),
        "present_voltage": (62, 1),
        "present_temperature": (63, 1),
        "moving": (66, 1),
    },
    writable=frozenset(
        {
            "id",
            "baud_rate",
            "return_delay_time",
            "torque_enable",
            "acceleration",
            "goal_position",
            "goal_time",
            "goal_speed",
            "lock",
        }
    ),
    eeprom_end=40,
    defaults={
        "firmware_version": 3,
        "baud_rate": 0,
        "return_delay_time": 250,
        "goal_position": CENTER_STEPS,
        "present_position": CENTER_STEPS,
        "present_temperature": 25,
    },
    bauds={
        0: 1_000_000,
        1: 500_000,
        2: 250_000,
        3: 128_000,
        4: 115_200,
        5: 76_800,
        6: 57_600,
        7: 38_400,
    },
    velocity_unit_rad_s=RAD_PER_STEP,  # steps/s
    load_unit=0.001,  # 0.1 %
    signed="magnitude",
)

TABLES = {"dynamixel": XM430_W350, "feetech": STS3215}
