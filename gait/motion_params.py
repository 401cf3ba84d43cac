"""Parameters of how CA and the motion vector reach the gait (docs/DESIGN.md §4): the steering term
K of eq (29) (`steer`) and the motion ramp of seed 004's start-up phase (`ramp`, `gait.ramp`). Part
of the one schema (`gait.params.GaitParams`)."""

from __future__ import annotations

from dataclasses import dataclass

from gait.schema_fields import check_ranges as _check_ranges
from gait.schema_fields import switch as _switch
from gait.schema_fields import tunable as _param


@dataclass(frozen=True)
class SteerParams:
    """The steering term (docs/DESIGN.md §4, §10): CA also feeds the leg-yaw swing of eq (29).

    (1 +- CA) on the sagittal swing turns a biped whose hips do not yaw only as far as its feet
    twist on the floor; a_y,eff = a_y + K*CA adds the yaw that eq (13) assumes. K = 0 is the
    literal paper gait.
    """

    yaw_per_ca: float = _param(
        0.0, -1.0, 1.0, step=0.005, unit="rad", eq="(29), seed 004 (13)",
        doc="K: leg-yaw swing amplitude per unit CA (a_y,eff = a_y + K*CA); 0 = the paper; "
        "> 0 turns the same way as CA (clockwise for CA > 0)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


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
