"""The World panel in a real headless Chromium (docs/DESIGN.md §8), at both window sizes: the
header names the robot; the sliders set the live robot's world and the header says it is varied;
the robustness report is drawn as bars, and a worst variation's button loads it."""

import re
from contextlib import contextmanager

import httpx
import pytest
from playwright.sync_api import expect, sync_playwright

from app.worlds.variations import NOMINAL
from gait import JOINT_NAMES
from tests.testing.browser_support import BOTH_SIZES, SMALL, shot_path
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server

SIZES = [(1600, 1000), (1280, 720)]


@contextmanager
def opened_page(tmp_path, width: int, height: int):
    """(page, http client, JavaScript errors) of the dashboard on a fresh server; the page's
    404s are JavaScript errors too (it asks only for what the state says exists)."""
    with (
        running_server(tmp_path) as (base_url, _app),
        httpx.Client(base_url=base_url, timeout=10) as http,
        sync_playwright() as p,
    ):
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": width, "height": height})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.on("response", lambda r: r.status == 404 and errors.append(f"404 {r.url}"))
        page.goto(base_url + "/")
        yield page, http, errors
        browser.close()


@pytest.mark.slow
@SMALL
def test_the_world_panel_varies_the_live_robot_and_draws_the_report(tmp_path, width, height):
    with opened_page(tmp_path, width, height) as (page, http, errors):
        expect(page.locator("#robot-badge")).to_have_text("robot artro", timeout=30_000)
        world_badge = page.locator("#world-badge")
        expect(world_badge).to_be_hidden()
        expect(page.locator("#world-friction-out")).to_have_text("0.70", timeout=30_000)

        page.locator("#world-friction").fill("0.5")  # a range input takes its value so
        page.locator("#world-latency_ms").fill("30")
        page.click("#world-apply")
        expect(world_badge).to_be_visible(timeout=30_000)
        world = http.get("/api/state").json()["world"]
        assert world == "friction=0.5,latency_ms=30"  # the sliders left at nominal add nothing
        expect(page.locator("#world-state")).to_have_text("varied: friction, latency_ms")
        expect(page.locator("#world-state")).to_have_attribute("title", world)

        page.fill("#world-text", "friction=7")  # refused, nothing changes
        page.click("#world-text-apply")
        expect(page.locator("#world-message")).to_contain_text("friction must be")
        assert http.get("/api/state").json()["world"] == world

        page.fill("#robust-samples", "400")  # a long job, cancelled from the page
        page.click("#robust-start")
        cancel = page.locator("#robust-cancel")
        expect(cancel).to_be_visible(timeout=30_000)
        expect(page.locator("#robust-start")).to_be_disabled()
        page.locator("#robot-select").select_option("micro")  # refused in the page's words
        robot_message = page.locator("#robot-message")
        expect(robot_message).to_contain_text("cancel it (its Cancel button) before changing")
        assert "/api/" not in robot_message.text_content()
        expect(page.locator("#robot-select")).to_have_value("artro")
        cancel.click()
        expect(page.locator("#robust-message")).to_contain_text(
            "robustness cancelled: no report", timeout=120_000
        )
        expect(cancel).to_be_hidden()
        expect(page.locator("#robust-start")).to_be_focused()  # the focus went on from Cancel
        assert http.get("/api/jobs/robustness-1").json()["status"] == "cancelled"  # the first job

        page.fill("#robust-samples", "4")
        page.click("#robust-start")
        rows = page.locator("#robust-bars .robust-row:not(.robust-header)")
        expect(rows).to_have_count(9, timeout=600_000)
        bars = page.locator("#robust-bars .robust-bar")
        widths = [bars.nth(i).evaluate("e => e.style.width") for i in range(9)]
        job_shares = [float(w.rstrip("%")) for w in widths]
        assert all(0 <= s <= 100 for s in job_shares)
        page.locator("#world-panel").screenshot(path=str(tmp_path / f"world-{width}.png"))
        header = page.locator("#robust-bars .robust-header")
        expect(header).to_contain_text("failures depend on")
        ranges = http.get("/api/world").json()["ranges"]
        nominal = {f: getattr(NOMINAL, f) for f in ranges if f != "calibration_deg"}
        nominal["friction"] = 0.7
        for term in page.locator("#robust-worst .term.extreme").all_text_contents():
            key, value = term.strip().rstrip(",").split("=")
            lo, hi = ranges["calibration_deg" if key.startswith("cal.") else key]
            edge, v, home = 0.1 * (hi - lo), float(value), nominal.get(key, 0.0)
            # marked: in the outer tenth of its default range, on its side of the nominal value
            assert (v > home and v >= hi - edge) or (v < home and v <= lo + edge), term

        page.reload()  # the report of this gait is kept by the server and drawn again
        expect(rows).to_have_count(9, timeout=30_000)
        expect(page.locator("#robust-title")).to_contain_text("kept from")
        page.locator("#world-panel").screenshot(path=shot_path(f"report-{width}.png", tmp_path))
        again = [bars.nth(i).evaluate("e => e.style.width") for i in range(9)]
        assert [float(w.rstrip("%")) for w in again] == job_shares
        walk = page.locator("#robust-worst button")
        if walk.count():  # a variation that failed a case: watch it there, in that case's motion
            kept = http.get("/api/world/robustness").json()
            (report,) = kept["presets"]
            walk.first.click()
            expect(page.locator("#world-message")).to_contain_text(
                "in the variation", timeout=30_000
            )
            assert http.get("/api/state").json()["world"] != "nominal"
            assert http.get("/api/params").json()["motion"] == report["worst"][0]["motion"]

        page.click("#world-nominal")
        expect(world_badge).to_be_hidden(timeout=30_000)
        assert errors == [], f"JavaScript errors on the page: {errors}"


