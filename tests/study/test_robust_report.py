"""The report of `artro bench robust` (app/study/robust_report.py, docs/DESIGN.md §12): a title
saying what was measured, every figure in a column with its unit and sign convention, and a
plot whose labels and legend keep off the frame and the bars. The report is summarised from
runs' metrics by the real `summarise`, without simulating."""

from __future__ import annotations

import itertools
import math

import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.patches import Rectangle
from matplotlib.text import Text

from app.analysis.robust_cases import PASS_RULE, ROBUST_CASES, RobustCase
from app.analysis.robustness import summarise
from app.study.robust_report import SIGNS, render, robust_figure
from app.worlds.sampling import VariationRanges, sample

SAMPLES = 4


def walked(case: RobustCase, scale: float) -> dict:
    """A run's metrics that walk `case` at `scale` times its paper figure (0: it fell)."""
    m = case.motion
    run = {"fell": scale == 0, "forward_cm_s": 0.2, "lateral_cm_s": 0.1, "turn_deg_s": 0.5}
    if case.kind == "forward":
        run["forward_cm_s"] = math.copysign(3.8, m.a_p) * scale
    elif case.kind == "lateral":
        run["lateral_cm_s"] = -math.copysign(3.5, m.a_r) * scale  # a_r > 0 steps right: y < 0
    elif case.kind == "turn":
        run["turn_deg_s"] = -math.copysign(12.1, m.a_y) * scale  # a_y > 0 turns clockwise
    elif case.kind == "curve":
        run.update(forward_cm_s=3.8 * scale, turn_deg_s=-math.copysign(6.0, m.ca) * scale)
    return run


@pytest.fixture(scope="module")
def results() -> dict:
    variations = sample(VariationRanges(), SAMPLES, seed=1)
    presets = []
    for name, scales in (("tuned", (1.0, 0.8, 0.3, 0.0)), ("paper", (1.0, 1.0, 1.0, 0.6))):
        metrics = [walked(c, 1.0) for c in ROBUST_CASES]
        metrics += [walked(c, s) for s in scales for c in ROBUST_CASES]
        report = summarise(name, variations, metrics)
        presets.append({**report, "servo_advice": None})
    return {
        "robot": "artro",
        "samples": SAMPLES,
        "seed": 1,
        "duration_s": 60.0,
        "warmup_s": 5.0,
        "pass_rule": PASS_RULE,
        "presets": presets,
    }


def rows_of(text: str, preset: str) -> dict[str, list[str]]:
    """The markdown table under `## preset`: each case's cells, and the header under "case"."""
    lines = text.splitlines()
    start = lines.index(f"## {preset}")
    table = {}
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        table[cells[0]] = cells
    return table


def test_the_report_says_what_was_measured_in_its_title(results):
    md = render(results, markdown=True).splitlines()
    title = (
        "bench robust: tuned, paper on robot artro, 4 model variations (seed 1), 60 s runs "
        "(5 s warm-up)"
    )
    assert md[0] == f"# {title}" and md[1] == ""
    assert render(results).splitlines()[0] == title
    one = render({**results, "samples": 1}).splitlines()[0]  # issue 56 item 18: not "1 ...s"
    assert "artro, 1 model variation (seed 1)" in one, one


def test_every_figure_has_its_unit_and_turns_are_counter_clockwise_positive(results):
    md = render(results, markdown=True)
    assert SIGNS in md and "counter-clockwise +" in SIGNS and "clockwise (a_y > 0)" in SIGNS
    for preset in ("tuned", "paper"):
        table = rows_of(md, preset)
        assert table["case"][1:6] == [
            "nominal cm/s (fwd, left +)",
            "nominal deg/s (ccw +)",
            "pass (runs)",
            "95 % interval",
            "falls (runs)",
        ]
        assert table["turn clockwise"][1:3] == ["", "-12.10"]  # a_y > 0: clockwise, negative
        assert table["turn counter-clockwise"][1:3] == ["", "+12.10"]
        assert table["curve CA +0.1"][1:3] == ["", "-6.00"]
        assert table["sideways right"][1:3] == ["-3.50", ""]  # to the right: y < 0
        assert table["backward"][1:3] == ["-3.80", ""]
        assert table["on the spot"][1:3] == ["0.22", ""]  # the drift, without a sign
    case = results["presets"][0]["cases"]
    assert [c["metric"] for c in case[:6:5]] == ["drift_cm_s", "turn_deg_s"]
    lines = md.splitlines()  # a table ends at a blank line (else the next line joins it)
    ends = [b for a, b in itertools.pairwise(lines) if a[:1] == "|" != b[:1]]
    assert ends == ["", ""]


@pytest.mark.parametrize("n_presets", [1, 2])
def test_the_plots_labels_and_legend_keep_off_the_frame_the_bars_and_each_other(results, n_presets):
    fig = robust_figure({**results, "presets": results["presets"][:n_presets]})
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    ax = fig.axes[0]
    frame = ax.get_window_extent(renderer)
    page = fig.bbox
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
    assert any(t.get_text() == "90 %" for t in texts)
    boxes = {}
    for t in texts:
        box = boxes[t] = t.get_window_extent(renderer)
        inside_page = page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0
        assert inside_page and box.y1 <= page.y1, f"{t.get_text()!r} is cut off"
        crosses_top = box.y0 < frame.y1 < box.y1 and box.x1 > frame.x0 and box.x0 < frame.x1
        crosses_side = box.x0 < frame.x1 < box.x1 and box.y1 > frame.y0 and box.y0 < frame.y1
        assert not (crosses_top or crosses_side), f"{t.get_text()!r} crosses the frame"
    legend = fig.legends[0]
    outside = [t for t in texts if t.figure is fig and t not in legend.get_texts()]
    for a, b in itertools.combinations(outside, 2):
        assert not boxes[a].overlaps(boxes[b]), f"{a.get_text()!r} on {b.get_text()!r}"
    legend_box = legend.get_window_extent(renderer)
    bars = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_width() > 0]
    assert len(bars) > 4
    for bar in bars:
        assert not legend_box.overlaps(bar.get_window_extent(renderer)), "the legend is on a bar"
    for t in outside:
        assert not legend_box.overlaps(boxes[t]), f"the legend is on {t.get_text()!r}"
