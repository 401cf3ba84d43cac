"""What `artro tune` searches and judges: the tunable gait fields (`tunable_fields`), the box
CMA-ES walks in (`Dimension`, normalised to [0, 1] per field) and the runs a candidate walks
(`judged_runs`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from app.analysis.cases import CASES, CURVES, JUDGED_RUNS, curve_run_names
from gait import GaitParams, Motion
from gait.params import FEEDBACK_GROUPS, describe_fields, group_class, merge

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


@dataclass(frozen=True)
class Dimension:
    name: str  # dotted, e.g. "swing.v"
    low: float
    high: float

    def to_value(self, u: float) -> float:
        return self.low + float(np.clip(u, 0.0, 1.0)) * (self.high - self.low)

    def to_unit(self, value: float) -> float:
        return (value - self.low) / (self.high - self.low)


TUNABLE_GROUPS = ("clock", "shift", "short", "swing", "load", "balance", "leg", *FEEDBACK_GROUPS)


def tunable_fields() -> dict[str, list[str]]:
    """What `--tune` accepts: each group -> its numeric fields (switches are not tuned)."""
    return {
        group: [f for f, _d, m in describe_fields(group_class(group)) if m.get("unit") != "bool"]
        for group in TUNABLE_GROUPS
    }


def dimensions(names: Sequence[str]) -> list[Dimension]:
    """The tunable parameters with their schema ranges; ValueError names what is allowed."""
    tunable = [f"{g}.{f}" for g, fs in tunable_fields().items() for f in fs]
    if not names:
        raise ValueError(f"nothing to tune: name at least one of {tunable}")
    twice = sorted({n for n in names if list(names).count(n) > 1})
    if twice:
        raise ValueError(f"each parameter to tune once: {', '.join(twice)} named twice")
    out = []
    for name in names:
        group, _, field = name.partition(".")
        try:
            fields = {f: meta for f, _d, meta in describe_fields(group_class(group))}
        except KeyError:
            fields = {}
        meta = fields.get(field)
        if meta is None or meta.get("unit") == "bool":
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


def judged_runs(cases: Sequence[str] | None) -> tuple[tuple[str, Motion], ...]:
    """JUDGED_RUNS, or only the named cases and the curve pairs walking at their a_p."""
    if not cases:
        return JUDGED_RUNS
    known = [c.name for c in CASES]
    unknown = [c for c in cases if c not in known]
    if unknown:
        raise ValueError(f"unknown cases {unknown}; allowed: {', '.join(known)}")
    twice = sorted({c for c in cases if list(cases).count(c) > 1})
    if twice:
        raise ValueError(f"each case once: {', '.join(twice)} named twice")
    curves = {n for p in CURVES if p.straight in cases for n in curve_run_names(p)}
    return tuple((n, m) for n, m in JUDGED_RUNS if n in cases or n in curves)