@pytest.mark.parametrize(("width", "height"), SIZES)
def test_the_robot_is_switched_on_the_page_and_undo_takes_it_back(tmp_path, width, height):
    with opened_page(tmp_path, width, height) as (page, http, errors):
        badge, select = page.locator("#robot-badge"), page.locator("#robot-select")
        expect(badge).to_have_text("robot artro", timeout=30_000)
        expect(select).to_have_value("artro")
        expect(page.locator("#robot-figures")).to_contain_text("1.65 kg")

        select.select_option("micro")
        message = page.locator("#robot-message")
        expect(message).to_contain_text("now micro", timeout=30_000)
        expect(message).to_contain_text("Undo goes back to artro")
        expect(badge).to_have_text("robot micro")
        expect(page.locator("#params-name")).to_have_text("micro-robust", timeout=30_000)
        assert http.get("/api/state").json()["robot"] == "micro"
        page.locator("#world-panel").screenshot(path=str(tmp_path / f"robot-{width}.png"))

        # a set tuned for ArtRo, loaded on the micro robot: the page says so and keeps saying it
        page.locator('button[data-preset="paper"]', has_text="Load").click()
        preset_message = page.locator("#preset-message")
        expect(preset_message).to_contain_text("tuned for the robot 'artro'", timeout=30_000)
        expect(preset_message).to_have_class(re.compile(r"\bwarn\b"))
        note = page.locator("#params-robot-note")  # by the sliders, while the set is in use
        expect(note).to_contain_text("'paper' was tuned for the robot artro, not micro")
        robots = page.locator("#preset-list tr[data-preset='micro-robust'] td").nth(1)
        expect(robots).to_have_text("micro")  # the table names each set's robot

        page.click("#params-undo")  # the preset load
        expect(page.locator("#params-message")).to_contain_text("undone", timeout=30_000)
        expect(note).to_be_hidden()  # micro-robust, on micro
        page.click("#params-undo")  # the switch: the page says the robot changed back
        expect(page.locator("#params-message")).to_contain_text(
            "the robot is artro again (was micro)", timeout=30_000
        )
        expect(badge).to_have_text("robot artro", timeout=30_000)
        expect(select).to_have_value("artro")
        assert http.get("/api/params").json()["robot"] == "artro"
        assert errors == [], f"JavaScript errors on the page: {errors}"


@BOTH_SIZES
def test_the_sliders_follow_the_live_world_and_apply_keeps_what_they_do_not_show(
    tmp_path, width, height
):
    """A world set elsewhere (the API, a worst variation's button) moves the sliders; Apply then
    changes what the sliders changed and keeps the calibration no slider shows; a long world is
    summed up in the header, not cut at its edge (issue 33)."""
    with opened_page(tmp_path, width, height) as (page, http, errors):
        expect(page.locator("#world-friction-out")).to_have_text("0.70", timeout=30_000)
        many = ",".join(f"cal.{j}=1.2" for j in JOINT_NAMES)
        world = f"friction=0.45,latency_ms=40,tilt_deg=2.5,{many}"
        assert http.put("/api/world", json={"variation": world}).status_code == 200
        expect(page.locator("#world-friction-out")).to_have_text("0.45", timeout=30_000)
        expect(page.locator("#world-latency_ms-out")).to_have_text("40")
        state = page.locator("#world-state")
        expect(state).to_have_text("varied: friction, latency_ms +2 more")
        assert state.evaluate("e => e.scrollWidth <= e.clientWidth"), "the header is cut"
        assert state.get_attribute("title") == http.get("/api/state").json()["world"]
        page.locator("#world-panel").screenshot(path=shot_path(f"world-{width}.png", tmp_path))

        page.locator("#world-latency_ms").fill("10")
        page.click("#world-apply")
        wait = page.locator("#world-message")
        expect(wait).to_contain_text("walking in:", timeout=30_000)
        now = http.get("/api/state").json()["world"]
        assert "latency_ms=10" in now and "friction=0.45" in now
        assert all(f"cal.{j}=1.2" in now for j in JOINT_NAMES), now
        assert errors == [], f"JavaScript errors on the page: {errors}"
