"""What a fit found and how sure it is (docs/FIT.md): each coordinate's σ from the loss's
curvature (Gauss-Newton on central differences, the residuals' autocorrelation counted), which
fields the recording cannot tell apart, whether the search converged, and the residual against
the sensors' noise."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from app.analysis import fit_sensors
from app.analysis.identify_replay import Traces
from app.sim.headless import AT_LIMIT
from app.study import fit_space
from app.study.fit_space import Dim
from app.worlds.variations import Variation

#: two coordinates correlated beyond this in the fit's covariance: the recording cannot tell
#: them apart (one moves the traces as the other does)
CORRELATED = 0.9
#: a fit that lowers the nominal's loss by less than this share did not find a better model
MIN_GAIN = 0.02
#: the torque scale is told only when the fit's replay holds a servo at its torque limit (at
#: AT_LIMIT of it) for at least this share of the frames; below, the routine never leans on it
#: (decision 0067: robots at 0.1 and 0.17 % fitted 0.19 and 0.14 off, at 5-26 % within 0.035)
TORQUE_TOLD_SHARE = 0.01
#: CMA-ES has converged when each coordinate's spread left in its search (its σ) is within
#: this many times the precision the field must reach: on a loss the contacts make rough the
#: spread stops shrinking at the roughness (decision 0067: 2.55 ms of latency, 0.14 ms off)
CONVERGED_SPREAD = 1.0


@dataclass
class Fit:
    """What `fit` found (docs/FIT.md): each coordinate's value and σ, what was identified."""

    values: dict[str, float]
    sigma: dict[str, float]
    identified: dict[str, bool]
    correlated: list[tuple[str, str, float]]
    flat: list[str]
    still: dict[str, str]  # fields the routine does not move enough to tell -> why, in words
    loss_nominal: float
    loss_fit: float
    rms_nominal: dict[str, float]
    rms_fit: dict[str, float]
    converged: bool
    why_not: str
    evaluations: int
    variation: Variation
    replay_nominal: Traces = field(repr=False)
    replay_fit: Traces = field(repr=False)

    def noise_ratio(self) -> dict[str, float]:
        """Each channel's rms residual after the fit over the noise its sensor carries."""
        return {c: v / fit_sensors.NOISE[c] for c, v in self.rms_fit.items()}


