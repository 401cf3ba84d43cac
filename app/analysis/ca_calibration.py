"""Calibrating CA steering (docs/DESIGN.md §4): the steering term K = `steer.yaw_per_ca` that makes
the heading rate per CA match eq (13), and the effective axle b_eff with it, fitted from short
curve walks on the batch evaluator (`calibrate_ca`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from app.analysis.axle_fit import walking_amplitude
from app.analysis.ca_analysis import fit_axle
from app.evaluation import Evaluator, Job
from app.sim.metrics import RunMetrics
from gait import GaitParams, Motion

CA_STEP = 0.1  # c: the curve walks are at CA = -c, 0, +c (the steering search's pair)
PROBE_K = 0.15  # the first K tried (models/README.md: this made tuned follow eq (13) at 0.07)
K_RANGE = (-1.0, 1.0)  # steer.yaw_per_ca's range
DURATION_S = 20.0
WARMUP_S = 4.0
TOLERANCE = 0.1  # stop when the slope is within 10 % of eq (13)'s


class CalibrationError(RuntimeError):
    """No calibration: the robot fell, did not walk, or K does not change its turning."""


@dataclass(frozen=True)
class Trial:
    """One K and what CA did with it."""

    yaw_per_ca: float  # K
    slope_deg_s: float  # d theta_dot / d CA, deg/s per unit CA (counter-clockwise +)
    gain: float  # slope / eq (13)'s slope: 1 = turns as eq (13) says


@dataclass(frozen=True)
class CaCalibration:
    yaw_per_ca: float  # K, the fitted steering term (the trial nearest eq (13))
    field: str  # which K: "yaw_per_ca" (forward) or "yaw_per_ca_backward" (a_p < 0)
    axle_eff_m: float | None  # b_eff with that K: -2 V / slope (None: CA does not turn it)
    axle_eff_without_m: float | None  # b_eff with K = 0, CA's own steering
    feet_m: float  # b of eq (13): the mean distance between the feet, straight walk
    speed_m_s: float  # V: the straight walk's forward speed
    target_slope_deg_s: float  # eq (13): -2 V / b, in deg/s per unit CA
    a_p: float
    ca_step: float
    trials: tuple[Trial, ...] = ()
    sim_s: float = 0.0

    @property
    def gain(self) -> float:
        """The chosen K's slope as a share of eq (13)'s."""
        return next(t.gain for t in self.trials if t.yaw_per_ca == self.yaw_per_ca)

    @property
    def converged(self) -> bool:
        return abs(self.gain - 1.0) <= TOLERANCE

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self) | {"gain": self.gain, "converged": self.converged}


def k_field(a_p: float) -> str:
    """The steering term's K that a walk at a_p uses: forward or backward (SteerParams)."""
    return "yaw_per_ca" if a_p >= 0 else "yaw_per_ca_backward"


def with_k(params: GaitParams, a_p: float, k: float) -> GaitParams:
    """`params` with the K that a walk at a_p uses set to k (the other one kept)."""
    return dataclasses.replace(params, steer=dataclasses.replace(params.steer, **{k_field(a_p): k}))


def _clip_k(k: float) -> float:
    return round(min(max(k, K_RANGE[0]), K_RANGE[1]), 4)


def _secant_pair(trials: list[Trial], target: float) -> list[tuple[float, float]]:
    """The two trials (K, slope rad/s per CA) the next K is drawn between: the nearest on
    either side of eq (13)'s slope when some lie on each (the target between them: a step that
    overshot is not forgotten), else the two nearest it."""
    by_miss = sorted(
        ((t.yaw_per_ca, math.radians(t.slope_deg_s)) for t in trials),
        key=lambda ks: abs(ks[1] - target),
    )
    below = [ks for ks in by_miss if ks[1] < target]
    above = [ks for ks in by_miss if ks[1] > target]
    return [below[0], above[0]] if below and above else by_miss[:2]


