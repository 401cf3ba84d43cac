"""A fitted robot (docs/FIT.md): its description with `fitted:` loads as the same robot, walks
its fit by default, and robust ranges are centred on the fit and narrowed to its uncertainty
only for what the recording told."""

from __future__ import annotations

import pytest
import yaml

from app.robots import RobotError, load_description
from app.robots.fitted import Fitted, write_fitted
from app.robots.model import RobotModel
from app.worlds.fitted import fitted_ranges, fitted_variation
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import NOMINAL

FIT = Fitted(
    variation="trunk_mass_scale=1.06,kp_scale=0.9,latency_ms=22,tilt_deg=1.2,"
    "tilt_direction_deg=100,gyro_bias_deg_s=0.25",
    sigma={"trunk_mass_scale": 0.004, "kp_scale": 0.08, "latency_ms": 1.0, "tilt_x_deg": 0.1,
           "tilt_y_deg": 0.1, "gyro_bias_deg_s": 0.01},
    identified=("trunk_mass_scale", "kp_scale", "latency_ms", "tilt_x_deg", "tilt_y_deg"),
    recording="rec.json",
)  # fmt: skip


@pytest.fixture(scope="module")
def fitted_robot(tmp_path_factory):
    path = tmp_path_factory.mktemp("fit") / "artro-fitted.yaml"
    write_fitted(load_description("artro"), FIT, path)
    return path, RobotModel.load(path)


def test_the_fitted_robot_is_the_robot_with_its_fit(fitted_robot):
    path, robot = fitted_robot
    plain = RobotModel.load()
    assert robot.name == plain.name and robot.total_mass_kg() == plain.total_mass_kg()
    assert robot.description.model_copy(update={"fitted": None}) == plain.description
    assert fitted_variation(robot).trunk_mass_scale == 1.06
    assert fitted_variation(plain) is NOMINAL
    assert yaml.safe_load(path.read_text())["fitted"]["recording"] == "rec.json"


def test_ranges_are_centred_on_what_was_told(fitted_robot):
    _, robot = fitted_robot
    default = VariationRanges()
    ranges = fitted_ranges(robot, default)
    assert ranges.trunk_mass_scale == pytest.approx((1.01, 1.11))  # ± the 0.05 floor
    assert ranges.kp_scale == pytest.approx((0.8, 1.06))  # ± 2σ, inside the default 0.8-1.2
    assert ranges.latency_ms == pytest.approx((17, 27))
    assert ranges.tilt_deg == pytest.approx((0.7, 1.7))
    assert ranges.tilt_direction_deg == pytest.approx((70, 130))
    assert ranges.gyro_bias_deg_s == default.gyro_bias_deg_s  # not told: as it was
    assert ranges.friction == default.friction
    assert fitted_ranges(RobotModel.load(), default) is default
    for v in sample(ranges, 20, seed=2):
        assert 1.01 <= v.trunk_mass_scale <= 1.11


def test_a_broken_fit_is_named(tmp_path):
    path = tmp_path / "bad.yaml"
    write_fitted(load_description("artro"), FIT.model_copy(update={"variation": "kp=2"}), path)
    with pytest.raises(ValueError, match=r"fitted\.variation: unknown variation field 'kp'"):
        fitted_variation(RobotModel.load(path))


def test_a_fit_does_not_make_another_robot_a_builtin(tmp_path):
    description = load_description("artro")
    other = description.model_copy(update={"title": "not ArtRo"})
    path = tmp_path / "impostor.yaml"
    write_fitted(other, FIT, path)
    with pytest.raises(RobotError, match="like a built-in robot it is not"):
        load_description(path)
