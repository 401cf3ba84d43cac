"""The Sensors panel and the Push in a real headless Chromium (docs/DESIGN.md §15): the three
plots and the soles are drawn from the live sensors, the laws switched on are named, the Push
button and the P key push the robot (the state says so), a bad push is said and sends nothing;
the World panel has the sensors' error sliders. Screenshots at both window sizes."""

from __future__ import annotations

import httpx
import pytest
from playwright.sync_api import expect, sync_playwright

from tests.testing.browser_support import SHOTS, SIZE_IDS, SIZES, rgb, wait_until
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server

#: where to keep the screenshots to look at (unset: none kept)


@pytest.mark.slow
def test_the_sensors_panel_draws_the_sensors_and_pushes_the_robot(tmp_path):
    with (
        running_server(tmp_path) as (base_url, _app),
        httpx.Client(base_url=base_url, timeout=10) as http,
        sync_playwright() as p,
    ):
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        width, height = SIZES[0]
        page = browser.new_page(viewport={"width": width, "height": height})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(base_url + "/")
        panel = page.locator("#sensors-panel")
        panel.scroll_into_view_if_needed()
        laws = page.locator("#sensors-laws")  # the server starts with `robust-3`: its laws on
        expect(laws).to_have_text("laws on: tilt trim, yaw rate, gyro damping", timeout=20_000)
        off = {g: {"enabled": False} for g in ("tilt", "yaw_rate", "damping", "cop")}
        http.patch("/api/params", json={"gait": off})
        expect(laws).to_have_text("every law off (open loop)", timeout=10_000)
        for plot in ("attitude", "gyro", "laws-plot"):  # uPlot drew each, with its legend
            expect(page.locator(f"#sensors-{plot} canvas")).to_have_count(1)
        expect(page.locator("#sensors-attitude .u-legend")).to_contain_text("pitch, estimated")

        # the soles' drawing has the left foot's colour where its centre of pressure is
        cop = page.locator("#sensors-cop")
        wait_until(page, lambda: (rgb(cop.screenshot())[..., 2] > 200).sum() > 20, "a CoP drawn")

        # a law switched on is named
        http.patch("/api/params", json={"gait": {"tilt": {"enabled": True}}})
        expect(laws).to_have_text("laws on: tilt trim", timeout=10_000)

        # the button pushes; the state and the message say so
        page.fill("#push-impulse", "0.25")
        page.fill("#push-direction", "90")
        page.click("#push-button")
        expect(page.locator("#push-message")).to_contain_text("pushed: 0.25 N·s toward 90°")
        push = wait_until(page, lambda: http.get("/api/state").json()["push"], "the push acted")
        assert push["impulse_n_s"] == 0.25
        # the P key pushes again (outside a text field)
        page.locator("h1").first.click()
        page.keyboard.press("p")
        wait_until(
            page,
            lambda: http.get("/api/state").json()["push"]["sim_time_s"] > push["sim_time_s"],
            "the key pushed",
        )
        # a bad push is said and sends nothing
        before = http.get("/api/state").json()["push"]
        page.fill("#push-impulse", "9")
        page.click("#push-button")
        expect(page.locator("#push-message")).to_contain_text("no push")
        assert http.get("/api/state").json()["push"] == before

        # the World panel has the sensors' errors
        expect(page.locator("#world-imu_delay_ms")).to_have_count(1)
        expect(page.locator("#world-fsr_gain")).to_have_value("1")

        for (w, h), name in zip(SIZES, SIZE_IDS, strict=True):
            page.set_viewport_size({"width": w, "height": h})
            panel.scroll_into_view_if_needed()
            box = panel.bounding_box()
            assert box is not None and box["width"] <= w  # the panel fits the window's width
            if SHOTS is not None:
                SHOTS.mkdir(parents=True, exist_ok=True)
                panel.screenshot(path=str(SHOTS / f"sensors-{name}.png"))
                page.screenshot(path=str(SHOTS / f"page-{name}.png"), full_page=True)
        browser.close()
        assert errors == [], f"JavaScript errors on the page: {errors}"
