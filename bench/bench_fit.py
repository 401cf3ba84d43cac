"""Benchmark: `artro fit` on simulated robots whose variation it is not told (docs/FIT.md).
Each robot draws the goal fields from the default ranges (latency, kp and torque scales, trunk
mass, floor tilt, the IMU's tilt and gyro bias; the gyro's noise at the default range's top,
0.1 °/s), records the identify routine, is fitted, and is compared with its truth field by
field (within the goals' tolerances, for the fields the fit calls identified); then the fitted
and the nominal model predict the hidden robot's speeds on walks not in the routine (the
paper's forward a_p 0.07, sideways a_r 0.1, turning a_y 0.2). Seconds per fit are reported.

    python bench/bench_fit.py [--robots 10] [--budget 160] [--workers 2] [--seed 1] [--resume]

Writes its JSON document into bench/results/ (or --json PATH) after every robot, so a run
stopped early keeps what it measured; --resume goes on from that document's robots (the same
budget, workers and seed: the robots are drawn from the seed).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import results

from app.analysis import identify_record
from app.analysis.identify_replay import play
from app.analysis.identify_routine import IDENTIFY, open_loop
from app.robots.gait_reach import preset_gait
from app.robots.model import RobotModel
from app.sim.headless import run
from app.study import fit_space
from app.study.fit import fit
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import NOMINAL, Variation
from gait import Motion

GOAL_FIELDS = (
    "latency_ms", "kp_scale", "torque_scale", "trunk_mass_scale", "tilt_deg",
    "tilt_direction_deg", "imu_tilt_bias_deg", "imu_tilt_direction_deg", "gyro_bias_deg_s",
)  # fmt: skip
#: walks not in the routine: the prediction's test
WALKS = {"forward": Motion(a_p=0.07), "sideways": Motion(a_r=0.1), "turning": Motion(a_y=0.2)}
METRIC = {"forward": "forward_cm_s", "sideways": "lateral_cm_s", "turning": "turn_deg_s"}


def hidden_robots(n: int, seed: int) -> list[Variation]:
    """n variations of the goal fields, the others nominal, the gyro's noise at 0.1 °/s."""
    drawn = sample(VariationRanges(), n, seed)
    keep = {f.name for f in dataclasses.fields(Variation)} & set(GOAL_FIELDS)
    out = []
    for v in drawn:
        values = {k: getattr(v, k) for k in keep}
        out.append(dataclasses.replace(NOMINAL, **values, gyro_noise_deg_s=0.1))
    return out


def speeds(robot: RobotModel, gait: Any, variation: Variation) -> dict[str, float | None]:
    out: dict[str, float | None] = {}
    for name, motion in WALKS.items():
        m = run(gait, motion, duration_s=20, warmup_s=5, robot=robot, variation=variation).metrics
        out[name] = None if m["fell"] else m[METRIC[name]]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=10, help="hidden robots (default: 10)")
    parser.add_argument("--budget", type=int, default=160, help="replays a fit (default: 160)")
    parser.add_argument("--workers", type=int, default=2, help="processes (default: 2)")
    parser.add_argument("--seed", type=int, default=1, help="the robots' draw (default: 1)")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="go on from the robots the results document holds (default: start afresh)",
    )
    args = results.parse_args(parser)
    robot = RobotModel.load()
    gait = preset_gait(robot.description.default_preset)
    dims = {**fit_space.PHYSICS, **fit_space.IMU}
    cases = resumed(args) if args.resume else []
    for i, truth in enumerate(hidden_robots(args.robots, args.seed)):
        if i < len(cases):
            continue
        traces = play(robot, open_loop(gait), IDENTIFY, truth)
        recording = identify_record.to_recording(
            traces, routine="identify", source="simulation", robot=robot.name,
            robot_mass_kg=robot.total_mass_kg(), params=open_loop(gait).to_dict(),
            truth=truth.to_text(),
        )  # fmt: skip
        start = time.perf_counter()
        result = fit(recording, "artro", budget=args.budget, workers=args.workers, seed=args.seed)
        seconds = time.perf_counter() - start
        expected = fit_space.truth_values(truth)
        fields = {
            k: {
                "fitted": v,
                "truth": expected[k],
                "error": v - expected[k],
                "sigma": result.sigma[k],
                "identified": result.identified[k],
                "within": abs(v - expected[k]) <= dims[k].tolerance,
            }
            for k, v in result.values.items()
        }
        hidden = speeds(robot, gait, truth)
        fitted = speeds(robot, gait, result.variation)
        nominal = speeds(robot, gait, NOMINAL)
        case = {
            "robot": i,
            "truth": truth.to_text(),
            "fell_in_routine": traces.fell_frame is not None,
            "converged": result.converged,
            "seconds": seconds,
            "fields": fields,
            "speeds": {"hidden": hidden, "fitted": fitted, "nominal": nominal},
        }
        cases.append(case)
        told = sum(f["within"] for f in fields.values())
        print(
            f"robot {i}: {seconds:.0f} s, {told}/{len(fields)} within, converged "
            f"{result.converged}; speeds hidden {hidden} fitted {fitted}",
            flush=True,
        )
        write(args, cases)


def predicted(case: dict[str, Any], walk: str) -> bool:
    """Whether the fitted model predicts the hidden robot's speed on `walk`: within 10 % or
    0.3 (cm/s or °/s), or both fall."""
    hidden, fitted = case["speeds"]["hidden"][walk], case["speeds"]["fitted"][walk]
    if hidden is None or fitted is None:
        return hidden is None and fitted is None
    return bool(abs(fitted - hidden) <= max(0.1 * abs(hidden), 0.3))


def resumed(args: argparse.Namespace) -> list[dict[str, Any]]:
    """The robots an earlier run of the same budget, workers and seed measured, in order."""
    path = Path(args.json) if args.json not in (None, "-") else results.default_path("bench_fit")
    if not path.exists():
        return []
    doc = json.loads(path.read_text(encoding="utf-8"))
    same = ("budget", "workers", "seed")
    if any(doc["arguments"].get(k) != getattr(args, k) for k in same):
        raise SystemExit(f"--resume: {path} was run with other {same}: {doc['arguments']}")
    cases: list[dict[str, Any]] = doc["figures"]["cases"]
    print(f"resuming after {len(cases)} robots of {path}", flush=True)
    return cases


def write(args: argparse.Namespace, cases: list[dict[str, Any]]) -> None:
    """The document of the robots measured so far (written after each one)."""
    dims = {**fit_space.PHYSICS, **fit_space.IMU}
    per_field = {}
    for k in dims:
        rows = [c["fields"][k] for c in cases if k in c["fields"]]
        identified = [r for r in rows if r["identified"]]
        per_field[k] = {
            "identified": len(identified),
            "within_of_identified": sum(r["within"] for r in identified),
            "within_of_all": sum(r["within"] for r in rows),
        }
    headline = {
        "robots_done": len(cases),
        "fit_s_median": sorted(c["seconds"] for c in cases)[len(cases) // 2],
        **{f"{k}_within_of_{len(cases)}": v["within_of_all"] for k, v in per_field.items()},
        **{f"{w}_predicted_of_{len(cases)}": sum(predicted(c, w) for c in cases) for w in WALKS},
    }
    results.write("bench_fit", args, {"cases": cases, "per_field": per_field}, headline)


if __name__ == "__main__":
    main()
