"""`artro tune`: CMA-ES over chosen gait parameters toward the paper's measured walking.

Each candidate is scored on `app.study.cases.JUDGED_RUNS` by `total_loss`; the search, its
resumable results file and its output are described at `Tuner`.
"""

from __future__ import annotations

import argparse
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

from app.core.batch import BatchEvaluator, Job
from app.params.document import ParameterSet
from app.params.presets import stamped, write_parameter_set
from app.study.cases import (
    CASES,
    CURVES,
    JUDGED_RUNS,
    MIRROR_TOLERANCE,
    SPOT_DRIFT_LIMIT_CM_S,
    CurvePair,
    PaperCase,
    curve_run_names,
    measured,
    passes,
    steering,
    steers_right,
)
from gait import GaitParams, Motion
from gait.params import describe_fields, group_class, merge, parse_settings

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
GYRO_WEIGHT = 0.05
BAND_MARGIN = 0.2  # the band penalty starts at 20 % error, inside the 25 % tolerance
STEERING_WEIGHT = {True: 1.0, False: 0.5}  # the required (forward) pair, the backward one
BEND_WEIGHT = 4.0  # tipping into a turn either way is not steering


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


@dataclass(frozen=True)
class LossWeights:
    """The weights `artro tune` lets one change; a results file records those not at default."""

    band: float = 0.0  # > 0: a steep extra penalty per case for errors beyond BAND_MARGIN
    steering: float = 1.0  # scale of the CA steering terms (gain toward eq (13), bend)
    cross_talk: float = 0.2  # unwanted rotation while translating, translation while turning

    def settings(self) -> dict[str, float]:
        default = LossWeights()
        return {
            f"{f.name}_weight": getattr(self, f.name)
            for f in dataclasses.fields(self)
            if getattr(self, f.name) != getattr(default, f.name)
        }


def case_loss(
    case: PaperCase,
    metrics: dict[str, Any],
    duration_s: float,
    weights: LossWeights = LossWeights(),
) -> float:
    """One case's loss: the relative speed error squared, plus the cross-talk terms."""
    if metrics["fell"]:
        fall_time = metrics.get("fall_time_s", 0.0)
        return FALL_LOSS * (2.0 - fall_time / duration_s)
    value = measured(case, metrics)
    if value is None:
        return FALL_LOSS
    if case.metric == "drift_cm_s":
        loss = (value / SPOT_DRIFT_LIMIT_CM_S) ** 2
        turn = metrics["turn_deg_s"] or 0.0
        return loss + weights.cross_talk * (turn / 5.0) ** 2
    error = (value - case.paper) / case.paper
    loss = error**2 + weights.band * max(0.0, abs(error) - BAND_MARGIN) ** 2
    if case.metric == "turn_deg_s":
        drift = math.hypot(metrics["forward_cm_s"], metrics["lateral_cm_s"])
        loss += weights.cross_talk * (drift / 1.0) ** 2
    else:
        loss += weights.cross_talk * ((metrics["turn_deg_s"] or 0.0) / 5.0) ** 2
    return loss


def curve_loss(
    pair: CurvePair,
    plus: dict[str, Any],
    minus: dict[str, Any],
    straight: dict[str, Any],
    duration_s: float,
    weights: LossWeights = LossWeights(),
) -> float:
    """A fall as in `case_loss` (the straight walk is a case of its own); else the squared
    distance of the steering gain from 1 and the squared bend (`app.study.cases.Steering`)."""
    falls = [m for m in (plus, minus) if m["fell"]]
    if falls:
        return sum(FALL_LOSS * (2.0 - m.get("fall_time_s", 0.0) / duration_s) for m in falls)
    s = steering(plus, minus, straight)
    if s is None:
        return FALL_LOSS if not straight["fell"] else 0.0
    weight = weights.steering * STEERING_WEIGHT[pair.required]
    return weight * ((s.gain - 1.0) ** 2 + BEND_WEIGHT * s.bend**2)


