"""What a case's failures depend on, over a robust bench's variations: the 95 % Wilson interval
of a pass share, the parameters a failure may depend on, the one most correlated with failing and
whether the sample is large enough to trust it (docs/DESIGN.md §12)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from app.worlds.variations import FIELDS, Variation

Z95 = 1.959964  # the normal quantile of a two-sided 95 % interval


def wilson(k: int, n: int) -> tuple[float, float]:
    """The 95 % Wilson score interval of a share k / n (it stays inside [0, 1] at 0 % and 100 %,
    where the normal approximation's ±1.96·sqrt(p(1-p)/n), ±9.8 points at n = 100 and 50 %,
    does not)."""
    if n == 0:
        return 0.0, 1.0
    p = k / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / (1 + Z95**2 / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def features(v: Variation) -> dict[str, float]:
    """What a failure may depend on: the scalar fields, the tilt split into its downhill-forward
    and sideways parts, and the largest calibration error."""
    out = {f: float(getattr(v, f)) for f in FIELDS if f not in ("calibration_deg", "friction")}
    out["friction"] = 0.7 if v.friction is None else v.friction
    direction = math.radians(v.tilt_direction_deg)
    out["tilt_forward_deg"] = v.tilt_deg * math.cos(direction)
    out["tilt_sideways_deg"] = v.tilt_deg * abs(math.sin(direction))
    out["calibration_max_deg"] = max(abs(c) for c in v.calibration_deg)
    del out["tilt_direction_deg"]
    return out


def trust_p(r: float, n: int, compared: int) -> float:
    """How likely an |r| this large is by chance among `compared` parameters of n samples: the
    Fisher z test's two-sided p, times `compared` (Bonferroni: the largest of them was picked)."""
    if n <= 3:
        return 1.0
    z = math.atanh(min(abs(r), 0.999999)) * math.sqrt(n - 3)
    return min(1.0, compared * math.erfc(z / math.sqrt(2)))


TRUST_P = 0.05  # a correlation trusted: less likely than this by chance, the search counted
TRUST_EACH = 5  # ... and at least this many variations failing and as many passing


def dependence(variations: Sequence[Variation], failed: Sequence[bool]) -> dict[str, Any] | None:
    """The parameter most correlated with failing (point-biserial r), and the failure shares
    below and above its median; None when all pass or all fail. `trusted` says whether the sample
    is large enough to trust it (issue 56, item 15): `p_value` (`trust_p`) under TRUST_P and at
    least TRUST_EACH variations failing and passing."""
    y = np.array(failed, dtype=float)
    if y.min() == y.max():
        return None
    table = [features(v) for v in variations]
    best: dict[str, Any] | None = None
    compared = 0
    for name in table[0]:
        x = np.array([row[name] for row in table])
        if x.std() == 0:
            continue
        compared += 1
        r = float(np.corrcoef(x, y)[0, 1])
        if best is None or abs(r) > abs(best["r"]):
            median = float(np.median(x))
            best = {
                "parameter": name,
                "r": r,
                "median": median,
                "fail_below": float(y[x <= median].mean()),
                "fail_above": float(y[x > median].mean()) if (x > median).any() else 0.0,
            }
    if best is not None:
        n, failing = len(y), int(y.sum())
        p_value = trust_p(best["r"], n, compared)
        trusted = p_value < TRUST_P and min(failing, n - failing) >= TRUST_EACH
        best |= {"samples": n, "failing": failing, "compared": compared, "p_value": p_value,
                 "trusted": trusted}  # fmt: skip
    return best
