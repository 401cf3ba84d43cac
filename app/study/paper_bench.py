"""`artro bench paper`: simulate what the papers measured and compare, for one or more presets.

Seed 000's cases and seed 004's curve walks (docs/DESIGN.md §12) against eq (13), the fitted axle
and the stability limits; what it runs, prints and writes: `run_paper_bench`.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from app.analysis import ca_analysis as ca_math
from app.analysis.cases import (
    CA_PROBE,
    CASES,
    MIRROR_TOLERANCE,
    SPOT_DRIFT_LIMIT_CM_S,
    measured,
    passes,
    speed_scale_of,
    steering,
    steers_right,
    target,
    within_eq13,
)
from app.evaluation.progress import progress_printer
from app.robots.model import RobotModel
from app.study import speed_limits
from app.study.runs import (
    CIRCLE_CA,
    WALK_A_P,
    BenchConfig,
    PresetRuns,
    case_by_name,
    finite_or_none,
    run_all,
)
from app.study.walks import Run, resolve_presets

PAPER_CA_LIMIT = {"forward": 0.15, "backward": 0.17}  # seed 004 §V, the simulated Nao


def case_rows(runs: PresetRuns, warmup_s: float, speed_scale: float = 1.0) -> list[dict[str, Any]]:
    """Per paper case: the paper's figure, the target for this robot (`target`: speeds scaled by
    its leg length against ArtRo's), the simulated figure (the run metric, as `artro run` gives
    it), its ratio to the target, pass, fell, gyro."""
    rows = []
    for case in CASES:
        run = runs.cases[case.name]
        m = run.metrics
        value = finite_or_none(measured(case, m))
        goal = target(case, speed_scale)
        rows.append(
            {
                "case": case.name,
                "metric": case.metric,
                "paper": case.paper,
                "target": goal,
                "sim": value,
                "ratio": value / goal if value is not None and goal else None,
                "pass": passes(case, value, m["fell"], speed_scale),
                "fell": m["fell"],
                "fall_time_s": m.get("fall_time_s"),
                "gyro_rms": m["gyro_rms"],
            }
        )
    return rows


def mirror_rows(runs: PresetRuns) -> list[dict[str, Any]]:
    """Each mirrored pair: |a - (-b)| / mean(|a|, |b|) within MIRROR_TOLERANCE."""
    rows = []
    for case in CASES:
        if case.mirror_of is None:
            continue
        original = case_by_name(case.mirror_of)
        a = finite_or_none(measured(original, runs.cases[original.name].metrics))
        b = finite_or_none(measured(case, runs.cases[case.name].metrics))
        mismatch = None
        if a is not None and b is not None and (a or b):
            mismatch = abs(a + b) / (0.5 * (abs(a) + abs(b)))  # |a - (-b)| / mean(|a|, |b|)
        rows.append(
            {
                "pair": f"{case.mirror_of} / {case.name}",
                "a": a,
                "b": b,
                "mismatch": mismatch,
                "ok": mismatch is not None and mismatch <= MIRROR_TOLERANCE,
            }
        )
    return rows


def _walk_row(
    run: Run, speed_m_s: float | None, axle_m: float | None, drift: float | None
) -> dict[str, Any]:
    ca, m = run.motion.ca, run.metrics
    turn = finite_or_none(m["turn_deg_s"])
    eq13 = None
    if speed_m_s is not None and axle_m:
        eq13 = math.degrees(float(ca_math.eq13_turn_rate_rad_s(ca, speed_m_s, axle_m))) + 0.0
    checked = abs(ca) <= ca_math.FIT_CA_LIMIT + 1e-9 and ca != 0 and not m["fell"]
    rel = rel_drift = None
    if checked and turn is not None and eq13:
        rel = (turn - eq13) / abs(eq13)
        rel_drift = None if drift is None else (turn - drift - eq13) / abs(eq13)
    return {
        "ca": ca,
        "turn_deg_s": turn,
        "eq13_turn_deg_s": eq13,
        "rel_error": rel,
        "rel_error_drift_removed": rel_drift,
        "forward_cm_s": m["forward_cm_s"],
        "gyro_rms": m["gyro_rms"],
        "fell": m["fell"],
        "fall_time_s": m.get("fall_time_s"),
    }


def _reference(walks: list[Run]) -> tuple[float | None, float | None, float | None]:
    """V (m/s), b (m) and the drift (deg/s) of the CA = 0 walk among `walks`."""
    ref = next(r for r in walks if r.motion.ca == 0)
    v_cm_s = finite_or_none(ref.metrics["forward_cm_s"])
    feet_cm = finite_or_none(ref.metrics["feet_distance_cm"])
    return (
        None if v_cm_s is None else v_cm_s / 100.0,
        None if feet_cm is None else feet_cm / 100.0,
        finite_or_none(ref.metrics["turn_deg_s"]),
    )


def ca_summary(walks: list[Run], warmup_s: float, freq_hz: float) -> dict[str, Any]:
    """Heading rate vs eq (13), axle fit, antisymmetry and the stable limit of one direction."""
    speed, axle, drift = _reference(walks)
    v_cm_s = None if speed is None else 100.0 * speed
    rows = [_walk_row(r, speed, axle, drift) for r in walks]
    usable = [r for r in rows if abs(r["ca"]) <= ca_math.FIT_CA_LIMIT + 1e-9 and not r["fell"]]
    usable = [r for r in usable if r["turn_deg_s"] is not None]
    fit = None
    if speed is not None and len({r["ca"] for r in usable}) >= 2:
        f = ca_math.fit_axle(
            [r["ca"] for r in usable], [math.radians(r["turn_deg_s"]) for r in usable], speed
        )
        fit = {
            "axle_eff_cm": None if f.axle_eff_m is None else 100.0 * f.axle_eff_m,
            "slope_deg_s_per_ca": math.degrees(f.slope_rad_s),
            "drift_deg_s": math.degrees(f.drift_rad_s),
            "residual_rms_deg_s": math.degrees(f.residual_rms_rad_s),
            "n_points": f.n_points,
        }
    standing = [r for r in rows if r["turn_deg_s"] is not None]
    ca_values = [r["ca"] for r in standing]
    turns = np.array([r["turn_deg_s"] for r in standing])
    fell = [r["fell"] for r in standing]
    pairs = ca_math.antisymmetry_pairs(ca_values, turns, fell)
    pairs_no_drift = ca_math.antisymmetry_pairs(ca_values, turns - (drift or 0.0), fell)
    limit = ca_math.largest_stable_ca([r["ca"] for r in rows], [r["fell"] for r in rows])
    return {
        "steering": _steering(rows),
        "speed_cm_s": v_cm_s,
        "axle_cm": None if axle is None else 100.0 * axle,
        "drift_deg_s": drift,
        "rows": rows,
        "fit": fit,
        "antisymmetry": [
            {
                "ca": p.ca,
                "turn_pos_deg_s": p.turn_pos,
                "turn_neg_deg_s": p.turn_neg,
                "even_part_deg_s": p.even_part,
                "mismatch": p.mismatch,
                "ok": p.ok,
                "mismatch_drift_removed": q.mismatch,
                "ok_drift_removed": q.ok,
            }
            for p, q in zip(pairs, pairs_no_drift, strict=True)
        ],
        "stable_limit": {
            "limit": limit.limit,
            "first_fall": limit.first_fall,
            "sweep_max": limit.sweep_max,
            "beyond_sweep": limit.beyond_sweep,
        },
    }


def _steering(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    """`app.analysis.cases.steering` of the sweep's CA = +-0.1 and 0 runs (eq (13) with the CA = 0
    run's V and b), as the tuner judges it."""
    by_ca = {round(r["ca"], 6): r for r in rows}
    found = [by_ca.get(ca) for ca in (CA_PROBE, -CA_PROBE, 0.0)]
    picked = [r for r in found if r is not None]
    if len(picked) < len(found):
        return None
    plus, minus, straight = (
        {
            "fell": r["fell"],
            "turn_deg_s": r["turn_deg_s"],
            "predicted_turn_deg_s": r["eq13_turn_deg_s"],
        }
        for r in picked
    )
    s = steering(plus, minus, straight)
    if s is None:
        return None
    return {
        "ca": CA_PROBE,
        "gain": s.gain,
        "bend": s.bend,
        "steers_right": steers_right(s),
        "within_eq13": within_eq13(s),
    }


