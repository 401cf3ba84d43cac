"""Fit the model to a recording (docs/FIT.md): CMA-ES over the physics fields, each point the
routine replayed on worker processes with the IMU's errors fitted in closed form; then each
field's uncertainty from the loss's curvature (Gauss-Newton on finite differences, the
residuals' autocorrelation counted), which fields the recording cannot tell apart, and the
residual against the sensors' noise."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.analysis import fit_sensors
from app.analysis.identify_record import Recording, traces_of
from app.analysis.identify_replay import Traces, play
from app.analysis.identify_routine import ROUTINES
from app.robots.model import RobotModel
from app.study import fit_space
from app.study.fit_space import Dim
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams

#: two coordinates correlated beyond this in the fit's covariance: the recording cannot tell
#: them apart (one moves the traces as the other does)
CORRELATED = 0.9
#: a fit that lowers the nominal's loss by less than this share did not find a better model
MIN_GAIN = 0.02
#: CMA-ES has converged when its step (in the unit box) is below this; it stops at TOL_X
CONVERGED_SIGMA = 0.05
TOL_X = 0.002
#: the fields the routine's first segment (standing still) tells alone: searched first, on it
#: alone (a replay a tenth as long), then held while the walks fit the others (docs/FIT.md)
STANDING = ("trunk_mass_scale", "link_mass_scale", "tilt_x_deg", "tilt_y_deg")
#: the share of the budget (in whole replays' worth) the standing stage may use: its replays
#: are short, so it gets many (a 160-replay budget: ~290 of the first segment)
STANDING_SHARE = 0.15


class FitCancelled(RuntimeError):
    """The fit was cancelled; nothing was written."""


@dataclass
class Fit:
    """What `fit` found (docs/FIT.md): each coordinate's value and σ, what was identified."""

    values: dict[str, float]
    sigma: dict[str, float]
    identified: dict[str, bool]
    correlated: list[tuple[str, str, float]]
    flat: list[str]
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


# --- the work a process does: one replay at a point --------------------------------------------

_WORKER: dict[str, Any] = {}


def _start_worker(
    robot: str,
    params: dict[str, Any],
    routine: str,
    recording: Traces,
    present: bool,
    fixed: str,
    lengths: list[int],
) -> None:
    _WORKER.update(
        robot=RobotModel.load(robot),
        params=GaitParams.from_dict(params),
        routine=ROUTINES[routine],
        recorded=recording,
        present=present,
        fixed=fit_space.parse_fixed([fixed] if fixed else []),
        lengths=lengths,
    )


def _replay(values: dict[str, float], segments: int | None = None) -> Traces:
    """The routine (its first `segments` only, when given) replayed at the physics `values`."""
    w = _WORKER
    variation = fit_space.physics_variation(values, w["fixed"])
    routine, lengths = w["routine"][:segments], w["lengths"][:segments]
    return play(w["robot"], w["params"], routine, variation, sensor_errors=False, lengths=lengths)


def _score(
    values: dict[str, float], imu: tuple[str, ...], segments: int | None = None
) -> tuple[float, dict[str, float]]:
    """The loss at the physics point `values` over the routine's first `segments` (all: None),
    the IMU's errors fitted there (those in `imu`)."""
    w = _WORKER
    recorded = within(w["recorded"], sum(w["lengths"][:segments]))
    replay = aligned(_replay(values, segments), recorded)
    errors = _imu_fit(replay, recorded, imu, w["fixed"])
    cycles = fit_sensors.Cycles(tuple(w["lengths"][:segments]), w["params"].clock.freq_hz)
    parts = fit_sensors.residuals(replay, errors, recorded, w["present"], cycles)
    return fit_sensors.soft_l1(parts), fit_space.imu_values(errors)


def within(traces: Traces, frames: int) -> Traces:
    """The rows of `traces` in the routine's first `frames` frames."""
    return traces.at(np.flatnonzero(traces.positions < frames))


def aligned(replay: Traces, recorded: Traces) -> Traces:
    """The replay's rows at the recording's frames (a recording may lack some)."""
    return replay.at(recorded.positions)


