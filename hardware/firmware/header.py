"""The C header `artro_params.h` for ArtRo's ATmega128 firmware (seed 000 §3, docs/DESIGN.md §5).

Pure: from a plain `ParameterSet.to_dict()` document it writes provenance, timer set-up, servo and
channel maps, calibration, the gait engine and every gait constant; contents: see `c_header`.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from gait.params import ENGINES
from hardware.servo import (
    PERIOD_US,
    PULSE_CENTER_US,
    PULSE_MAX_US,
    PULSE_MIN_US,
    US_PER_DEG,
    ServoCalibration,
)
from hardware.tdm import CHANNELS, SERVO_NAMES, ChannelMap, TdmConfig
from hardware.timer import (
    F_CPU_HZ,
    FRAME_TICKS,
    OCR_MAX,
    PRESCALER,
    SLOT_TICKS,
    SLOTS_PER_FRAME,
    SLOTS_USED,
    TICK_US,
    WGM_MODE,
    timer_registers,
)

HEADER_NAME = "artro_params.h"
GUARD = "ARTRO_PARAMS_H"
PULSE_MAX_TICKS = round(PULSE_MAX_US / TICK_US)  # 4800: the longest pulse must end before select
FRAME_PERIOD_US = round(FRAME_TICKS * TICK_US)  # 20000 µs, one TDM frame = one gait time step
_C_IDENTIFIER = re.compile(r"[A-Z_][A-Z0-9_]*")


def c_float(value: Any, where: str = "value") -> str:
    """A C float literal that round-trips `value`: '0.07f', '(-0.15f)', '2.0f', '1e-05f'.

    Written with `repr`, the shortest text that round-trips the double; the compiler rounds that
    once to the target's float. ValueError for a bool, a non-number or a non-finite value.
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise ValueError(f"{where} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{where} must be finite, got {number!r}")
    if np.float32(number) == 0.0:
        number = 0.0  # below float32's smallest subnormal: the target's value is 0 (no warning)
    text = repr(number) + "f"  # repr always has '.' or 'e', so the 'f' suffix is valid C
    return f"({text})" if number < 0 else text


def c_identifier(*parts: str) -> str:
    """'ARTRO_' + the upper-cased parts joined by '_'; ValueError if that is no C identifier."""
    name = "_".join(["ARTRO", *(re.sub(r"[^0-9A-Za-z_]", "_", p).upper() for p in parts)])
    if not _C_IDENTIFIER.fullmatch(name):
        raise ValueError(f"{'.'.join(parts)!r} does not give a valid C identifier ({name!r})")
    return name


def _comment_text(value: Any) -> str:
    """`value` as an ASCII JSON string with no '*/': safe inside a C block comment."""
    return json.dumps(str(value), ensure_ascii=True).replace("*/", "*\\/")


def _define(name: str, value: str, comment: str = "") -> str:
    line = f"#define {name} {value}"
    if not comment:
        return line
    text = comment.encode("ascii", "replace").decode("ascii").replace("*/", "* /")
    return f"{line:<56} /* {text} */"


def _array(ctype: str, name: str, values: Iterable[int], labels: Iterable[str]) -> list[str]:
    items = list(values)
    lines = [f"static const {ctype} {name}[{len(items)}] = {{"]
    for value, label in zip(items, labels, strict=True):
        lines.append(f"    {f'{value},':<8} /* {label} */")
    return [*lines, "};"]


def _float_array(name: str, values: Iterable[float], labels: Iterable[str]) -> list[str]:
    items = [c_float(value, name) for value in values]
    lines = [f"static const float {name}[{len(items)}] = {{"]
    for value, label in zip(items, labels, strict=True):
        lines.append(f"    {f'{value},':<24} /* {label} */")
    return [*lines, "};"]


