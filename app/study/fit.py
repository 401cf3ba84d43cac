"""Fit the model to a recording (docs/FIT.md): CMA-ES over the physics fields in two rounds of
two stages (standing, then the walks), each point the routine replayed where
`app.study.fit_replays` runs it; what was found and how sure: `app.study.fit_result`."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.analysis import fit_sensors
from app.analysis.identify_record import Recording, traces_of
from app.analysis.identify_replay import Traces
from app.study import fit_space
from app.study.fit_replays import FitCancelled, Replays, aligned, imu_fit
from app.study.fit_result import Fit, judged, uncertainty
from app.study.fit_space import Dim
from app.worlds.variations import NOMINAL, Variation
from gait import GaitParams

__all__ = ["STAGES", "FitCancelled", "Stage", "fit", "stages"]

#: CMA-ES stops when its step (in the unit box) is below this
TOL_X = 0.002
#: the fields the routine's first segment (standing still) tells alone: searched on it alone
#: (a replay a tenth as long) with the others held (docs/FIT.md)
STANDING = ("trunk_mass_scale", "link_mass_scale", "tilt_x_deg", "tilt_y_deg")


@dataclass(frozen=True)
class Stage:
    """One CMA-ES search: the standing fields on the first segment or the others on the whole
    routine, the rest held where the stages before left them; `share` of the budget (in whole
    replays' worth), `sigma0` its first step in the unit box."""

    standing: bool
    share: float
    sigma0: float


#: standing still's answer leans on the stiffness it is replayed with (a floor 0.2° off at the
#: nominal kp, decision 0067), so a second round asks it again with the walks' fields found, and
#: then refines those from where they were, with a smaller first step
STAGES = (
    Stage(standing=True, share=0.10, sigma0=0.2),
    Stage(standing=False, share=0.55, sigma0=0.2),
    Stage(standing=True, share=0.05, sigma0=0.05),
    Stage(standing=False, share=0.30, sigma0=0.08),
)


def stages(standing: bool, walking: bool) -> list[Stage]:
    """The stages for fields of each kind; with one kind only, one search of the whole
    budget; none without physics fields (the IMU's errors alone are fitted in closed form)."""
    if standing and walking:
        return list(STAGES)
    return [Stage(standing=standing, share=1.0, sigma0=0.2)] if standing or walking else []


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
    cluster: str | None = None,
    wait_workers_s: float | None = None,
) -> Fit:
    """Fit `recording` on `robot` (a name or description file): at most `budget` replays in the
    search, on `workers` processes (1: in this one) or the Dask scheduler at `cluster`, the same
    result for a seed wherever it runs. `fields` the searched ones (`fit_space.FIELDS`), `fixed`
    held; `progress(done, total, best_loss)` in whole replays' worth of work."""
    physics, imu_dims = fit_space.coordinates(fields)
    imu = tuple(d.name for d in imu_dims)
    recorded = traces_of(recording)
    present = recording.frames.present is not None
    name = recording.routine.split("-v", 1)[0]
    lengths = [s.frames for s in recording.segments]
    init = (robot, recording.params, name, recorded, present, fixed.to_text(), lengths)
    runner = Replays(
        init, workers=workers, cluster=cluster, wait_workers_s=wait_workers_s, cancel=cancel
    )
    run_all = runner.map

    try:
        nominal = {d.name: d.nominal for d in physics}
        held = fit_space.truth_values(fixed)
        nominal = {k: held.get(k, v) for k, v in nominal.items()}
        # the nominal model's loss (the IMU's errors as held too)
        ((loss0, _),) = run_all("score", [(nominal, ())])
        best, evaluations = dict(nominal), 1
        spread: dict[str, float] = {}
        kinds = {
            True: [d for d in physics if d.name in STANDING],
            False: [d for d in physics if d.name not in STANDING],
        }
        weight = lengths[0] / sum(lengths)  # a standing replay's share of a whole one
        plan = stages(bool(kinds[True]), bool(kinds[False]))
        done_work, work = 0.0, float(budget)
        for stage in plan:
            segments, cost = (1, weight) if stage.standing else (None, 1.0)
            ((start_loss, _),) = run_all("score", [(best, imu, segments)])
            best, _, done, stds = _search(
                kinds[stage.standing],
                best,
                imu,
                max(1, round(budget * stage.share / cost)),
                seed,
                run_all,
                told(progress, done_work, work, cost),
                start_loss,
                segments,
                stage.sigma0,
            )
            evaluations += done + 1
            done_work = min(work, done_work + done * cost)
            spread |= stds
        ((best_loss, _),) = run_all("score", [(best, imu)])
        evaluations += 1
        replays = [aligned(r, recorded) for r in run_all("replay", [(nominal,), (best,)])]
        values = dict(best)
        errors = imu_fit(replays[1], recorded, imu, fixed)
        values |= {k: v for k, v in fit_space.imu_values(errors).items() if k in imu}
        cycles = fit_sensors.Cycles(
            tuple(lengths), GaitParams.from_dict(recording.params).clock.freq_hz
        )

        def replays_at(points: list[dict[str, float]]) -> list[Traces]:
            return [aligned(r, recorded) for r in run_all("replay", [(p,) for p in points])]

        sigma, corr = uncertainty(
            cycles, physics, imu_dims, values, replays[1], recorded, present, fixed, replays_at
        )
    finally:
        runner.close()
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
        spread,
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
    segments: int | None,
    sigma0: float,
) -> tuple[dict[str, float], float, int, dict[str, float]]:
    """CMA-ES over the coordinates `physics` from `start` (the others held there), at most
    `budget` replays of the routine's first `segments` (None: all): the best point, its loss,
    the replays done and each coordinate's spread left in the search (its σ, in its unit)."""
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
    es = cma.CMAEvolutionStrategy(x0, sigma0, options)
    best, best_loss, done = dict(start), loss0, 0
    while done < budget and not es.stop():
        xs = es.ask()
        points = [
            start | {d.name: d.from_unit(u) for d, u in zip(physics, x, strict=True)} for x in xs
        ]
        scores = run_all("score", [(p, imu, segments) for p in points])
        losses = [s for s, _ in scores]
        es.tell(xs, losses)
        done += len(xs)
        i = int(np.argmin(losses))
        if losses[i] < best_loss:
            best, best_loss = points[i], losses[i]
        if progress is not None:
            progress(min(done, budget), best_loss)
    stds = es.result.stds  # each coordinate's σ in the unit box
    spread = {d.name: float(u) * (d.high - d.low) for d, u in zip(physics, stds, strict=True)}
    return best, best_loss, done, spread


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
