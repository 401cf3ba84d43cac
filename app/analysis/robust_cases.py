"""The cases `artro bench robust` and `artro tune --robust` judge a gait on (the paper's and
CA = ±0.1 forward) and the one pass rule: `passes`, its smooth form `pass_margin_loss` and its
words `PASS_RULE` (docs/DESIGN.md §12)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from app.analysis.cases import CA_PROBE, CASES
from gait import Motion

#: "Passes": no fall, and the case's motion in the right direction at >= this share of the
#: nominal model's figure; translating, the heading drifts by at most MAX_TURN_DEG_S.
PASS_SHARE = 0.5
MAX_TURN_DEG_S = 5.0
SPOT_DRIFT_CM_S = 1.0  # on the spot: drift at most this, and the heading as above
#: the nominal model walks a case when it moves the case's way (the paper's sign; a CA curve
#: eq (13)'s) by at least this much, cm/s or deg/s: judged against its own figure, a gait that
#: barely moves (or the wrong way) let varied runs that stood still pass (decision 0044)
NOMINAL_WALKS_CM_S, NOMINAL_WALKS_DEG_S = 0.3, 1.0


@dataclass(frozen=True)
class RobustCase:
    name: str
    motion: Motion
    kind: str  # "spot", "forward", "lateral", "turn", "curve"
    way: float  # the sign its figure should have (0: on the spot)


#: the paper's cases (`app.analysis.cases.CASES`), and CA = +-0.1 walking forward (CA > 0 turns
#: clockwise: its heading rate is negative)
ROBUST_CASES = (
    *(
        RobustCase(c.name, c.motion, c.kind, math.copysign(1.0, c.paper) if c.paper else 0.0)
        for c in CASES
    ),
    RobustCase(f"curve CA +{CA_PROBE:g}", Motion(a_p=0.07, ca=CA_PROBE), "curve", -1.0),
    RobustCase(f"curve CA -{CA_PROBE:g}", Motion(a_p=0.07, ca=-CA_PROBE), "curve", 1.0),
)


def figure_metric(case: RobustCase) -> str:
    """The run metric a case is judged on, as `bench paper` names it (signed as docs/DESIGN.md
    §3: forward +, left +, counter-clockwise +; "drift_cm_s", on the spot, has no sign)."""
    if case.kind == "spot":
        return "drift_cm_s"
    return {"forward": "forward_cm_s", "lateral": "lateral_cm_s"}.get(case.kind, "turn_deg_s")


def case_figure(case: RobustCase, m: Mapping[str, Any]) -> float | None:
    """A run's figure for `case` (`figure_metric`; on the spot the drift, cm/s), None where the
    run has none."""
    if case.kind == "spot":
        fwd, lat = m.get("forward_cm_s"), m.get("lateral_cm_s")
        return None if fwd is None or lat is None else math.hypot(fwd, lat)
    return m.get(figure_metric(case))


def nominal_walks(case: RobustCase, nominal: Mapping[str, Any]) -> bool:
    """Whether the nominal model walks `case`: no fall, and its figure the case's way by at
    least NOMINAL_WALKS_CM_S / _DEG_S (on the spot: no fall)."""
    if nominal["fell"]:
        return False
    value = case_figure(case, nominal)
    if case.kind == "spot" or value is None:
        return value is not None
    floor = NOMINAL_WALKS_DEG_S if figure_metric(case) == "turn_deg_s" else NOMINAL_WALKS_CM_S
    return value * case.way >= floor


def passes(case: RobustCase, m: Mapping[str, Any], nominal: Mapping[str, Any]) -> bool:
    """The one definition of passing (see PASS_SHARE), only where the nominal model walks the
    case (`nominal_walks`)."""
    if m["fell"] or not nominal_walks(case, nominal):
        return False
    value, goal = case_figure(case, m), case_figure(case, nominal)
    turn = m.get("turn_deg_s")
    if value is None or goal is None or turn is None:
        return False
    if case.kind == "spot":
        return value <= SPOT_DRIFT_CM_S and abs(turn) <= MAX_TURN_DEG_S
    along = value * math.copysign(1.0, goal) >= PASS_SHARE * abs(goal)
    if case.kind in ("forward", "lateral"):
        return along and abs(turn) <= MAX_TURN_DEG_S
    if case.kind == "curve":
        ahead = m["forward_cm_s"] >= PASS_SHARE * nominal["forward_cm_s"]
        return along and ahead
    return along


#: `pass_margin_loss` aims this far above the pass line, so a tuned gait passes with room to spare
MARGIN = 1.2
FALL_MARGIN_LOSS = 2.0  # a fall, or a nominal run that fell: worse than any miss while walking


def pass_margin_loss(case: RobustCase, m: Mapping[str, Any], nominal: Mapping[str, Any]) -> float:
    """How far one varied run is from passing with room (0 when it passes by MARGIN): the
    smooth form of `passes` that `artro tune --robust` minimises. Each shortfall (of the motion
    along, the forward speed of a curve, the heading or spot drift allowed) is relative to its
    line, squared and capped at 1; a fall, or a nominal model that does not walk the case,
    costs FALL_MARGIN_LOSS."""
    if m["fell"] or not nominal_walks(case, nominal):
        return FALL_MARGIN_LOSS
    value, goal, turn = case_figure(case, m), case_figure(case, nominal), m.get("turn_deg_s")
    if value is None or goal is None or turn is None:
        return FALL_MARGIN_LOSS

    def short(have: float, line: float) -> float:  # have should be at least line (> 0)
        return min(1.0, max(0.0, (line - have) / line) ** 2) if line > 0 else 0.0

    def over(have: float, limit: float) -> float:  # have should be at most limit (> 0)
        return min(1.0, max(0.0, (have - limit) / limit) ** 2)

    steady = over(abs(turn), MAX_TURN_DEG_S / MARGIN)
    if case.kind == "spot":
        return over(value, SPOT_DRIFT_CM_S / MARGIN) + steady
    loss = short(value * math.copysign(1.0, goal), MARGIN * PASS_SHARE * abs(goal))
    if case.kind in ("forward", "lateral"):
        loss += steady
    if case.kind == "curve":
        loss += short(m["forward_cm_s"], MARGIN * PASS_SHARE * nominal["forward_cm_s"])
    return loss


PASS_RULE = (
    f"no fall, and the case's motion in the right direction at >= {PASS_SHARE:.0%} of the "
    f"nominal model's figure (forward or sideways speed, turn rate; a CA curve also keeps "
    f">= {PASS_SHARE:.0%} of the forward speed); translating or on the spot the heading drifts "
    f"<= {MAX_TURN_DEG_S:g} deg/s, and on the spot the trunk drifts <= {SPOT_DRIFT_CM_S:g} cm/s; "
    f"only where the nominal model walks the case (the paper's way by >= "
    f"{NOMINAL_WALKS_CM_S:g} cm/s or {NOMINAL_WALKS_DEG_S:g} deg/s)"
)
