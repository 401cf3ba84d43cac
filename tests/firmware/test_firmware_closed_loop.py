"""The firmware closes the loop (docs/DESIGN.md §15): the real avr-gcc build on simavr's core
walks the simulated robot from the simulated sensors it reads through its emulated IMU (TWI) and
ADC, with the run's sensor errors, and its pins, angles and law outputs equal the host's model
fed the counts it read."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from app.firmware import protocol as proto
from app.firmware.build import build_firmware
from app.firmware.closed_loop import (
    LAW_OUTPUT_MEMBERS,
    LAW_TOLERANCE,
    PLAN_LATCH_TICK,
    PLAN_REQUEST_TICK,
    LawFrame,
    run_closed_loop,
)
from app.firmware.conformance import ANGLE_TOLERANCE_RAD
from app.firmware.emulator import CYCLES_PER_TICK, FRAME_CYCLES, Mcu
from app.firmware.link import EmulatedLink
from app.firmware.sensor_feed import GYRO_ZERO_RATE_COUNTS, RawSample, at_rest, sample_of
from app.worlds.variations import Variation
from gait import feedback
from hardware.firmware.schema import complete_document
from tests.testing.firmware_support import preset

#: every sensor error of the variation ranges at once (docs/DESIGN.md §8)
SENSOR_ERRORS = Variation(
    imu_tilt_bias_deg=1.0,
    imu_tilt_direction_deg=30.0,
    gyro_bias_deg_s=0.5,
    gyro_noise_deg_s=0.1,
    imu_delay_ms=10.0,
    fsr_gain=1.15,
)


def closed_loop_set(laws: tuple[str, ...] = ("tilt", "yaw_rate", "damping", "cop"), **motion):
    doc = complete_document(preset("tuned", **motion))  # every group, the laws' defaults too
    for law in laws:
        doc["gait"][law]["enabled"] = True
    return doc


def assert_conforms(run) -> None:
    c = run.comparison
    assert c.mismatches == [], c.mismatches[:3]
    assert c.one_tick <= 0.01 * c.pulses and c.select_outside_guard == 0
    assert c.max_angle_error_rad <= ANGLE_TOLERANCE_RAD
    assert run.law_error_max <= LAW_TOLERANCE


@pytest.mark.parametrize(
    "motion",
    [{"a_p": 0.05}, {"a_p": 0.03, "a_y": 0.1}, {"a_p": 0.05, "ca": 0.1}],
    ids=["forward", "turning", "ca"],
)
def test_closed_loop_walks_with_sensor_errors_are_pin_exact(motion) -> None:
    run = run_closed_loop(closed_loop_set(**motion), 100, variation=SENSOR_ERRORS)
    assert_conforms(run)
    assert run.comparison.pulses == 100 * 12
    # one burst of the IMU and one sweep of the eight force sensors in every frame
    assert run.twi_transactions == [1] * 100 and run.adc_conversions == [8] * 100
    assert run.imu_stale_frames == [] and run.imu_failures == 0
    assert run.gyro_offset == GYRO_ZERO_RATE_COUNTS  # calibrated at rest at boot
    # the laws acted: trims, a turn-rate change and CoP corrections are not all zero
    assert max(abs(law.a_y_delta) for law in run.laws) > 1e-3
    assert max(np.abs(law.tilt_rad).max() for law in run.laws) > 1e-3
    assert {law.support for law in run.laws} >= {0, 1}


LEAN = math.radians(2.0)


def tilt_trim_set() -> dict:
    """The tilt trim alone, quick (ki 2/s, kp 0.5)."""
    doc = closed_loop_set(("tilt",))
    doc["gait"]["tilt"].update(ki_per_s=2.0, kp=0.5)
    return doc


def leaning_forward(lean: float) -> RawSample:
    """The IMU's counts of a trunk at rest leaning `lean` rad forward, the soles loaded."""
    return RawSample(
        accel=(round(-math.sin(lean) * 16384), 0, round(math.cos(lean) * 16384)),
        gyro=GYRO_ZERO_RATE_COUNTS,
        adc=(300,) * 8,
    )


