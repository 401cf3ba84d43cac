"""The tune for a robot as `artro tune --robot` runs it and the dashboard's "Tune for this robot"
job follows it (docs/DESIGN.md §12): the result's name, the study under the data folder, the
shortest run, the result's figures and the events the command writes (`--events`, JSON lines)."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

from app.analysis.cases import (
    CASES,
    CURVES,
    curve_run_names,
    measured,
    passes,
    steering,
    target,
    within_eq13,
)

#: the events, one JSON object a line: {"event": START | RUNS | TRIAL | RESULT, ...}
START, RUNS, TRIAL, RESULT = "start", "runs", "trial", "result"
STUDIES = "studies"  # the studies' folder in the data folder (beside `presets`)


def tuned_name(robot: str, builtins: Iterable[str]) -> str:
    """`tuned-ROBOT` (characters a preset name may not hold as '-'), never a built-in's name."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "-", f"tuned-{robot}")[:60].rstrip(".-")
    name, n, taken = stem, 1, set(builtins)
    while name in taken:
        n += 1
        name = f"{stem}-{n}"
    return name


def study_file(data_dir: Path, robot: str) -> Path:
    """The journal file of a robot's tunes from the dashboard: DATA/studies/tune-ROBOT.log."""
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "-", robot)[:60].strip(".-") or "robot"
    return Path(data_dir) / STUDIES / f"tune-{safe}.log"


def study_name(generations: int, popsize: int, duration_s: float, cases: Sequence[str]) -> str:
    """A study per budget, so that a tune of the same size resumes the one it continues."""
    judged = "all" if not cases else "+".join(sorted(c.replace(" ", "_") for c in cases))
    return f"artro-tune-g{generations}x{popsize}-{duration_s:g}s-{judged}"


def shortest_duration_s(freq_hz: float, warmup_s: float) -> float:
    """The shortest run that leaves a whole gait cycle at `freq_hz` after `warmup_s` (the runs
    are measured over whole cycles)."""
    return warmup_s + 1.0 / freq_hz


def result_figures(
    by_run: Mapping[str, Mapping[str, Any]], speed_scale: float = 1.0
) -> list[dict[str, Any]]:
    """What the chosen set did in each judged run, as `artro tune` prints it: a paper case's
    figure against its target ({"run", "unit", "target", "value", "fell", "passes"}: within
    the paper table's tolerance, `cases.passes`), a CA pair's steering against eq (13) ({"run",
    "gain", "bend", "fell", "passes"}: within 30 %, `within_eq13`); the runs not judged left
    out."""
    rows: list[dict[str, Any]] = []
    for case in CASES:
        if case.name not in by_run:
            continue
        metrics = by_run[case.name]
        value = measured(case, dict(metrics))
        unit = "deg/s" if case.metric == "turn_deg_s" else "cm/s"
        rows.append(
            {
                "run": case.name,
                "unit": unit,
                "target": target(case, speed_scale),
                "value": value,
                "fell": bool(metrics.get("fell")),
                "passes": passes(case, value, bool(metrics.get("fell")), speed_scale),
            }
        )
    for pair in CURVES:
        names = curve_run_names(pair)
        if pair.straight not in by_run or any(n not in by_run for n in names):
            continue
        plus, minus = (dict(by_run[n]) for n in names)
        s = steering(plus, minus, dict(by_run[pair.straight]))
        rows.append(
            {
                "run": pair.name,
                "gain": None if s is None else s.gain,
                "bend": None if s is None else s.bend,
                "fell": s is None,
                "passes": within_eq13(s),
            }
        )
    return rows


class EventWriter:
    """Writes the events to `out` (a line each, flushed at once); `None` writes nothing. A write
    that fails raises OSError naming `where` (the first event is written before any work)."""

    def __init__(self, out: TextIO | None, where: str = "the events") -> None:
        self.out, self.where = out, where

    def __call__(self, event: str, **fields: Any) -> None:
        if self.out is not None:
            line = json.dumps(_finite({"event": event, **fields}), allow_nan=False)
            try:
                self.out.write(line + "\n")
                self.out.flush()
            except OSError as exc:
                raise OSError(f"cannot write {self.where}: {exc.strerror or exc}") from exc


def _finite(value: Any) -> Any:
    """`value` with every float that is not finite as None (JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def read_event(line: str) -> dict[str, Any] | None:
    """The event a line of the command's output holds, None for any other line."""
    text = line.strip()
    if not text.startswith('{"event"'):
        return None
    try:
        event = json.loads(text)
    except ValueError:
        return None
    return event if isinstance(event, dict) and isinstance(event.get("event"), str) else None
