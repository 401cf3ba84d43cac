"""`artro tune`: CMA-ES over chosen gait parameters toward the paper's measured walking.

One candidate = one parameter set, evaluated on every case of `app.paper_cases` (on the spot,
forward, sideways, turning, and their mirror images) with the batch evaluator. The loss rewards
each case's speed being the paper's (relative error squared), walking on the spot without drift,
not falling (a fall costs more the earlier it happens), little unwanted rotation or translation,
and a calm trunk (gyro RMS).

The search runs in a box normalised to [0, 1] per parameter (the schema's range), starting from a
base parameter set. Every evaluation is appended to a JSON-lines results file. Resuming replays
that file through the same seeded CMA-ES: the optimiser proposes the same candidates again, takes
the recorded losses instead of simulating, and carries on where the file ends. The best set found
is written as a parameter-set file with provenance.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import cma
import numpy as np

from app.batch import BatchEvaluator, Job
from app.paper_cases import (
    CASES,
    MIRROR_TOLERANCE,
    SPOT_DRIFT_LIMIT_CM_S,
    PaperCase,
    measured,
    passes,
)
from app.paramset import ParameterSet
from app.presets import stamped, write_parameter_set
from gait import GaitParams
from gait.params import describe_fields, group_class, merge

DEFAULT_NAMES = (
    "clock.freq_hz",
    "shift.amp_base",
    "short.amp_base",
    "short.amp_speed",
    "swing.v",
    "swing.o",
    "balance.foot_pitch_offset",
    "balance.leg_roll_offset",
)
FALL_LOSS = 20.0  # a fall costs this much, plus as much again scaled by how early it came
CROSS_TALK_WEIGHT = 0.2  # unwanted rotation while translating, translation while turning
GYRO_WEIGHT = 0.05
BAND_MARGIN = 0.2  # the band penalty starts at 20 % error, inside the 25 % tolerance


@dataclass(frozen=True)
class Dimension:
    name: str  # dotted, e.g. "swing.v"
    low: float
    high: float

    def to_value(self, u: float) -> float:
        return self.low + float(np.clip(u, 0.0, 1.0)) * (self.high - self.low)

    def to_unit(self, value: float) -> float:
        return (value - self.low) / (self.high - self.low)


def dimensions(names: Sequence[str]) -> list[Dimension]:
    """The tunable parameters with their schema ranges; ValueError names what is allowed."""
    out = []
    for name in names:
        group, _, field = name.partition(".")
        try:
            fields = {f: meta for f, _d, meta in describe_fields(group_class(group))}
        except KeyError:
            fields = {}
        meta = fields.get(field)
        if meta is None or meta.get("unit") == "bool":
            tunable = [
                f"{g}.{f}"
                for g in ("clock", "shift", "short", "swing", "load", "balance", "leg")
                for f, _d, m in describe_fields(group_class(g))
                if m.get("unit") != "bool"
            ]
            raise ValueError(f"{name!r} is not a tunable number; choose from {tunable}")
        out.append(Dimension(name, meta["min"], meta["max"]))
    return out


def with_values(base: GaitParams, dims: Sequence[Dimension], unit: np.ndarray) -> GaitParams:
    """`base` with each dimension set from its normalised coordinate."""
    patch: dict[str, dict[str, float]] = {}
    for dim, u in zip(dims, unit, strict=True):
        group, _, field = dim.name.partition(".")
        patch.setdefault(group, {})[field] = round(dim.to_value(u), 6)
    return merge(base, patch)


def case_loss(
    case: PaperCase, metrics: dict[str, Any], duration_s: float, band_weight: float = 0.0
) -> float:
    """One case's loss; `band_weight` > 0 adds a steep penalty for leaving the tolerance band."""
    if metrics["fell"]:
        fall_time = metrics.get("fall_time_s", 0.0)
        return FALL_LOSS * (2.0 - fall_time / duration_s)
    value = measured(case, metrics)
    if value is None:
        return FALL_LOSS
    if case.metric == "drift_cm_s":
        loss = (value / SPOT_DRIFT_LIMIT_CM_S) ** 2
        turn = metrics["turn_deg_s"] or 0.0
        return loss + CROSS_TALK_WEIGHT * (turn / 5.0) ** 2
    error = (value - case.paper) / case.paper
    loss = error**2 + band_weight * max(0.0, abs(error) - BAND_MARGIN) ** 2
    if case.metric == "turn_deg_s":
        drift = math.hypot(metrics["forward_cm_s"], metrics["lateral_cm_s"])
        loss += CROSS_TALK_WEIGHT * (drift / 1.0) ** 2
    else:
        loss += CROSS_TALK_WEIGHT * ((metrics["turn_deg_s"] or 0.0) / 5.0) ** 2
    return loss


def total_loss(
    per_case: Sequence[dict[str, Any]], duration_s: float, band_weight: float = 0.0
) -> float:
    loss = sum(
        case_loss(c, m, duration_s, band_weight) for c, m in zip(CASES, per_case, strict=True)
    )
    gyro = [m["gyro_rms"] for m in per_case if m.get("gyro_rms") is not None]
    return loss + GYRO_WEIGHT * (float(np.mean(gyro)) if gyro else 10.0)


