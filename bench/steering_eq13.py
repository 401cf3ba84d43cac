"""Does CA steer as eq (13) says? The heading rate against theta_dot = -2 CA V / b, per speed.

For a parameter set (default: `tuned` with its K calibrated by `artro calibrate-ca`), walks
CA = 0, +-0.05, +-0.1, +-0.15 at a_p = 0.05, 0.07, 0.09 and -0.07 (batch rollouts), with V and
b = the feet distance from each speed's own CA = 0 walk, and prints per CA the measured rate, eq
(13)'s, their ratio, and the antisymmetry |th(CA) + th(-CA)| / mean(|th|). Goals (issue 11):
ratio within 30 % for 0.05 <= |CA| <= 0.15, antisymmetry within 15 %, no fall.

    python bench/steering_eq13.py [--preset FILE|tuned] [--duration 60] [--calibrate]
        [--json PATH]

Writes its figures (per speed: V, b, the drift, per CA the rate, eq (13)'s and their ratio, per
|CA| the antisymmetry; the count of figures outside the goals) to
bench/results/steering_eq13.json, or to --json PATH (bench/results.py).
"""

from __future__ import annotations

import argparse
import math
import sys

import results

from app.analysis.ca_analysis import eq13_turn_rate_rad_s
from app.analysis.ca_calibration import calibrate_ca, with_k
from app.evaluation import BatchEvaluator, Job
from app.study.walks import resolve_presets
from gait import Motion

SPEEDS = (0.05, 0.07, 0.09, -0.07)
CAS = (0.05, 0.1, 0.15)
RATIO_GOAL = 0.30
ANTISYMMETRY_GOAL = 0.15
PAPER_A_P = 0.07  # seed 000's forward walk, where its CA table was measured


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--preset", default="tuned", help="built-in preset name or a file")
    parser.add_argument("--duration", type=float, default=60.0, metavar="S")
    parser.add_argument("--warmup", type=float, default=5.0, metavar="S")
    parser.add_argument(
        "--calibrate", action="store_true", help="calibrate K both ways first (30 s walks)"
    )
    args = results.parse_args(parser)
    (preset,), _notes = resolve_presets([args.preset])
    params = preset.params
    evaluator = BatchEvaluator()
    if args.calibrate:
        for a_p in (0.07, -0.07):
            result = calibrate_ca(params, Motion(a_p=a_p), evaluator, duration_s=30.0)
            params = with_k(params, a_p, result.yaw_per_ca)
    steer = params.steer
    print(
        f"{preset.name}: K forward {steer.yaw_per_ca:+.4f}, backward "
        f"{steer.yaw_per_ca_backward:+.4f}, full at |a_p| {steer.full_at_a_p}; "
        f"{args.duration:g} s walks"
    )
    cas = (0.0, *CAS, *(-c for c in CAS))
    jobs = [Job(params, Motion(a_p=a_p, ca=ca)) for a_p in SPEEDS for ca in cas]
    metrics = evaluator.evaluate(jobs, duration_s=args.duration, warmup_s=args.warmup)
    by = {(j.motion.a_p, j.motion.ca): r for j, r in zip(jobs, metrics, strict=True)}
    misses = 0
    speeds = []
    for a_p in SPEEDS:
        straight = by[a_p, 0.0]
        v = (straight["forward_cm_s"] or 0.0) / 100
        b = (straight["feet_distance_cm"] or 0.0) / 100
        print(f"\na_p {a_p:+.2f}: V {100 * v:+.2f} cm/s, b {100 * b:.1f} cm, "
              f"drift {straight['turn_deg_s'] or 0:+.2f} deg/s")  # fmt: skip
        print("   CA    turn    eq13  ratio   | antisym")
        runs, pairs = [], []
        for ca in CAS:
            pair = []
            for c in (ca, -ca):
                r = by[a_p, c]
                eq13 = math.degrees(float(eq13_turn_rate_rad_s(c, v, b))) if b else float("nan")
                turn = r["turn_deg_s"]
                ratio = turn / eq13 if turn is not None and eq13 else float("nan")
                ok = not r["fell"] and abs(ratio - 1) <= RATIO_GOAL
                misses += not ok
                pair.append(turn)
                fell = " FELL" if r["fell"] else ""
                print(f"{c:+.3f} {turn or float('nan'):+7.2f} {eq13:+7.2f} {ratio:6.2f}"
                      f"{'' if ok else ' !'}{fell}")  # fmt: skip
                runs.append(
                    {
                        "ca": c,
                        "turn_deg_s": turn,
                        "eq13_turn_deg_s": eq13,
                        "ratio": ratio,
                        "fell": r["fell"],
                        "within_goal": ok,
                    }
                )
            anti = None
            if None not in pair:
                anti = abs(pair[0] + pair[1]) / (0.5 * (abs(pair[0]) + abs(pair[1])))
                misses += anti > ANTISYMMETRY_GOAL
                flag = "" if anti <= ANTISYMMETRY_GOAL else " !"
                print(f"                         | |CA| {ca}: {100 * anti:.0f} %{flag}")
            pairs.append(
                {
                    "abs_ca": ca,
                    "antisymmetry_pct": None if anti is None else 100 * anti,
                    "within_goal": anti is not None and anti <= ANTISYMMETRY_GOAL,
                }
            )
        speeds.append(
            {
                "a_p": a_p,
                "v_cm_s": 100 * v,
                "b_cm": 100 * b,
                "drift_deg_s": straight["turn_deg_s"],
                "fell_at_ca_0": straight["fell"],
                "runs": runs,
                "pairs": pairs,
            }
        )
    print(f"\n{misses} figures outside the goals (ratio within {RATIO_GOAL:.0%}, "
          f"antisymmetry within {ANTISYMMETRY_GOAL:.0%}, no fall)")  # fmt: skip
    ratios = [r["ratio"] for s in speeds for r in s["runs"] if not math.isnan(r["ratio"])]
    antis = [p["antisymmetry_pct"] for s in speeds for p in s["pairs"]]
    figures = {
        "preset": preset.name,
        "k_forward": steer.yaw_per_ca,
        "k_backward": steer.yaw_per_ca_backward,
        "full_at_a_p": steer.full_at_a_p,
        "goals": {"ratio_within": RATIO_GOAL, "antisymmetry_within": ANTISYMMETRY_GOAL},
        "speeds": speeds,
        "figures_outside_goals": misses,
    }
    headline = {
        f"figures outside the goals (of {len(speeds) * len(CAS) * 3})": misses,
        "largest |ratio - 1| to eq 13": max((abs(r - 1) for r in ratios), default=None),
        "largest antisymmetry (%)": None if None in antis else max(antis, default=None),
        "largest |ratio - 1| at the paper's a_p 0.07": max(
            (abs(r["ratio"] - 1) for s in speeds if s["a_p"] == PAPER_A_P for r in s["runs"]),
            default=None,
        ),
    }
    results.write("steering_eq13", args, figures, headline)
    return 0


if __name__ == "__main__":
    sys.exit(main())
