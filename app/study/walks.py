"""What a study walks and keeps: presets by name or file (`resolve_presets`), and each run's
metrics with its trunk path, one sample per 20 ms frame (`Run`, `RunTrace`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.params.document import ParameterSet
from app.params.formats import load_parameter_set
from app.params.presets import BUILTIN_DIR
from app.sim.metrics import Trace, whole_cycles
from gait import GaitParams, Motion

NAMED_PRESETS = tuple(sorted(p.stem for p in BUILTIN_DIR.glob("*.json")))  # paper, tuned, ...


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
        """The measured samples: whole gait cycles after the warm-up (as app.sim.metrics)."""
        return whole_cycles(self.t_s, warmup_s, freq_hz)


@dataclass
class Run:
    label: str
    motion: Motion
    metrics: Mapping[str, Any]
    trace: RunTrace