def steering_by_amplitude(runs: PresetRuns) -> list[dict[str, Any]]:
    """The CA = +-0.1 steering (`_steering`) at the sweep's forward a_p and every probed one."""
    by_a_p = {WALK_A_P["forward"]: runs.walks["forward"], **runs.steer_probes}
    out = []
    for a_p in sorted(by_a_p):
        speed, axle, drift = _reference(by_a_p[a_p])
        rows = [_walk_row(r, speed, axle, drift) for r in by_a_p[a_p]]
        probed = [r for r in rows if round(abs(r["ca"]), 6) in (0.0, CA_PROBE)]
        v_cm_s = None if speed is None else 100.0 * speed
        out.append(
            {
                "a_p": a_p,
                "speed_cm_s": v_cm_s,
                # slower than the on-the-spot drift limit, eq (13)'s rate is noise-sized
                "walks": v_cm_s is not None and abs(v_cm_s) >= SPOT_DRIFT_LIMIT_CM_S,
                "steering": _steering(rows),
                "fell": any(r["fell"] for r in probed),
            }
        )
    return out


def circle_summary(run: Run, forward: dict[str, Any]) -> dict[str, Any] | None:
    """The long CA = 0.058 walk: heading turned, measured and eq (13) rates (V and b from the
    forward sweep's CA = 0 run), and the time a full circle takes."""
    trace = run.trace
    if len(trace.t_s) < 2:
        return None
    speed = None if forward["speed_cm_s"] is None else forward["speed_cm_s"] / 100.0
    axle = None if forward["axle_cm"] is None else forward["axle_cm"] / 100.0
    row = _walk_row(run, speed, axle, forward["drift_deg_s"])
    check = ca_math.CircleCheck(
        turned_deg=math.degrees(float(trace.yaw_rad[-1] - trace.yaw_rad[0])),
        run_s=float(trace.t_s[-1]),
        rate_deg_s=row["turn_deg_s"],
        predicted_rate_deg_s=row["eq13_turn_deg_s"],
    )
    turned = np.abs(trace.yaw_rad - trace.yaw_rad[0])
    full = np.flatnonzero(turned >= 2 * math.pi)
    v = finite_or_none(run.metrics["forward_cm_s"])
    rate = row["turn_deg_s"]
    radius = None if v is None or not rate else abs(v / 100.0 / math.radians(rate))
    return asdict(check) | {
        # the circle's radius from its own V and heading rate; eq (13): b / (2 |CA|)
        "radius_m": radius,
        "predicted_radius_m": None if axle is None else axle / (2 * abs(CIRCLE_CA)),
        "time_to_360_s": float(trace.t_s[full[0]]) if full.size else None,
        "ca": CIRCLE_CA,
        "fell": row["fell"],
        "completed": check.completed and not row["fell"],
        "circle_s": check.circle_s,
        "predicted_circle_s": check.predicted_circle_s,
    }


