"""Plots of `artro bench paper` (matplotlib, Agg backend, no pyplot state).

paths_<preset>.png, ca_stability.png (seed 004 Fig. 6) and ca_heading.png (eq (13), fitted axle);
see `plot_paths`, `plot_stability`, `plot_heading`.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from app.analysis.ca_analysis import FIT_CA_LIMIT
from app.sim.planning import FRAME_S
from app.study import speed_limits
from app.study.runs import CIRCLE_CA, PresetRuns
from app.study.walks import Run, cycle_mean
from gait import Pose2D, predict_path

CA_AXIS = "curve amount CA  (> 0: left steps longer, turns clockwise)"
TURN_AXIS = "heading rate (deg/s, + = counter-clockwise)"
COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown")
DPI = 110


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=DPI)
    return path


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "preset"


def _path_panel(ax: Axes, run: Run, title: str, warmup_s: float, freq_hz: float) -> None:
    tr = run.trace
    if len(tr.t_s) < 2:
        ax.set_title(f"{title}\n(no samples)", fontsize=9)
        return
    x_cm, y_cm = 100.0 * tr.x_m, 100.0 * tr.y_m
    per_cycle = max(1, round(1.0 / (freq_hz * FRAME_S)))
    x_mean, y_mean, yaw_mean = (cycle_mean(v, per_cycle) for v in (tr.x_m, tr.y_m, tr.yaw_rad))
    ax.plot(x_cm, y_cm, color="tab:blue", lw=0.7, alpha=0.35, label="trunk (sways each step)")
    ax.plot(100 * x_mean, 100 * y_mean, color="tab:blue", lw=2.0, label="trunk, gait-cycle mean")
    ax.plot(x_cm[0], y_cm[0], "o", color="tab:blue", ms=5)
    arrow_cm = 3.0
    heading = float(tr.yaw_rad[0])
    ax.annotate(
        "",
        xy=(x_cm[0] + arrow_cm * math.cos(heading), y_cm[0] + arrow_cm * math.sin(heading)),
        xytext=(x_cm[0], y_cm[0]),
        arrowprops={"arrowstyle": "->", "color": "tab:blue"},
    )
    window = tr.window(warmup_s, freq_hz)
    speed_cm_s = run.metrics.get("forward_cm_s")
    feet_cm = run.metrics.get("feet_distance_cm")
    if window.start < len(tr.t_s) and speed_cm_s is not None and feet_cm is not None:
        i0 = window.start
        if np.isfinite(x_mean[i0]):  # anchor on the cycle-mean path where it exists
            anchor = Pose2D(float(x_mean[i0]), float(y_mean[i0]), float(yaw_mean[i0]))
        else:
            anchor = Pose2D(float(tr.x_m[i0]), float(tr.y_m[i0]), float(tr.yaw_rad[i0]))
        axle_m = feet_cm / 100.0
        t_rel_s = tr.t_s[i0:] - tr.t_s[i0]
        pred = predict_path(anchor, speed_cm_s / 100.0, run.motion.ca, axle_m, t_rel_s)
        ax.plot(
            100.0 * pred[:, 1],
            100.0 * pred[:, 2],
            "--",
            color="tab:red",
            lw=1.4,
            label=f"predicted (V {speed_cm_s:+.2f} cm/s, b {100 * axle_m:.1f} cm)",
        )
        ax.plot(100.0 * anchor.x_m, 100.0 * anchor.y_m, "s", color="tab:red", ms=4)
    if run.metrics["fell"]:
        ax.plot(x_cm[-1], y_cm[-1], "x", color="black", ms=9, mew=2, label="fell")
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6.5, loc="best")
    ax.tick_params(labelsize=7)


def plot_paths(runs: PresetRuns, summary: dict[str, Any], warmup_s: float, out: Path) -> Path:
    """paths_<preset>.png: the trunk path of every paper case and of the CA = 0.058 walk.

    Each path raw and as its moving mean over one gait cycle (which removes the sway of each
    step), against the differential-drive prediction (`gait.steering.predict_path`, the exact
    unicycle of seed 004 eq 9 with V_L,R = (1 +- CA) V) anchored on the mean path at the end of the
    warm-up, with that run's measured V (mean forward speed) and b (mean distance between the feet).
    """
    freq = runs.preset.params.clock.freq_hz
    panels: list[tuple[Run, str]] = []
    for row in summary["cases"]:
        unit = "deg/s" if row["metric"] == "turn_deg_s" else "cm/s"
        sim = "-" if row["sim"] is None else f"{row['sim']:+.2f}"
        panels.append(
            (
                runs.cases[row["case"]],
                f"{row['case']}: {sim} {unit} (target {row.get('target', row['paper']):+.1f})",
            )
        )
    circle, turn = runs.circle, runs.circle.metrics.get("turn_deg_s")
    turned = math.degrees(float(circle.trace.yaw_rad[-1] - circle.trace.yaw_rad[0]))
    panels.append(
        (
            circle,
            f"a_p={circle.motion.a_p:+.2f}, CA={CIRCLE_CA}, {circle.trace.t_s[-1]:.0f} s: "
            f"turned {turned:+.0f} deg ({'-' if turn is None else f'{turn:+.2f}'} deg/s)",
        )
    )
    cols = 3
    rows = math.ceil(len(panels) / cols)
    fig = Figure(figsize=(4.6 * cols, 4.2 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax, (run, title) in zip(axes.flat, panels, strict=False):
        _path_panel(ax, run, title, warmup_s, freq)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("x (cm, world; + = robot's initial forward)", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("y (cm, world; + = left)", fontsize=8)
    fig.suptitle(
        f"Trunk paths, preset '{runs.preset.name}': actual (o start, arrow = initial heading; "
        "thick: mean over one gait cycle)\nvs the differential-drive prediction, anchored on the "
        f"mean path at the end of the {warmup_s:g} s warm-up (square)",
        fontsize=10,
    )
    return _save(fig, out / f"paths_{_slug(runs.preset.name)}.png")


def plot_stability(results: dict[str, Any], out: Path) -> Path:
    """ca_stability.png: trunk gyro RMS against CA, forward and backward (seed 004, Fig. 6)."""
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    for ax, direction in zip(axes, ("forward", "backward"), strict=True):
        paper_limit = results["config"]["paper_ca_limit"][direction]
        for k, p in enumerate(results["presets"]):
            s, color = p["ca"][direction], COLORS[k % len(COLORS)]
            ca = np.array([r["ca"] for r in s["rows"]])
            gyro = np.array([np.nan if r["gyro_rms"] is None else r["gyro_rms"] for r in s["rows"]])
            fell = np.array([r["fell"] for r in s["rows"]])
            ax.plot(ca[~fell], gyro[~fell], "o-", color=color, ms=4, label=f"{p['name']}")
            if fell.any():
                fell_label = f"{p['name']}: fell"
                ax.plot(ca[fell], gyro[fell], "x", color=color, ms=9, mew=2, label=fell_label)
            first_fall = s["stable_limit"]["first_fall"]
            if first_fall is not None:
                for sign in (-1, 1):
                    ax.axvline(sign * first_fall, color=color, ls="--", lw=1)
        for sign in (-1, 1):
            ax.axvline(sign * paper_limit, color="grey", ls=":", lw=1)
        ax.text(
            paper_limit,
            0.98,
            f"Nao limit {paper_limit} ",
            transform=ax.get_xaxis_transform(),
            fontsize=7,
            va="top",
            ha="right",
            color="grey",
        )
        ax.set_title(f"{direction} walking (a_p = {s['a_p']:+.2f})", fontsize=10)
        ax.set_xlabel(CA_AXIS, fontsize=8)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("trunk gyro RMS (rad/s; larger = less stable)", fontsize=8)
    fig.suptitle(
        "Stability against curve amount (seed 004, Fig. 6); x = fell (plotted at the gyro RMS "
        "measured before the fall), dashed = first |CA| that fell",
        fontsize=10,
    )
    return _save(fig, out / "ca_stability.png")


def plot_heading(results: dict[str, Any], out: Path) -> Path:
    """ca_heading.png: heading rate against CA with eq (13), theta_dot = -2 CA V / b, and the line
    of the fitted effective axle b_eff."""
    fig = Figure(figsize=(11, 4.4), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, direction in zip(axes, ("forward", "backward"), strict=True):
        ax.axvspan(-FIT_CA_LIMIT, FIT_CA_LIMIT, color="0.93", zorder=0)
        for k, p in enumerate(results["presets"]):
            s, color = p["ca"][direction], COLORS[k % len(COLORS)]
            ok = [r for r in s["rows"] if not r["fell"] and r["turn_deg_s"] is not None]
            ca_all = np.array([r["ca"] for r in s["rows"]])
            ax.plot(
                [r["ca"] for r in ok],
                [r["turn_deg_s"] for r in ok],
                "o",
                color=color,
                ms=5,
                label=f"{p['name']}: measured",
            )
            line = np.linspace(ca_all.min(), ca_all.max(), 50)
            if s["speed_cm_s"] is not None and s["axle_cm"]:
                eq13 = np.degrees(-2.0 * line * s["speed_cm_s"] / s["axle_cm"])
                ax.plot(
                    line,
                    eq13,
                    "-",
                    color=color,
                    lw=1,
                    label=f"{p['name']}: eq (13), V {s['speed_cm_s']:+.2f} cm/s, "
                    f"b {s['axle_cm']:.1f} cm",
                )
            fit = s["fit"]
            if fit is not None and fit["axle_eff_cm"] is not None:
                fitted = fit["drift_deg_s"] + fit["slope_deg_s_per_ca"] * line
                ax.plot(
                    line,
                    fitted,
                    "--",
                    color=color,
                    lw=1,
                    label=f"{p['name']}: fit, b_eff {fit['axle_eff_cm']:.1f} cm",
                )
        ax.axhline(0.0, color="black", lw=0.6)
        title = f"{direction} walking (a_p = {s['a_p']:+.2f}); grey band: fitted range"
        ax.set_title(title, fontsize=10)
        ax.set_xlabel(CA_AXIS, fontsize=8)
        ax.set_ylabel(TURN_AXIS, fontsize=8)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5)
    fig.suptitle("Heading rate against CA: theta_dot = -2 CA V / b (seed 004, eq 13)", fontsize=11)
    return _save(fig, out / "ca_heading.png")


def write_plots(all_runs: list[PresetRuns], results: dict[str, Any], out: Path) -> list[Path]:
    """All PNGs of the bench into `out`; returns their paths."""
    warmup = results["config"]["warmup_s"]
    written = [
        plot_paths(runs, summary, warmup, out)
        for runs, summary in zip(all_runs, results["presets"], strict=True)
    ]
    limits = speed_limits.plot(results, out, COLORS)
    return [*written, plot_stability(results, out), plot_heading(results, out), limits]
