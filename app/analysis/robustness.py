"""Will a gait walk on the real robot (`artro bench robust`, the dashboard's robustness job)?
Each preset walks the paper's cases and CA = ±0.1 forward on N model variations drawn with a seed;
per case the share that passes with its 95 % interval, the parameter failures depend on most,
and the worst variations, each repeatable with `artro run --vary` (docs/DESIGN.md §12)."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.analysis.cases import CA_PROBE, CASES
from app.evaluation import Evaluator, Job
from app.robots.description import RobotDescription
from app.robots.swap import derived, derived_name, lightest_servo, mirror, with_servo
from app.sim.headless import AT_LIMIT
from app.worlds.fitted import fitted_ranges, fitted_variation
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import FIELDS, NOMINAL, Variation
from gait import JOINT_NAMES, GaitParams, Motion
from hardware import SAFETY_FACTOR

#: "Passes": no fall, and the case's motion in the right direction at >= this share of the
#: nominal model's figure; translating, the heading drifts by at most MAX_TURN_DEG_S.
PASS_SHARE = 0.5
MAX_TURN_DEG_S = 5.0
SPOT_DRIFT_CM_S = 1.0  # on the spot: drift at most this, and the heading as above
#: the nominal model walks a case when it moves the case's way (the paper's sign; a CA curve
#: eq (13)'s) by at least this much, cm/s or deg/s: judged against its own figure, a gait that
#: barely moves (or the wrong way) let varied runs that stood still pass (decision 0044)
NOMINAL_WALKS_CM_S, NOMINAL_WALKS_DEG_S = 0.3, 1.0
Z95 = 1.959964  # the normal quantile of a two-sided 95 % interval
WORST = 5
#: a joint holds a case back when its failing runs sit at its limit for a larger share of their
#: frames than the passing runs, by this many standard errors, and for at least this share
LIMIT_Z = 2.0
MIN_LIMIT_SHARE = 0.05


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


def _figure(case: RobustCase, m: Mapping[str, Any]) -> float | None:
    if case.kind == "spot":
        fwd, lat = m.get("forward_cm_s"), m.get("lateral_cm_s")
        return None if fwd is None or lat is None else math.hypot(fwd, lat)
    return m.get(figure_metric(case))


def nominal_walks(case: RobustCase, nominal: Mapping[str, Any]) -> bool:
    """Whether the nominal model walks `case`: no fall, and its figure the case's way by at
    least NOMINAL_WALKS_CM_S / _DEG_S (on the spot: no fall)."""
    if nominal["fell"]:
        return False
    value = _figure(case, nominal)
    if case.kind == "spot" or value is None:
        return value is not None
    floor = NOMINAL_WALKS_DEG_S if figure_metric(case) == "turn_deg_s" else NOMINAL_WALKS_CM_S
    return value * case.way >= floor


def passes(case: RobustCase, m: Mapping[str, Any], nominal: Mapping[str, Any]) -> bool:
    """The one definition of passing (see PASS_SHARE), only where the nominal model walks the
    case (`nominal_walks`)."""
    if m["fell"] or not nominal_walks(case, nominal):
        return False
    value, goal = _figure(case, m), _figure(case, nominal)
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
    value, goal, turn = _figure(case, m), _figure(case, nominal), m.get("turn_deg_s")
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


def jobs_for(
    gait: GaitParams, variations: Sequence[Variation], base: Variation = NOMINAL
) -> list[Job]:
    """The nominal runs of every case (on a fitted robot: its fit, `base`), then every
    variation's, case by case."""
    nominal = [Job(gait, c.motion, variation=base) for c in ROBUST_CASES]
    return nominal + [Job(gait, c.motion, variation=v) for v in variations for c in ROBUST_CASES]


