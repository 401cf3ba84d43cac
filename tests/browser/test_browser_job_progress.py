"""The World panel's Robustness job on the page says how many of its runs are walked of all and
the time it has left (issue 56, item 13), in a real headless Chromium against a real server;
Cancel still stops it. Looked at in a screenshot (ARTRO_SCREENSHOTS=DIR keeps it)."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.test_browser_world import opened_page
from tests.testing.browser_support import LARGE, shot_path
from tests.testing.server_harness import CHROMIUM  # noqa: F401 (marks the module `browser`)

#: "walking the variations: 3 of 45 runs walked · ~2 min left" (4 variations and the nominal
#: model, each walking the nine cases)
SAID = re.compile(
    r"^walking the variations: ([1-9]\d*) of 45 runs walked · ~\d+ (s|min|h \d+ min) left$"
)


@pytest.mark.slow
@LARGE
def test_the_robustness_job_shows_its_runs_and_time_left(tmp_path, width, height):
    with opened_page(tmp_path, width, height) as (page, _http, errors):
        expect(page.locator("#robot-badge")).to_have_text("robot artro", timeout=30_000)
        page.fill("#robust-samples", "4")
        page.click("#robust-start")
        message = page.locator("#robust-message")
        expect(message).to_have_text(SAID, timeout=120_000)
        page.locator("#world-panel").scroll_into_view_if_needed()
        page.locator("#world-panel").screenshot(
            path=str(shot_path("robustness-progress.png", tmp_path))
        )
        page.click("#robust-cancel")
        expect(message).to_have_text("robustness cancelled: no report", timeout=60_000)
        assert errors == [], f"JavaScript errors on the page: {errors}"
