"""What the papers measured, as cases to simulate (SPEC §7).

Seed 000 measured ArtRo walking on the spot, forward, sideways and turning; we add the mirror image
of each (backward, the other side, the other turning direction), which the gait equations treat
alike. Targets are signed in our conventions: lateral > 0 is to the left, turn > 0 is
counter-clockwise; so a_r = +0.1 (a step to the right) targets -3.5 cm/s and a_y = +0.2
(clockwise) targets -12.1 deg/s.
"""

from __future__ import annotations

from dataclasses import dataclass

from gait import Motion

SPOT_DRIFT_LIMIT_CM_S = 0.5
SPEED_TOLERANCE = 0.25  # +-25 % of the paper's figure
MIRROR_TOLERANCE = 0.15  # mirror cases within 15 % of each other


@dataclass(frozen=True)
class PaperCase:
    name: str
    motion: Motion
    metric: str  # which run metric the paper's figure is ("drift_cm_s" for walking on the spot)
    paper: float  # the paper's figure, signed in our conventions
    mirror_of: str | None = None


CASES: tuple[PaperCase, ...] = (
    PaperCase("on the spot", Motion(), "drift_cm_s", 0.0),
    PaperCase("forward", Motion(a_p=0.07), "forward_cm_s", 3.8),
    PaperCase("backward", Motion(a_p=-0.07), "forward_cm_s", -3.8, mirror_of="forward"),
    PaperCase("sideways right", Motion(a_r=0.1), "lateral_cm_s", -3.5),
    PaperCase("sideways left", Motion(a_r=-0.1), "lateral_cm_s", 3.5, mirror_of="sideways right"),
    PaperCase("turn clockwise", Motion(a_y=0.2), "turn_deg_s", -12.1),
    PaperCase(
        "turn counter-clockwise", Motion(a_y=-0.2), "turn_deg_s", 12.1, mirror_of="turn clockwise"
    ),
)


def measured(case: PaperCase, metrics: dict) -> float | None:
    """The run's figure comparable with the paper's, or None if the run gave none."""
    if case.metric == "drift_cm_s":
        fwd, lat = metrics.get("forward_cm_s"), metrics.get("lateral_cm_s")
        return None if fwd is None or lat is None else (fwd**2 + lat**2) ** 0.5
    return metrics.get(case.metric)


def passes(case: PaperCase, value: float | None, fell: bool) -> bool:
    """Walks the whole run without falling, in the right direction, within the tolerance."""
    if fell or value is None:
        return False
    if case.metric == "drift_cm_s":
        return value < SPOT_DRIFT_LIMIT_CM_S
    return abs(value - case.paper) <= SPEED_TOLERANCE * abs(case.paper)


# --- curve walking (seed 004): the heading rate against eq (13) -------------------------------

CA_PROBE = 0.1  # the issue asks for eq (13) within 30 % over CA in [-0.1, 0.1]
STEERING_TOLERANCE = 0.30


@dataclass(frozen=True)
class CurvePair:
    """Walking at CA = +CA_PROBE and -CA_PROBE: how much the heading rate follows eq (13)."""

    name: str
    a_p: float
    required: bool  # the criterion (forward); backward is reported and only steered

    def motions(self) -> tuple[Motion, Motion]:
        return Motion(a_p=self.a_p, ca=CA_PROBE), Motion(a_p=self.a_p, ca=-CA_PROBE)


CURVES: tuple[CurvePair, ...] = (
    CurvePair("curve forward", 0.07, required=True),
    CurvePair("curve backward", -0.07, required=False),
)


def steering_gain(plus: dict, minus: dict) -> float | None:
    """(turn(+CA) - turn(-CA)) / (eq13(+CA) - eq13(-CA)): 1 follows eq (13) with b = the feet
    distance, 0 is no steering, < 0 steers the wrong way. Each run's eq (13) rate uses that
    run's own speed and feet distance (its `predicted_turn_deg_s`); the drift cancels."""
    if plus["fell"] or minus["fell"]:
        return None
    turns = (plus["turn_deg_s"], minus["turn_deg_s"])
    predicted = (plus["predicted_turn_deg_s"], minus["predicted_turn_deg_s"])
    if None in turns or None in predicted or predicted[0] == predicted[1]:
        return None
    return (turns[0] - turns[1]) / (predicted[0] - predicted[1])


def steering_passes(pair: CurvePair, gain: float | None) -> bool:
    """Forward: within 30 % of eq (13). Backward: at least turns the way eq (13) says."""
    if gain is None:
        return False
    if pair.required:
        return abs(gain - 1.0) <= STEERING_TOLERANCE
    return gain > 0.0


def curve_run_names(pair: CurvePair) -> tuple[str, str]:
    return f"{pair.name} CA=+{CA_PROBE:g}", f"{pair.name} CA=-{CA_PROBE:g}"


#: Every run that judges one parameter set: the paper's cases, then the curve pairs (+CA, -CA).
JUDGED_RUNS: tuple[tuple[str, Motion], ...] = tuple(
    (case.name, case.motion) for case in CASES
) + tuple(
    (name, motion)
    for pair in CURVES
    for name, motion in zip(curve_run_names(pair), pair.motions(), strict=True)
)
