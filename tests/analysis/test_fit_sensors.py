"""The IMU's errors fitted in closed form (docs/FIT.md): a replay read without errors and the
same replay read by an IMU tilted on its mount with a gyro bias give back that tilt and bias; a
trace folded on the gait's cycle keeps each bin's mean."""

from __future__ import annotations

import numpy as np
import pytest

from app.analysis.fit_sensors import Cycles, fit_imu, residuals, soft_l1
from app.analysis.identify_replay import play
from app.analysis.identify_routine import IDENTIFY, open_loop
from app.robots.gait_reach import preset_gait
from app.robots.model import RobotModel
from app.worlds.variations import NOMINAL, parse_variation

ERRORS = "imu_tilt_bias_deg=0.6,imu_tilt_direction_deg=200,gyro_bias_deg_s=0.3"


@pytest.fixture(scope="module")
def replays():
    robot = RobotModel.load()
    gait = open_loop(preset_gait(robot.description.default_preset))
    clean = play(robot, gait, IDENTIFY[:3], NOMINAL)
    erred = play(robot, gait, IDENTIFY[:3], parse_variation(ERRORS))
    return clean, erred


def test_the_imu_errors_come_back(replays):
    clean, erred = replays
    errors = fit_imu(clean, erred)
    assert errors.imu_tilt_bias_deg == pytest.approx(0.6, abs=0.02)
    assert errors.imu_tilt_direction_deg == pytest.approx(200, abs=2)
    assert errors.gyro_bias_deg_s == pytest.approx(0.3, abs=0.01)
    assert (
        soft_l1(residuals(clean, errors, erred))
        < 1e-3
        < soft_l1(residuals(clean, fit_imu(clean, clean), erred))
    )


def test_a_fold_keeps_each_bins_mean():
    lengths = (100, 80)
    x = np.arange(180, dtype=float)[:, None] * np.array([[1.0, -1.0]])
    cycles = Cycles(lengths, freq_hz=1.0, bins=4, skip_frames=10)
    folded = cycles.fold(x)
    assert folded.shape == (8, 2)
    which = (np.mod((np.arange(180) + 1) * 0.02, 1.0) * 4).astype(int)
    first = [x[10:100][which[10:100] == b, 0].mean() for b in range(4)]
    np.testing.assert_allclose(folded[:4, 0], first)
    np.testing.assert_allclose(folded[:, 1], -folded[:, 0])