def _timer_section(select_change_ticks: int) -> list[str]:
    regs = timer_registers()
    return [
        "/* ---- Timer1 / Timer3: fast PWM mode 14, TOP = ICRn, one period = one slot ---- */",
        "#ifndef F_CPU",
        f"#define F_CPU {F_CPU_HZ}UL",
        f"#elif F_CPU != {F_CPU_HZ}UL",
        f'#error "{HEADER_NAME} was generated for F_CPU = {F_CPU_HZ} Hz"',
        "#endif",
        _define("ARTRO_TIMER_PRESCALER", str(PRESCALER), "clk_I/O / 8: one tick = 0.5 us"),
        _define("ARTRO_TIMER_WGM_MODE", str(WGM_MODE), "WGMn3:0 = 1110"),
        _define("ARTRO_TIMER_ICR_TOP", f"{regs['ICR']}u", "ICRn: the counter runs 0..TOP"),
        _define("ARTRO_TIMER_TCCRNA", f"0x{regs['TCCRnA']:02X}u", "COMnA/B/C1 = 1, WGMn1 = 1"),
        _define("ARTRO_TIMER_TCCRNB", f"0x{regs['TCCRnB']:02X}u", "WGMn3:2 = 11, CSn1 = 1"),
        _define("ARTRO_TICK_NS", str(round(TICK_US * 1000)), "timer tick in ns"),
        _define("ARTRO_OCR_MAX", f"{OCR_MAX}u", "longest pulse inside a slot: OCR + 1 ticks"),
        _define("ARTRO_SLOT_TICKS", f"{SLOT_TICKS}u", "one TDM slot, 2.5 ms"),
        _define("ARTRO_SLOTS_PER_FRAME", str(SLOTS_PER_FRAME)),
        _define("ARTRO_SLOTS_USED", str(SLOTS_USED), "slots carrying servos; the rest stay low"),
        _define("ARTRO_FRAME_TICKS", f"{FRAME_TICKS}u", "one servo frame, 20 ms"),
        _define("ARTRO_FRAME_PERIOD_US", f"{FRAME_PERIOD_US}u"),
        _define("ARTRO_NUM_CHANNELS", str(len(CHANNELS)), ", ".join(CHANNELS)),
        _define(
            "ARTRO_SELECT_CHANGE_TICKS",
            f"{select_change_ticks}u",
            "select lines move to the next slot here",
        ),
    ]


def _servo_section(
    calibration: ServoCalibration, channel_map: ChannelMap, select_change_ticks: int
) -> list[str]:
    center_ticks = round(PULSE_CENTER_US / TICK_US)
    lines = [
        "/* ---- Servos: pulse_us = CENTER + direction * deg * US_PER_DEG + trim ---- */",
        _define("ARTRO_NUM_SERVOS", str(len(SERVO_NAMES))),
        _define("ARTRO_SERVO_CENTER_US", f"{round(PULSE_CENTER_US)}u", "0 rad"),
        _define("ARTRO_SERVO_US_PER_DEG", f"{round(US_PER_DEG)}u"),
        _define("ARTRO_SERVO_PULSE_MIN_US", f"{round(PULSE_MIN_US)}u", "-90 deg"),
        _define("ARTRO_SERVO_PULSE_MAX_US", f"{round(PULSE_MAX_US)}u", "+90 deg"),
        _define("ARTRO_SERVO_PERIOD_US", f"{round(PERIOD_US)}u"),
        _define("ARTRO_SERVO_CENTER_TICKS", f"{center_ticks}u"),
        _define("ARTRO_SERVO_PULSE_MAX_TICKS", f"{PULSE_MAX_TICKS}u"),
        "#if ARTRO_SELECT_CHANGE_TICKS < ARTRO_SERVO_PULSE_MAX_TICKS",
        '#error "the select lines would change while a 2.4 ms pulse is still high"',
        "#endif",
        "",
        "/* Servo indexes (the joint order of the gait) */",
    ]
    lines += [_define(c_identifier("SERVO", name), str(i)) for i, name in enumerate(SERVO_NAMES)]
    labels = [
        f"{name}: {CHANNELS[channel]} slot {slot}"
        for name, (channel, slot) in zip(SERVO_NAMES, channel_map.assignments, strict=True)
    ]
    trim_ticks = np.floor(calibration.trim_us / TICK_US + 0.5).astype(np.int64)
    min_cdeg = np.round(np.degrees(calibration.min_rad) * 100).astype(np.int64)
    max_cdeg = np.round(np.degrees(calibration.max_rad) * 100).astype(np.int64)
    lines += ["", "/* TDM channel (0 = OC1A .. 5 = OC3C) and slot (0..4) of each servo */"]
    lines += _array("uint8_t", "ARTRO_SERVO_CHANNEL", channel_map.channel_index, labels)
    lines += _array("uint8_t", "ARTRO_SERVO_SLOT", channel_map.slot_index, labels)
    lines += ["", "/* Calibration: direction +1/-1, trim in 0.5 us ticks, limits in 1/100 deg */"]
    lines += _array("int8_t", "ARTRO_SERVO_DIRECTION", calibration.direction, SERVO_NAMES)
    lines += _array("int16_t", "ARTRO_SERVO_TRIM_TICKS", trim_ticks, SERVO_NAMES)
    lines += _array("int16_t", "ARTRO_SERVO_MIN_CDEG", min_cdeg, SERVO_NAMES)
    lines += _array("int16_t", "ARTRO_SERVO_MAX_CDEG", max_cdeg, SERVO_NAMES)
    lines += ["", "/* The same calibration exactly, as the firmware computes pulses in float */"]
    lines += _float_array("ARTRO_SERVO_TRIM_US", calibration.trim_us, SERVO_NAMES)
    lines += _float_array("ARTRO_SERVO_MIN_RAD", calibration.min_rad, SERVO_NAMES)
    lines += _float_array("ARTRO_SERVO_MAX_RAD", calibration.max_rad, SERVO_NAMES)
    return lines


