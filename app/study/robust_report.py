"""The report of `artro bench robust` (docs/DESIGN.md §12): a table for the terminal or as
markdown, and a PNG of the pass share per case with its 95 % interval, preset beside preset."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

TARGET_PERCENT = 90.0  # the dotted line: a case most worlds walk


def _figure(case: dict[str, Any]) -> str:
    value = case["nominal"]
    if value is None:
        return "-"
    return f"{value:.2f}" if case["metric"] == "drift_cm_s" else f"{value:+.2f}"


def _depends(case: dict[str, Any]) -> str:
    d = case["depends_on"]
    if d is None:
        return "-"
    doubt = (
        f"; {d['samples']} variations, {d['failing']} failing: too small a sample to trust"
        if d.get("trusted") is False  # (a report of before issue 56, item 15, does not say)
        else ""
    )
    return (
        f"{d['parameter']} (r {d['r']:+.2f}; fails {d['fail_below']:.0%} at <= {d['median']:.3g}, "
        f"{d['fail_above']:.0%} above{doubt})"
    )


#: where each case's nominal figure goes, by the run metric it is (`figure_metric`)
SPEED_METRICS = ("forward_cm_s", "lateral_cm_s", "drift_cm_s")
SIGNS = (
    "signs (docs/DESIGN.md §3, as in `bench paper`): cm/s forward + and left +, on the spot the "
    "trunk's drift (no sign); deg/s counter-clockwise + seen from above, so turn clockwise "
    "(a_y > 0) reads negative"
)


def model_variations(results: dict[str, Any]) -> str:
    """How many variations the bench ran: 1 model variation, 8 model variations."""
    count = results["samples"]
    return f"{count} model variation{'' if count == 1 else 's'}"


def title(results: dict[str, Any]) -> str:
    """What was measured on which robot: presets, variations, seed, run length."""
    names = ", ".join(r["preset"] for r in results["presets"])
    return (
        f"bench robust: {names} on robot {results['robot']}, {model_variations(results)} "
        f"(seed {results['seed']}), {results['duration_s']:g} s runs "
        f"({results['warmup_s']:g} s warm-up)"
    )


def render(results: dict[str, Any], *, markdown: bool = False) -> str:
    """A title; per preset each case's nominal figure (in its unit, signed as SIGNS says), pass
    share, interval, falls, what failures depend on; then the worst variations with the command
    that repeats each."""
    gap = [""] if markdown else []  # markdown: paragraphs, and a table ends at a blank line
    out = [f"# {title(results)}" if markdown else title(results), *gap]
    out += [f"pass: {results['pass_rule']}", *gap, SIGNS]
    for report in results["presets"]:
        out.append("")
        out += [f"## {report['preset']}", ""] if markdown else [f"{report['preset']}:"]
        header = [
            "case",
            "nominal cm/s (fwd, left +)",
            "nominal deg/s (ccw +)",
            "pass (runs)",
            "95 % interval",
            "falls (runs)",
            "failures depend on",
        ]
        rows = []
        for c in report["cases"]:
            lo, hi = c["interval"]
            nominal = "fell" if c["nominal_fell"] else _figure(c)
            if not c["nominal_fell"] and not c.get("nominal_walks", True):
                nominal += " (does not walk it: no run passes)"
            speed = c["metric"] in SPEED_METRICS
            rows.append(
                [
                    c["case"],
                    nominal if speed else "",
                    "" if speed else nominal,
                    f"{c['share']:.0%} ({c['passed']}/{c['runs']})",
                    f"{lo:.0%}–{hi:.0%}",
                    str(c["falls"]),
                    _depends(c),
                ]
            )
        out += [*_table(header, rows, markdown), *gap]
        out.append(f"all cases: {report['overall_share']:.0%} pass")
        out += _servo_lines(report)
        if report["worst"]:
            out.append("worst variations, each with the command that repeats its first failure:")
            for w in report["worst"]:
                failed = ", ".join(w["failed"])
                out.append(f"- fails {w['failed_cases']} ({failed}):")
                out.append(f"  `{w['command']}`" if markdown else f"  {w['command']}")
    return "\n".join(out)


def _servo_lines(report: dict[str, Any]) -> list[str]:
    """Which cases fail at a servo's torque, and the servo that would carry it."""
    lines = []
    for c in report["cases"]:
        t = c.get("torque")
        if t and t["bound"]:
            held = ", ".join(
                f"{joint} {100 * fail:.0f} % ({t['reference']} {100 * ref:.0f} %)"
                for joint, (fail, ref) in t["at_limit_share"].items()
            )
            lines.append(
                f"{c['case']}: the failing runs sat at the torque limit of {held} of their "
                f"frames; {t['at_stall_runs']} of {t['failing_runs']} reached their stall torque"
            )
    advice = report.get("servo_advice")
    for group in advice["groups"] if advice else []:
        joints = ", ".join(group["joints"])
        asks = (
            f"servos: eq (1) asks {group['need_nm']:.2f} N·m of {joints} (1.2 x the "
            f"{group['stall_nm']:.2f} N·m their {group['servo_now']} reached)"
        )
        if group["servo"] is None:
            lines.append(f"{asks}; no servo of models/servos.yaml or the robot's file gives that "
                         "at this supply")  # fmt: skip
        else:
            lines.append(f"{asks}; {group['servo']} gives {group['servo_stall_nm']:.2f} N·m")
    if advice and "command" in advice:
        lines.append(f"  with them: {advice['command']}")
    return lines


