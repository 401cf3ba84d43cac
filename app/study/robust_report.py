"""The report of `artro bench robust` (docs/DESIGN.md §12): a table for the terminal or as
markdown, and a PNG of the pass share per case with its 95 % interval, preset beside preset."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def _depends(case: dict[str, Any]) -> str:
    d = case["depends_on"]
    if d is None:
        return "-"
    return (
        f"{d['parameter']} (r {d['r']:+.2f}; fails {d['fail_below']:.0%} at <= {d['median']:.3g}, "
        f"{d['fail_above']:.0%} above)"
    )


def render(results: dict[str, Any], *, markdown: bool = False) -> str:
    """Per preset: each case's pass share, interval, falls, what failures depend on; then the
    worst variations with the command that repeats each."""
    out = [
        f"bench robust: robot {results['robot']}, {results['samples']} variations (seed "
        f"{results['seed']}), {results['duration_s']:g} s runs",
        f"pass: {results['pass_rule']}",
    ]
    for report in results["presets"]:
        out.append("")
        out.append(f"## {report['preset']}" if markdown else f"{report['preset']}:")
        header = ["case", "nominal", "pass", "95 % interval", "falls", "failures depend on"]
        rows = []
        for c in report["cases"]:
            lo, hi = c["interval"]
            nominal = "fell" if c["nominal_fell"] else f"{c['nominal']:+.2f}"
            rows.append(
                [
                    c["case"],
                    nominal,
                    f"{c['share']:.0%} ({c['passed']}/{c['runs']})",
                    f"{lo:.0%}–{hi:.0%}",
                    str(c["falls"]),
                    _depends(c),
                ]
            )
        out += _table(header, rows, markdown)
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
            lines.append(
                f"{c['case']}: {t['at_stall_runs']} of {t['failing_runs']} failing runs had a "
                f"servo at its stall torque ({', '.join(t['joints'])}; peak {t['peak_nm']:.2f} N·m)"
            )
    advice = report.get("servo_advice")
    if advice:
        joints = ", ".join(advice["joints"])
        if advice["servo"] is None:
            lines.append(
                f"servos: eq (1) asks {advice['need_nm']:.2f} N·m of {joints}; no servo of "
                "models/servos.yaml gives that at this supply"
            )
        else:
            lines.append(
                f"servos: eq (1) asks {advice['need_nm']:.2f} N·m of {joints} (1.2 x the "
                f"{advice['stall_nm']:.2f} N·m they reached); {advice['servo']} gives "
                f"{advice['servo_stall_nm']:.2f} N·m"
            )
            if "command" in advice:
                lines.append(f"  with it: {advice['command']}")
    return lines


def _table(header: list[str], rows: list[list[str]], markdown: bool) -> list[str]:
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        return lines + ["| " + " | ".join(r) + " |" for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:{w}}}" for w in widths)
    return [fmt.format(*header)] + [fmt.format(*r) for r in rows]


def write_plot(results: dict[str, Any], path: Path) -> Path:
    """Bars of each case's pass share per preset, with the 95 % interval as error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    reports = results["presets"]
    names = [c["case"] for c in reports[0]["cases"]]
    y = np.arange(len(names))
    height = 0.8 / len(reports)
    fig, ax = plt.subplots(figsize=(8, 0.45 * len(names) + 1.5))
    for i, report in enumerate(reports):
        share = np.array([c["share"] for c in report["cases"]]) * 100
        lo = share - np.array([c["interval"][0] for c in report["cases"]]) * 100
        hi = np.array([c["interval"][1] for c in report["cases"]]) * 100 - share
        errors = np.clip([lo, hi], 0.0, None)  # rounding may put an end a hair past the share
        ax.barh(y + i * height, share, height, xerr=errors, capsize=2, label=report["preset"])
    ax.axvline(90, color="0.4", linestyle=":", linewidth=1)
    ax.text(90, -0.7, "90 %", ha="center", fontsize=8, color="0.3")
    ax.set_yticks(y + height * (len(reports) - 1) / 2, names)
    ax.invert_yaxis()
    ax.set_xlim(0, 100)
    ax.set_xlabel("runs that pass, % (95 % interval)")
    ax.set_title(
        f"{results['robot']}: {results['samples']} variations, seed {results['seed']}",
        fontsize=10,
    )
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
