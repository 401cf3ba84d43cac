"""The ATmega128 C header (hardware.firmware): exact contents, and it compiles as strict C99."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from app.params.document import ParameterSet
from gait import GaitParams, Motion
from hardware import ICR_TOP, ChannelMap, ServoCalibration, timer_registers
from hardware.firmware import c_float, c_header

MAIN_C = r"""
#include <stdio.h>
#include "artro_params.h"

int main(void) {
    printf("%.17g\n", (double)ARTRO_SWING_V);
    printf("%.17g\n", (double)ARTRO_SWING_O);
    printf("%.17g\n", (double)ARTRO_MOTION_A_P);
    printf("%.17g\n", (double)ARTRO_MOTION_CA);
    printf("%d\n", ARTRO_LEG_PAPER_SIGNS);
    printf("%u\n", (unsigned)ARTRO_TIMER_TCCRNA);
    printf("%u\n", (unsigned)ARTRO_TIMER_TCCRNB);
    printf("%u\n", (unsigned)ARTRO_TIMER_ICR_TOP);
    printf("%lu\n", (unsigned long)F_CPU);
    printf("%u\n", (unsigned)ARTRO_SELECT_CHANGE_TICKS);
    printf("%u %u\n", ARTRO_SERVO_CHANNEL[5], ARTRO_SERVO_SLOT[5]);
    printf("%d %d\n", ARTRO_SERVO_DIRECTION[3], ARTRO_SERVO_TRIM_TICKS[3]);
    printf("%d %d\n", ARTRO_SERVO_MIN_CDEG[0], ARTRO_SERVO_MAX_CDEG[0]);
    printf("%.17g\n", (double)ARTRO_GAIT_PHASE_STEP_RAD);
    return 0;
}
"""


def tuned() -> dict:
    gait = GaitParams.from_dict({"swing": {"v": 2.35, "o": -0.17}, "leg": {"paper_signs": False}})
    motion = Motion(a_p=0.07, a_y=-0.1, ca=0.013)
    return ParameterSet(name="tuned */ walk", motion=motion, gait=gait).to_dict()


def calibration() -> ServoCalibration:
    cal = ServoCalibration.default()
    direction = np.ones(12, dtype=np.int64)
    direction[3] = -1
    trim_us = np.zeros(12)
    trim_us[3] = -12.25  # -24.5 ticks, rounds half up to -24
    return ServoCalibration(direction, trim_us, cal.min_rad * 0.5, cal.max_rad)


def header(**overrides: object) -> str:
    kwargs = {
        "calibration": calibration(),
        "channel_map": ChannelMap.default(),
        "select_change_ticks": 4900,
    }
    kwargs.update(overrides)
    return c_header(tuned(), **kwargs)  # type: ignore[arg-type]


def defines(text: str) -> dict[str, str]:
    return dict(re.findall(r"^#define (\w+) (\S+)", text, flags=re.MULTILINE))


def test_header_contents() -> None:
    text = header()
    found = defines(text)
    assert text.startswith("/* artro_params.h")
    assert "#ifndef ARTRO_PARAMS_H\n#define ARTRO_PARAMS_H" in text
    assert "#include <stdint.h>" in text and text.endswith("#endif /* ARTRO_PARAMS_H */\n")
    assert found["ARTRO_TIMER_ICR_TOP"] == f"{ICR_TOP}u" == "4999u"
    assert found["ARTRO_TIMER_TCCRNA"] == "0xAAu" and found["ARTRO_TIMER_TCCRNB"] == "0x1Au"
    assert found["ARTRO_SLOT_TICKS"] == "5000u" and found["ARTRO_FRAME_TICKS"] == "40000u"
    assert found["ARTRO_SLOTS_USED"] == "5" and found["ARTRO_SERVO_CENTER_US"] == "1500u"
    assert found["ARTRO_MOTION_A_Y"] == "(-0.1f)" and found["ARTRO_SWING_V"] == "2.35f"
    assert found["ARTRO_LEG_PAPER_SIGNS"] == "0" and found["ARTRO_SHIFT_ENABLED"] == "1"
    assert found["ARTRO_CLOCK_FREQ_HZ"] == "1.0f" and found["ARTRO_GAIT_FREQ_HZ"] == "1.0f"
    # Every parameter of the schema is there, under a valid upper-case C name.
    flat = ParameterSet().gait.flat()
    for dotted in flat:
        assert "ARTRO_" + dotted.replace(".", "_").upper() in found
    assert all(re.fullmatch(r"[A-Z_][A-Z0-9_]*", name) for name in found)
    # Provenance, with the comment-closing '*/' of the name defused.
    assert ' * name:            "tuned *\\/ walk"' in text
    assert "a_p = 0.07" in text and "*/ walk" not in text


def test_c_float_round_trips() -> None:
    for value in (0.07, -0.15, 2.0, 1e-5, 0.1 + 0.2, 123456789.0):
        literal = c_float(value).strip("()")
        assert float(literal[:-1]) == value and literal.endswith("f")
    with pytest.raises(ValueError, match="finite"):
        c_float(float("nan"))
    with pytest.raises(ValueError, match="number"):
        c_float(True)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"select_change_ticks": 4700}, "must be 4800..4999"),
        ({"select_change_ticks": 5000}, "select_change_ticks must be in 1..4999"),
        ({"calibration": ServoCalibration.default(6)}, "must cover the 12 servos"),
    ],
)
def test_bad_hardware_rejected(overrides: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        header(**overrides)


def test_header_compiles_and_values_match(tmp_path: Path) -> None:
    (tmp_path / "artro_params.h").write_text(header(), encoding="ascii")  # ASCII only
    (tmp_path / "main.c").write_text(MAIN_C, encoding="ascii")
    compiler = ["gcc", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"]
    subprocess.run([*compiler, "-o", str(tmp_path / "main"), "main.c"], cwd=tmp_path, check=True)
    out = subprocess.run([str(tmp_path / "main")], capture_output=True, text=True, check=True)
    lines = out.stdout.splitlines()

    pset = tuned()
    regs = timer_registers()
    as_float32 = [float(np.float32(v)) for v in (2.35, -0.17, 0.07, 0.013)]
    assert [float(v) for v in lines[:4]] == as_float32
    assert pset["gait"]["swing"]["v"] == 2.35 and pset["motion"]["ca"] == 0.013
    assert lines[4:10] == [
        "0",
        str(regs["TCCRnA"]),
        str(regs["TCCRnB"]),
        str(regs["ICR"]),
        "16000000",
        "4900",
    ]
    channel, slot = ChannelMap.default().assignments[5]
    assert lines[10] == f"{channel} {slot}" == "2 0"
    assert lines[11] == "-1 -24"
    assert lines[12] == "-4500 9000"
    assert float(lines[13]) == float(np.float32(2 * np.pi * 1.0 * 0.02))


def test_header_refuses_a_different_f_cpu(tmp_path: Path) -> None:
    (tmp_path / "artro_params.h").write_text(header(), encoding="ascii")
    (tmp_path / "main.c").write_text('#include "artro_params.h"\nint main(void) { return 0; }\n')
    result = subprocess.run(
        ["gcc", "-std=c99", "-DF_CPU=8000000UL", "-c", "main.c", "-o", "main.o"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert result.returncode != 0 and "generated for F_CPU = 16000000" in result.stderr


def test_c_float_flushes_what_float32_cannot_hold() -> None:
    """1e-300 is a valid schema value (0..x); as float32 it is 0, and the literal says so."""
    assert c_float(1e-300) == "0.0f" and c_float(-1e-300) == "0.0f"
    assert c_float(1e-40) == "1e-40f"  # a float32 subnormal stays as written


@pytest.mark.parametrize("law", ["tilt", "yaw_rate", "damping", "cop"])
def test_the_feedback_laws_are_ids_after_the_gaits(law):
    """The firmware runs the laws (docs/DESIGN.md §15): their switches and gains are ids of the
    table after every gait id (the open-loop firmware's ids unchanged), and a set that switches
    one on boots with it on."""
    from app.firmware.build import generated_headers
    from hardware.firmware.schema import FEEDBACK_GROUPS, param_specs

    specs = param_specs()
    groups = [s.group for s in specs]
    first_law = min(i for i, g in enumerate(groups) if g in FEEDBACK_GROUPS)
    assert all(g in FEEDBACK_GROUPS for g in groups[first_law:])
    assert [s for s in specs if s.group == law and s.name == "enabled" and s.is_switch]
    headers = generated_headers({"gait": {law: {"enabled": True}}})
    assert f"#define ARTRO_{law.upper()}_ENABLED 1" in headers["artro_params.h"]
