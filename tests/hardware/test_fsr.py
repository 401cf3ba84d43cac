"""The force sensors as the MCU reads them (`hardware.fsr`, docs/DESIGN.md §15): the divider's
counts, the forces decoded from them, and the simulation's laws reading the same steps."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from app.firmware.sensor_feed import GYRO_ZERO_RATE_COUNTS, decoded, raw_of
from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.sim.sensors import Sensors
from hardware.fsr import ADC_FULL, adc_counts, as_read, decoded_forces

forces = st.floats(min_value=-5.0, max_value=1e4, allow_nan=False)


@given(st.lists(forces, min_size=1, max_size=16))
def test_a_decoded_force_reads_its_count_again(values):
    counts = adc_counts(values)
    assert np.all((counts >= 0) & (counts <= ADC_FULL - 1))
    np.testing.assert_array_equal(adc_counts(decoded_forces(counts)), counts)
    np.testing.assert_array_equal(as_read(as_read(values)), as_read(values))


def test_the_steps_are_the_dividers():
    """At 5 N the divider is at half the supply: count 512; a step there is ~0.02 N, at 20 N
    ~0.12 N; no force reads below 0, and past ~5 kN the count stays at 1023."""
    assert adc_counts([0.0, -1.0, 5.0, 1e6]).tolist() == [0, 0, 512, 1023]
    assert 0.015 < decoded_forces(513) - decoded_forces(512) < 0.025
    at_20 = adc_counts(20.0)
    assert 0.1 < decoded_forces(at_20 + 1) - decoded_forces(at_20) < 0.14


def test_the_simulations_laws_read_the_forces_the_firmware_decodes():
    """The simulation's reading is in the ADC's steps, so the CoP law is tuned on what it runs
    on: the firmware's decoding of the counts the reading gives is the reading (to float32)."""
    robot = RobotModel.load()
    loop = FrameLoop(robot)
    for _ in range(30):
        loop.step_frame()
    reading = Sensors(robot).read(np.array([loop.data.sensordata]), loop.data)
    assert reading.fsr_n.sum() > 5.0  # standing on its soles
    counts = adc_counts(reading.fsr_n)
    np.testing.assert_array_equal(decoded_forces(counts), reading.fsr_n)
    firmware = decoded(raw_of(reading), GYRO_ZERO_RATE_COUNTS)
    np.testing.assert_allclose(firmware.fsr_n, reading.fsr_n, rtol=1e-6)