class Tuner:
    def __init__(
        self,
        base: ParameterSet,
        names: Sequence[str] = DEFAULT_NAMES,
        *,
        evaluator: BatchEvaluator | None = None,
        duration_s: float = 20.0,
        warmup_s: float = 4.0,
        popsize: int = 10,
        sigma0: float = 0.12,
        seed: int = 1,
        band_weight: float = 0.0,
    ) -> None:
        self.base = base
        self.dims = dimensions(names)
        self.evaluator = evaluator or BatchEvaluator()
        self.duration_s, self.warmup_s = duration_s, warmup_s
        self.band_weight = band_weight
        start = base.gait.flat()
        x0 = [dim.to_unit(float(start[dim.name])) for dim in self.dims]
        options = {
            "bounds": [0.0, 1.0],
            "popsize": popsize,
            "seed": seed,
            "verbose": -9,
        }
        self.es = cma.CMAEvolutionStrategy(x0, sigma0, options)
        self.settings = {
            "base": base.name,
            "names": list(names),
            "duration_s": duration_s,
            "warmup_s": warmup_s,
            "popsize": popsize,
            "sigma0": sigma0,
            "seed": seed,
        }
        if band_weight:
            self.settings["band_weight"] = band_weight
        self.best: tuple[float, GaitParams, list[dict[str, Any]]] | None = None
        self.evaluated: list[tuple[float, GaitParams, list[dict[str, Any]]]] = []
        self.generation = 0

    def evaluate(
        self, candidates: Sequence[np.ndarray], progress: TextIO | None
    ) -> list[tuple[float, list]]:
        sets = [with_values(self.base.gait, self.dims, u) for u in candidates]
        jobs = [Job(p, case.motion) for p in sets for case in CASES]
        started = time.monotonic()

        def report(done: int, total: int) -> None:
            if progress is not None:
                _progress_bar(progress, self.generation, done, total, self.best, started)

        metrics = self.evaluator.evaluate(
            jobs, duration_s=self.duration_s, warmup_s=self.warmup_s, progress=report
        )
        n = len(CASES)
        out = []
        for i, params in enumerate(sets):
            per_case = metrics[i * n : (i + 1) * n]
            loss = total_loss(per_case, self.duration_s, self.band_weight)
            out.append((loss, per_case))
            self._record(loss, params, per_case)
        return out

    def run(
        self,
        generations: int,
        results_path: Path,
        progress: TextIO | None = sys.stderr,
    ) -> ParameterSet:
        """Run until `generations` in total (counting resumed ones); return the best set."""
        recorded = _read_results(results_path, self.settings)
        with results_path.open("a", encoding="utf-8") as log:
            if not recorded:
                log.write(json.dumps({"settings": self.settings}) + "\n")
            while self.generation < generations and not self.es.stop():
                candidates = self.es.ask()
                if self.generation < len(recorded):
                    losses = self._replay(candidates, recorded[self.generation])
                else:
                    evaluated = self.evaluate(candidates, progress)
                    losses = [loss for loss, _m in evaluated]
                    for u, (loss, per_case) in zip(candidates, evaluated, strict=True):
                        row = {
                            "generation": self.generation,
                            "unit": [float(x) for x in u],
                            "values": {
                                d.name: d.to_value(x) for d, x in zip(self.dims, u, strict=True)
                            },
                            "loss": loss,
                            "metrics": {c.name: m for c, m in zip(CASES, per_case, strict=True)},
                        }
                        log.write(json.dumps(row) + "\n")
                    log.flush()
                self.es.tell(candidates, losses)
                self.generation += 1
        if progress is not None:
            progress.write("\n")
        if self.best is None:
            raise RuntimeError("nothing was evaluated")
        loss, params, _ = self.best
        return ParameterSet(name="tuned", gait=params)

    def _replay(self, candidates: list[np.ndarray], rows: list[dict[str, Any]]) -> list[float]:
        if len(rows) != len(candidates) or not all(
            np.allclose(u, r["unit"], atol=1e-12) for u, r in zip(candidates, rows, strict=True)
        ):
            raise ValueError(
                "the results file does not match this tuning run (different settings or seed); "
                "use another --results file"
            )
        for u, r in zip(candidates, rows, strict=True):
            params = with_values(self.base.gait, self.dims, u)
            self._record(r["loss"], params, [r["metrics"][c.name] for c in CASES])
        return [r["loss"] for r in rows]

    def _record(self, loss: float, params: GaitParams, per_case: list[dict[str, Any]]) -> None:
        self.evaluated.append((loss, params, per_case))
        if self.best is None or loss < self.best[0]:
            self.best = (loss, params, per_case)

    def best_passing(self) -> tuple[float, GaitParams, list[dict[str, Any]]] | None:
        """The lowest-loss candidate that meets every paper criterion, if any did."""
        passing = [e for e in self.evaluated if meets_all_criteria(e[2])]
        return min(passing, key=lambda e: e[0]) if passing else None


