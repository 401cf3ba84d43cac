"""A fitted robot's variation (docs/FIT.md): what every run on it departs by when no other
variation is given, and the ranges a robust study draws from, centred on the fit and narrowed
to its uncertainty (never below the precision a fit can reach, never wider than the default)."""

from __future__ import annotations

import dataclasses

from app.robots.model import RobotModel
from app.worlds.sampling import VariationRanges
from app.worlds.variations import NOMINAL, Variation, parse_variation

#: the half-width a fitted field's range keeps at least: the precision a fit of one recording
#: is held to (docs/FIT.md's goals); a field the recording did not tell keeps its default range
FLOOR = {
    "latency_ms": 5.0,
    "kp_scale": 0.1,
    "torque_scale": 0.1,
    "trunk_mass_scale": 0.05,
    "link_mass_scale": 0.05,
    "damping_scale": 0.15,
    "frictionloss_scale": 0.3,
    "tilt_deg": 0.5,
    "imu_tilt_bias_deg": 0.3,
    "gyro_bias_deg_s": 0.1,
}
#: the coordinates of `artro fit` that make each field's σ (a tilt's is its components' larger)
COORDINATES = {
    "tilt_deg": ("tilt_x_deg", "tilt_y_deg"),
    "imu_tilt_bias_deg": ("imu_tilt_x_deg", "imu_tilt_y_deg"),
}
DIRECTION_OF = {"tilt_deg": "tilt_direction_deg", "imu_tilt_bias_deg": "imu_tilt_direction_deg"}


def fitted_variation(robot: RobotModel) -> Variation:
    """The variation the robot's description was fitted to (nominal when it was not);
    ValueError naming the description's field when its text is no variation."""
    fitted = robot.description.fitted
    if fitted is None:
        return NOMINAL
    try:
        return parse_variation(fitted.variation)
    except ValueError as exc:
        raise ValueError(f"robot {robot.name!r}: fitted.variation: {exc}") from None


def fitted_ranges(robot: RobotModel, ranges: VariationRanges) -> VariationRanges:
    """`ranges` for a fitted robot: each identified field's range centred on its fitted value,
    half as wide as 2σ or FLOOR, whichever is larger, inside its default range; an identified
    tilt's direction within ±30° of the fitted one (where that stays inside 0-360°); `ranges`
    as they are for a robot not fitted."""
    fitted = robot.description.fitted
    if fitted is None:
        return ranges
    variation = fitted_variation(robot)
    changes: dict[str, tuple[float, float]] = {}
    for name, floor in FLOOR.items():
        coords = COORDINATES.get(name, (name,))
        if not all(c in fitted.identified for c in coords):
            continue
        sigma = max(fitted.sigma.get(c, 0.0) for c in coords)
        low, high = getattr(ranges, name)
        value = float(getattr(variation, name))
        half = min(max(2 * sigma, floor), (high - low) / 2 or floor)
        lo, hi = max(low, value - half), min(high, value + half)
        if name in ("tilt_deg", "imu_tilt_bias_deg"):
            lo, hi = max(0.0, value - half), value + half
        if lo > hi:  # the fit lies outside the default range: its own neighbourhood
            lo, hi = value - half, value + half
        changes[name] = (lo, hi)
        direction = float(getattr(variation, DIRECTION_OF.get(name, "tilt_direction_deg")))
        if name in DIRECTION_OF and value > half and 30.0 <= direction <= 330.0:
            changes[DIRECTION_OF[name]] = (direction - 30.0, direction + 30.0)
    return dataclasses.replace(ranges, **changes)
