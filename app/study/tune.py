"""`artro tune`: CMA-ES over chosen gait parameters toward the paper's measured walking.

Each candidate is scored on `app.analysis.cases.JUDGED_RUNS` by `total_loss`; the search, its
study store (`app.study.study_store`) and its output are described at `Tuner`.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TextIO

import numpy as np

from app.analysis.robot_tune import RUNS, TRIAL, EventWriter
from app.analysis.robust_cases import ROBUST_CASES, RobustCase
from app.evaluation import BatchEvaluator, Evaluator, Job
from app.evaluation.progress import ProgressLine, about, bar, time_left_s
from app.params.document import ParameterSet
from app.robots.model_parts import joint_settings
from app.study.study_store import StudyStore
from app.study.tune_families import (
    cvar25,
    families_term,
    family_scores,
    kept_shortfall,
    torque_penalty,
    world_losses,
)
from app.study.tune_loss import LossWeights, total_loss
from app.study.tune_space import DEFAULT_NAMES, dimensions, judged_runs, with_values
from app.worlds.fitted import fitted_ranges, fitted_variation
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import Variation
from gait import JOINT_NAMES, GaitParams, Motion


class Tuner:
    """CMA-ES over `names` (dotted gait fields), starting from `base`, scored by `total_loss`.

    The search runs in a box normalised to [0, 1] per parameter (the schema's range). Every
    evaluation is a trial in the study store (`run`), written as soon as it is done; resuming
    replays the store through the same seeded CMA-ES (docs/DESIGN.md §12). `artro tune`
    (`command`) writes the best set found as a parameter-set file with provenance.
    """

    def __init__(
        self,
        base: ParameterSet,
        names: Sequence[str] = DEFAULT_NAMES,
        *,
        evaluator: Evaluator | None = None,
        duration_s: float = 20.0,
        warmup_s: float = 4.0,
        popsize: int = 10,
        sigma0: float = 0.12,
        seed: int = 1,
        weights: LossWeights | None = None,
        cases: Sequence[str] | None = None,
        robust: int = 0,
        robust_weight: float = 1.0,
        ranges: VariationRanges | None = None,
        keep_base: float = 0.0,
    ) -> None:
        if robust < 0 or not math.isfinite(robust_weight) or robust_weight < 0:
            raise ValueError(
                f"robust needs N >= 0 variations and a weight >= 0, got {robust}, {robust_weight}"
            )
        if not math.isfinite(keep_base) or keep_base < 0 or (keep_base and not robust):
            raise ValueError(
                f"keeping the base needs a weight >= 0 and robust N >= 1 variations to keep it "
                f"in, got {keep_base} with robust {robust}"
            )
        self.base = base
        self.robust, self.robust_weight = robust, robust_weight
        #: with --robust: the weight of the shortfall of each family's pass share below the
        #: base set's in the same worlds (`kept_shortfall`); 0: the base is not walked
        self.keep_base = keep_base
        self._base_families: dict[int, dict[str, dict[str, Any]]] = {}  # by generation
        self.ranges = ranges or VariationRanges()
        self.runs = judged_runs(cases)
        self.dims = dimensions(names)
        self.evaluator = evaluator or BatchEvaluator()
        #: a robot fitted to its recording walks its fit; robust worlds are drawn about it
        self.fitted = fitted_variation(self.evaluator.robot)
        self.ranges = fitted_ranges(self.evaluator.robot, self.ranges)
        #: each servo's stall torque on the nominal runs (JOINT_NAMES), for `torque_penalty`
        settings = joint_settings(self.evaluator.robot.description)
        self.stall_nm = [
            settings[j].stall_torque_nm * self.fitted.torque_scale for j in JOINT_NAMES
        ]
        self.duration_s, self.warmup_s = duration_s, warmup_s
        self.weights = weights = weights or LossWeights()
        start = base.gait.flat()
        x0 = [dim.to_unit(float(start[dim.name])) for dim in self.dims]
        options = {
            "bounds": [0.0, 1.0],
            "popsize": popsize,
            "seed": seed,
            "verbose": -9,
        }
        if len(self.dims) == 1:  # cma's step-size cap from the bounds fails on one dimension
            options["maxstd_boundrange"] = math.inf  # ("not yet initialized"): none for one
        import cma  # ~0.25 s: only to tune

        self.es = cma.CMAEvolutionStrategy(x0, sigma0, options)
        self.seed = seed
        self.settings = {
            "base": base.name,
            "names": list(names),
            "duration_s": duration_s,
            "warmup_s": warmup_s,
            "popsize": popsize,
            "sigma0": sigma0,
            "seed": seed,
            "runs": [name for name, _motion in self.runs],
        }
        if robust:
            self.settings |= {"robust": robust, "robust_weight": robust_weight,
                              "robust_loss": "families"}  # fmt: skip
            self.settings["ranges"] = {f.name: list(getattr(self.ranges, f.name))
                                       for f in dataclasses.fields(self.ranges)}  # fmt: skip
        if keep_base:
            self.settings["keep_base"] = keep_base
        self.settings |= weights.settings()
        self.best: tuple[float, GaitParams, dict[str, dict[str, Any]]] | None = None
        #: with --robust, each evaluated candidate's varied runs ("passed" of "runs"), by the
        #: id of its runs' dict in `evaluated` (`varied_summary`)
        self.robust_of: dict[int, dict[str, Any]] = {}
        self.evaluated: list[tuple[float, GaitParams, dict[str, dict[str, Any]]]] = []
        self.generation = 0
        #: a TRIAL event per candidate scored (replayed too), RUNS as a generation's runs end
        self.events = EventWriter(None)
        self.budget = 0  # candidates `run` may score: generations x popsize
        self.generations = 0  # the generations `run` was asked for (0: `evaluate` alone)
        self._walked = 0  # runs simulated by this `run` before the generation in hand
        self._since = time.monotonic()  # when this `run` began (what the time left is paced on)

    def variations(self, generation: int) -> list[Variation]:
        """The generation's worlds: every candidate walks the same ones (common random numbers),
        drawn anew each generation from the seed."""
        if not self.robust:
            return []
        return sample(self.ranges, self.robust, seed=self.seed * 100_003 + generation)

    def evaluate(
        self,
        candidates: Sequence[np.ndarray],
        progress: TextIO | None,
        *,
        done: Callable[[int, float, dict[str, Any]], None] | None = None,
    ) -> list[tuple[float, dict[str, dict[str, Any]]]]:
        """Loss and runs of each candidate; `done(i, loss, metrics)` as soon as candidate i's
        runs are all finished (the study store keeps it then)."""
        sets = [with_values(self.base.gait, self.dims, u) for u in candidates]
        worlds = self.variations(self.generation)
        varied = self.robust_runs()  # in a varied world only what the robust term judges
        per = len(self.runs) + len(worlds) * len(varied)

        def jobs_of(p: GaitParams) -> list[Job]:
            return [
                *(Job(p, m, variation=self.fitted) for _n, m in self.runs),
                *(Job(p, m, variation=v) for v in worlds for _n, m in varied),
            ]

        if self.keep_base and self.generation not in self._base_families:
            base_runs = self.evaluator.evaluate(
                jobs_of(self.base.gait), duration_s=self.duration_s, warmup_s=self.warmup_s
            )
            self._walked += per
            self._base_families[self.generation] = self._families([dict(m) for m in base_runs])
        jobs = [job for p in sets for job in jobs_of(p)]
        started = time.monotonic()
        finished: dict[int, dict[int, Any]] = {}
        out: list[tuple[float, dict[str, dict[str, Any]]] | None] = [None] * len(sets)
        line = None if progress is None else ProgressLine(progress)

        def report(n_done: int, total: int) -> None:
            left = self.time_left_s(n_done, total, per)
            self.events(RUNS, generation=self.generation, generations=self.generations,
                        done=n_done, total=total, left_s=left)  # fmt: skip
            if line is not None:
                best = "-" if self.best is None else f"{self.best[0]:.3f}"
                shown = bar(n_done, total) + " " if line.live else ""
                of = f" of {self.generations}" if self.generations else ""
                line.update(
                    n_done,
                    total,
                    f"generation {self.generation + 1}{of}: {shown}{n_done}/{total} runs, "
                    f"{time.monotonic() - started:.0f} s, {about(left)} left in all, "
                    f"best loss {best}",
                )

        def on_result(index: int, metrics: Mapping[str, Any]) -> None:
            i = index // per
            finished.setdefault(i, {})[index % per] = metrics
            if len(finished[i]) == per:
                runs = [finished[i][k] for k in range(per)]
                loss, stored = self.score(runs)
                out[i] = (loss, stored["nominal"])
                self._record(loss, sets[i], stored["nominal"], stored.get("robust"))
                if done is not None:
                    done(i, loss, stored)

        self.evaluator.evaluate(
            jobs,
            duration_s=self.duration_s,
            warmup_s=self.warmup_s,
            progress=report,
            on_result=on_result,
        )
        self._walked += len(jobs)
        evaluated = [o for o in out if o is not None]
        assert len(evaluated) == len(out)
        return evaluated

    def time_left_s(self, done: int, total: int, per: int) -> float | None:
        """The time left of the whole `run` (this generation's `total` runs, `done` of them
        walked, and `per` runs for each candidate of the generations after it) at the pace of
        the runs this `run` has walked so far; None before the first run ends."""
        walked = self._walked + done
        sets = self.es.popsize + (1 if self.keep_base else 0)  # and the base, kept
        after = max(self.generations - self.generation - 1, 0) * sets * per
        return time_left_s(time.monotonic() - self._since, walked, walked + total - done + after)

    def score(self, runs: list[dict[str, Any]]) -> tuple[float, dict[str, Any]]:
        """A candidate's loss from its runs (every judged run on the nominal model, then each
        world's `robust_runs`, world by world): the paper loss on the nominal model, plus with
        --robust the robust weight times the per-family term (`families_term`: the worst of
        spot, forward/backward, sideways, turning and curves, each family's pass share and
        worst quarter of worlds' pass margins scored apart, so a gain forward cannot hide a loss
        sideways), plus the torque weight times eq (1)'s margin of the nominal runs
        (`torque_penalty`; decision 0062), and with `keep_base` W times the families' pass
        share below the base set's in the same worlds (`kept_shortfall`, decision 0070). In a
        varied world the goal is to walk, not the paper's speed."""
        n = len(self.runs)
        home = {name: m for (name, _), m in zip(self.runs, runs[:n], strict=True)}
        nominal = total_loss(home, self.duration_s, self.weights)
        stored: dict[str, Any] = {"nominal": home}
        if len(runs) == n:
            return nominal, stored
        cases, names, worlds = self._varied(runs)
        varied = world_losses(cases, names, worlds, home)
        families = family_scores(cases, names, worlds, home)
        term = families_term(families)
        torque = torque_penalty(list(home.values()), self.stall_nm)
        stored["robust"] = {
            "losses": varied,
            "cvar25": cvar25(varied),
            "passed": sum(f["passed"] for f in families.values()),
            "runs": len(cases) * len(worlds),
            "families": families,
            "term": term,
            "torque": torque,
        }
        if self.keep_base:
            base = self._base_families[self.generation]
            shortfall = kept_shortfall(families, base)
            term += self.keep_base * shortfall
            stored["robust"] |= {"term": term, "base_shares": {f: b["share"] for f, b in
                                 base.items()}, "kept_shortfall": shortfall}  # fmt: skip
        return nominal + self.robust_weight * term + self.weights.torque * torque, stored

    def _varied(
        self, runs: list[dict[str, Any]]
    ) -> tuple[list[RobustCase], list[str], list[list[dict[str, Any]]]]:
        """The robustness cases of `robust_runs`, their names, and `runs`' varied runs world
        by world (after the nominal runs)."""
        judged = self.robust_runs()
        cases = [next(c for c in ROBUST_CASES if c.motion == m) for _n, m in judged]
        names = [name for name, _m in judged]
        n = len(self.runs)
        return cases, names, [runs[k : k + len(judged)] for k in range(n, len(runs), len(judged))]

    def _families(self, runs: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
        """`family_scores` of one set's runs (nominal runs, then each world's)."""
        home = {name: m for (name, _), m in zip(self.runs, runs[: len(self.runs)], strict=True)}
        cases, names, worlds = self._varied(runs)
        return family_scores(cases, names, worlds, home)

    def robust_runs(self) -> list[tuple[str, Motion]]:
        """The tuner's runs that walk a case of the robustness report (a tuner limited to
        some cases walks only theirs): what each varied world is judged on."""
        robust = {c.motion for c in ROBUST_CASES}
        return [(name, motion) for name, motion in self.runs if motion in robust]

    def run(
        self,
        generations: int,
        store: StudyStore,
        progress: TextIO | None = sys.stderr,
        *,
        events: EventWriter | None = None,
    ) -> ParameterSet:
        """Run until `generations` in total (counting resumed ones); return the best set;
        `events` (`app.analysis.robot_tune`) hears of each candidate scored and run walked.

        Resuming replays the store through the same seeded CMA-ES: it proposes the same
        candidates again; each recorded one takes its recorded loss, the others (a generation
        interrupted part way) are simulated, and the search carries on."""
        self.events = events or EventWriter(None)
        self.budget = generations * self.es.popsize
        self.generations, self._walked, self._since = generations, 0, time.monotonic()
        recorded = store.recorded()
        if (held := max(recorded, default=-1) + 1) > generations:
            raise ValueError(
                f"the study {store.where} holds {held} generations, more than the "
                f"{generations} asked for (a tune of fewer would choose among them only): give "
                f"--generations {held} or more to resume it, or use another --study file"
            )
        while self.generation < generations and not self.es.stop():
            candidates = self.es.ask()
            known = self._match(candidates, recorded.get(self.generation, []))
            missing = [i for i, row in enumerate(known) if row is None]
            losses: list[float] = [math.nan] * len(candidates)
            for i, row in enumerate(known):
                if row is not None:
                    losses[i] = row["loss"]
                    params = with_values(self.base.gait, self.dims, candidates[i])
                    metrics = row["metrics"]
                    self._record(row["loss"], params, metrics["nominal"], metrics.get("robust"))
            if missing:
                points = [candidates[i] for i in missing]
                keep = self._keeper(store, points)
                evaluated = self.evaluate(points, progress, done=keep)
                for i, (loss, _m) in zip(missing, evaluated, strict=True):
                    losses[i] = loss
            self.es.tell(candidates, losses)
            self.generation += 1
        if self.best is None:
            raise RuntimeError("nothing was evaluated")
        loss, params, _ = self.best
        return ParameterSet(name="tuned", gait=params)

    def _keeper(
        self, store: StudyStore, points: list[np.ndarray]
    ) -> Callable[[int, float, dict[str, Any]], None]:
        """What writes candidate j of `points` to the store as soon as it is evaluated (its
        trial lasts from the generation's start to its last run's end)."""
        generation = self.generation
        started = time.time()

        def keep(j: int, loss: float, stored: dict[str, Any]) -> None:
            u = points[j]
            values = {
                d.name: (d.to_value(x), d.low, d.high) for d, x in zip(self.dims, u, strict=True)
            }
            store.record(generation, u, values, loss, stored, started_s=started)

        return keep

    @staticmethod
    def _match(
        candidates: list[np.ndarray], rows: list[dict[str, Any]]
    ) -> list[dict[str, Any] | None]:
        """The recorded evaluation of each candidate, by its point in the unit box."""
        out: list[dict[str, Any] | None] = []
        for u in candidates:
            hit = next((r for r in rows if np.allclose(u, r["unit"], rtol=0, atol=1e-12)), None)
            out.append(hit)
        if rows and not any(out):
            raise ValueError(
                "the study's recorded candidates do not match this tuning run (another seed or "
                "settings); use another --study file"
            )
        return out

    def _record(
        self,
        loss: float,
        params: GaitParams,
        by_run: dict[str, dict[str, Any]],
        robust: dict[str, Any] | None = None,
    ) -> None:
        self.evaluated.append((loss, params, by_run))
        if robust is not None:  # with --robust: how its varied runs went
            self.robust_of[id(by_run)] = robust
        if self.best is None or loss < self.best[0]:
            self.best = (loss, params, by_run)
        self.events(
            TRIAL, done=len(self.evaluated), budget=self.budget, loss=loss, best=self.best[0]
        )
