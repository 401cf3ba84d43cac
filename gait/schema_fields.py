"""Field helpers of the one parameter schema (docs/DESIGN.md §4): a tunable number or a switch, with
the metadata that validation, sliders and exports are generated from, and the range check."""

from __future__ import annotations

import math
from dataclasses import field, fields
from typing import Any

#: user-facing group names by class name, for error messages ("swing.v", not "SwingParams.v");
#: `gait.params` registers its groups
GROUP_KEYS: dict[str, str] = {"Motion": "motion"}


def tunable(
    default: float,
    lo: float,
    hi: float,
    *,
    step: float,
    unit: str,
    eq: str,
    doc: str,
) -> Any:
    """A tunable float field: its paper default plus the metadata the UI and validation use."""
    meta = {"min": lo, "max": hi, "step": step, "unit": unit, "eq": eq, "doc": doc}
    return field(default=default, metadata=meta)


def switch(doc: str, default: bool = True) -> Any:
    """An on/off field (unit "bool")."""
    return field(default=default, metadata={"unit": "bool", "doc": doc, "eq": ""})


def check_ranges(obj: Any) -> None:
    """ValueError naming `group.field` and the allowed range if a number of `obj` is outside it,
    not finite, or no number."""
    for f in fields(obj):
        meta = f.metadata
        if "min" not in meta:
            continue
        value = getattr(obj, f.name)
        where = f"{GROUP_KEYS.get(type(obj).__name__, type(obj).__name__)}.{f.name}"
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise ValueError(f"{where} must be a number, got {value!r}")
        if not math.isfinite(value) or not meta["min"] <= value <= meta["max"]:
            unit = "" if meta["unit"] == "1" else f" {meta['unit']}"
            allowed = f"{meta['min']} to {meta['max']}{unit}"
            raise ValueError(f"{where} = {value!r} is out of range; allowed: {allowed}")
