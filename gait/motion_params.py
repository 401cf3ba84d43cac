"""Parameters of how CA and the motion vector reach the gait (docs/DESIGN.md §4): the steering term
K of eq (29) (`steer`) and the motion ramp of seed 004's start-up phase (`ramp`, `gait.ramp`). Part
of the one schema (`gait.params.GaitParams`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gait.schema_fields import check_ranges as _check_ranges
from gait.schema_fields import switch as _switch
from gait.schema_fields import tunable as _param


@dataclass(frozen=True)
class SteerParams:
    """The steering term (docs/DESIGN.md §4): CA also feeds the leg-yaw swing of eq (29).

    a_y,eff = a_y + K*CA*s(a_p), K = `yaw_per_ca` walking forward, `yaw_per_ca_backward` backward;
    s = clip(a_p / `full_at_a_p`, -1, 1) turns it as eq (13) does (V < 0: the other way; V = 0:
    none). K = 0 both ways is the literal paper gait."""

    yaw_per_ca: float = _param(
        0.0, -1.0, 1.0, step=0.005, unit="rad", eq="(29), seed 004 (13)",
        doc="K walking forward: leg-yaw swing amplitude per unit CA (a_y,eff = a_y + K*CA); "
        "0 = the paper; > 0 turns the same way as CA (clockwise for CA > 0)",
    )  # fmt: skip
    yaw_per_ca_backward: float = _param(
        0.0, -1.0, 1.0, step=0.005, unit="rad", eq="(29), seed 004 (13)",
        doc="K walking backward (a_p < 0): > 0 turns as eq (13) says there, counter-clockwise "
        "for CA > 0 (a_y,eff = a_y - K*CA)",
    )  # fmt: skip
    full_at_a_p: float = _param(
        0.02, 0.005, 0.1, step=0.005, unit="rad", eq="seed 004 (13)",
        doc="|a_p| from which the steering term is whole; below it fades to none on the spot, "
        "where eq (13) has V = 0",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)

    def yaw_amplitude(self, a_p: float, ca: float) -> float:
        """K*CA*s(a_p): what the term adds to a_y in eq (29), rad (elementwise for arrays)."""
        k = np.where(np.asarray(a_p) >= 0, self.yaw_per_ca, self.yaw_per_ca_backward)
        return k * ca * np.minimum(np.maximum(a_p / self.full_at_a_p, -1.0), 1.0)


@dataclass(frozen=True)
class RampParams:
    """Motion changes are ramped (seed 004's start-up phase, its Fig. 3; docs/DESIGN.md §4).

    The motion vector and CA reach the gait through a rate limit, so that a sudden slider move
    does not throw the robot: each component moves toward its target by at most rate * dt.
    """

    enabled: bool = _switch("rate-limit the motion vector and CA on their way to the gait")
    amp_rad_s: float = _param(
        0.05, 0.005, 1.0, step=0.005, unit="rad/s", eq="seed 004 Fig. 3",
        doc="largest change of a_r and a_p per second (0 to 0.07 in 1.4 s)",
    )  # fmt: skip
    yaw_rad_s: float = _param(
        0.1, 0.005, 2.0, step=0.005, unit="rad/s", eq="seed 004 Fig. 3",
        doc="largest change of a_y per second (0 to 0.2 in 2 s)",
    )  # fmt: skip
    ca_per_s: float = _param(
        0.1, 0.005, 2.0, step=0.005, unit="1/s", eq="seed 004 Fig. 3",
        doc="largest change of CA per second (0 to 0.1 in 1 s)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class LateralParams:
    """Lateral support on the support leg (docs/SENSORS.md, decision 0061): a PWM hobby servo has
    one stiffness (its proportional band is fixed in the servo), so where OP3 stiffens the
    support hip roll this leans it instead -- the support leg's roll (the foot kept level, as
    eq (39)) by `support_roll_rad` plus `sway_per_a_r` |a_r|, weighted by how much that leg
    carries (sin phi_Leg, > 0 while it supports). 0 and 0: the gait as before, to the bit."""

    support_roll_rad: float = _param(
        0.0, -0.1, 0.1, step=0.002, unit="rad", eq="",
        doc="support leg's roll lean (outward > 0): pre-loads the hip roll against its sag",
    )  # fmt: skip
    sway_per_a_r: float = _param(
        0.0, -1.0, 1.0, step=0.01, unit="1", eq="",
        doc="more support lean per unit |a_r|: side steps load the hip roll most",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)