def _parameter_section(
    motion: Mapping[str, Any], gait: Mapping[str, Any], comments: Mapping[str, str]
) -> list[str]:
    lines = ["/* ---- Motion vector a_Robot = (a_r, a_p, a_y) and curve amount CA ---- */"]
    lines += [
        _define(c_identifier("MOTION", key), c_float(value, f"motion.{key}"), comments.get(key, ""))
        for key, value in motion.items()
    ]
    lines += ["", *_engine_section(gait.get("engine", "behnke"))]
    for group, values in gait.items():
        if group == "engine":
            continue
        if not isinstance(values, Mapping):
            raise ValueError(f"gait.{group} must be an object, got {type(values).__name__}")
        lines += ["", f"/* ---- gait: {group} ---- */"]
        for key, value in values.items():
            dotted = f"{group}.{key}"
            literal = str(int(value)) if isinstance(value, bool) else c_float(value, dotted)
            lines.append(_define(c_identifier(group, key), literal, comments.get(dotted, "")))
    return lines


def _engine_section(engine: Any) -> list[str]:
    """ARTRO_ENGINE: which gait the firmware runs, one number per engine of gait.ENGINES."""
    if engine not in ENGINES:
        raise ValueError(f"gait.engine {engine!r} is unknown; allowed: {', '.join(ENGINES)}")
    lines = ["/* ---- Gait engine (docs/DESIGN.md, section 4) ---- */"]
    lines += [_define(c_identifier("ENGINE", e), str(i)) for i, e in enumerate(ENGINES)]
    lines.append(_define("ARTRO_ENGINE", c_identifier("ENGINE", engine), f"gait.engine {engine}"))
    return lines


def _clock_section(gait: Mapping[str, Any]) -> list[str]:
    freq_hz = float(gait.get("clock", {}).get("freq_hz", math.nan))
    if not math.isfinite(freq_hz) or freq_hz <= 0:
        raise ValueError(f"gait.clock.freq_hz must be a positive number, got {freq_hz!r}")
    frame_s = FRAME_PERIOD_US * 1e-6
    return [
        "/* ---- Walking clock, eqs (10)-(11): phi_Trunk += PHASE_STEP_RAD every frame ---- */",
        _define("ARTRO_GAIT_FREQ_HZ", c_float(freq_hz), "gait cycles per second"),
        _define("ARTRO_GAIT_PERIOD_S", c_float(1.0 / freq_hz), "one left and one right step"),
        _define("ARTRO_GAIT_FRAME_PERIOD_S", c_float(frame_s), "one gait time step = one frame"),
        _define("ARTRO_GAIT_PHASE_STEP_RAD", c_float(2 * math.pi * freq_hz * frame_s)),
        _define("ARTRO_GAIT_FRAMES_PER_CYCLE", c_float(1.0 / (freq_hz * frame_s))),
    ]