def test_a_tilt_bias_in_the_imu_moves_the_firmwares_trim_as_it_moves_the_models() -> None:
    """The IMU's registers read a 2° forward lean of a robot stepping on the spot (and, in the
    walk above, with the simulation's mounting bias): the estimate follows the accelerometer
    through the filter, the trim integrates the error past the dead band, firmware and model
    alike; level, nothing moves."""
    doc, tilted = tilt_trim_set(), leaning_forward(LEAN)
    level = run_closed_loop(
        doc, 60, samples=[dataclasses.replace(tilted, accel=(0, 0, 16384))] * 60
    )
    biased = run_closed_loop(doc, 60, samples=[tilted] * 60)
    for run in (level, biased):
        assert_conforms(run)
    assert all(law.tilt_rad[0] == 0.0 for law in level.laws)
    trims = [float(law.tilt_rad[0]) for law in biased.laws]
    assert trims[-1] > 0.02 and trims == sorted(trims)  # growing toward the lean, toes down
    assert trims[-1] == pytest.approx(biased.model_laws[-1].tilt_rad[0], abs=LAW_TOLERANCE)
    # and the pins show it: the ankles' pitch pulses differ from the level run's
    assert np.any(biased.ocr[-1] != level.ocr[-1])


def test_the_roll_share_scales_the_hips_roll_trim_in_the_firmware_as_in_the_model() -> None:
    """A 2° lean to the right: the roll trim the hips get is the law's times `roll_share`,
    firmware and model alike (`robust` sets it to 0: a pitch trim)."""
    leaning = dataclasses.replace(
        leaning_forward(0.0),
        accel=(0, round(math.sin(LEAN) * 16384), round(math.cos(LEAN) * 16384)),
    )
    rolls = {}
    for share in (1.0, 0.5):
        doc = tilt_trim_set()
        doc["gait"]["tilt"]["roll_share"] = share
        run = run_closed_loop(doc, 40, samples=[leaning] * 40)
        assert_conforms(run)
        rolls[share] = float(run.laws[-1].tilt_rad[1])
    assert rolls[1.0] > 0.01
    assert rolls[0.5] == pytest.approx(0.5 * rolls[1.0], abs=LAW_TOLERANCE)


def test_the_timing_law_moves_the_firmwares_clock_as_it_moves_the_models() -> None:
    """A 3° lean to the right against an expected roll swing: the timing law slows the clock
    while the right foot carries (leaning out over it) and speeds it up while the left does,
    firmware and model alike, pin for pin; the steps then fall elsewhere than open loop."""
    leaning = dataclasses.replace(
        leaning_forward(0.0),
        accel=(0, round(math.sin(1.5 * LEAN) * 16384), round(math.cos(1.5 * LEAN) * 16384)),
    )
    doc = closed_loop_set(("timing",))
    doc["gait"]["timing"].update(swing_rad=0.02, swing_phase_rad=0.5, roll_per_a_r=0.3)
    timed = run_closed_loop(doc, 80, samples=[leaning] * 80)
    assert_conforms(timed)
    changes = np.array([law.freq_delta_hz for law in timed.laws])
    assert changes.min() < -0.05 and changes.max() > 0.05
    limit = doc["gait"]["timing"]["clamp_share"] * doc["gait"]["clock"]["freq_hz"]
    assert np.abs(changes).max() <= limit + 1e-6
    doc["gait"]["timing"]["enabled"] = False
    doc["gait"]["tilt"].update(enabled=True, ki_per_s=0.0, kp=0.0)  # a law on, acting on nothing
    steady = run_closed_loop(doc, 80, samples=[leaning] * 80)
    assert_conforms(steady)
    assert np.any(timed.ocr[-1] != steady.ocr[-1])


def test_a_first_reading_in_free_fall_starts_no_attitude_in_the_firmware_nor_the_model() -> None:
    """A robot dropped onto the floor reads ~0 g: neither the firmware nor its model starts
    the attitude from it (it would start at a roll of 180°) nor trims; the readings at 1 g
    after it start both alike."""
    doc, tilted = tilt_trim_set(), leaning_forward(LEAN)
    falling = dataclasses.replace(tilted, accel=(0, 0, 0))
    run = run_closed_loop(doc, 30, samples=[falling] * 3 + [tilted] * 27)
    assert_conforms(run)
    assert all(not law.attitude_rad.any() and not law.tilt_rad.any() for law in run.laws[:3])
    assert run.laws[3].attitude_rad[0] == pytest.approx(LEAN, abs=1e-3)  # started at its tilt
    assert run.laws[-1].tilt_rad[0] > 0.0


