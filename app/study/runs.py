"""The runs of `artro bench paper`: presets, the job list, and batch rollouts that keep the path.

All runs of all presets go to one batch call (`run_all`); each keeps its trunk trace, one sample
per 20 ms frame -- the very samples its metrics come from -- for the plots.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from app.analysis.cases import CA_PROBE, CASES, PaperCase
from app.evaluation import Evaluator, Job, close_evaluator, evaluator_for
from app.robots.model import RobotModel
from app.sim.metrics import Trace
from app.study import speed_limits
from app.study.walks import Preset, Run, RunTrace
from gait import Motion

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
    wait_workers_s: float | None = None  # for a worker of that scheduler (default 60 s)
    backend: str = "cpu"  # or "warp", "auto": MuJoCo Warp (docs/GPU.md)
    device: str | None = None  # of the warp backend (default cuda)


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
    case of `app.analysis.cases.CASES` and a curve-walking sweep (seed 004): a_p = +0.07 and -0.07
    with CA up to the ends of its range (+-0.5), to find where the robot falls; and CA = -0.1, 0
    and +0.1 forward at other amplitudes a_p (`BenchConfig.steer_a_p`): how CA steers at other
    speeds.
    All these runs of all presets go to one `evaluate` call so its threads (or workers) stay
    busy. A second call walks CA = 0.058 forward long enough for a full circle (seed 004, Fig. 5).
    """
    if not presets:
        raise ValueError("no presets to run")
    if 0.0 not in config.ca_values:
        raise ValueError("the CA sweep must contain 0: it gives V for eq (13)")
    evaluator = evaluator_for(
        RobotModel.load(config.robot),
        cluster=config.cluster,
        threads=config.threads,
        wait_workers_s=config.wait_workers_s,
        backend=config.backend,
        device=config.device,
    )
    try:
        return _bench(presets, config, evaluator, progress)
    finally:
        close_evaluator(evaluator)


def _bench(
    presets: Sequence[Preset],
    config: BenchConfig,
    evaluator: Evaluator,
    progress: Callable[[int, int], None] | None,
) -> list[PresetRuns]:
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
