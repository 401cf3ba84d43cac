"""The Robustness report on the page speaks the World panel's words (issue 56, item 15), in a real
headless Chromium against a real server: "failures depend on" names the parameter by its slider's
label with its unit, says when the sample is too small to trust the correlation, and the worst
variations' highlighted values are explained. Looked at in a screenshot (ARTRO_SCREENSHOTS=DIR)."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.test_browser_world import opened_page
from tests.testing.browser_support import LARGE, shot_path
from tests.testing.server_harness import CHROMIUM  # noqa: F401 (marks the module `browser`)

LABEL = "key => import('./js/world.js').then((m) => m.featureLabel(key))"


@pytest.mark.slow
@LARGE
def test_failures_depend_on_in_the_panel_s_words_with_the_sample_s_trust(tmp_path, width, height):
    with opened_page(tmp_path, width, height) as (page, http, errors):
        expect(page.locator("#robot-badge")).to_have_text("robot artro", timeout=30_000)
        assert http.post("/api/presets/paper/load").status_code == 200  # open loop: it fails some
        expect(page.locator("#params-name")).to_have_text("paper", timeout=30_000)
        page.fill("#robust-samples", "4")
        page.click("#robust-start")
        rows = page.locator("#robust-bars .robust-row:not(.robust-header)")
        expect(rows).to_have_count(9, timeout=600_000)
        (report,) = http.get("/api/world/robustness").json()["presets"]
        traced = [(k, c) for k, c in enumerate(report["cases"]) if c["depends_on"]]
        assert traced, "paper failed no case on 4 variations"
        assert page.evaluate(LABEL, "latency_ms") == "latency (ms)"
        assert page.evaluate(LABEL, "trunk_mass_scale") == "trunk mass ×"
        assert page.evaluate(LABEL, "tilt_sideways_deg") == "floor tilt, sideways (°)"
        for k, case in traced:
            cell = rows.nth(k).locator("span").last
            said = cell.text_content() or ""
            label = page.evaluate(LABEL, case["depends_on"]["parameter"])
            assert said.startswith(label) and "_" not in said, (said, case["depends_on"])
            # four variations cannot carry a correlation: said on the row and why in its title
            assert case["depends_on"]["trusted"] is False
            assert said == f"{label}? too few to trust", said
            title = rows.nth(k).get_attribute("title") or ""
            assert "Too small a sample to trust" in title and "over 4 variations" in title, title
        # the highlighted values of the worst variations are explained, under the list and each
        extreme = page.locator("#robust-worst .term.extreme")
        legend = page.locator("#robust-legend")
        if extreme.count():
            expect(legend).to_be_visible()
            expect(legend).to_contain_text("outer tenth of its default range")
            for i in range(extreme.count()):
                title = extreme.nth(i).get_attribute("title") or ""
                assert "outer tenth of its default range" in title, title
                assert "likeliest cause" in title, title
        else:
            expect(legend).to_be_hidden()
        page.locator("#world-panel").scroll_into_view_if_needed()
        page.locator("#world-panel").screenshot(
            path=str(shot_path("robustness-report.png", tmp_path))
        )
        assert errors == [], f"JavaScript errors on the page: {errors}"