def calibrate_ca(
    params: GaitParams,
    motion: Motion,
    evaluator: Evaluator,
    *,
    duration_s: float = DURATION_S,
    warmup_s: float = WARMUP_S,
    probe_k: float = PROBE_K,
    iterations: int = 2,
    say: Callable[[str], None] = lambda _text: None,
) -> CaCalibration:
    """Fit K and b_eff for `params` walking at `motion`'s a_p (0.07 forward if it stands).

    CA scales the step lengths (seed 004 eqs (10)–(11)) and eq (13) says that turns the robot at
    theta_dot = -2 CA V / b; a biped turns only as far as its feet skid, and a_y,eff = a_y + K*CA
    adds leg yaw. The heading rate is close to linear in CA and the term acts like an a_y of K*CA,
    so the slope d theta_dot / d CA is close to linear in K:

    1. one batch: K = 0 at CA = -c, 0, +c and K = `probe_k` at CA = -c, +c (the CA = 0 walk is the
       same gait for every K) -> the slopes, and V and b (feet distance) from the straight walk;
    2. a secant step toward the slope of eq (13), s* = -2 V / b, between the nearest trials on
       either side of it (else the two nearest: `_secant_pair`);
    3. a check walk at that K (CA = +-c); steps 2–3 repeat up to `iterations` times while the
       slope misses s* by more than TOLERANCE.

    The K nearest eq (13) is returned with b_eff = -2 V / slope at it (b when it matches).
    `say` gets one line per stage and per finished batch (progress for a terminal or a log).
    CalibrationError if the robot falls, does not walk, or K does not change its turning.
    """
    if not probe_k:
        raise ValueError("probe_k must not be 0")
    if iterations < 1:
        raise ValueError("iterations must be >= 1")
    a_p = walking_amplitude(motion)
    base = dataclasses.replace(motion, a_p=a_p, a_y=0.0, ca=0.0)
    ca = (-CA_STEP, 0.0, CA_STEP)
    sim_s = 0.0

    def walks(label: str, jobs: list[Job]) -> list[RunMetrics]:
        nonlocal sim_s
        say(f"{label}: {len(jobs)} curve walks of {duration_s:g} s at a_p = {a_p:+.3f}")
        results = evaluator.evaluate(
            jobs,
            duration_s=duration_s,
            warmup_s=warmup_s,
            progress=lambda done, total: say(f"  {done}/{total} runs done"),
        )
        fell = [
            (getattr(j.params.steer, k_field(a_p)), j.motion.ca)
            for j, r in zip(jobs, results, strict=True)
            if r["fell"]
        ]
        if fell:
            raise CalibrationError(f"the robot fell at (K, CA) = {fell}, a_p = {a_p:+.3f}")
        sim_s += duration_s * len(jobs)
        return results

    def curve(k: float) -> list[Job]:
        return [
            Job(with_k(params, a_p, k), dataclasses.replace(base, ca=c)) for c in (ca[0], ca[2])
        ]

    first = walks(
        f"K = 0 and K = {probe_k:g}",
        [Job(with_k(params, a_p, 0.0), dataclasses.replace(base, ca=c)) for c in ca]
        + curve(probe_k),
    )
    straight = first[1]
    speed = (straight["forward_cm_s"] or 0.0) / 100.0
    feet = (straight["feet_distance_cm"] or 0.0) / 100.0
    if abs(speed) < 1e-3 or feet <= 0.0:
        raise CalibrationError(f"the robot does not walk at a_p = {a_p:+.3f} ({speed:.4f} m/s)")
    target = -2.0 * speed / feet  # eq (13): rad/s per unit CA

    def turns(results: list[RunMetrics]) -> list[float]:
        return [math.radians(r["turn_deg_s"] or 0.0) for r in results]

    def trial(k: float, left_right: list[RunMetrics]) -> Trial:
        rates = turns([left_right[0], straight, left_right[1]])
        fit = fit_axle(ca, rates, speed)
        done = Trial(k, math.degrees(fit.slope_rad_s), fit.slope_rad_s / target)
        say(
            f"K = {k:+.4f}: {done.slope_deg_s:+.2f} deg/s per CA, "
            f"{100 * done.gain:.0f} % of eq (13)'s {math.degrees(target):+.2f}"
        )
        return done

    trials = [trial(0.0, [first[0], first[2]]), trial(probe_k, first[3:])]
    without = fit_axle(ca, turns(first[:3]), speed).axle_eff_m
    for _ in range(iterations):
        (k_a, s_a), (k_b, s_b) = _secant_pair(trials, target)
        if s_a == s_b or k_a == k_b:
            raise CalibrationError("K does not change how CA turns this gait")
        k = _clip_k(k_a + (target - s_a) * (k_b - k_a) / (s_b - s_a))  # secant through two
        if any(t.yaw_per_ca == k for t in trials):
            break
        trials.append(trial(k, walks(f"check K = {k:+.4f}", curve(k))))
        if abs(trials[-1].gain - 1.0) <= TOLERANCE:
            break
    best = min(trials, key=lambda t: abs(t.gain - 1.0))
    slope = math.radians(best.slope_deg_s)
    return CaCalibration(
        yaw_per_ca=best.yaw_per_ca,
        field=k_field(a_p),
        axle_eff_m=None if slope == 0 else -2.0 * speed / slope,
        axle_eff_without_m=without,
        feet_m=feet,
        speed_m_s=speed,
        target_slope_deg_s=math.degrees(target),
        a_p=a_p,
        ca_step=CA_STEP,
        trials=tuple(trials),
        sim_s=sim_s,
    )
