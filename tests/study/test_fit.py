"""`app.study.fit` on a simulated recording whose variation it is not told (docs/FIT.md): the
standing stage gives back the floor's tilt and the IMU's errors within the goals' tolerances,
says them identified, and gives the same values for the same seed, on processes or a cluster."""

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
from tests.testing.cluster_support import LoopbackCluster

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


@pytest.fixture(scope="module")
def small(recording):
    """A fit of a small budget (two dozen standing replays) in this process."""
    return fit(recording, "artro", fields=("tilt",), budget=2, workers=1, seed=5)


def test_one_seed_one_fit(recording, small):
    again = fit(recording, "artro", fields=("tilt",), budget=2, workers=2, seed=5)
    assert small.values == again.values and small.variation == again.variation


def test_a_dask_cluster_replays_the_same_fit(recording, small):
    """Real `dask scheduler` and `dask worker` processes: the robot sent as its description,
    the replays on the workers, the same fit to the bit."""
    with LoopbackCluster(workers=2) as cluster:
        remote = fit(recording, "artro", fields=("tilt",), budget=2, seed=5,
                     cluster=cluster.address, wait_workers_s=60)  # fmt: skip
    assert remote.values == small.values and remote.sigma == small.sigma
    assert remote.variation == small.variation and remote.evaluations == small.evaluations


def test_a_held_field_is_held(recording):
    held = fit_space.parse_fixed(["trunk_mass_scale=1.05"])
    result = fit(recording, "artro", fields=("gyro_bias_deg_s",), fixed=held, budget=10, workers=1)
    assert result.variation.trunk_mass_scale == 1.05
    assert set(result.values) == {"gyro_bias_deg_s"}
