"""The walking phases' parameters of Behnke's gait (seed 000 eqs (2)–(39)): shifting,
shortening, swinging, loading, balancing and the leg interface, paper defaults. Part of the one
schema (docs/DESIGN.md §4), gathered in `gait.params.GaitParams`."""

from __future__ import annotations

from dataclasses import dataclass

from gait.schema_fields import check_ranges as _check_ranges
from gait.schema_fields import switch as _switch
from gait.schema_fields import tunable as _param


@dataclass(frozen=True)
class ShiftParams:
    """Lateral shifting of the centre of mass, eqs (12)–(15)."""

    enabled: bool = _switch("lateral shifting phase on")
    amp_base: float = _param(
        0.12, 0.0, 0.4, step=0.005, unit="rad", eq="(13)", doc="shift amplitude at rest"
    )
    amp_speed: float = _param(
        0.08, 0.0, 1.0, step=0.01, unit="1", eq="(13)", doc="shift gain on |(a_r, a_p)|"
    )
    amp_lateral: float = _param(
        0.7, 0.0, 2.0, step=0.01, unit="1", eq="(13)", doc="shift gain on |a_r|"
    )
    foot_ratio: float = _param(
        0.5, 0.0, 1.5, step=0.01, unit="1", eq="(15)",
        doc="foot roll counter-shift, as a fraction of the leg shift",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class ShortParams:
    """Shortening of the swing leg and lifting of the leading foot edge, eqs (16)–(21)."""

    enabled: bool = _switch("shortening phase on")
    v: float = _param(
        3.0, 2.5, 6.0, step=0.05, unit="1", eq="(17)", doc="phase speed: 1/duration of shortening"
    )
    o: float = _param(
        -0.05, -0.5, 0.3, step=0.01, unit="rad", eq="(18)", doc="phase shift vs lateral shifting"
    )
    amp_base: float = _param(
        0.2, 0.0, 1.0, step=0.01, unit="1", eq="(20)", doc="shortening amplitude at rest"
    )
    amp_speed: float = _param(
        2.0, 0.0, 6.0, step=0.05, unit="1/rad", eq="(20)", doc="shortening gain on |(a_r, a_p)|"
    )
    foot_lift: float = _param(
        0.125, 0.0, 1.0, step=0.005, unit="1", eq="(21)", doc="toe lift gain on a_p"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class SwingParams:
    """The fast swing and slow linear reverse motion, eqs (22)–(32)."""

    enabled: bool = _switch("swinging phase on")
    v: float = _param(
        2.0, 1.5, 6.0, step=0.05, unit="1", eq="(23)", doc="phase speed: 1/duration of the swing"
    )
    o: float = _param(
        -0.15, -0.5, 0.4, step=0.01, unit="rad", eq="(24)", doc="phase shift vs lateral shifting"
    )
    foot_roll: float = _param(
        0.25, 0.0, 1.0, step=0.01, unit="1", eq="(30)", doc="foot roll swing, fraction of a_r"
    )
    foot_pitch: float = _param(
        0.25, 0.0, 1.0, step=0.01, unit="1", eq="(31)", doc="foot pitch swing, fraction of a_p"
    )
    #: eq (28)'s coefficient, 1 in the paper: the stride per unit a_p, for a robot whose legs
    #: walk shorter than the paper's at its a_p (decision 0071)
    pitch_gain: float = _param(
        1.0, 0.5, 2.0, step=0.01, unit="1", eq="(28)", doc="leg pitch swing per a_p (paper: 1)"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class LoadParams:
    """The second shortening that eases loading of the landing leg, eqs (33)–(36)."""

    enabled: bool = _switch("loading phase on")
    v: float = _param(
        3.0, 2.0, 6.0, step=0.05, unit="1", eq="(34)", doc="phase speed: 1/duration of loading"
    )
    amp_base: float = _param(
        0.025, 0.0, 0.5, step=0.005, unit="1", eq="(36)", doc="loading amplitude at rest"
    )
    amp_pitch: float = _param(
        0.5, 0.0, 2.0, step=0.01, unit="1", eq="(36)", doc="loading gain on 1 - cos|a_p|"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class BalanceParams:
    """Per-step tilting and constant offsets of leg and foot angles, eqs (37)–(39)."""

    enabled: bool = _switch("balancing phase on")
    foot_roll_amp: float = _param(
        0.5, 0.0, 2.0, step=0.01, unit="1", eq="(37)", doc="foot roll balance gain on a_r"
    )
    foot_roll_phase: float = _param(
        0.35, -3.14, 3.14, step=0.01, unit="rad", eq="(37)", doc="foot roll balance phase"
    )
    foot_pitch_offset: float = _param(
        0.02, -0.3, 0.3, step=0.005, unit="rad", eq="(38)", doc="constant foot pitch (toe up > 0)"
    )
    foot_pitch_speed: float = _param(
        0.12, -1.0, 1.0, step=0.01, unit="1", eq="(38)", doc="foot pitch gain on a_p"
    )
    foot_pitch_amp: float = _param(
        0.04, -1.0, 1.0, step=0.01, unit="1", eq="(38)", doc="foot pitch oscillation gain on a_p"
    )
    foot_pitch_phase: float = _param(
        0.7, -3.14, 3.14, step=0.01, unit="rad", eq="(38)", doc="foot pitch oscillation phase"
    )
    leg_roll_offset: float = _param(
        0.05, -0.2, 0.3, step=0.005, unit="rad", eq="(39)", doc="constant leg roll (outwards > 0)"
    )
    leg_roll_yaw: float = _param(
        0.1, -1.0, 1.0, step=0.01, unit="1", eq="(39)", doc="leg roll gain on a_y"
    )
    #: eq (39)'s coefficient of I_s a_r + |a_r|, 1 in the paper: the leading leg's spread on a
    #: side step (2 |a_r|), which loads the hip rolls of stock servos past their stall (0071)
    leg_roll_side: float = _param(
        1.0, 0.0, 2.0, step=0.01, unit="1", eq="(39)", doc="side-step leg spread gain (paper: 1)"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)


@dataclass(frozen=True)
class LegParams:
    """The leg interface, eqs (2)–(9)."""

    eta_min: float = _param(
        0.875, 0.6, 0.99, step=0.005, unit="1", eq="(2)",
        doc="relative leg length at full shortening (gamma = -1)",
    )  # fmt: skip
    paper_signs: bool = _switch(
        "eqs (30), (31), (39) with the signs as printed (I_s on foot pitch, not foot roll; "
        "0.1*a_y not 0.1*|a_y|); off: the mirror-symmetric form"
    )

    def __post_init__(self) -> None:
        _check_ranges(self)