def summarise(all_runs: list[PresetRuns], config: BenchConfig, notes: list[str]) -> dict:
    """Every number of the bench, as one JSON-ready document."""
    scale = speed_scale_of(RobotModel.load(config.robot).geometry)
    presets = []
    for runs in all_runs:
        freq = runs.preset.params.clock.freq_hz
        ca = {
            d: ca_summary(runs.walks[d], config.warmup_s, freq) | {"a_p": WALK_A_P[d]}
            for d in WALK_A_P
        }
        presets.append(
            {
                "name": runs.preset.name,
                "source": runs.preset.source,
                "gait_freq_hz": freq,
                "cases": case_rows(runs, config.warmup_s, scale),
                "mirror": mirror_rows(runs),
                "ca": ca,
                "circle": circle_summary(runs.circle, ca["forward"]),
                "steering_by_a_p": steering_by_amplitude(runs),
                "speed_limits": speed_limits.summarise(runs.limit_walks),
                "metrics": {
                    "cases": {name: r.metrics for name, r in runs.cases.items()},
                    "walks": {d: [r.metrics for r in rs] for d, rs in runs.walks.items()},
                    "circle": runs.circle.metrics,
                    "steer_probes": {
                        f"{a_p:g}": [r.metrics for r in rs] for a_p, rs in runs.steer_probes.items()
                    },
                },
            }
        )
    return {
        "config": {
            "duration_s": config.duration_s,
            "warmup_s": config.warmup_s,
            "ca_values": list(config.ca_values),
            "paper_ca_limit": PAPER_CA_LIMIT,
            "circle_ca": CIRCLE_CA,
            "circle_s": config.circle_s,
            "steer_a_p": list(config.steer_a_p),
            "limit_a_p": list(config.limit_a_p),
            "limit_ca": list(config.limit_ca),
            "limit_duration_s": config.limit_duration_s,
            "limit_gyro_factor": speed_limits.GYRO_FACTOR,
            "speed_scale": scale,
        },
        "notes": notes,
        "presets": presets,
    }