def total_loss(
    by_run: dict[str, dict[str, Any]], duration_s: float, weights: LossWeights = LossWeights()
) -> float:
    """The loss of one parameter set from its runs' metrics, keyed by JUDGED_RUNS names.

    JUDGED_RUNS: on the spot, forward, sideways, turning, their mirror images, and curve walking at
    CA = +-0.1 forward and backward. The loss rewards each case's speed being the paper's (relative
    error squared), walking on the spot without drift, CA steering as eq (13) says (the gain of
    `steering` near 1), not falling (a fall costs more the earlier it happens), little unwanted
    rotation or translation, and a calm trunk (gyro RMS).
    """
    loss = sum(case_loss(c, by_run[c.name], duration_s, weights) for c in CASES if c.name in by_run)
    for pair in CURVES:
        if not _judged(pair, by_run):
            continue
        plus, minus = (by_run[name] for name in curve_run_names(pair))
        loss += curve_loss(pair, plus, minus, by_run[pair.straight], duration_s, weights)
    gyro = [m["gyro_rms"] for m in by_run.values() if m.get("gyro_rms") is not None]
    return loss + GYRO_WEIGHT * (float(np.mean(gyro)) if gyro else 10.0)


class Tuner:
    """CMA-ES over `names` (dotted gait fields), starting from `base`, scored by `total_loss`.

    The search runs in a box normalised to [0, 1] per parameter (the schema's range). Every
    evaluation is appended to a JSON-lines results file. Resuming replays that file through the
    same seeded CMA-ES: the optimiser proposes the same candidates again, takes the recorded losses
    instead of simulating, and carries on where the file ends. `artro tune` (`command`) writes the
    best set found as a parameter-set file with provenance.
    """

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
        weights: LossWeights = LossWeights(),
        cases: Sequence[str] | None = None,
    ) -> None:
        self.base = base
        self.runs = judged_runs(cases)
        self.dims = dimensions(names)
        self.evaluator = evaluator or BatchEvaluator()
        self.duration_s, self.warmup_s = duration_s, warmup_s
        self.weights = weights
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
            "runs": [name for name, _motion in self.runs],
        }
        self.settings |= weights.settings()
        self.best: tuple[float, GaitParams, dict[str, dict[str, Any]]] | None = None
        self.evaluated: list[tuple[float, GaitParams, dict[str, dict[str, Any]]]] = []
        self.generation = 0

    def evaluate(
        self, candidates: Sequence[np.ndarray], progress: TextIO | None
    ) -> list[tuple[float, dict[str, dict[str, Any]]]]:
        sets = [with_values(self.base.gait, self.dims, u) for u in candidates]
        jobs = [Job(p, motion) for p in sets for _name, motion in self.runs]
        started = time.monotonic()

        def report(done: int, total: int) -> None:
            if progress is not None:
                _progress_bar(progress, self.generation, done, total, self.best, started)

        metrics = self.evaluator.evaluate(
            jobs, duration_s=self.duration_s, warmup_s=self.warmup_s, progress=report
        )
        n = len(self.runs)
        out = []
        for i, params in enumerate(sets):
            runs = zip(self.runs, metrics[i * n : (i + 1) * n], strict=True)
            by_run = {name: m for (name, _motion), m in runs}
            loss = total_loss(by_run, self.duration_s, self.weights)
            out.append((loss, by_run))
            self._record(loss, params, by_run)
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
                    for u, (loss, by_run) in zip(candidates, evaluated, strict=True):
                        row = {
                            "generation": self.generation,
                            "unit": [float(x) for x in u],
                            "values": {
                                d.name: d.to_value(x) for d, x in zip(self.dims, u, strict=True)
                            },
                            "loss": loss,
                            "metrics": by_run,
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
            self._record(r["loss"], params, r["metrics"])
        return [r["loss"] for r in rows]

    def _record(self, loss: float, params: GaitParams, by_run: dict[str, dict[str, Any]]) -> None:
        self.evaluated.append((loss, params, by_run))
        if self.best is None or loss < self.best[0]:
            self.best = (loss, params, by_run)

    def best_passing(
        self, by: str = "loss"
    ) -> tuple[float, GaitParams, dict[str, dict[str, Any]]] | None:
        """Of the candidates that meet every paper criterion (if any did): the lowest loss
        (by="loss"), or the one CA steers most, forward (by="steering": the highest gain)."""
        passing = [e for e in self.evaluated if meets_all_criteria(e[2])]
        if not passing:
            return None
        if by == "steering":
            pair = next(p for p in CURVES if p.required)

            def gain(entry: tuple[float, GaitParams, dict[str, dict[str, Any]]]) -> float:
                plus, minus = (entry[2][name] for name in curve_run_names(pair))
                s = steering(plus, minus, entry[2][pair.straight])
                return -math.inf if s is None else s.gain

            return max(passing, key=gain)
        return min(passing, key=lambda e: e[0])


def _judged(pair: Any, by_run: dict[str, Any]) -> bool:
    """The curve pair was walked (a tuner limited to some cases walks only theirs)."""
    return pair.straight in by_run and all(n in by_run for n in curve_run_names(pair))


def judged_runs(cases: Sequence[str] | None) -> tuple[tuple[str, Motion], ...]:
    """JUDGED_RUNS, or only the named cases and the curve pairs walking at their a_p."""
    if not cases:
        return JUDGED_RUNS
    known = [c.name for c in CASES]
    unknown = [c for c in cases if c not in known]
    if unknown:
        raise ValueError(f"unknown cases {unknown}; allowed: {', '.join(known)}")
    curves = {n for p in CURVES if p.straight in cases for n in curve_run_names(p)}
    return tuple((n, m) for n, m in JUDGED_RUNS if n in cases or n in curves)


def meets_all_criteria(by_run: dict[str, dict[str, Any]]) -> bool:
    """No fall, every case within its tolerance, mirror pairs within 15 % of each other, and CA
    steering forward the way eq (13) says, in proportion (`steers_right`). How close the rate
    comes to eq (13)'s (the issue's 30 %) is reported, not required: no gait on this model has
    been found to reach it without tipping (models/README.md)."""
    values = {c.name: measured(c, by_run[c.name]) for c in CASES if c.name in by_run}
    for case in CASES:
        if case.name in values and not passes(case, values[case.name], by_run[case.name]["fell"]):
            return False
    for pair in CURVES:
        if not _judged(pair, by_run):
            continue
        plus, minus = (by_run[name] for name in curve_run_names(pair))
        if pair.required and not steers_right(steering(plus, minus, by_run[pair.straight])):
            return False
    for case in CASES:
        if case.mirror_of and case.name in values and case.mirror_of in values:
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

MAX_DURATION_S = 3600.0  # one simulated hour per case at most


def number(
    low: float, high: float, *, integer: bool = False, above: bool = False, what: str = "it"
) -> Any:
    """An argparse type: a finite number from `low` (exclusive if `above`) to `high`; the error
    says what is allowed (argparse exits with status 2)."""
    kind = "a whole number " if integer else ""
    allowed = f"> {low:g} and at most {high:g}" if above else f"{low:g} to {high:g}"

    def parse(text: str) -> float | int:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value > high or (value <= low if above else value < low):
            raise argparse.ArgumentTypeError(f"{what} must be {kind}{allowed}, got {text!r}")
        return value

    return parse


def check_timing(
    names: Sequence[str], base: GaitParams, duration_s: float, warmup_s: float
) -> None:
    """Each run must leave at least one whole gait cycle after the warm-up (the metrics are
    measured over whole cycles): of the slowest clock the search may try. ValueError otherwise."""
    slowest = base.clock.freq_hz
    if "clock.freq_hz" in names:
        slowest = next(
            m["min"] for f, _d, m in describe_fields(group_class("clock")) if f == "freq_hz"
        )
    need = warmup_s + 1.0 / slowest
    if duration_s < need:
        raise ValueError(
            f"--duration {duration_s:g} leaves no whole gait cycle after --warmup {warmup_s:g}: "
            f"the runs are measured over whole cycles after the warm-up, and a cycle at "
            f"{slowest:g} Hz takes {1.0 / slowest:g} s; allowed: --duration of at least {need:g}"
        )


def add_arguments(parser: Any) -> None:
    parser.add_argument("--base", default="paper", help="parameter-set file, or 'paper'")
    parser.add_argument(
        "--cases",
        default=None,
        metavar="NAME,...",
        help="judge only these paper cases (e.g. forward,backward) and the CA pairs at their "
        "speed; default: all of them",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="GROUP.FIELD=VALUE",
        help="change the base before tuning, e.g. leg.paper_signs=false or engine=pfs (repeatable)",
    )
    parser.add_argument(
        "--tune", default=",".join(DEFAULT_NAMES), help="comma-separated parameters to tune"
    )
    whole = {"integer": True}
    parser.add_argument(
        "--generations", type=number(1, 100_000, **whole, what="generations"), default=30
    )
    parser.add_argument(
        "--popsize",
        type=number(2, 1000, **whole, what="popsize"),
        default=10,
        help="candidates per generation (CMA-ES needs 2 or more)",
    )
    parser.add_argument(
        "--sigma",
        type=number(0, 1, above=True, what="sigma"),
        default=0.12,
        help="initial step, share of range",
    )
    parser.add_argument(
        "--duration",
        type=number(0, MAX_DURATION_S, above=True, what="duration"),
        default=20.0,
        help="simulated s per case; at least one gait cycle longer than --warmup",
    )
    parser.add_argument("--warmup", type=number(0, MAX_DURATION_S, what="warmup"), default=4.0)
    parser.add_argument("--seed", type=number(0, 2**32 - 1, **whole, what="seed"), default=1)
    parser.add_argument(
        "--band-weight",
        type=number(0, 1000, what="band weight"),
        default=0.0,
        help="extra penalty per case for errors beyond 20 %% (the tolerance is 25 %%)",
    )
    parser.add_argument(
        "--steering-weight",
        type=number(0, 1000, what="steering weight"),
        default=1.0,
        help="scale of the CA steering terms (gain toward eq (13), bend) in the loss",
    )
    parser.add_argument(
        "--cross-talk-weight",
        type=number(0, 1000, what="cross-talk weight"),
        default=0.2,
        help="weight of unwanted rotation while translating and translation while turning",
    )
    parser.add_argument("--threads", type=number(1, 1024, **whole, what="threads"), default=None)
    parser.add_argument("--results", default="out/tune/results.jsonl", help="resumable log")
    parser.add_argument("--out", default="out/tune/tuned.json", help="best set, as a preset file")
    parser.add_argument("--name", default="tuned", help="name of the saved preset")
    parser.add_argument(
        "--select",
        choices=("best", "passing", "steering"),
        default="best",
        help="save the lowest loss; the lowest loss that meets every paper criterion; or of "
        "those, the one CA steers most (forward)",
    )


def command(args: Any) -> int:
    from app.params.document import load_parameter_set

    base = ParameterSet() if args.base == "paper" else load_parameter_set(args.base)
    base = dataclasses.replace(base, gait=merge(base.gait, parse_settings(args.set)))
    names = [n.strip() for n in args.tune.split(",") if n.strip()]
    check_timing(names, base.gait, args.duration, args.warmup)
    tuner = Tuner(
        base,
        names,
        evaluator=BatchEvaluator(threads=args.threads),
        duration_s=args.duration,
        warmup_s=args.warmup,
        popsize=args.popsize,
        sigma0=args.sigma,
        seed=args.seed,
        weights=LossWeights(
            band=args.band_weight, steering=args.steering_weight, cross_talk=args.cross_talk_weight
        ),
        cases=[c.strip() for c in args.cases.split(",") if c.strip()] if args.cases else None,
    )
    tuner.settings["set"] = args.set
    results = Path(args.results)
    results.parent.mkdir(parents=True, exist_ok=True)
    tuner.run(args.generations, results)
    chosen = tuner.best
    if args.select in ("passing", "steering"):
        chosen = tuner.best_passing(by="loss" if args.select == "passing" else "steering")
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
    for case in CASES:
        if case.name not in chosen[2]:
            continue  # not judged (--cases)
        metrics = chosen[2][case.name]
        value = measured(case, metrics)
        shown = "fell" if metrics["fell"] else f"{value:+.2f}"
        print(f"  {case.name:24s} paper {case.paper:+6.1f}  tuned {shown}")
    for pair in CURVES:
        if not _judged(pair, chosen[2]):
            continue
        plus, minus = (chosen[2][name] for name in curve_run_names(pair))
        s = steering(plus, minus, chosen[2][pair.straight])
        shown = "fell" if s is None else f"gain {s.gain:.2f}, bend {s.bend:+.2f}"
        print(f"  {pair.name:24s} eq (13): gain 1, bend 0;  tuned {shown}")
    return 0