def _table(header: list[str], rows: list[list[str]], markdown: bool) -> list[str]:
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        return lines + ["| " + " | ".join(r) + " |" for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:{w}}}" for w in widths)
    return [fmt.format(*header)] + [fmt.format(*r) for r in rows]


def robust_figure(results: dict[str, Any]) -> Figure:
    """Bars of each case's pass share per preset, with the 95 % interval as error bars, a line
    at 90 % labelled above the frame, and the legend below the axis, off the bars."""
    reports = results["presets"]
    names = [c["case"] for c in reports[0]["cases"]]
    y = np.arange(len(names))
    height = 0.8 / len(reports)
    fig = Figure(figsize=(8, 0.45 * len(names) + 2.2), layout="constrained")
    ax = fig.add_subplot()
    for i, report in enumerate(reports):
        share = np.array([c["share"] for c in report["cases"]]) * 100
        lo = share - np.array([c["interval"][0] for c in report["cases"]]) * 100
        hi = np.array([c["interval"][1] for c in report["cases"]]) * 100 - share
        errors = np.clip([lo, hi], 0.0, None)  # rounding may put an end a hair past the share
        ax.barh(y + i * height, share, height, xerr=errors, capsize=2, label=report["preset"])
    ax.axvline(TARGET_PERCENT, color="0.4", linestyle=":", linewidth=1)
    top = ax.secondary_xaxis("top")  # the line's label, laid out above the frame
    top.set_xticks([TARGET_PERCENT], [f"{TARGET_PERCENT:g} %"])
    top.tick_params(length=0, labelsize=8, labelcolor="0.3")
    ax.set_yticks(y + height * (len(reports) - 1) / 2, names)
    ax.invert_yaxis()
    ax.set_xlim(0, 102)  # the caps at 100 % whole
    ax.set_xticks(range(0, 101, 20))
    ax.set_xlabel("runs that pass, % (whiskers: 95 % interval)")
    ax.set_title(
        f"{', '.join(r['preset'] for r in reports)} on {results['robot']}: "
        f"{model_variations(results)} (seed {results['seed']}), "
        f"{results['duration_s']:g} s runs",
        fontsize=10,
    )
    fig.legend(loc="outside lower center", ncols=len(reports), fontsize=8, frameon=False)
    return fig


def write_plot(results: dict[str, Any], path: Path) -> Path:
    """`robust_figure` as a PNG at `path`."""
    fig = robust_figure(results)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=110)
    return path
