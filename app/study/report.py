"""Plain-text report of `artro bench paper`, rendered from its results document (results.json).

Tables put the presets side by side: one group of columns per preset. Signs follow our
conventions (docs/DESIGN.md §3): forward +, lateral + = left, turn + = counter-clockwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from app.analysis.ca_analysis import FIT_CA_LIMIT
from app.analysis.cases import (
    BEND_LIMIT,
    MIRROR_TOLERANCE,
    SPEED_TOLERANCE,
    SPOT_DRIFT_LIMIT_CM_S,
    STEERING_TOLERANCE,
)
from app.study import speed_limits

METRIC_LABELS = {
    "drift_cm_s": "drift cm/s",
    "forward_cm_s": "fwd cm/s",
    "lateral_cm_s": "lat cm/s",
    "turn_deg_s": "turn deg/s",
}


def fmt(value: float | None, spec: str = "+.2f") -> str:
    return "-" if value is None else format(value, spec)


def pct(value: float | None, signed: bool = False, digits: int = 0) -> str:
    spec = f"{'+' if signed else ''}.{digits}f"
    return "-" if value is None else format(100.0 * value, spec) + " %"


def fell_text(row: dict[str, Any]) -> str:
    if not row["fell"]:
        return "no"
    t = row.get("fall_time_s")
    return "yes" if t is None else f"@{t:.1f}s"


def table(groups: Sequence[tuple[str, Sequence[str]]], rows: Sequence[Sequence[str]]) -> list[str]:
    """Aligned columns in titled groups separated by ' | '; the first column left-aligned."""
    headers = [h for _, cols in groups for h in cols]
    widths = [max([len(h), *(len(r[i]) for r in rows)]) for i, h in enumerate(headers)]
    spans, start = [], 0
    for _, cols in groups:
        spans.append(range(start, start + len(cols)))
        start += len(cols)

    def line(cells: Sequence[str]) -> str:
        parts = []
        for span in spans:
            cell_text = [
                cells[i].ljust(widths[i]) if i == 0 else cells[i].rjust(widths[i]) for i in span
            ]
            parts.append("  ".join(cell_text))
        return " | ".join(parts).rstrip()

    group_widths = [sum(widths[i] for i in span) + 2 * (len(span) - 1) for span in spans]
    for k, (title, _) in enumerate(groups):  # widen a group's last column to fit its title
        if len(title) > group_widths[k]:
            widths[spans[k][-1]] += len(title) - group_widths[k]
            group_widths[k] = len(title)
    title_line = " | ".join(t.center(w) for (t, _), w in zip(groups, group_widths, strict=True))
    out = [title_line.rstrip(), line(headers)]
    out.append("-+-".join("-" * w for w in group_widths))
    out += [line(r) for r in rows]
    return out


def cases_section(results: dict[str, Any]) -> list[str]:
    presets = results["presets"]
    cfg = results["config"]
    scale = cfg.get("speed_scale", 1.0)
    out = [
        f"PAPER CASES (seed 000 §5) -- {cfg['duration_s']:g} s runs, measured after "
        f"{cfg['warmup_s']:g} s over whole gait cycles",
        f"  pass: no fall, within ±{SPEED_TOLERANCE:.0%} of the target (on the spot: drift < "
        f"{SPOT_DRIFT_LIMIT_CM_S * scale:.2g} cm/s)",
        "  target: the paper's figure"
        + (
            ""
            if scale == 1.0
            else f", speeds scaled by {scale:.2f} (the robot's leg against ArtRo's; turns not)"
        ),
        "  signs: fwd + = forward, lat + = left, turn + = counter-clockwise",
        "  sim: the run metric (as `artro run`); gyro: trunk gyro RMS, rad/s",
        "",
    ]
    groups: list[tuple[str, Sequence[str]]] = [("", ("case", "metric", "paper", "target"))]
    groups += [(p["name"], ("sim", "ratio", "pass", "fell", "gyro")) for p in presets]
    rows = []
    for i, case in enumerate(presets[0]["cases"]):
        row = [case["case"], METRIC_LABELS[case["metric"]], fmt(case["paper"], "+.1f")]
        row.append(fmt(case.get("target", case["paper"]), "+.1f"))
        for p in presets:
            c = p["cases"][i]
            row += [
                fmt(c["sim"]),
                fmt(c["ratio"], ".2f"),
                "yes" if c["pass"] else "NO",
                fell_text(c),
                fmt(c["gyro_rms"], ".2f"),
            ]
        rows.append(row)
    out += table(groups, rows)
    out += ["", f"mirror check: |a - (-b)| / mean(|a|, |b|) <= {MIRROR_TOLERANCE:.0%}", ""]
    groups = [("", ("pair",))] + [(p["name"], ("a", "b", "mismatch", "ok")) for p in presets]
    rows = []
    for i, pair in enumerate(presets[0]["mirror"]):
        row = [pair["pair"]]
        for p in presets:
            m = p["mirror"][i]
            row += [
                fmt(m["a"]),
                fmt(m["b"]),
                pct(m["mismatch"], digits=1),
                "ok" if m["ok"] else "NO",
            ]
        rows.append(row)
    return out + table(groups, rows)


def ca_section(results: dict[str, Any], direction: str) -> list[str]:
    presets = results["presets"]
    limit_paper = results["config"]["paper_ca_limit"][direction]
    a_p = presets[0]["ca"][direction]["a_p"]
    out = [
        f"CA CURVE WALKING, {direction.upper()} (a_p = {a_p:+.2f}); seed 004 §V, eq (13): "
        "theta_dot = -2 CA V / b",
        "  turn: measured heading rate, eq13: predicted, deg/s, + = counter-clockwise",
        f"  err = (turn - eq13) / |eq13| for 0 < |CA| <= {FIT_CA_LIMIT}; "
        "err-drift: the same, turn minus the drift",
        "  (drift: the heading rate at CA = 0)",
        "",
    ]
    groups: list[tuple[str, Sequence[str]]] = [("", ("CA",))]
    groups += [(p["name"], ("turn", "eq13", "err", "err-drift", "gyro", "fell")) for p in presets]
    rows = []
    for i, first in enumerate(presets[0]["ca"][direction]["rows"]):
        row = [f"{first['ca']:+.3f}"]
        for p in presets:
            r = p["ca"][direction]["rows"][i]
            row += [
                fmt(r["turn_deg_s"]),
                fmt(r["eq13_turn_deg_s"]),
                pct(r["rel_error"], signed=True),
                pct(r["rel_error_drift_removed"], signed=True),
                fmt(r["gyro_rms"], ".2f"),
                fell_text(r),
            ]
        rows.append(row)
    out += table(groups, rows)
    for p in presets:
        lines = ca_summary_lines(p["ca"][direction], limit_paper)
        if direction == "forward":
            lines += circle_lines(p.get("circle"))
            lines += amplitude_lines(p.get("steering_by_a_p", []))
            lines += speed_limits.report_lines(p.get("speed_limits", []))
        out += ["", f"{p['name']}:", *(f"  {line}" for line in lines)]
    return out


def ca_summary_lines(s: dict[str, Any], paper_limit: float) -> list[str]:
    """The summary of one preset's sweep in one direction, a few lines under 100 characters."""
    lines = [
        f"V (CA = 0) {fmt(s['speed_cm_s'])} cm/s, b (feet apart) {fmt(s['axle_cm'], '.1f')} cm, "
        f"drift {fmt(s['drift_deg_s'])} deg/s",
    ]
    if s["speed_cm_s"] is not None and abs(s["speed_cm_s"]) < SPOT_DRIFT_LIMIT_CM_S:
        lines += [
            f"  the robot barely walks (|V| < {SPOT_DRIFT_LIMIT_CM_S} cm/s):",
            "  eq (13)'s rate is tiny, the CA figures below are drift, not steering",
        ]
    fit = s["fit"]
    if fit is None:
        lines.append(f"axle fit: fewer than two standing runs with |CA| <= {FIT_CA_LIMIT}")
    else:
        ratio = None
        if fit["axle_eff_cm"] is not None and s["axle_cm"]:
            ratio = fit["axle_eff_cm"] / s["axle_cm"]
        lines += [
            f"fit theta_dot = drift - 2 CA V / b_eff, |CA| <= {FIT_CA_LIMIT}, "
            f"{fit['n_points']} runs: b_eff {fmt(fit['axle_eff_cm'], '.1f')} cm "
            f"= {fmt(ratio, '.2f')} b",
            f"  (fitted drift {fmt(fit['drift_deg_s'])} deg/s, residual RMS "
            f"{fmt(fit['residual_rms_deg_s'], '.2f')} deg/s)",
        ]
        if fit["axle_eff_cm"] is not None and fit["axle_eff_cm"] < 0:
            lines.append("  b_eff < 0: CA turns the robot against the direction of eq (13)")
        elif ratio:
            lines.append(f"  CA steers at {1.0 / ratio:.0%} of eq (13) with b = the feet distance")
    st = s.get("steering")
    if st is not None:
        right, within = ("yes" if st[k] else "NO" for k in ("steers_right", "within_eq13"))
        lines += [
            f"CA = +-{st['ca']:g}: gain {st['gain']:.2f} (eq (13): 1), bend {st['bend']:+.2f} "
            f"(linear: 0, limit {BEND_LIMIT})",
            f"  steers right: {right}; within {STEERING_TOLERANCE:.0%} of eq (13): {within}",
        ]
    pairs = s["antisymmetry"]
    if pairs:
        raw = [f"{q['ca']:.3f}: {pct(q['mismatch'])}{_flag(q['ok'])}" for q in pairs]
        no_drift = [
            f"{q['ca']:.3f}: {pct(q['mismatch_drift_removed'])}{_flag(q['ok_drift_removed'])}"
            for q in pairs
        ]
        even = sum(q["even_part_deg_s"] for q in pairs) / len(pairs)
        lines.append("antisymmetry |th(CA) + th(-CA)| / mean(|th(CA)|, |th(-CA)|), '!' above 15 %:")
        lines += _wrapped("  raw:           ", raw)
        lines += _wrapped("  drift removed: ", no_drift)
        lines.append(f"  even part (th(CA) + th(-CA)) / 2, mean over the pairs: {even:+.2f} deg/s")
    lim = s["stable_limit"]
    if lim["limit"] is None:
        stable = f"none (already |CA| = {lim['first_fall']:.3f} fell)"
    elif lim["beyond_sweep"]:
        stable = f">= {lim['limit']:.3f} (nothing in the sweep fell)"
    else:
        stable = f"{lim['limit']:.3f} (first fall at |CA| = {lim['first_fall']:.3f})"
    lines.append(f"largest stable |CA|: {stable}; seed 004 (Nao): {paper_limit}")
    return lines