def _imu_fit(replay: Traces, recorded: Traces, imu: tuple[str, ...], fixed: Variation):
    errors = fit_sensors.fit_imu(
        replay, recorded, bias="gyro_bias_deg_s" in imu, tilt="imu_tilt_x_deg" in imu
    )
    held = fit_space.imu_errors({}, fixed)
    return fit_sensors.ImuErrors(
        errors.imu_tilt_bias_deg if "imu_tilt_x_deg" in imu else held.imu_tilt_bias_deg,
        errors.imu_tilt_direction_deg if "imu_tilt_x_deg" in imu else held.imu_tilt_direction_deg,
        errors.gyro_bias_deg_s if "gyro_bias_deg_s" in imu else held.gyro_bias_deg_s,
    )


# --- the search ---------------------------------------------------------------------------------


def fit(
    recording: Recording,
    robot: str,
    *,
    fields: tuple[str, ...] = fit_space.DEFAULT_FIELDS,
    fixed: Variation = NOMINAL,
    budget: int = 160,
    workers: int = 2,
    seed: int = 1,
    progress: Callable[[float, float, float], None] | None = None,
    cancel: threading.Event | None = None,
) -> Fit:
    """Fit `recording` on `robot` (a name or description file): at most `budget` replays in the
    search, on `workers` processes (1: in this one), the same result for a seed. `fields` the
    searched ones (`fit_space.FIELDS`), `fixed` held; `progress(done, total, best_loss)` in whole
    replays' worth of work."""
    physics, imu_dims = fit_space.coordinates(fields)
    imu = tuple(d.name for d in imu_dims)
    recorded = traces_of(recording)
    present = recording.frames.present is not None
    name = recording.routine.split("-v", 1)[0]
    lengths = [s.frames for s in recording.segments]
    init = (robot, recording.params, name, recorded, present, fixed.to_text(), lengths)
    pool = (
        ProcessPoolExecutor(workers, initializer=_start_worker, initargs=init)
        if workers > 1
        else None
    )
    if pool is None:
        _start_worker(*init)

    def run_all(fn: Callable[..., Any], points: list[Any]) -> list[Any]:
        if cancel is not None and cancel.is_set():
            raise FitCancelled("the fit was cancelled; nothing was written")
        if pool is None:
            return [fn(*p) for p in points]
        return list(pool.map(fn, *zip(*points, strict=True)))

    try:
        nominal = {d.name: d.nominal for d in physics}
        held = fit_space.truth_values(fixed)
        nominal = {k: held.get(k, v) for k, v in nominal.items()}
        # the nominal model's loss (the IMU's errors as held too), and at nominal physics with
        # the IMU's errors fitted: where the search starts
        (loss0, _), (start_loss, _) = run_all(_score, [(nominal, ()), (nominal, imu)])
        best, best_loss, evaluations, sigma_now = dict(nominal), start_loss, 2, 0.0
        standing = [d for d in physics if d.name in STANDING]
        walking = [d for d in physics if d.name not in STANDING]
        weight = lengths[0] / sum(lengths)  # a standing replay's share of a whole one
        share = 0 if not standing else round(budget * (STANDING_SHARE if walking else 1) / weight)
        walking_budget = budget - round(share * weight)
        work = share * weight + (walking_budget if walking else 0)
        if standing:
            best, _, done, sigma_now = _search(
                standing,
                best,
                imu,
                share,
                seed,
                run_all,
                told(progress, 0.0, work, weight),
                math.inf,
                segments=1,
            )
            evaluations += done
        if walking:
            ((start_loss, _),) = run_all(_score, [(best, imu)])
            best, best_loss, done, sigma_now = _search(
                walking,
                best,
                imu,
                walking_budget,
                seed,
                run_all,
                told(progress, share * weight, work, 1.0),
                start_loss,
            )
            evaluations += done
        else:
            ((best_loss, _),) = run_all(_score, [(best, imu)])
        replays = [aligned(r, recorded) for r in run_all(_replay, [(nominal,), (best,)])]
        values = dict(best)
        errors = _imu_fit(replays[1], recorded, imu, fixed)
        values |= {k: v for k, v in fit_space.imu_values(errors).items() if k in imu}
        cycles = fit_sensors.Cycles(
            tuple(lengths), GaitParams.from_dict(recording.params).clock.freq_hz
        )
        sigma, corr = _uncertainty(
            cycles, physics, imu_dims, values, replays[1], recorded, present, fixed, run_all
        )
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return _judged(
        physics + imu_dims,
        values,
        sigma,
        corr,
        replays,
        recorded,
        present,
        fixed,
        loss0,
        best_loss,
        evaluations,
        sigma_now,
    )


