"""Curve walking against seed 004 eqs (9), (12)–(13): heading rate vs CA, axle fit, stability.

Pure numpy on plain arrays, so it is tested on synthetic data (docs/DESIGN.md §4); the fit is
`fit_axle`, the stability limit (seed 004 Fig. 6) `largest_stable_ca`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

FIT_CA_LIMIT = 0.1  # eq (13) is checked and fitted over |CA| <= 0.1
ANTISYMMETRY_TOLERANCE = 0.15  # theta_dot(CA) and -theta_dot(-CA) within 15 % of each other
FULL_CIRCLE_DEG = 360.0


def eq13_turn_rate_rad_s(ca: ArrayLike, speed_m_s: float, axle_m: float) -> np.ndarray:
    """theta_dot = -2 CA V / b, eq (13) of seed 004 solved for theta_dot (CCW positive).

    V_L = (1 + CA) V, V_R = (1 - CA) V with V the straight-walking (CA = 0) speed in m/s and b the
    distance between the feet in m; `ca` may be an array; returns rad/s of the same shape.
    """
    return -2.0 * np.asarray(ca, dtype=float) * speed_m_s / axle_m


@dataclass(frozen=True)
class AxleFit:
    """theta_dot = drift + slope * CA fitted by least squares; b_eff = -2 V / slope."""

    axle_eff_m: float | None  # None when the slope is zero (CA does not steer at all)
    slope_rad_s: float  # d theta_dot / d CA
    drift_rad_s: float  # theta_dot at CA = 0 according to the fit
    residual_rms_rad_s: float
    n_points: int


def fit_axle(ca: ArrayLike, turn_rad_s: ArrayLike, speed_m_s: float) -> AxleFit:
    """Fit theta_dot = drift + k CA and return b_eff = -2 V / k (needs two distinct CA values).

    A simulated robot also turns a little when walking straight (drift), so the least-squares fit
    has a constant term; on a sweep symmetric about CA = 0 it does not change k. b_eff is the axle
    that makes eq (13) match the measured slope: b_eff = b means the biped steers exactly like the
    differential drive.

    Args:
        ca: the CA of each run. turn_rad_s: its measured heading rate (rad/s, CCW), same shape.
        speed_m_s: V, the straight-walking speed in m/s.

    Raises:
        ValueError: shapes differ, or fewer than two distinct CA values.
    """
    ca_a = np.asarray(ca, dtype=float)
    turn = np.asarray(turn_rad_s, dtype=float)
    if ca_a.shape != turn.shape or len(np.unique(ca_a)) < 2:
        raise ValueError("the axle fit needs at least two distinct CA values, one rate each")
    design = np.stack([np.ones_like(ca_a), ca_a], axis=1)
    (drift, slope), *_ = np.linalg.lstsq(design, turn, rcond=None)
    residual = turn - (drift + slope * ca_a)
    axle = None if slope == 0 else float(-2.0 * speed_m_s / slope)
    return AxleFit(
        axle_eff_m=axle,
        slope_rad_s=float(slope),
        drift_rad_s=float(drift),
        residual_rms_rad_s=float(np.sqrt(np.mean(residual**2))),
        n_points=len(ca_a),
    )


@dataclass(frozen=True)
class StableLimit:
    """The largest |CA| with no fall at it or at any smaller |CA| (both signs) of the sweep."""

    limit: float | None  # None: even the smallest |CA| of the sweep fell
    first_fall: float | None  # the smallest |CA| that fell, None if nothing fell
    sweep_max: float  # the largest |CA| tried; limit == sweep_max and no fall: limit lies beyond

    @property
    def beyond_sweep(self) -> bool:
        return self.first_fall is None


def largest_stable_ca(ca: ArrayLike, fell: ArrayLike) -> StableLimit:
    """Largest m in |CA| such that every run with |CA| <= m did not fall.

    Stability as seed 004, Fig. 6: a CA is stable when its run did not fall; the limit holds for
    either sign. `ca` and `fell` are one entry per run; ValueError if they differ or are empty.
    """
    magnitude = np.abs(np.asarray(ca, dtype=float))
    fell_a = np.asarray(fell, dtype=bool)
    if magnitude.shape != fell_a.shape or magnitude.size == 0:
        raise ValueError("need one fall flag per CA value, and at least one run")
    fallen = magnitude[fell_a]
    first_fall = float(fallen.min()) if fallen.size else None
    below = magnitude[magnitude < first_fall] if first_fall is not None else magnitude
    limit = float(below.max()) if below.size else None
    return StableLimit(limit=limit, first_fall=first_fall, sweep_max=float(magnitude.max()))


@dataclass(frozen=True)
class AntisymmetryPair:
    """theta_dot(CA) against -theta_dot(-CA) for one CA > 0 (both runs standing).

    The rates are in whatever unit the caller measured them in; the mismatch is unitless.
    """

    ca: float
    turn_pos: float  # theta_dot(+CA)
    turn_neg: float  # theta_dot(-CA)

    @property
    def even_part(self) -> float:
        """(theta_dot(CA) + theta_dot(-CA)) / 2: the part CA does not explain (drift)."""
        return 0.5 * (self.turn_pos + self.turn_neg)

    @property
    def mismatch(self) -> float | None:
        """|a - (-b)| / mean(|a|, |b|), as the mirror check of the paper cases."""
        scale = 0.5 * (abs(self.turn_pos) + abs(self.turn_neg))
        if scale == 0:
            return None
        return abs(self.turn_pos + self.turn_neg) / scale

    @property
    def ok(self) -> bool:
        m = self.mismatch
        return m is not None and m <= ANTISYMMETRY_TOLERANCE


def antisymmetry_pairs(ca: ArrayLike, turn: ArrayLike, fell: ArrayLike) -> list[AntisymmetryPair]:
    """One pair per CA > 0 whose mirror -CA is in the sweep too; fallen runs are left out."""
    ca_a = np.asarray(ca, dtype=float)
    turn_a = np.asarray(turn, dtype=float)
    fell_a = np.asarray(fell, dtype=bool)
    pairs = []
    for i in np.argsort(ca_a):
        if ca_a[i] <= 0 or fell_a[i]:
            continue
        mirror = np.flatnonzero(np.isclose(ca_a, -ca_a[i], rtol=0, atol=1e-9) & ~fell_a)
        if mirror.size:
            j = int(mirror[0])
            pairs.append(AntisymmetryPair(float(ca_a[i]), float(turn_a[i]), float(turn_a[j])))
    return pairs


@dataclass(frozen=True)
class CircleCheck:
    """Does a curve walk turn a full circle within its run, and how long would one take?"""

    turned_deg: float  # heading change from the run's first to its last sample
    run_s: float
    rate_deg_s: float | None  # the measured heading rate (after warm-up, whole cycles)
    predicted_rate_deg_s: float | None  # eq (13)

    @property
    def completed(self) -> bool:
        return abs(self.turned_deg) >= FULL_CIRCLE_DEG

    @property
    def circle_s(self) -> float | None:
        """Time a full circle takes at the measured rate (None if it does not turn)."""
        return _circle_time_s(self.rate_deg_s)

    @property
    def predicted_circle_s(self) -> float | None:
        return _circle_time_s(self.predicted_rate_deg_s)


def _circle_time_s(rate_deg_s: float | None) -> float | None:
    if rate_deg_s is None or rate_deg_s == 0 or not math.isfinite(rate_deg_s):
        return None
    return FULL_CIRCLE_DEG / abs(rate_deg_s)