def _wrapped(head: str, items: list[str], per_line: int = 4) -> list[str]:
    chunks = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return [(head if k == 0 else " " * len(head)) + c for k, c in enumerate(chunks)]


def _flag(ok: bool) -> str:
    return "" if ok else "!"


def amplitude_lines(rows: list[dict[str, Any]]) -> list[str]:
    """The CA = +-0.1 gain at each forward amplitude: does CA steer at other speeds too?"""
    if len(rows) < 2:
        return []
    items = []
    for r in rows:
        st = r["steering"]
        if r["fell"]:
            result = "fell"
        elif not r["walks"]:
            result = f"does not walk (|V| < {SPOT_DRIFT_LIMIT_CM_S} cm/s), no gain"
        elif st is None:
            result = "no figure"
        else:
            result = f"gain {st['gain']:.2f}, bend {st['bend']:+.2f}"
        items.append(f"a_p {r['a_p']:.3f} ({fmt(r['speed_cm_s'])} cm/s): {result}")
    return ["CA = +-0.1 at other forward amplitudes:", *(f"  {item}" for item in items)]


def circle_lines(c: dict[str, Any] | None) -> list[str]:
    if c is None:
        return ["full circle: the CA = 0.058 walk has no samples"]
    head = f"full circle, CA = {c['ca']}: turned {c['turned_deg']:+.0f} deg in {c['run_s']:.0f} s"
    if c["fell"]:
        return [head + ", then FELL"]
    rates = f"measured {fmt(c['rate_deg_s'])} deg/s, eq (13) {fmt(c['predicted_rate_deg_s'])} deg/s"
    radius = (
        f"  radius {fmt(c.get('radius_m'), '.2f')} m, eq (13): b / (2 CA) = "
        f"{fmt(c.get('predicted_radius_m'), '.2f')} m"
    )
    if c["completed"]:
        rate, eq13 = c["rate_deg_s"], c["predicted_rate_deg_s"]
        way = "" if rate is None or eq13 is None or rate * eq13 > 0 else ", AGAINST eq (13)"
        when = c.get("time_to_360_s")
        at = "" if when is None else f", 360 deg after {when:.0f} s"
        return [f"{head}: a full circle{at}{way}", f"  ({rates})", radius]
    circle_s, pred_s = c["circle_s"], c["predicted_circle_s"]
    measured = "never (no turn)" if circle_s is None else f"{circle_s:.0f} s"
    predicted = "never" if pred_s is None else f"{pred_s:.0f} s"
    return [
        f"{head}: no full circle",
        f"  one takes {measured} at the measured {fmt(c['rate_deg_s'])} deg/s; "
        f"eq (13): {predicted} at {fmt(c['predicted_rate_deg_s'])} deg/s",
        radius,
    ]


def render_report(results: dict[str, Any]) -> str:
    out = [f"note: {n}" for n in results["notes"]]
    out += cases_section(results)
    for direction in ("forward", "backward"):
        out += ["", "", *ca_section(results, direction)]
    return "\n".join(out)