def _vector(parts: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    return np.concatenate([e.reshape(-1) for e in parts.values()])


def uncertainty(
    cycles: fit_sensors.Cycles,
    physics: list[Dim],
    imu_dims: list[Dim],
    values: dict[str, float],
    replay: Traces,
    recorded: Traces,
    present: bool,
    fixed: Variation,
    replays_at: Callable[[list[dict[str, float]]], list[Traces]],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """σ of each coordinate and their correlations: J from central differences (the physics
    replayed at ±step, the IMU's errors turned at ±step; inside the bounds, `_ends`), cov =
    s²·τ·(JᵀJ)⁻¹ with s² the residuals' variance and τ = (1 + ρ)/(1 − ρ) from their lag-one
    autocorrelation ρ (a recording's frames are not independent draws)."""

    def at(v: dict[str, float], rep: Traces) -> NDArray[np.float64]:
        errors = fit_space.imu_errors({k: x for k, x in v.items() if k in fit_space.IMU}, fixed)
        return _vector(fit_sensors.residuals(rep, errors, recorded, present, cycles))

    dims = physics + imu_dims
    base = at(values, replay)
    ends = {d.name: _ends(d, values[d.name]) for d in dims}
    points = []
    for d in physics:
        for end in ends[d.name]:
            here = {p.name: values[p.name] for p in physics}
            points.append(here | {d.name: end})
    replays = replays_at(points) if points else []
    columns = []
    for i, d in enumerate(physics):
        plus, minus = at(values, replays[2 * i]), at(values, replays[2 * i + 1])
        high, low = ends[d.name]
        columns.append((plus - minus) / (high - low))
    for d in imu_dims:
        high, low = ends[d.name]
        plus = at({**values, d.name: high}, replay)
        minus = at({**values, d.name: low}, replay)
        columns.append((plus - minus) / (high - low))
    jac = np.stack(columns, 1) if columns else np.zeros((len(base), 0))
    n, p = jac.shape
    s2 = float(base @ base) / max(1, n - p)
    rho = float(np.clip(np.corrcoef(base[:-1], base[1:])[0, 1], 0.0, 0.99)) if n > 2 else 0.0
    tau = (1 + rho) / (1 - rho)
    info = jac.T @ jac
    cov = np.linalg.pinv(info) * s2 * tau if p else np.zeros((0, 0))
    sigma = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    scale = np.where(sigma > 0, sigma, 1.0)
    corr = cov / np.outer(scale, scale)
    return sigma, corr if len(dims) else np.zeros((0, 0))


def too_still(names: list[str], replay: Traces) -> dict[str, str]:
    """The fields among `names` the routine, as the fit replays it, does not move enough to
    tell: the torque scale where no servo sits at its limit for TORQUE_TOLD_SHARE of the frames
    (the curvature's σ then measures how the contacts part, not the torque)."""
    if "torque_scale" not in names or replay.effort is None:
        return {}
    share = float((replay.effort >= AT_LIMIT).any(axis=1).mean())
    if share >= TORQUE_TOLD_SHARE:
        return {}
    return {
        "torque_scale": f"the servos sat at their torque limit in {100 * share:.1f} % of the "
        f"replay's frames (told from {100 * TORQUE_TOLD_SHARE:g} %): the routine does not lean "
        "on it"
    }


def _ends(d: Dim, value: float) -> tuple[float, float]:
    """The central difference's two points about `value`, a step apart each way, moved inside
    the coordinate's bounds where a step would leave them (a latency fitted at 1 ms: 0 and 4 ms;
    a variation refuses a negative latency)."""
    low, high = max(d.low, value - d.step), min(d.high, value + d.step)
    if high - low < d.step:  # squeezed against a bound: one step from it, inward
        low, high = (d.low, d.low + d.step) if low == d.low else (d.high - d.step, d.high)
    return high, low


def judged(
    dims: list[Dim],
    values: dict[str, float],
    sigma: NDArray[np.float64],
    corr: NDArray[np.float64],
    replays: list[Traces],
    recorded: Traces,
    present: bool,
    fixed: Variation,
    loss0: float,
    best_loss: float,
    evaluations: int,
    spread: dict[str, float],
) -> Fit:
    names = [d.name for d in dims]
    sig = dict(zip(names, map(float, sigma), strict=True))
    correlated = [
        (names[i], names[j], float(corr[i, j]))
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if abs(corr[i, j]) > CORRELATED
    ]
    flat = [d.name for d in dims if sig[d.name] > (d.high - d.low) / 2]
    tangled = {n for a, b, _ in correlated for n in (a, b)}
    still = too_still(names, replays[1])
    identified = {
        d.name: 2 * sig[d.name] <= d.tolerance
        and d.name not in tangled
        and d.name not in flat
        and d.name not in still
        for d in dims
    }
    gain = 1 - best_loss / loss0 if loss0 > 0 else 0.0
    converged, why = True, ""
    if gain < MIN_GAIN and loss0 > 1e-3:
        converged, why = (
            False,
            (
                f"the fit lowered the nominal's loss by {100 * gain:.1f} %, "
                f"less than {100 * MIN_GAIN:g} %"
            ),
        )
    elif wide := [d for d in dims if spread.get(d.name, 0.0) > CONVERGED_SPREAD * d.tolerance]:
        d = wide[0]
        converged, why = (
            False,
            (
                f"CMA-ES's spread in {d.name} is still {spread[d.name]:.3g}, more than "
                f"{CONVERGED_SPREAD:g} × its precision {d.tolerance:g}, after {evaluations} "
                "replays: give it a larger --budget"
            ),
        )
    physics_values = {k: v for k, v in values.items() if k in fit_space.PHYSICS}
    errors = fit_space.imu_errors({k: v for k, v in values.items() if k in fit_space.IMU}, fixed)
    variation = fixed  # not converged: the nominal, with what the builder held
    if converged:
        physical = fit_space.physics_variation(physics_values, fixed)
        variation = fit_space.with_imu(physical, errors)
    nominal_errors = fit_space.imu_errors({}, fixed)
    rms0 = fit_sensors.rms(fit_sensors.residuals(replays[0], nominal_errors, recorded, present))
    rms1 = fit_sensors.rms(fit_sensors.residuals(replays[1], errors, recorded, present))
    return Fit(
        values,
        sig,
        identified,
        correlated,
        flat,
        still,
        loss0,
        best_loss,
        rms0,
        rms1,
        converged,
        why,
        evaluations,
        variation,
        replays[0],
        replays[1],
    )