def meets_all_criteria(per_case: Sequence[dict[str, Any]]) -> bool:
    """No fall, every case within its tolerance, mirror pairs within 15 % of each other."""
    values = {c.name: measured(c, m) for c, m in zip(CASES, per_case, strict=True)}
    for case, metrics in zip(CASES, per_case, strict=True):
        if not passes(case, values[case.name], metrics["fell"]):
            return False
    for case in CASES:
        if case.mirror_of:
            a, b = abs(values[case.name]), abs(values[case.mirror_of])
            if abs(a - b) > MIRROR_TOLERANCE * 0.5 * (a + b):
                return False
    return True


def _read_results(path: Path, settings: dict[str, Any]) -> list[list[dict[str, Any]]]:
    """Recorded evaluations grouped by generation; only whole generations count."""
    if not path.exists():
        return []
    lines = [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line]
    if not lines or lines[0].get("settings") != settings:
        found = lines[0].get("settings") if lines else None
        raise ValueError(
            f"{path} was written with other settings ({found}); "
            "use another --results file or the same options"
        )
    by_gen: dict[int, list[dict[str, Any]]] = {}
    for row in lines[1:]:
        by_gen.setdefault(row["generation"], []).append(row)
    popsize = settings["popsize"]
    out = []
    for gen in range(len(by_gen)):
        rows = by_gen.get(gen, [])
        if len(rows) != popsize:
            break
        out.append(rows)
    return out


def _progress_bar(
    stream: TextIO, generation: int, done: int, total: int, best, started: float
) -> None:
    width = 30
    filled = int(width * done / max(total, 1))
    best_text = "-" if best is None else f"{best[0]:.3f}"
    stream.write(
        f"\rgeneration {generation + 1}: [{'#' * filled}{'.' * (width - filled)}] "
        f"{done}/{total} runs, {time.monotonic() - started:5.0f} s, best loss {best_text}   "
    )
    stream.flush()


# --- the command line ---------------------------------------------------------------------------


def add_arguments(parser: Any) -> None:
    parser.add_argument("--base", default="paper", help="parameter-set file, or 'paper'")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="GROUP.FIELD=VALUE",
        help="change the base before tuning, e.g. leg.paper_signs=false (repeatable)",
    )
    parser.add_argument(
        "--tune", default=",".join(DEFAULT_NAMES), help="comma-separated parameters to tune"
    )
    parser.add_argument("--generations", type=int, default=30)
    parser.add_argument("--popsize", type=int, default=10)
    parser.add_argument("--sigma", type=float, default=0.12, help="initial step, share of range")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated s per case")
    parser.add_argument("--warmup", type=float, default=4.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--band-weight",
        type=float,
        default=0.0,
        help="extra penalty per case for errors beyond 20 %% (the tolerance is 25 %%)",
    )
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--results", default="out/tune/results.jsonl", help="resumable log")
    parser.add_argument("--out", default="out/tune/tuned.json", help="best set, as a preset file")
    parser.add_argument("--name", default="tuned", help="name of the saved preset")
    parser.add_argument(
        "--select",
        choices=("best", "passing"),
        default="best",
        help="save the lowest loss, or the lowest loss that meets every paper criterion",
    )


def command(args: Any) -> int:
    from app.paramset import load_parameter_set

    base = ParameterSet() if args.base == "paper" else load_parameter_set(args.base)
    overrides: dict[str, dict[str, Any]] = {}
    for item in args.set:
        key, sep, raw = item.partition("=")
        group, dot, field = key.partition(".")
        if not sep or not dot:
            raise ValueError(f"--set takes GROUP.FIELD=VALUE, got {item!r}")
        value: Any = {"true": True, "false": False}.get(raw.lower())
        overrides.setdefault(group, {})[field] = float(raw) if value is None else value
    base = dataclasses.replace(base, gait=merge(base.gait, overrides))
    names = [n.strip() for n in args.tune.split(",") if n.strip()]
    tuner = Tuner(
        base,
        names,
        evaluator=BatchEvaluator(threads=args.threads),
        duration_s=args.duration,
        warmup_s=args.warmup,
        popsize=args.popsize,
        sigma0=args.sigma,
        seed=args.seed,
        band_weight=args.band_weight,
    )
    tuner.settings["set"] = args.set
    results = Path(args.results)
    results.parent.mkdir(parents=True, exist_ok=True)
    tuner.run(args.generations, results)
    chosen = tuner.best
    if args.select == "passing":
        chosen = tuner.best_passing()
        if chosen is None:
            print("no candidate met every criterion; saving the lowest loss instead")
            chosen = tuner.best
    assert chosen is not None
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_parameter_set(out, stamped(ParameterSet(gait=chosen[1]), args.name))
    print(
        f"loss {chosen[0]:.4f} ({args.select}) after {tuner.generation} generations; "
        f"saved {args.out}"
    )
    for case, metrics in zip(CASES, chosen[2], strict=True):
        value = measured(case, metrics)
        shown = "fell" if metrics["fell"] else f"{value:+.2f}"
        print(f"  {case.name:24s} paper {case.paper:+6.1f}  tuned {shown}")
    return 0
