"""`app.study.fit` on a simulated recording whose variation it is not told (docs/FIT.md): the
standing stage gives back the floor's tilt and the IMU's errors within the goals' tolerances,
says them identified, and gives the same values for the same seed."""

from __future__ import annotations

import pytest

from app.analysis import identify_record as rec
from app.analysis.identify_replay import play
from app.analysis.identify_routine import IDENTIFY, open_loop
from app.robots.gait_reach import preset_gait
from app.robots.model import RobotModel
from app.study import fit_space
from app.study.fit import fit
from app.worlds.variations import parse_variation

TRUTH = (
    "tilt_deg=1.5,tilt_direction_deg=60,imu_tilt_bias_deg=0.5,imu_tilt_direction_deg=120,"
    "gyro_bias_deg_s=0.3,gyro_noise_deg_s=0.1"
)
FIELDS = ("tilt", "imu_tilt_bias", "gyro_bias_deg_s")

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def recording():
    robot = RobotModel.load()
    gait = open_loop(preset_gait(robot.description.default_preset))
    traces = play(robot, gait, IDENTIFY, parse_variation(TRUTH))
    return rec.to_recording(
        traces, routine="identify", source="simulation", robot=robot.name,
        robot_mass_kg=robot.total_mass_kg(), params=gait.to_dict(), truth=TRUTH,
    )  # fmt: skip


@pytest.fixture(scope="module")
def fitted(recording):
    return fit(recording, "artro", fields=FIELDS, budget=60, workers=1, seed=3)


def test_the_floor_and_the_imu_come_back(fitted):
    truth = fit_space.truth_values(parse_variation(TRUTH))
    dims = {**fit_space.PHYSICS, **fit_space.IMU}
    for name, value in fitted.values.items():
        assert value == pytest.approx(truth[name], abs=dims[name].tolerance), name
        assert fitted.identified[name], name
    assert fitted.converged, fitted.why_not
    assert fitted.loss_fit < fitted.loss_nominal / 3
    assert fitted.variation.tilt_deg == pytest.approx(1.5, abs=0.5)


def test_the_residual_is_said_against_the_noise(fitted):
    ratio = fitted.noise_ratio()
    assert set(ratio) == {"gyro", "accel", "fsr"}
    assert all(fitted.rms_fit[c] < fitted.rms_nominal[c] for c in ratio)


def test_one_seed_one_fit(recording):
    """Two fits of a small budget (two dozen standing replays) with one seed: the same fit."""
    first, again = (fit(recording, "artro", fields=("tilt",), budget=2, workers=1, seed=5)
                    for _ in range(2))  # fmt: skip
    assert first.values == again.values and first.variation == again.variation


def test_a_held_field_is_held(recording):
    held = fit_space.parse_fixed(["trunk_mass_scale=1.05"])
    result = fit(recording, "artro", fields=("gyro_bias_deg_s",), fixed=held, budget=10, workers=1)
    assert result.variation.trunk_mass_scale == 1.05
    assert set(result.values) == {"gyro_bias_deg_s"}