def summarise(
    name: str,
    variations: Sequence[Variation],
    metrics: Sequence[Mapping[str, Any]],
    *,
    repeat: str = "artro run",
    stall_nm: Sequence[float] | None = None,
) -> dict[str, Any]:
    """One preset's report from its `jobs_for` metrics; `repeat` starts the command that
    repeats a worst variation's first failed case. With each servo's stall torque `stall_nm`
    (JOINT_NAMES order), each case says which servos' torque holds its failures back
    (`torque_bound`)."""
    n_cases = len(ROBUST_CASES)
    nominal, varied = metrics[:n_cases], metrics[n_cases:]
    grid = [varied[i * n_cases : (i + 1) * n_cases] for i in range(len(variations))]
    cases = []
    shortfall = np.zeros(len(variations))
    failures = np.zeros(len(variations), dtype=int)
    for k, case in enumerate(ROBUST_CASES):
        ok = [passes(case, row[k], nominal[k]) for row in grid]
        failures += ~np.array(ok, dtype=bool)
        goal = _figure(case, nominal[k]) or 0.0
        for i, row in enumerate(grid):
            value = _figure(case, row[k])
            if row[k]["fell"] or value is None:
                shortfall[i] += 2.0
            elif case.kind != "spot" and goal:
                shortfall[i] += max(0.0, 1.0 - value / goal)
        lo, hi = wilson(sum(ok), len(ok))
        cases.append(
            {
                "case": case.name,
                "motion": f"{case.motion.a_r:g},{case.motion.a_p:g},{case.motion.a_y:g}",
                "ca": case.motion.ca,
                "metric": figure_metric(case),
                "nominal": _figure(case, nominal[k]),
                "nominal_fell": nominal[k]["fell"],
                "nominal_walks": nominal_walks(case, nominal[k]),
                "passed": sum(ok),
                "runs": len(ok),
                "share": sum(ok) / len(ok) if ok else 0.0,
                "interval": [lo, hi],
                "falls": sum(row[k]["fell"] for row in grid),
                "depends_on": dependence(variations, [not o for o in ok]),
                "torque": torque_bound(
                    [row[k] for row, o in zip(grid, ok, strict=True) if not o],
                    [row[k] for row, o in zip(grid, ok, strict=True) if o],
                    nominal[k],
                    stall_nm,
                    [v.torque_scale for v, o in zip(variations, ok, strict=True) if not o],
                ),
            }
        )
    order = sorted(range(len(variations)), key=lambda i: (-failures[i], -shortfall[i], i))
    worst = []
    for i in order[:WORST]:
        failed = [c for k, c in enumerate(ROBUST_CASES) if not passes(c, grid[i][k], nominal[k])]
        if not failed:
            continue
        m = failed[0].motion
        worst.append(
            {
                "variation": variations[i].name,
                "failed_cases": len(failed),
                "failed": [c.name for c in failed],
                "motion": {"a_r": m.a_r, "a_p": m.a_p, "a_y": m.a_y, "ca": m.ca},  # the first's
                "command": f"{repeat} --motion a_p={m.a_p:g},a_r={m.a_r:g},a_y={m.a_y:g},"
                f"ca={m.ca:g} --vary {variations[i].name}",
            }
        )
    every = sum(c["passed"] for c in cases) / max(1, sum(c["runs"] for c in cases))
    return {"preset": name, "cases": cases, "worst": worst, "overall_share": every}


def torque_bound(
    failed: Sequence[Mapping[str, Any]],
    passed: Sequence[Mapping[str, Any]],
    nominal: Mapping[str, Any],
    stall_nm: Sequence[float] | None,
    torque_scales: Sequence[float] | None = None,
) -> dict[str, Any] | None:
    """Whether a case's failures are a servo's torque. Every run has its servos at their limit
    now and then (the knees at each step), so a peak at the stall torque says little; what
    tells is time: a joint is at its limit when the failing runs spend a larger share of their
    frames there (`at_limit_share`) than the passing runs do, by at least LIMIT_Z standard
    errors and at least MIN_LIMIT_SHARE (the nominal run is the reference when fewer than two
    pass). Also the failing runs with a peak at AT_LIMIT of their own stall torque (`stall_nm`,
    the robot as described, times each run's `torque_scale`) and the largest peak; None
    without failures or figures."""
    if not failed or stall_nm is None:
        return None
    scales = np.ones(len(failed)) if torque_scales is None else np.asarray(torque_scales)
    own_stall = scales[:, None] * np.asarray(stall_nm)[None, :]
    peaks = np.asarray([m["peak_torque_nm"] for m in failed])
    share = np.asarray([m["at_limit_share"] for m in failed])
    out: dict[str, Any] = {
        "failing_runs": len(failed),
        "at_stall_runs": int((peaks >= AT_LIMIT * own_stall).any(axis=1).sum()),
        "joints": [],
        "at_limit_share": {},
        "peak_nm": float(peaks.max()),
        "reference": "passing runs" if len(passed) >= 2 else "the nominal run",
    }
    ref = np.asarray(
        [m["at_limit_share"] for m in passed] if len(passed) >= 2 else [nominal["at_limit_share"]]
    )
    if len(failed) >= 2:
        var = share.var(axis=0, ddof=1) / len(share)
        if len(ref) >= 2:
            var = var + ref.var(axis=0, ddof=1) / len(ref)
        more = share.mean(axis=0) - ref.mean(axis=0)
        for j, name in enumerate(JOINT_NAMES):
            fail_share = float(share[:, j].mean())
            if fail_share >= MIN_LIMIT_SHARE and more[j] > LIMIT_Z * math.sqrt(var[j]):
                out["joints"].append(name)
                out["at_limit_share"][name] = [fail_share, float(ref[:, j].mean())]
    out["bound"] = bool(out["joints"])
    return out