def turning(axis: int, rate_rad_s: float, frames: int) -> list[RawSample]:
    """The IMU's counts of a trunk turning about x (0) or y (1) at `rate_rad_s` from level."""
    samples = []
    for k in range(1, frames + 1):
        angle = rate_rad_s * 0.02 * k
        up = round(math.cos(angle) * 16384)
        side = round(math.sin(angle) * 16384)
        accel = (0, side, up) if axis == 0 else (-side, 0, up)
        rate = [0, 0, 0]
        rate[axis] = round(math.degrees(rate_rad_s) * 131)
        gyro = tuple(z + r for z, r in zip(GYRO_ZERO_RATE_COUNTS, rate, strict=True))
        samples.append(RawSample(accel=accel, gyro=gyro, adc=(300,) * 8))
    return samples


@pytest.mark.parametrize("axis", [0, 1], ids=["rolled over", "pitched over"])
def test_a_robot_turned_over_keeps_its_attitude_in_range_in_the_firmware_as_in_the_model(axis):
    """Rolled over, the roll went on past π (5.5 rad seen), which the dashboard's sensor
    stream refused; pitched over, tan(pitch) blew up: both now wrap and hold alike."""
    run = run_closed_loop(tilt_trim_set(), 130, samples=turning(axis, 2.5, 130))
    if axis == 0:
        assert_conforms(run)
    else:  # at the pitch's limit the roll's gyro path takes tan(1.5) = 14 times 2.5 rad/s: the
        # last bits of float32 (avr-libc's tanf against numpy's) grow ~70 % a frame for a while
        assert run.comparison.ok
        want = run.model_laws[1:]
        assert max(np.abs(g.joint_delta_rad - w.joint_delta_rad).max()
                   for g, w in zip(run.laws, want, strict=True)) <= LAW_TOLERANCE  # fmt: skip
        assert max(np.abs(g.attitude_rad - w.attitude_rad).max()
                   for g, w in zip(run.laws, want, strict=True)) <= 2e-4  # fmt: skip
    attitude = np.array([law.attitude_rad for law in run.laws])
    assert np.all(np.abs(attitude[:, 0]) <= 1.5)
    assert np.all((-math.pi < attitude[:, 1]) & (attitude[:, 1] <= math.pi))
    if axis == 0:
        assert attitude[:, 1].min() < -3.0  # went on past π, as -π + ...
    else:
        assert attitude[:, 0].max() == np.float32(1.5)


def test_a_corrupted_imu_read_is_flagged_and_the_last_good_sample_held() -> None:
    """A NACK in frame 20 and a burst cut short by a bus error after 5 bytes in frame 30: both
    detected and counted; the laws of those frames use the frame before's sample, as the model
    fed that sample computes."""
    doc = closed_loop_set(a_p=0.05)
    run = run_closed_loop(doc, 45, variation=SENSOR_ERRORS, faults={20: (1, -1), 30: (0, 5)})
    assert run.imu_stale_frames == [20, 30] and run.imu_failures == 2
    assert_conforms(run)
    # the held sample: frame 20's laws saw frame 19's IMU sample (the same attitude input)
    assert run.twi_transactions[20] == 1 and run.twi_transactions[30] == 1


AFTER_PLANNING_TICK = 30_000  # the sample is read in slot 3 (tick 15 000) and used from 19 900
READ_TICK = 14_900  # the guard of slot 2 starts the read


def next_read_frame(mcu: Mcu) -> int:
    """The frame whose sensor read comes next (a reply takes ~15 ms of UART)."""
    cycles = mcu.cycle - mcu.t0_cycle
    frame, tick = cycles // FRAME_CYCLES, cycles % FRAME_CYCLES // CYCLES_PER_TICK
    return frame if tick < READ_TICK else frame + 1


