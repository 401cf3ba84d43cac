"""Parameters of seed 004's oscillator gait (`gait.pfs`, eqs 1–3, 10–11; docs/DESIGN.md §4): per
joint kind the offset C, amplitude A and phase phi of eq (2), the stride phase and the start-up time
of Fig. 3. Part of the one schema (`gait.params.GaitParams.pfs`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from gait.schema_fields import check_ranges as _check_ranges
from gait.schema_fields import tunable as _param

_PHASE_RANGE = (-3.15, 3.15)


def _offset(default: float, lo: float, hi: float, joint: str) -> Any:
    return _param(
        default, lo, hi, step=0.005, unit="rad", eq="seed 004 (2)", doc=f"C: {joint} offset"
    )


def _amplitude(default: float, joint: str, hi: float = 0.5) -> Any:
    return _param(
        default, 0.0, hi, step=0.005, unit="rad", eq="seed 004 (2)",
        doc=f"A: {joint} oscillation amplitude",
    )  # fmt: skip


def _phase(default: float, joint: str) -> Any:
    return _param(
        default, *_PHASE_RANGE, step=0.01, unit="rad", eq="seed 004 (2)",
        doc=f"phi: {joint} phase (left leg; the right leg is pi later, eq (11))",
    )  # fmt: skip


@dataclass(frozen=True)
class PfsParams:
    """Seed 004's own gait (eqs 1–3, 10–11): per joint C + A*sin(2*pi*t/T + phi), T = 1/f of
    `clock.freq_hz`, the right leg pi later; see `gait.pfs` and docs/DESIGN.md §4.

    Angles in the per-leg convention of the leg interface (roll > 0 outwards, pitch > 0 forwards,
    knee <= 0). The paper gives no values for a robot like ArtRo; the defaults are the first
    Fourier harmonic of the `behnke` engine's paper gait stepping on the spot, made exact where
    a harmonic would break a rule: the knee oscillates in [-2A, 0] (C = -A), and hip and ankle
    pitch take half the knee bend each (thigh and shank are equally long), so the sole stays
    level; the ankle adds the paper's 0.02 rad toe-up of eq (38).
    """

    startup_s: float = _param(
        2.0, 0.0, 10.0, step=0.1, unit="s", eq="seed 004 Fig. 3",
        doc="start-up phase: every oscillation amplitude grows linearly from 0 over this time "
        "after a start or reset (0 = at once)",
    )  # fmt: skip
    hip_roll_c: float = _offset(0.05, -0.3, 0.3, "hip roll (leg spread, eq (39)'s 0.05)")
    hip_roll_a: float = _amplitude(0.12, "hip roll (lateral shift, eq (13)'s 0.12)")
    hip_roll_phi: float = _phase(-1.57, "hip roll")
    hip_pitch_c: float = _offset(0.075, -0.5, 0.8, "hip pitch")
    hip_pitch_a: float = _amplitude(0.075, "hip pitch")
    hip_pitch_phi: float = _phase(-1.97, "hip pitch")
    knee_c: float = _offset(-0.15, -1.2, 0.0, "knee (<= 0; knee <= 0 needs C + A <= 0)")
    knee_a: float = _amplitude(0.15, "knee", hi=0.6)
    knee_phi: float = _phase(1.17, "knee")
    ankle_pitch_c: float = _offset(0.095, -0.5, 0.8, "ankle pitch (toe up > 0)")
    ankle_pitch_a: float = _amplitude(0.075, "ankle pitch")
    ankle_pitch_phi: float = _phase(-1.97, "ankle pitch")
    ankle_roll_c: float = _offset(-0.05, -0.3, 0.3, "ankle roll (keeps the sole level)")
    ankle_roll_a: float = _amplitude(0.18, "ankle roll")
    ankle_roll_phi: float = _phase(1.57, "ankle roll")
    stride_phi: float = _param(
        2.99, *_PHASE_RANGE, step=0.01, unit="rad", eq="seed 004 (2); (27)–(29)",
        doc="phase of the stride oscillators a*sin(2*pi*t/T + phi_s) that a_r, a_p and a_y "
        "drive (default: the first harmonic of the swing of eq (25), forward while lifted)",
    )  # fmt: skip
    stride_gain: float = _param(
        1.0, 0.0, 6.0, step=0.05, unit="1", eq="seed 004 (2); (27)–(29)",
        doc="stride amplitude per rad of the motion vector: the stride oscillators are "
        "gain * a * sin(...) (1: a_p itself, as the swing of eq (28) peaks)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        _check_ranges(self)