def servo_advice(report: dict[str, Any], robot: RobotDescription, stall_nm: Sequence[float]):
    """The servo swaps a preset's torque-bound cases ask for, one per group of joints with the
    same servo (a servo's figures are its own: an MG90S hip yaw and MG995 knees at their limits
    are two swaps, never one): the joints at their limit and their mirror joints where both legs
    have that servo (a robot built alike on both sides stays so), eq (1)'s torque for the group
    ((1 + sf) x the stall torque its joints reached, `stall_nm` per joint: what they were asked
    is at least that) and the lightest servo of the table or the robot's file that gives it at
    its supply (None where none does); None if no case is torque-bound."""
    cases = [c for c in report["cases"] if c["torque"] and c["torque"]["bound"]]
    if not cases:
        return None
    bound = {j for c in cases for j in c["torque"]["joints"]}
    bound |= {mirror(j) for j in bound if robot.joint_servo(mirror(j)) == robot.joint_servo(j)}
    by_servo: dict[str, list[str]] = {}
    for joint in JOINT_NAMES:  # the gait's order, left leg first
        if joint in bound:
            by_servo.setdefault(robot.joint_servo(joint), []).append(joint)
    groups = []
    for servo, joints in by_servo.items():
        reached = max(stall_nm[JOINT_NAMES.index(j)] for j in joints)
        need = (1.0 + SAFETY_FACTOR) * reached
        choice = lightest_servo(need, robot.supply_voltage_v, servos=robot.servo_catalogue())
        groups.append(
            {
                "joints": joints,
                "servo_now": servo,
                "stall_nm": reached,
                "need_nm": need,
                "servo": None if choice is None else choice.name,
                "servo_stall_nm": None if choice is None else choice.stall_torque_nm,
            }
        )
    return {"cases": [c["case"] for c in cases], "groups": groups}


def advised_robot(robot: RobotDescription, advice: dict[str, Any]) -> RobotDescription | None:
    """`robot` with the servos `servo_advice` names swapped in, group by group (a stated total
    mass moved by each servo's difference), named `<name>-advised`; None where no group has a
    servo that carries it."""
    swapped = robot
    for group in advice["groups"]:
        if group["servo"] is not None:
            swapped = with_servo(swapped, group["joints"], group["servo"])
    if swapped is robot:
        return None
    changes = "; ".join(
        f"{g['servo']} on {', '.join(g['joints'])}" for g in advice["groups"] if g["servo"]
    )
    return derived(swapped, derived_name(robot.name, "advised"), f"{robot.title}; {changes}")


def run_robust(
    presets: Sequence[tuple[str, GaitParams, str]],
    evaluator: Evaluator,
    *,
    samples: int,
    seed: int,
    ranges: VariationRanges,
    duration_s: float,
    warmup_s: float,
    progress: Callable[[int, int], None] | None = None,
    cancel: threading.Event | None = None,
    robot_arg: str | None = None,
) -> dict[str, Any]:
    """Every preset (name, gait, file) on the same `samples` variations (one evaluation call, so
    the threads or workers stay busy); the report as a JSON-ready dict, the same to the bit for a
    seed. `robot_arg` is the robot as the worst runs' `artro run --robot` gets it (default its
    name; the description's path for a robot from a file)."""
    base = fitted_variation(evaluator.robot)  # a fitted robot: ranges centred on its fit
    drawn = fitted_ranges(evaluator.robot, ranges)
    variations = sample(drawn, samples, seed)
    all_jobs: list[Job] = []
    for _, gait, _ in presets:
        all_jobs += jobs_for(gait, variations, base)
    metrics = evaluator.evaluate(
        all_jobs, duration_s=duration_s, warmup_s=warmup_s, progress=progress, cancel=cancel
    )
    per = len(all_jobs) // max(1, len(presets))
    robot = evaluator.robot
    stall = np.abs(robot.model.actuator_forcerange[robot.actuator_ids, 1]).tolist()
    reports = [
        summarise(
            name,
            variations,
            metrics[i * per : (i + 1) * per],
            repeat=f"artro run --robot {robot_arg or robot.name} --params {source} "
            f"--duration {duration_s:g} --warmup {warmup_s:g}",
            stall_nm=stall,
        )
        for i, (name, _, source) in enumerate(presets)
    ]
    for report in reports:
        report["servo_advice"] = servo_advice(report, robot.description, stall)
    return {
        "robot": evaluator.robot.name,
        "samples": samples,
        "seed": seed,
        "duration_s": duration_s,
        "warmup_s": warmup_s,
        "ranges": {f: list(getattr(drawn, f)) for f in FIELDS},
        "fitted": base.to_text() if evaluator.robot.description.fitted else None,
        "pass_rule": PASS_RULE,
        "presets": reports,
    }


PASS_RULE = (
    f"no fall, and the case's motion in the right direction at >= {PASS_SHARE:.0%} of the "
    f"nominal model's figure (forward or sideways speed, turn rate; a CA curve also keeps "
    f">= {PASS_SHARE:.0%} of the forward speed); translating or on the spot the heading drifts "
    f"<= {MAX_TURN_DEG_S:g} deg/s, and on the spot the trunk drifts <= {SPOT_DRIFT_CM_S:g} cm/s; "
    f"only where the nominal model walks the case (the paper's way by >= "
    f"{NOMINAL_WALKS_CM_S:g} cm/s or {NOMINAL_WALKS_DEG_S:g} deg/s)"
)