def _search(
    physics: list[Dim],
    start: dict[str, float],
    imu: tuple[str, ...],
    budget: int,
    seed: int,
    run_all: Callable[..., list[Any]],
    progress: Callable[[int, float], None] | None,
    loss0: float,
    segments: int | None = None,
) -> tuple[dict[str, float], float, int, float]:
    """CMA-ES over the coordinates `physics` from `start` (the others held there), at most
    `budget` replays of the routine's first `segments`."""
    import cma  # only to fit

    x0 = [d.to_unit(start[d.name]) for d in physics]
    options: dict[str, Any] = {
        "bounds": [0.0, 1.0],
        "seed": seed,
        "verbose": -9,
        "tolx": TOL_X,  # converged: the step below this in the unit box
        "tolfun": 1e-6,
    }
    if len(physics) == 1:
        options["maxstd_boundrange"] = math.inf
    es = cma.CMAEvolutionStrategy(x0, 0.2, options)
    best, best_loss, done = dict(start), loss0, 0
    while done < budget and not es.stop():
        xs = es.ask()
        points = [
            start | {d.name: d.from_unit(u) for d, u in zip(physics, x, strict=True)} for x in xs
        ]
        scores = run_all(_score, [(p, imu, segments) for p in points])
        losses = [s for s, _ in scores]
        es.tell(xs, losses)
        done += len(xs)
        i = int(np.argmin(losses))
        if losses[i] < best_loss:
            best, best_loss = points[i], losses[i]
        if progress is not None:
            progress(min(done, budget), best_loss)
    return best, best_loss, done, float(es.sigma)


def told(
    progress: Callable[[float, float, float], None] | None,
    before: float,
    total: float,
    weight: float,
) -> Callable[[int, float], None] | None:
    """A stage's progress (its replays done, best loss) as the whole search's work: whole
    replays' worth done of `total`, a replay of this stage worth `weight`."""
    if progress is None:
        return None
    return lambda done, loss: progress(min(total, before + done * weight), total, loss)


def _vector(parts: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    return np.concatenate([e.reshape(-1) for e in parts.values()])


def _uncertainty(
    cycles: fit_sensors.Cycles,
    physics: list[Dim],
    imu_dims: list[Dim],
    values: dict[str, float],
    replay: Traces,
    recorded: Traces,
    present: bool,
    fixed: Variation,
    run_all: Callable[..., list[Any]],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """σ of each coordinate and their correlations: J from central differences (the physics
    replayed at ±step, the IMU's errors turned at ±step), cov = s²·τ·(JᵀJ)⁻¹ with s² the
    residuals' variance and τ = (1 + ρ)/(1 − ρ) from their lag-one autocorrelation ρ (a
    recording's frames are not independent draws)."""

    def at(v: dict[str, float], rep: Traces) -> NDArray[np.float64]:
        errors = fit_space.imu_errors({k: x for k, x in v.items() if k in fit_space.IMU}, fixed)
        return _vector(fit_sensors.residuals(rep, errors, recorded, present, cycles))

    dims = physics + imu_dims
    base = at(values, replay)
    points = []
    for d in physics:
        for sign in (1, -1):
            points.append(
                (
                    {
                        **{p.name: values[p.name] for p in physics},
                        d.name: values[d.name] + sign * d.step,
                    },
                )
            )
    replays = [aligned(r, recorded) for r in run_all(_replay, points)] if points else []
    columns = []
    for i, d in enumerate(physics):
        plus, minus = at(values, replays[2 * i]), at(values, replays[2 * i + 1])
        columns.append((plus - minus) / (2 * d.step))
    for d in imu_dims:
        plus = at({**values, d.name: values[d.name] + d.step}, replay)
        minus = at({**values, d.name: values[d.name] - d.step}, replay)
        columns.append((plus - minus) / (2 * d.step))
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


def _judged(
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
    sigma_now: float,
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
    identified = {
        d.name: 2 * sig[d.name] <= d.tolerance and d.name not in tangled and d.name not in flat
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
    elif sigma_now > CONVERGED_SIGMA:
        converged, why = (
            False,
            (
                f"CMA-ES's step is still {sigma_now:.2f} of the range after "
                f"{evaluations} replays: give it a larger --budget"
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
