"""The runs of `artro bench paper`: presets, the job list, and batch rollouts that keep the path.

All runs of all presets go to one batch call (`run_all`); each keeps its trunk trace, one sample
per 20 ms frame -- the very samples its metrics come from -- for the plots.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.core.batch import Job
from app.core.evaluation import Evaluator, evaluator_for
from app.core.metrics import Trace, whole_cycles
from app.core.robot import RobotModel
from app.params.document import ParameterSet, load_parameter_set
from app.params.presets import BUILTIN_DIR
from app.study import speed_limits
from app.study.cases import CA_PROBE, CASES, PaperCase
from gait import GaitParams, Motion

NAMED_PRESETS = tuple(sorted(p.stem for p in BUILTIN_DIR.glob("*.json")))  # paper, tuned, ...
PROBE_CA = (-CA_PROBE, 0.0, CA_PROBE)
WALK_A_P = {"forward": 0.07, "backward": -0.07}  # seed 000's forward amplitude, both directions
CIRCLE_CA = 0.058  # seed 004: the simulated Nao walks a full circle at this CA


# other forward amplitudes to probe CA steering at (0.07 is the sweep's)
STEER_A_P = (0.035, 0.05, 0.09)
CA_BEYOND = (0.25, 0.3, 0.35, 0.4, 0.5)  # coarser, past seed 004's limits, to find where it falls


def ca_sweep(
    start: float = -0.20,
    stop: float = 0.20,
    step: float = 0.025,
    beyond: Sequence[float] = CA_BEYOND,
) -> tuple[float, ...]:
    """CA values start..stop (inclusive) in steps, +-each of `beyond`, 0 and the full-circle CA."""
    n = round((stop - start) / step)
    values = {round(start + i * step, 6) for i in range(n + 1)} | {0.0, CIRCLE_CA}
    values |= {sign * ca for ca in beyond for sign in (-1.0, 1.0)}
    return tuple(sorted(values))


@dataclass(frozen=True)
class BenchConfig:
    duration_s: float = 60.0
    warmup_s: float = 5.0
    ca_values: tuple[float, ...] = field(default_factory=ca_sweep)
    circle_s: float = 360.0  # the full-circle walk: eq (13) at 3.8 cm/s, b = 10 cm takes ~150 s
    steer_a_p: tuple[float, ...] = STEER_A_P
    limit_a_p: tuple[float, ...] = speed_limits.LIMIT_A_P  # the largest stable CA vs speed
    limit_ca: tuple[float, ...] = speed_limits.LIMIT_CA
    limit_duration_s: float = 30.0
    threads: int | None = None
    robot: str | None = None  # a built-in robot's name or a description file (default: artro)
    cluster: str | None = None  # a Dask scheduler (tcp://HOST:PORT) instead of local threads


QUICK = BenchConfig(
    duration_s=10.0,
    warmup_s=2.0,
    ca_values=(-0.2, -0.1, 0.0, 0.058, 0.1, 0.2),
    circle_s=12.0,
    steer_a_p=(0.05,),
    limit_a_p=(-0.05,),
    limit_ca=(0.2, 0.5),
    limit_duration_s=10.0,
)


@dataclass(frozen=True)
class Preset:
    name: str
    source: str  # the file it came from, or a note on where its values came from
    params: GaitParams


def resolve_presets(specs: Sequence[str]) -> tuple[list[Preset], list[str]]:
    """Presets for names ("paper", "tuned": models/presets/NAME.json) or parameter-set files.

    A missing paper.json means the paper defaults (ParameterSet()); any other named preset whose
    file is missing is skipped with a note. A missing explicit file is an error.
    """
    presets: list[Preset] = []
    notes: list[str] = []
    for spec in specs:
        if spec in NAMED_PRESETS:
            path = BUILTIN_DIR / f"{spec}.json"
            if path.is_file():
                presets.append(Preset(spec, str(path), load_parameter_set(path).gait))
            elif spec == "paper":
                presets.append(Preset("paper", "ParameterSet() defaults", ParameterSet().gait))
                notes.append(f"{path} not found: 'paper' uses the paper's values, ParameterSet()")
            else:
                notes.append(f"preset {spec!r} skipped: {path} not found")
            continue
        path = Path(spec)
        if not path.is_file():
            raise ValueError(
                f"preset {spec!r} is neither a named preset {list(NAMED_PRESETS)} nor a file"
            )
        pset = load_parameter_set(path)
        presets.append(Preset(pset.name or path.stem, str(path), pset.gait))
    names = [p.name for p in presets]
    if len(set(names)) != len(names):
        raise ValueError(f"preset names must differ, got {names}")
    return presets, notes


def cycle_mean(values: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """Centred moving mean over n samples (one gait cycle); NaN where the window is incomplete.

    Averaging over a whole cycle removes the trunk's sideways sway of each step and leaves the
    net progression that the differential-drive model describes.
    """
    if n <= 1:
        return values.astype(float)
    out = np.full(len(values), np.nan)
    if len(values) >= n:
        kernel = np.full(n, 1.0 / n)
        out[n // 2 : n // 2 + len(values) - n + 1] = np.convolve(values, kernel, mode="valid")
    return out


@dataclass(frozen=True)
class RunTrace:
    """The trunk path of one run, one sample per frame: time, pose (yaw unwrapped), feet apart."""

    t_s: NDArray[np.float64]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    yaw_rad: NDArray[np.float64]
    feet_m: NDArray[np.float64]

    @classmethod
    def from_trace(cls, trace: Trace) -> RunTrace:
        a = trace.arrays()
        return cls(t_s=a["t"], x_m=a["x"], y_m=a["y"], yaw_rad=a["yaw"], feet_m=a["feet"])

    def window(self, warmup_s: float, freq_hz: float) -> slice:
        """The measured samples: whole gait cycles after the warm-up (as app.core.metrics)."""
        return whole_cycles(self.t_s, warmup_s, freq_hz)


@dataclass
class Run:
    label: str
    motion: Motion
    metrics: dict[str, Any]
    trace: RunTrace


@dataclass
class PresetRuns:
    preset: Preset
    cases: dict[str, Run]  # by case name, in CASES order
    walks: dict[str, list[Run]]  # "forward" / "backward" -> runs in CA order
    circle: Run  # forward at CIRCLE_CA for config.circle_s
    steer_probes: dict[float, list[Run]]  # a_p -> the runs at CA = -CA_PROBE, 0, +CA_PROBE
    limit_walks: dict[float, list[Run]] = field(default_factory=dict)  # a_p -> runs, CA order


def _probe_label(a_p: float, ca: float) -> str:
    return f"steer a_p={a_p:+.3f} CA={ca:+.3f}"


def _walk_label(direction: str, ca: float) -> str:
    return f"{direction} CA={ca:+.3f}"


def plan_jobs(presets: Sequence[Preset], config: BenchConfig) -> list[tuple[Preset, str, Job]]:
    """(preset, label, job) for every case and every curve walk of every preset."""
    planned: list[tuple[Preset, str, Job]] = []
    for preset in presets:
        for case in CASES:
            planned.append((preset, case.name, Job(preset.params, case.motion)))
        for direction, a_p in WALK_A_P.items():
            for ca in config.ca_values:
                label = _walk_label(direction, ca)
                planned.append((preset, label, Job(preset.params, Motion(a_p=a_p, ca=ca))))
        for a_p in config.steer_a_p:
            for ca in PROBE_CA:
                job = Job(preset.params, Motion(a_p=a_p, ca=ca))
                planned.append((preset, _probe_label(a_p, ca), job))
    return planned


def run_all(
    presets: Sequence[Preset],
    config: BenchConfig,
    progress: Callable[[int, int], None] | None = None,
) -> list[PresetRuns]:
    """Simulate everything in one batch and sort the runs back by preset.

    For each preset (a parameter-set file; only its gait constants are used) the bench runs every
    case of `app.study.cases.CASES` and a curve-walking sweep (seed 004): a_p = +0.07 and -0.07 with
    CA up to the ends of its range (+-0.5), to find where the robot falls; and CA = -0.1, 0 and
    +0.1 forward at other amplitudes a_p (`BenchConfig.steer_a_p`): how CA steers at other speeds.
    All these runs of all presets go to one `evaluate` call so its threads (or workers) stay
    busy. A second call walks CA = 0.058 forward long enough for a full circle (seed 004, Fig. 5).
    """
    if not presets:
        raise ValueError("no presets to run")
    if 0.0 not in config.ca_values:
        raise ValueError("the CA sweep must contain 0: it gives V for eq (13)")
    evaluator = evaluator_for(
        RobotModel.load(config.robot), cluster=config.cluster, threads=config.threads
    )
    by_label = _walk(evaluator, plan_jobs(presets, config), config.duration_s, config, progress)
    circle_motion = Motion(a_p=WALK_A_P["forward"], ca=CIRCLE_CA)
    circle_traces: list[Trace] = []
    circle_metrics = evaluator.evaluate(
        [Job(preset.params, circle_motion) for preset in presets],
        duration_s=config.circle_s,
        warmup_s=config.warmup_s,
        traces=circle_traces,
    )
    circles = [
        Run(f"circle CA={CIRCLE_CA}", circle_motion, m, RunTrace.from_trace(trace))
        for m, trace in zip(circle_metrics, circle_traces, strict=True)
    ]
    limit_planned = [
        item
        for preset in presets
        for item in speed_limits.plan(preset, config.limit_a_p, config.limit_ca)
    ]
    by_label |= _walk(evaluator, limit_planned, config.limit_duration_s, config)
    limit_cas = speed_limits.limit_ca_values(config.limit_ca)
    out = []
    for preset, circle in zip(presets, circles, strict=True):
        cases = {c.name: by_label[preset.name, c.name] for c in CASES}
        walks = {
            d: [by_label[preset.name, _walk_label(d, ca)] for ca in config.ca_values]
            for d in WALK_A_P
        }
        probes = {
            a_p: [by_label[preset.name, _probe_label(a_p, ca)] for ca in PROBE_CA]
            for a_p in config.steer_a_p
        }
        limits = {
            a_p: [by_label[preset.name, speed_limits.label(a_p, ca)] for ca in limit_cas]
            for a_p in config.limit_a_p
        }
        # seed 000's +-0.07 from the CA sweep, at the same |CA| values where it has them
        for direction, a_p in WALK_A_P.items():
            sweep = [r for r in walks[direction] if round(r.motion.ca, 6) in limit_cas]
            if any(r.motion.ca == 0.0 for r in sweep):
                limits[a_p] = sweep
        out.append(PresetRuns(preset, cases, walks, circle, probes, limits))
    return out


def _walk(
    evaluator: Evaluator,
    planned: list[tuple[Preset, str, Job]],
    duration_s: float,
    config: BenchConfig,
    progress: Callable[[int, int], None] | None = None,
) -> dict[tuple[str, str], Run]:
    """Every planned run in one batch, keyed by (preset name, label), with its trunk path."""
    traces: list[Trace] = []
    metrics = evaluator.evaluate(
        [job for _, _, job in planned],
        duration_s=duration_s,
        warmup_s=config.warmup_s,
        progress=progress,
        traces=traces,
    )
    return {
        (preset.name, label): Run(label, job.motion, m, RunTrace.from_trace(trace))
        for (preset, label, job), m, trace in zip(planned, metrics, traces, strict=True)
    }


def case_by_name(name: str) -> PaperCase:
    return next(c for c in CASES if c.name == name)


def finite_or_none(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None
