"""The runs of `artro bench paper`: presets, the job list, and batch rollouts that keep the path.

For each preset (a parameter-set file; only its gait constants are used) the bench runs every case
of `app.paper_cases.CASES` and a curve-walking sweep (seed 004): a_p = +0.07 and -0.07 with CA over
a range. All runs of all presets go to one `BatchEvaluator.evaluate` call so its threads stay busy.

The plots need the trunk path as well as the metrics: the evaluator hands out each run's trace,
one sample per 20 ms frame -- the very samples the metrics are computed from.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.batch import BatchEvaluator, Job
from app.metrics import Trace, mean_body_velocity, whole_cycles
from app.paper_cases import CASES, PaperCase
from app.paramset import ParameterSet, load_parameter_set
from app.presets import BUILTIN_DIR
from app.simulation import FRAME_S
from gait import GaitParams, Motion

NAMED_PRESETS = ("paper", "tuned")
WALK_A_P = {"forward": 0.07, "backward": -0.07}  # seed 000's forward amplitude, both directions
CIRCLE_CA = 0.058  # seed 004: the simulated Nao walks a full circle at this CA


def ca_sweep(start: float = -0.20, stop: float = 0.20, step: float = 0.025) -> tuple[float, ...]:
    """CA values start..stop (inclusive) in steps, plus 0 and the paper's full-circle CA."""
    n = round((stop - start) / step)
    values = {round(start + i * step, 6) for i in range(n + 1)} | {0.0, CIRCLE_CA}
    return tuple(sorted(values))


@dataclass(frozen=True)
class BenchConfig:
    duration_s: float = 60.0
    warmup_s: float = 5.0
    ca_values: tuple[float, ...] = field(default_factory=ca_sweep)
    threads: int | None = None


QUICK = BenchConfig(duration_s=10.0, warmup_s=2.0, ca_values=(-0.2, -0.1, 0.0, 0.058, 0.1, 0.2))


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
        """The measured samples: whole gait cycles after the warm-up (as app.metrics)."""
        return whole_cycles(self.t_s, warmup_s, freq_hz)

    def net_velocity(self, warmup_s: float, freq_hz: float) -> tuple[float, float, float] | None:
        """(forward m/s, lateral m/s, turn rad/s) of the gait-cycle-mean path after the warm-up.

        The run metrics integrate the body-frame velocity of the swaying trunk; when the trunk's
        yaw oscillates with its sideways sway, that rectifies part of the sway into forward
        speed. The cycle-mean path has no sway: this is the speed a video of the robot shows.
        """
        per_cycle = max(1, round(1.0 / (freq_hz * FRAME_S)))
        means = [cycle_mean(v, per_cycle) for v in (self.x_m, self.y_m, self.yaw_rad)]
        window = self.window(warmup_s, freq_hz)
        ok = np.isfinite(means[0])
        ok[: window.start] = False
        idx = np.flatnonzero(ok)
        if len(idx) < 2:
            return None
        return mean_body_velocity(self.t_s[idx], *(m[idx] for m in means))


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
    return planned


def run_all(
    presets: Sequence[Preset],
    config: BenchConfig,
    progress: Callable[[int, int], None] | None = None,
) -> list[PresetRuns]:
    """Simulate everything in one batch and sort the runs back by preset."""
    if not presets:
        raise ValueError("no presets to run")
    if 0.0 not in config.ca_values:
        raise ValueError("the CA sweep must contain 0: it gives V for eq (13)")
    planned = plan_jobs(presets, config)
    traces: list[Trace] = []
    metrics = BatchEvaluator(threads=config.threads).evaluate(
        [job for _, _, job in planned],
        duration_s=config.duration_s,
        warmup_s=config.warmup_s,
        progress=progress,
        traces=traces,
    )
    by_label = {
        (preset.name, label): Run(label, job.motion, m, RunTrace.from_trace(trace))
        for (preset, label, job), m, trace in zip(planned, metrics, traces, strict=True)
    }
    out = []
    for preset in presets:
        cases = {c.name: by_label[preset.name, c.name] for c in CASES}
        walks = {
            d: [by_label[preset.name, _walk_label(d, ca)] for ca in config.ca_values]
            for d in WALK_A_P
        }
        out.append(PresetRuns(preset, cases, walks))
    return out


def case_by_name(name: str) -> PaperCase:
    return next(c for c in CASES if c.name == name)


def finite_or_none(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None
