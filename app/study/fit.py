"""Fit the model to a recording (docs/FIT.md): CMA-ES over the physics fields in two stages
(standing, then the walks), each point the routine replayed on worker processes with the IMU's
errors fitted in closed form; what was found and how sure: `app.study.fit_result`."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from app.analysis import fit_sensors
from app.analysis.identify_record import Recording, traces_of
from app.analysis.identify_replay import Traces, play
from app.analysis.identify_routine import ROUTINES
from app.robots.model import RobotModel
from app.study import fit_space
from app.study.fit_result import Fit, judged, uncertainty
from app.study.fit_space import Dim
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams

#: CMA-ES stops when its step (in the unit box) is below this
TOL_X = 0.002
#: the fields the routine's first segment (standing still) tells alone: searched first, on it
#: alone (a replay a tenth as long), then held while the walks fit the others (docs/FIT.md)
STANDING = ("trunk_mass_scale", "link_mass_scale", "tilt_x_deg", "tilt_y_deg")
#: the share of the budget (in whole replays' worth) the standing stage may use: its replays
#: are short, so it gets many (a 160-replay budget: ~290 of the first segment)
STANDING_SHARE = 0.15


class FitCancelled(RuntimeError):
    """The fit was cancelled; nothing was written."""


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

        def replays_at(points: list[dict[str, float]]) -> list[Traces]:
            return [aligned(r, recorded) for r in run_all(_replay, [(p,) for p in points])]

        sigma, corr = uncertainty(
            cycles, physics, imu_dims, values, replays[1], recorded, present, fixed, replays_at
        )
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return judged(
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
