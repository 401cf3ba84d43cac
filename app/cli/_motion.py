"""`--motion` as every `artro` command takes it: by name, `a_p=0.07,ca=0.1` (the keys and ranges
of the `Motion` schema, eqs (13), (28), (29) and seed 004's CA), or the older triple `AR,AP,AY`."""

from __future__ import annotations

import argparse
import dataclasses
import math
from dataclasses import dataclass

from gait import Motion
from gait.params import describe_fields

MOTION_METAVAR = "KEY=VALUE,...|AR,AP,AY"
MOTION_HELP = (
    "the motion by name, e.g. a_p=0.07 (forward) or a_r=-0.05 (left) or a_y=0.1,ca=0.05; keys "
    "a_r (> 0 steps right), a_p (> 0 walks forward), a_y and ca (> 0 turn clockwise), any of "
    "them, those left out 0; or the older triple AR,AP,AY (CA then stays the set's)"
)


def motion_fields() -> dict[str, tuple[float, float, str]]:
    """Each motion key -> (min, max, unit), from the schema."""
    return {name: (m["min"], m["max"], m["unit"]) for name, _d, m in describe_fields(Motion)}


def allowed_keys() -> str:
    """The keys and ranges, as the errors say them: `a_r (-0.3 to 0.3 rad), ...`."""
    return ", ".join(
        f"{k} ({_span(lo, hi, unit)})" for k, (lo, hi, unit) in motion_fields().items()
    )


def _span(low: float, high: float, unit: str) -> str:
    return f"{low:g} to {high:g}" + ("" if unit == "1" else f" {unit}")


@dataclass(frozen=True)
class MotionChoice:
    """What `--motion` gave: the values it sets, and whether it named them (then every key it
    left out is 0) or is the triple (then CA is the parameter set's)."""

    values: dict[str, float]
    named: bool

    def applied(self, motion: Motion, ca: float | None = None) -> Motion:
        """`motion` (the parameter set's) with this choice and a `--ca` on top; ValueError if
        CA is given both ways."""
        if ca is not None and "ca" in self.values:
            raise ValueError("CA is given twice: leave out either --ca or ca= in --motion")
        base = Motion(ca=motion.ca) if not self.named else Motion()
        out = dataclasses.replace(base, **self.values)
        return out if ca is None else dataclasses.replace(out, ca=ca)


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        return math.nan
    return value


def motion_arg(text: str) -> MotionChoice:
    """An argparse type for `--motion`: `KEY=VALUE,...` or `AR,AP,AY`; the error names the
    allowed keys and ranges (argparse exits with status 2)."""
    fields = motion_fields()
    allowed = f"allowed keys: {allowed_keys()}"
    if "=" not in text:  # the triple of older scripts
        parts = text.split(",")
        values = [_number(p) for p in parts]
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(
                f"expected three numbers a_r,a_p,a_y such as 0,0.07,0, or KEY=VALUE,... such as "
                f"a_p=0.07,ca=0.1 ({allowed}); got {text!r}"
            )
        choice = dict(zip(("a_r", "a_p", "a_y"), values, strict=True))
        named = False
    else:
        choice, named = {}, True
        for item in text.split(","):
            where = "" if item == text else f" in {text!r}"
            key, sep, raw = (part.strip() for part in item.partition("="))
            if not sep or key not in fields:
                raise argparse.ArgumentTypeError(
                    f"{item.strip()!r}{where} is not KEY=VALUE with a motion key; {allowed}"
                )
            if key in choice:
                raise argparse.ArgumentTypeError(f"{key} is given twice in {text!r}")
            choice[key] = _number(raw)
    for key, value in choice.items():
        low, high, unit = fields[key]
        if not low <= value <= high:  # NaN too
            raise argparse.ArgumentTypeError(
                f"{key} in {text!r} is not a number in its range; allowed: "
                f"{_span(low, high, unit)}; {allowed}"
            )
    return MotionChoice(choice, named)