def clear_of_read(mcu: Mcu) -> None:
    """Past the current frame's read and plan when a reply ended within them: a fault set
    while a burst is on the bus would cut that burst, not the next (how many cycles the main
    loop takes moves the reply's end by hundreds of ticks)."""
    cycles = mcu.cycle - mcu.t0_cycle
    frame, tick = cycles // FRAME_CYCLES, cycles % FRAME_CYCLES // CYCLES_PER_TICK
    if READ_TICK <= tick < AFTER_PLANNING_TICK:
        mcu.run_to_frame(frame, AFTER_PLANNING_TICK)


def test_the_sensors_message_reports_what_the_firmware_read() -> None:
    """SENSORS (PROTOCOL.md): the raw counts read, the calibration, and a failed read's flags."""
    build = build_firmware(closed_loop_set(("tilt",), a_p=0.05))
    raw = RawSample(
        accel=(-300, 120, 16300), gyro=(250, -90, 60), adc=(100, 200, 300, 400, 0, 0, 0, 1023)
    )
    with Mcu(build.elf, sensors=sample_of(at_rest())) as mcu:
        link = EmulatedLink(mcu)
        mcu.set_sensors(sample_of(raw))
        mcu.run_to_frame(3, AFTER_PLANNING_TICK)
        (good,) = link.request(proto.command(proto.Msg.GET_SENSORS))
        clear_of_read(mcu)
        mcu.imu_fault(nack=1)
        mcu.run_to_frame(next_read_frame(mcu), AFTER_PLANNING_TICK)
        (nacked,) = link.request(proto.command(proto.Msg.GET_SENSORS))
        clear_of_read(mcu)
        mcu.imu_fault(short_after=3)
        mcu.run_to_frame(next_read_frame(mcu), AFTER_PLANNING_TICK)
        (short,) = link.request(proto.command(proto.Msg.GET_SENSORS))
    assert isinstance(good, proto.Sensors)
    assert good.status == proto.IMU_PRESENT and good.laws == 1 and good.imu_failures == 0
    assert good.gyro_offset == GYRO_ZERO_RATE_COUNTS
    assert (good.accel_raw, good.gyro_raw, good.adc) == (raw.accel, raw.gyro, raw.adc)
    # pitch from the accelerometer: atan2(-ax, |(ay, az)|), a forward lean of ~1°
    assert good.attitude_rad[0] == pytest.approx(np.arctan2(300, np.hypot(120, 16300)), abs=2e-3)
    assert nacked.status & proto.IMU_STALE and nacked.status & proto.IMU_NACK
    assert short.status & proto.IMU_STALE and short.status & proto.IMU_SHORT
    assert short.imu_failures == 2
    assert short.gyro_raw == raw.gyro  # the last good sample, not the cut-short burst


def test_a_whole_set_sent_mid_walk_keeps_every_plan_in_its_window() -> None:
    """A whole set (the laws' part, then the gait's) sent over the UART while the firmware walks
    closed loop: each part reaches the frame its ACK names, as the model has it, and every
    frame's plan -- also in the frames that receive it -- is ready with a fifth of the planning
    window to spare; no frame overruns (the emulator's cycle count, `Mcu.profile`)."""
    doc = closed_loop_set(a_p=0.05)
    new = closed_loop_set(a_p=0.03, a_y=0.1)
    new["gait"]["tilt"]["ki_per_s"] = 1.0
    new["gait"]["cop"]["kp"] = 1.0
    run = run_closed_loop(doc, 60, variation=SENSOR_ERRORS, changes={20: new}, profile=True)
    assert_conforms(run)
    assert len(run.switch_frames) == 2 and 20 < run.switch_frames[0] <= run.switch_frames[1]
    assert not run.overrun
    ready = np.array(run.plan_ready_ticks[1:])
    spare = (PLAN_LATCH_TICK - ready) / (PLAN_LATCH_TICK - PLAN_REQUEST_TICK)
    assert spare.min() >= 0.2, (spare.min(), int(ready.argmax()) + 1)