def c_header(
    pset: Mapping[str, Any],
    *,
    calibration: ServoCalibration,
    channel_map: ChannelMap,
    select_change_ticks: int,
    comments: Mapping[str, str] | None = None,
) -> str:
    """The include-guarded C99 header `artro_params.h` for one parameter set.

    It carries everything the firmware needs to reproduce a simulated gait:

    - provenance of the parameter set (name, created, project version, motion vector);
    - the Timer1/Timer3 set-up of `hardware.timer` (fast PWM mode 14, prescaler 8, ICRn = 4999, the
      TCCRnA/TCCRnB bytes), the TDM slot and frame lengths in ticks and the select-line change tick;
    - the servo mapping of `hardware.servo` (1500 µs = 0 rad, 10 µs per degree, 600..2400 µs);
    - the channel map (`ARTRO_SERVO_CHANNEL[12]`, `ARTRO_SERVO_SLOT[12]`) and the per-servo
      calibration (direction, trim in ticks, limits in centidegrees; and exactly, as floats:
      trim in µs, limits in rad);
    - the gait engine (`ARTRO_ENGINE`, one of `ARTRO_ENGINE_BEHNKE`, `ARTRO_ENGINE_PFS`), the
      motion vector, CA and every gait constant as `ARTRO_<GROUP>_<FIELD>` float literals
      (booleans as 0/1), plus the gait clock and the phase advance per 20 ms frame, eqs (10)–(11).

    Args:
        pset: a `ParameterSet.to_dict()` document (name, created, project_version, motion, gait).
        calibration: the 12 servos' calibration, in SERVO_NAMES order.
        channel_map: which (channel, slot) carries which servo.
        select_change_ticks: tick in each slot at which the select lines switch; must let the
            longest pulse (2.4 ms = 4800 ticks) end first, so 4800..4999.
        comments: optional text per parameter ('swing.v', or 'a_p' for motion) for the defines.

    Raises:
        ValueError: on a missing or non-numeric parameter, a calibration not of 12 servos, or a
            select-change tick that would cut pulses.
    """
    if calibration.n != len(SERVO_NAMES):
        raise ValueError(
            f"calibration must cover the {len(SERVO_NAMES)} servos, got {calibration.n}"
        )
    tdm = TdmConfig(channel_map=channel_map, select_change_ticks=select_change_ticks)
    if tdm.select_change_ticks < PULSE_MAX_TICKS:
        raise ValueError(
            f"select_change_ticks must be {PULSE_MAX_TICKS}..{SLOT_TICKS - 1} so a 2.4 ms pulse "
            f"ends before the select lines change, got {tdm.select_change_ticks}"
        )
    motion, gait = pset.get("motion"), pset.get("gait")
    if not isinstance(motion, Mapping) or not isinstance(gait, Mapping):
        raise ValueError("pset must be a parameter-set document with 'motion' and 'gait' objects")
    motion_text = ", ".join(f"{key} = {value!r}" for key, value in motion.items())
    lines = [
        f"/* {HEADER_NAME} -- ArtRo gait parameters and servo set-up (ATmega128).",
        " * Generated by artro-gait-studio (artro export --format c); do not edit by hand.",
        " *",
        f" * name:            {_comment_text(pset.get('name', ''))}",
        f" * created:         {_comment_text(pset.get('created', ''))}",
        f" * project version: {_comment_text(pset.get('project_version', ''))}",
        f" * schema version:  {_comment_text(pset.get('schema_version', ''))}",
        f" * motion:          {_comment_text(motion_text)}",
        " */",
        f"#ifndef {GUARD}",
        f"#define {GUARD}",
        "",
        "#include <stdint.h>",
        "",
        *_timer_section(tdm.select_change_ticks),
        "",
        *_servo_section(calibration, tdm.channel_map, tdm.select_change_ticks),
        "",
        *_parameter_section(motion, gait, comments or {}),
        "",
        *_clock_section(gait),
        "",
        f"#endif /* {GUARD} */",
    ]
    defined = [line.split()[1] for line in lines if line.startswith("#define ")]
    twice = sorted({name for name in defined if defined.count(name) > 1})
    if twice:
        raise ValueError(f"parameter names collide as C identifiers: {twice}")
    return "\n".join(lines) + "\n"
