""" "Fit to a recording" on the World panel in a real headless Chromium (issue 53 item 3): a
simulated REC.json picked is fitted on the server (progress shown), the fitted fields' table
and the report's plot appear, and "Use the fitted robot" makes the World say "fitted: ...";
a page reloaded meanwhile follows the fit."""

import re

import pytest
from playwright.sync_api import expect

from tests.browser.test_browser_world import opened_page
from tests.testing.browser_support import SMALL, shot_path
from tests.testing.fit_support import simulated_recording
from tests.testing.server_harness import CHROMIUM  # noqa: F401 (marks the module `browser`)

FIT_MS = 900_000  # a fit of the IMU's fields: 2 replays of the 60 s routine (about 1 min alone)


@pytest.mark.slow
@SMALL
def test_fit_to_a_recording_shows_progress_the_table_and_uses_the_fit(tmp_path, width, height):
    rec = simulated_recording(tmp_path)
    with opened_page(tmp_path / "data", width, height) as (page, _http, errors):
        expect(page.locator("#robot-badge")).to_have_text("robot artro", timeout=30_000)
        page.fill("#fit-fields", "gyro_bias_deg_s,imu_tilt_bias")
        page.fill("#fit-budget", "10")
        page.set_input_files("#fit-file", str(rec))
        expect(page.locator("#fit-progress-row")).to_be_visible(timeout=30_000)
        expect(page.locator("#fit-status")).to_have_text(re.compile("replaying the routine|% of"))
        expect(page.locator("#fit-cancel")).to_be_visible()
        page.reload()  # a page loaded while the fit runs follows it
        expect(page.locator("#fit-progress-row")).to_be_visible(timeout=30_000)
        expect(page.locator("#fit-message")).to_contain_text("sent before this page")
        expect(page.locator("#fit-cancel")).to_be_visible()
        rows = page.locator("#fit-table tbody tr")
        expect(rows).to_have_count(3, timeout=FIT_MS)  # the gyro's bias, the IMU's tilt (x, y)
        gyro = rows.filter(has_text="gyro_bias_deg_s")
        expect(gyro).to_contain_text("±")
        expect(gyro).to_contain_text("0.600")  # the truth of the simulated recording
        expect(page.locator("#fit-message")).to_contain_text("fit converged")
        expect(page.locator("#fit-progress-row")).to_be_hidden()
        plot = page.locator("#fit-traces")
        expect(plot).to_be_visible()
        page.wait_for_function("() => document.getElementById('fit-traces').naturalWidth > 0")
        page.click("#fit-use")
        expect(page.locator("#world-state")).to_contain_text(
            "fitted: gyro_bias_deg_s=", timeout=30_000
        )
        expect(page.locator("#world-badge")).to_have_text("fitted robot")
        page.locator("#fit-box").screenshot(path=shot_path(f"fit-done-{width}.png", tmp_path))
        page.locator("#world-panel").screenshot(path=shot_path(f"fit-world-{width}.png", tmp_path))
        assert errors == [], f"JavaScript errors on the page: {errors}"
