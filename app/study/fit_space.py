"""What a fit searches (docs/FIT.md): the variation fields a recording can tell, each with its
search bounds, finite-difference step and the precision it must reach to count as identified;
a point of the search as a `Variation`."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from app.analysis.fit_sensors import ImuErrors
from app.worlds.variations import NOMINAL, Variation, parse_variation


@dataclass(frozen=True)
class Dim:
    """One searched coordinate: bounds, nominal, the finite-difference step of the uncertainty
    and the tolerance (2σ within it: identified; the issue's goals where it has one)."""

    name: str
    low: float
    high: float
    nominal: float
    step: float
    tolerance: float

    def to_unit(self, value: float) -> float:
        return (value - self.low) / (self.high - self.low)

    def from_unit(self, u: float) -> float:
        return self.low + min(1.0, max(0.0, float(u))) * (self.high - self.low)


#: physics coordinates, searched by CMA-ES; the floor's tilt as its two components (downhill
#: toward x, toward y), so that no tilt has no direction to search
PHYSICS = {
    d.name: d
    for d in (
        Dim("latency_ms", 0.0, 80.0, 0.0, 3.0, 5.0),
        Dim("kp_scale", 0.6, 1.4, 1.0, 0.04, 0.1),
        Dim("torque_scale", 0.6, 1.2, 1.0, 0.04, 0.1),
        Dim("trunk_mass_scale", 0.75, 1.25, 1.0, 0.03, 0.05),
        Dim("link_mass_scale", 0.8, 1.2, 1.0, 0.03, 0.05),
        Dim("damping_scale", 0.5, 1.5, 1.0, 0.08, 0.15),
        Dim("frictionloss_scale", 0.3, 2.0, 1.0, 0.15, 0.3),
        Dim("tilt_x_deg", -4.0, 4.0, 0.0, 0.4, 0.5),
        Dim("tilt_y_deg", -4.0, 4.0, 0.0, 0.4, 0.5),
    )
}
#: the IMU's errors, fitted in closed form at each point (`fit_sensors.fit_imu`): the mount's
#: tilt as two components, the gyro's bias
IMU = {
    d.name: d
    for d in (
        Dim("imu_tilt_x_deg", -5.0, 5.0, 0.0, 0.1, 0.3),
        Dim("imu_tilt_y_deg", -5.0, 5.0, 0.0, 0.1, 0.3),
        Dim("gyro_bias_deg_s", -2.0, 2.0, 0.0, 0.02, 0.1),
    )
}
#: what `--fields` names: a field, or the floor's and the mount's tilt as one each
FIELDS = {
    "latency_ms": ("latency_ms",),
    "kp_scale": ("kp_scale",),
    "torque_scale": ("torque_scale",),
    "trunk_mass_scale": ("trunk_mass_scale",),
    "link_mass_scale": ("link_mass_scale",),
    "damping_scale": ("damping_scale",),
    "frictionloss_scale": ("frictionloss_scale",),
    "tilt": ("tilt_x_deg", "tilt_y_deg"),
    "imu_tilt_bias": ("imu_tilt_x_deg", "imu_tilt_y_deg"),
    "gyro_bias_deg_s": ("gyro_bias_deg_s",),
}
DEFAULT_FIELDS = (
    "latency_ms",
    "kp_scale",
    "torque_scale",
    "trunk_mass_scale",
    "tilt",
    "imu_tilt_bias",
    "gyro_bias_deg_s",
)


def parse_fields(text: str) -> tuple[str, ...]:
    """`--fields a,b,...`: ValueError naming the unknown one and what is allowed."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in FIELDS]
    if unknown or not names:
        raise ValueError(
            f"unknown field {unknown[0] if unknown else '(none)'!r}: choose from "
            f"{', '.join(FIELDS)}"
        )
    return names


def coordinates(fields: tuple[str, ...]) -> tuple[list[Dim], list[Dim]]:
    """The physics and IMU coordinates of `fields`, in table order."""
    wanted = {c for f in fields for c in FIELDS[f]}
    return (
        [d for n, d in PHYSICS.items() if n in wanted],
        [d for n, d in IMU.items() if n in wanted],
    )


def parse_fixed(texts: list[str]) -> Variation:
    """`--fix key=value` (any number): a variation whose fields the fit holds."""
    return parse_variation(",".join(texts)) if texts else NOMINAL


def polar(x: float, y: float) -> tuple[float, float]:
    """A tilt's two components as (angle, direction in [0, 360))."""
    angle = math.hypot(x, y)
    return angle, (math.degrees(math.atan2(y, x)) % 360.0 if angle else 0.0)


def components(angle: float, direction_deg: float) -> tuple[float, float]:
    d = math.radians(direction_deg)
    return angle * math.cos(d), angle * math.sin(d)


def physics_variation(values: dict[str, float], fixed: Variation) -> Variation:
    """The physics point `values` (coordinate -> value) on top of the held fields."""
    scalars = {k: v for k, v in values.items() if not k.startswith("tilt_")}
    if "tilt_x_deg" in values:
        tilt, direction = polar(values["tilt_x_deg"], values["tilt_y_deg"])
        scalars |= {"tilt_deg": tilt, "tilt_direction_deg": direction}
    merged = fixed.departures() | {k: round(float(v), 6) for k, v in scalars.items()}
    if "tilt_direction_deg" in merged:
        merged["tilt_direction_deg"] %= 360.0
    return parse_variation(",".join(f"{k}={v!r}" for k, v in merged.items()))


def imu_errors(values: dict[str, float], fixed: Variation) -> ImuErrors:
    """The IMU coordinates as the variation's fields (held ones where not searched)."""
    if "imu_tilt_x_deg" in values:
        tilt, direction = polar(values["imu_tilt_x_deg"], values["imu_tilt_y_deg"])
    else:
        tilt, direction = fixed.imu_tilt_bias_deg, fixed.imu_tilt_direction_deg
    bias = values.get("gyro_bias_deg_s", fixed.gyro_bias_deg_s)
    return ImuErrors(tilt, direction, bias)


def imu_values(errors: ImuErrors) -> dict[str, float]:
    x, y = components(errors.imu_tilt_bias_deg, errors.imu_tilt_direction_deg)
    return {"imu_tilt_x_deg": x, "imu_tilt_y_deg": y, "gyro_bias_deg_s": errors.gyro_bias_deg_s}


def truth_values(variation: Variation) -> dict[str, float]:
    """A variation as every coordinate of the table (what a test compares a fit with)."""
    x, y = components(variation.tilt_deg, variation.tilt_direction_deg)
    imu = imu_values(
        ImuErrors(
            variation.imu_tilt_bias_deg, variation.imu_tilt_direction_deg, variation.gyro_bias_deg_s
        )
    )
    scalars = {n: float(getattr(variation, n)) for n in PHYSICS if not n.startswith("tilt_")}
    return scalars | {"tilt_x_deg": x, "tilt_y_deg": y} | imu


def with_imu(variation: Variation, errors: ImuErrors) -> Variation:
    """`variation` with the IMU's errors `errors` (directions kept in [0, 360))."""
    return dataclasses.replace(
        variation,
        imu_tilt_bias_deg=round(errors.imu_tilt_bias_deg, 6),
        imu_tilt_direction_deg=round(errors.imu_tilt_direction_deg, 6) % 360.0,
        gyro_bias_deg_s=round(errors.gyro_bias_deg_s, 6),
    )