def _json_safe(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.generic):
        return _json_safe(value.item())
    return value


def run_paper_bench(
    preset_specs: list[str],
    config: BenchConfig,
    out_dir: Path,
    *,
    stdout: TextIO | None = None,
    stderr: TextIO | None = None,
) -> dict[str, Any]:
    """Run, print the report, write results.json and the PNGs; returns the results document.

    Seed 000 §5: walking on the spot, forward, sideways and turning, and their mirror images
    (`app.analysis.cases`). Seed 004 §V: curve walking forward and backward over a CA sweep --
    heading rate against eq (13), theta_dot = -2 CA V / b, an effective axle fitted to it, the
    stability (gyro RMS, falls) against CA as in its Fig. 6, and whether CA = 0.058 walks a full
    circle (`app.analysis.ca_analysis` has the formulas). Prints the tables (`app.study.report`),
    writes the plots (`app.study.plots`) and every number to results.json in `out_dir`.

    The report goes to stdout, progress to stderr (default: the sys streams at call time).
    """
    stdout = stdout or sys.stdout
    stderr = stderr or sys.stderr
    from app.study.plots import write_plots
    from app.study.report import render_report

    presets, notes = resolve_presets(preset_specs)
    if not presets:
        raise ValueError(f"no presets to run (asked for {preset_specs}): {'; '.join(notes)}")
    n_runs = len(presets) * (len(CASES) + len(WALK_A_P) * len(config.ca_values))
    progress = progress_printer(
        f"bench paper: {n_runs} runs of {config.duration_s:g} s "
        f"({', '.join(p.name for p in presets)}), then {len(presets)} full-circle walks of "
        f"{config.circle_s:g} s and the CA limit at {len(config.limit_a_p)} more speeds ...",
        stderr,
        label="bench paper",
    )
    all_runs = run_all(presets, config, progress)
    results = _json_safe(summarise(all_runs, config, notes))
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "results.json").write_text(
        json.dumps(results, indent=1, allow_nan=False), encoding="utf-8"
    )
    pngs = write_plots(all_runs, results, out_dir)
    print(render_report(results), file=stdout)
    written = ", ".join(p.name for p in [out_dir / "results.json", *pngs])
    print(f"\nwritten to {out_dir}: {written}", file=stdout)
    return results
