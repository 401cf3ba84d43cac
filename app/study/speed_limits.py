"""Seed 004 §V: slower walking allows more CA. The largest stable CA against walking speed.

Each forward amplitude a_p walks CA = 0 and +-LIMIT_CA; a CA is stable when the robot does not
fall and its trunk gyro RMS stays within GYRO_FACTOR of the straight walk's (docs/DESIGN.md §12).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from app.evaluation import Job
from app.study.walks import Preset, Run
from gait import Motion

#: forward amplitudes walked for the limit (the CA sweep adds +-0.07, seed 000's)
LIMIT_A_P = (-0.09, -0.05, -0.035, 0.035, 0.05, 0.09)
LIMIT_CA = (0.1, 0.2, 0.3, 0.4, 0.5)  # |CA| walked at each amplitude, both signs
GYRO_FACTOR = 1.5  # stable: gyro RMS at most 1.5 x the straight walk's at the same a_p
SIGNS = (("+", 1), ("-", -1))


def limit_ca_values(magnitudes: Sequence[float] = LIMIT_CA) -> tuple[float, ...]:
    """0 and +-each magnitude, sorted."""
    return tuple(sorted({0.0, *magnitudes, *(-m for m in magnitudes)}))


def label(a_p: float, ca: float) -> str:
    return f"limit a_p={a_p:+.3f} CA={ca:+.3f}"


def plan(
    preset: Preset, amplitudes: Sequence[float], magnitudes: Sequence[float]
) -> list[tuple[Preset, str, Job]]:
    """(preset, label, job) for every amplitude and CA of the limit study."""
    return [
        (preset, label(a_p, ca), Job(preset.params, Motion(a_p=a_p, ca=ca)))
        for a_p in amplitudes
        for ca in limit_ca_values(magnitudes)
    ]


def _limit(rows: list[dict[str, Any]], sign: int, key: str) -> float | None:
    """Largest |CA| of one sign such that every |CA| up to it is stable by `key`; None if the
    first one already is not."""
    best = None
    for row in sorted((r for r in rows if r["ca"] * sign > 0), key=lambda r: abs(r["ca"])):
        if not row[key]:
            break
        best = abs(row["ca"])
    return best


def summarise(walks: dict[float, list[Run]]) -> list[dict[str, Any]]:
    """Per amplitude: V at CA = 0, each CA's gyro and fall, and the largest stable CA each way
    by falls alone and by falls plus the gyro criterion."""
    out = []
    for a_p in sorted(walks):
        runs = walks[a_p]
        straight = next(r for r in runs if r.motion.ca == 0.0)
        gyro0 = straight.metrics["gyro_rms"]
        rows = []
        for r in runs:
            fell, gyro = bool(r.metrics["fell"]), r.metrics["gyro_rms"]
            calm = gyro is not None and gyro0 is not None and gyro <= GYRO_FACTOR * gyro0
            rows.append(
                {
                    "ca": r.motion.ca,
                    "fell": fell,
                    "gyro_rms": gyro,
                    "standing": not fell,
                    "stable": not fell and calm,
                }
            )
        out.append(
            {
                "a_p": a_p,
                "speed_cm_s": straight.metrics["forward_cm_s"],
                "fell_straight": bool(straight.metrics["fell"]),
                "gyro_rms_straight": gyro0,
                "rows": rows,
                "limit_no_fall": {
                    "+": _limit(rows, 1, "standing"),
                    "-": _limit(rows, -1, "standing"),
                },
                "limit_stable": {"+": _limit(rows, 1, "stable"), "-": _limit(rows, -1, "stable")},
                "ca_max": max(abs(r["ca"]) for r in rows),
            }
        )
    return out


def report_lines(rows: list[dict[str, Any]]) -> list[str]:
    """One line per amplitude: speed and the largest stable |CA| each way."""
    if not rows:
        return []

    def shown(value: float | None, ca_max: float) -> str:
        if value is None:
            return "none"
        return f">={value:.1f}" if value >= ca_max - 1e-9 else f"{value:.1f}"

    lines = [
        f"largest stable |CA| against speed (seed 004 §V; stable: no fall and gyro RMS <= "
        f"{GYRO_FACTOR:g} x the straight walk's; '>=' : the end of the sweep):",
    ]
    for r in rows:
        speed = "fell" if r["fell_straight"] else f"{r['speed_cm_s']:+.2f} cm/s"
        stable, standing = r["limit_stable"], r["limit_no_fall"]
        lines.append(
            f"  a_p {r['a_p']:+.3f} ({speed}): stable CA+ {shown(stable['+'], r['ca_max'])}, "
            f"CA- {shown(stable['-'], r['ca_max'])}; no fall CA+ "
            f"{shown(standing['+'], r['ca_max'])}, CA- {shown(standing['-'], r['ca_max'])}"
        )
    return lines


def plot(results: dict[str, Any], out: Path, colors: Sequence[str]) -> Path:
    """ca_limit_speed.png: the largest stable |CA| against the measured walking speed."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # ~0.9 s: only to draw
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4.4), layout="constrained")
    ax = fig.subplots()
    for k, p in enumerate(results["presets"]):
        rows = [r for r in p.get("speed_limits", []) if r["speed_cm_s"] is not None]
        color = colors[k % len(colors)]
        speed = np.array([r["speed_cm_s"] for r in rows])
        for sign, marker in (("+", "^"), ("-", "v")):
            stable = np.array(
                [
                    np.nan if r["limit_stable"][sign] is None else r["limit_stable"][sign]
                    for r in rows
                ]
            )
            standing = np.array(
                [
                    np.nan if r["limit_no_fall"][sign] is None else r["limit_no_fall"][sign]
                    for r in rows
                ]
            )
            order = np.argsort(speed)
            ax.plot(speed[order], stable[order], marker + "-", color=color, ms=6,
                    label=f"{p['name']}: CA {sign}, stable")  # fmt: skip
            ax.plot(speed[order], standing[order], marker, color=color, ms=11, mfc="none",
                    label=f"{p['name']}: CA {sign}, no fall")  # fmt: skip
    ax.set_xlabel("walking speed V at CA = 0 (cm/s; < 0 backward)", fontsize=9)
    ax.set_ylabel(f"largest stable |CA| (no fall, gyro <= {GYRO_FACTOR:g} x straight)", fontsize=8)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6.5, ncol=2)
    ax.set_title("Seed 004 §V: slower walking allows more CA? (the top of the y axis is the "
                 "end of the sweep)", fontsize=9)  # fmt: skip
    path = out / "ca_limit_speed.png"
    FigureCanvasAgg(fig).print_png(str(path))
    return path


def _nan(value: float | None) -> float:
    return np.nan if value is None else value