def test_a_gyro_at_its_rail_reads_the_way_it_turns() -> None:
    """A fall past 250 °/s pins the gyro's register at its rail; less the boot calibration's
    offset that is past the int16 range, which the firmware once cast back to 16 bits: -32768
    less +197 read as +32571, a roll the other way. Firmware and model read it as it turns."""
    raw = dataclasses.replace(leaning_forward(0.0), gyro=(-32768, 32767, 0))
    doc = closed_loop_set(("damping",))
    run = run_closed_loop(doc, 12, samples=[at_rest()] * 2 + [raw] * 10)
    assert_conforms(run)
    assert GYRO_ZERO_RATE_COUNTS[0] > 0 > GYRO_ZERO_RATE_COUNTS[1]  # both rails past int16
    pitch, roll = run.laws[-1].attitude_rad  # x at -32768 rolls left, y at +32767 pitches down
    assert roll < -0.3 and pitch > 0.3, (pitch, roll)


def law_integral(mcu: Mcu) -> np.ndarray:
    """The tilt trim's integral in the firmware's `g_law_state` (laws.h: two uint8 first)."""
    return np.frombuffer(mcu.read_symbol("g_law_state", 2 + 4 * 4, 8), dtype="<f4")


def test_the_laws_rest_while_the_robot_stands_and_start_anew_when_it_walks() -> None:
    """Held after STOP (or carried, or limp) a leaning robot's tilt integral wound up to its
    clamp for the next START. The laws now step only while the robot walks, and start anew
    with it (gait/feedback.py `restarted`); the attitude estimate runs on throughout."""
    doc = tilt_trim_set()
    with Mcu(build_firmware(doc).elf, sensors=sample_of(at_rest())) as mcu:
        link = EmulatedLink(mcu)
        mcu.set_sensors(sample_of(leaning_forward(LEAN)))
        mcu.run_to_frame(40, AFTER_PLANNING_TICK)
        (walking,) = link.request(proto.command(proto.Msg.GET_SENSORS))
        wound = law_integral(mcu)
        link.request(proto.command(proto.Msg.STOP))
        mcu.run_to_frame(next_read_frame(mcu) + 40, AFTER_PLANNING_TICK)
        (stopped,) = link.request(proto.command(proto.Msg.GET_SENSORS))
        held = law_integral(mcu)
        link.request(proto.command(proto.Msg.START))
        mcu.run_to_frame(next_read_frame(mcu) + 3, AFTER_PLANNING_TICK)
        (started,) = link.request(proto.command(proto.Msg.GET_SENSORS))
        restarted = law_integral(mcu)
    assert walking.tilt_rad[0] > 0.01 and wound[0] > 0.0
    assert stopped.tilt_rad == (0.0, 0.0) and not held.any()
    assert stopped.attitude_rad[0] == pytest.approx(LEAN, abs=1e-3)  # estimated all along
    assert 0.0 < restarted[0] < wound[0] / 10  # a frame or two's worth
    assert 0.0 < started.tilt_rad[0] < walking.tilt_rad[0] / 5


def test_the_law_outputs_read_off_the_firmware_are_laws_h_members_in_its_order() -> None:
    """`LAW_OUTPUT_MEMBERS` mirrors laws.h `law_output_t` member by member (type and count), and
    each names a field of `LawFrame` and of `feedback.Output`, which the model is judged on."""
    laws_h = (Path(__file__).parents[2] / "hardware/firmware/src/laws.h").read_text()
    body = laws_h.split("typedef struct {")[2].split("} law_output_t;")[0]
    members = re.findall(r"^\s*(float|int8_t) \w+(?:\[(\w+)\])?;", body, re.M)
    counts = {"": 1, "GAIT_NUM_JOINTS": 12}
    declared = [
        ({"float": "f", "int8_t": "b"}[c_type], counts.get(size) or int(size))
        for c_type, size in members
    ]
    assert [(code, n) for _, code, n in LAW_OUTPUT_MEMBERS] == declared
    names = {name for name, _, _ in LAW_OUTPUT_MEMBERS}
    assert names == {f.name for f in dataclasses.fields(LawFrame)}
    assert names <= {f.name for f in dataclasses.fields(feedback.Output)}
