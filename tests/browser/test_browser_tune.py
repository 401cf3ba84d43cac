""" "Tune for this robot" on the page in a real headless Chromium (issue 32 item 4): the button
starts the tune, the progress bar says the trials scored of the budget and the best loss,
Cancel stops it with nothing loaded, and a tiny tune's result is loaded (the set's name, the
preset's row marked) with its figures shown; Undo goes back."""

import re

import pytest
from playwright.sync_api import expect

from app.robots import load_description
from tests.browser.test_browser_world import opened_page
from tests.testing.browser_support import SMALL, shot_path
from tests.testing.server_harness import CHROMIUM  # noqa: F401 (marks the module `browser`)

TUNE_MS = 120_000  # the deadline of a tiny tune (about 10 s alone)
DEFAULT = load_description("artro").default_preset  # the set the server starts with


def size(page, generations: int, popsize: int, duration_s: int) -> None:
    page.fill("#tune-generations", str(generations))
    page.fill("#tune-popsize", str(popsize))
    page.fill("#tune-duration", str(duration_s))


@pytest.mark.slow
@SMALL
def test_tune_for_this_robot_shows_progress_cancels_and_loads_the_result(tmp_path, width, height):
    with opened_page(tmp_path, width, height) as (page, http, errors):
        expect(page.locator("#params-name")).to_have_text(DEFAULT, timeout=30_000)
        status, message = page.locator("#tune-status"), page.locator("#tune-message")

        # a long tune: its progress shows, Cancel stops it and nothing is loaded
        size(page, 20, 4, 9)
        page.click("#tune-start")
        expect(page.locator("#tune-progress-row")).to_be_visible()
        expect(page.locator("#tune-start")).to_be_disabled()
        expect(status).to_contain_text("/80 · best loss", timeout=TUNE_MS)
        expect(status).to_contain_text("generation 1 of 20 · run ", timeout=TUNE_MS)  # runs walked
        # and the time the whole tune has left (issue 56, item 13)
        expect(status).to_contain_text(re.compile(r" · ~\d+\s(s|min|h\s\d+\smin)\sleft$"))
        expect(status).to_have_attribute("title", re.compile(f"from '{DEFAULT}'"))
        assert page.locator("#tune-progress").evaluate("el => el.value") > 0
        page.locator("#world-panel").screenshot(
            path=shot_path(f"tune-running-{width}.png", tmp_path)
        )
        page.reload()  # a page loaded while it runs follows it (the state names it)
        expect(page.locator("#tune-cancel")).to_be_visible(timeout=30_000)
        expect(status).to_contain_text("/80 · best loss", timeout=TUNE_MS)
        page.click("#tune-cancel")
        expect(message).to_contain_text("tune cancelled: nothing loaded", timeout=30_000)
        expect(page.locator("#tune-cancel")).to_be_hidden()
        expect(page.locator("#tune-start")).to_be_focused()  # the focus went on, not to the top
        assert http.get("/api/params").json()["name"] == DEFAULT

        # a tiny one: done, tuned-artro is the set in use, its row marked, its figures shown
        size(page, 1, 2, 9)
        page.click("#tune-start")
        expect(message).to_contain_text("'tuned-artro' saved and loaded", timeout=TUNE_MS)
        expect(status).to_contain_text("trials 2/2")
        expect(page.locator("#tune-progress")).to_have_js_property("value", 1)
        expect(page.locator("#params-name")).to_have_text("tuned-artro", timeout=30_000)
        expect(page.locator('#preset-list tr[data-preset="tuned-artro"]')).to_have_class(
            re.compile(r"\bin-use\b"), timeout=30_000
        )
        rows = page.locator("#tune-figures-body tr")
        expect(rows).to_have_count(9)  # the seven paper cases, the two CA pairs
        forward = page.locator('#tune-figures-body tr[data-run="forward"]')
        expect(forward).to_contain_text("3.80 cm/s")
        judged = forward.get_attribute("data-passes") == "true"  # the tune's own verdict, shown
        assert (" ok" in forward.inner_text()) == judged
        expect(page.locator('#tune-figures-body tr[data-run="curve forward"]')).to_contain_text(
            "gain 1, bend 0"
        )
        page.locator("#world-panel").screenshot(path=shot_path(f"tune-done-{width}.png", tmp_path))
        page.click("#params-undo")
        expect(page.locator("#params-name")).to_have_text(DEFAULT, timeout=30_000)
        assert errors == [], f"JavaScript errors on the page: {errors}"
