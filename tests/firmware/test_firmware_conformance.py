"""The emulated firmware carries the Python model's edges tick for tick and its joint angles.

Real avr-gcc, real simavr (ATmega128 core): over at least five gait cycles the nine output lines
must equal `hardware.frame_edges` of the simulation's frame pipeline, a falling edge one tick off
being allowed only where float32 and float64 round a pulse to neighbouring ticks (counted, < 1 %);
select lines change only at the guard's change tick; angles within half a tick's worth of angle
(`ANGLE_TOLERANCE_RAD`, 4.4e-4 rad).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.firmware.conformance import ANGLE_TOLERANCE_RAD, model_frames, run_comparison
from hardware.firmware.schema import param_specs
from tests.testing.firmware_support import emulator, frames_for_cycles, preset

CYCLES = 5


def check(doc: dict, cycles: float = CYCLES) -> dict:
    n_frames = frames_for_cycles(doc, cycles)
    with emulator(doc) as mcu:
        result = run_comparison(mcu, model_frames(doc, n_frames))
    summary = result.summary()
    assert result.mismatches == [], result.mismatches[:5]
    assert result.select_outside_guard == 0
    assert result.pulses == 12 * n_frames
    assert result.exact + result.one_tick == result.pulses
    assert result.one_tick <= 0.01 * result.pulses, summary
    assert result.max_angle_error_rad <= ANGLE_TOLERANCE_RAD, summary
    return summary


def test_paper_preset_walking_forward_two_cycles() -> None:
    """The quick one: two cycles of the paper preset, a_p = 0.07 (eqs 2-45, paper signs)."""
    check(preset("paper", a_p=0.07), cycles=2)


def test_the_support_lean_is_pin_exact_stepping_sideways() -> None:
    """Lateral support (decision 0061): the support leg's roll leaned, more with |a_r|."""
    doc = preset("tuned", a_r=-0.1)
    doc["gait"]["lateral"] = {"support_roll_rad": 0.03, "sway_per_a_r": 0.2}
    check(doc, cycles=2)


@pytest.mark.parametrize("motion", [{"a_r": 0.1}, {"a_p": -0.07, "ca": 0.1}])
def test_the_stride_and_spread_coefficients_are_pin_exact(motion: dict) -> None:
    """Eq (28)'s `swing.pitch_gain` and eq (39)'s `balance.leg_roll_side` off the paper's 1
    (decision 0071), stepping sideways and walking backward on a curve."""
    doc = preset("tuned", **motion)
    doc["gait"]["swing"]["pitch_gain"] = 1.2
    doc["gait"]["balance"]["leg_roll_side"] = 0.15
    check(doc, cycles=2)


@pytest.mark.slow
@pytest.mark.parametrize(
    "motion",
    [
        {"a_p": 0.07},
        {"a_r": 0.1},
        {"a_r": -0.1},  # mirrored
        {"a_y": 0.2},
        {"a_y": -0.2},  # mirrored
        {"a_p": 0.07, "ca": 0.1},
        {"a_p": 0.07, "ca": -0.1},
    ],
    ids=lambda m: ",".join(f"{k}={v}" for k, v in m.items()),
)
@pytest.mark.parametrize("name", ["paper", "tuned"])
def test_presets_five_cycles(name: str, motion: dict) -> None:
    check(preset(name, **motion))


SPECS = param_specs()


@st.composite
def parameter_sets(draw: st.DrawFn) -> dict:
    doc = preset("paper")
    for spec in SPECS:
        if spec.is_switch:
            value: float | bool = draw(st.booleans())
        elif spec.dotted == "clock.freq_hz":  # keep five cycles short enough to emulate
            value = draw(st.floats(0.8, spec.hi))
        else:
            value = draw(st.floats(spec.lo, spec.hi, allow_subnormal=False))
        target = doc["motion"] if spec.group == "motion" else doc["gait"].setdefault(spec.group, {})
        target[spec.name] = value
    return doc


@pytest.mark.slow
@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(doc=parameter_sets())
def test_random_parameter_sets(doc: dict) -> None:
    check(doc)


def test_gait_clock_matches_frame_loop_phase() -> None:
    """The firmware's phase per frame is the frame loop's phi_Trunk (float32 of it)."""
    doc = preset("tuned", a_p=0.05)
    model = model_frames(doc, 40)
    from app.firmware.emulator import read_active_plan

    with emulator(doc) as mcu:
        phases = []
        for k in range(40):
            mcu.run_to_frame(k, 100)
            phases.append(read_active_plan(mcu).phase_rad)
    assert np.max(np.abs(np.array(phases) - model.phase)) < 1e-6


@pytest.mark.slow
def test_the_second_robots_firmware_is_conformant_tick_for_tick() -> None:
    """The micro robot's firmware (its leg lengths in artro_schema.h, its wiring) carries the
    Python model's edges of the same robot, as ArtRo's does (docs/DESIGN.md §7)."""
    from app.firmware.build import build_firmware, wiring
    from app.firmware.emulator import Mcu
    from app.robots.model import RobotModel

    robot = RobotModel.load("micro")
    doc = preset("micro-tuned", a_p=0.07, ca=0.05)
    n_frames = frames_for_cycles(doc, 3)
    build = build_firmware(doc, **wiring(robot))
    model = model_frames(doc, n_frames, robot.hardware(), geometry=robot.geometry)
    schema = (build.directory / "gen" / "artro_schema.h").read_text(encoding="ascii")
    assert "#define ARTRO_GEOM_UPPER_LEG_M 0.045f" in schema  # its own legs, not ArtRo's 0.09
    with Mcu(build.elf) as mcu:
        result = run_comparison(mcu, model, robot.hardware())
    assert result.mismatches == [], result.mismatches[:5]
    assert result.select_outside_guard == 0 and result.pulses == 12 * n_frames
    assert result.one_tick <= 0.01 * result.pulses and result.max_angle_error_rad <= 1e-4
