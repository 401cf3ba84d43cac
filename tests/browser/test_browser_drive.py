"""The drive switch of the page in a real headless Chromium: the firmware on the emulated MCU
takes over the pulses, the header says so, the scope shows its pins, and back."""

import httpx
import pytest
from playwright.sync_api import expect, sync_playwright

from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server


@pytest.mark.slow
def test_the_page_switches_the_pulses_to_the_firmware_and_back(tmp_path):
    with (
        running_server(tmp_path) as (base_url, _app),
        httpx.Client(base_url=base_url, timeout=10) as http,
        sync_playwright() as p,
    ):
        http.patch("/api/params", json={"motion": {"a_p": 0.06}})
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 720})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(base_url + "/")
        badge = page.locator("#drive-badge")
        expect(page.locator("#scope-info")).to_contain_text("#", timeout=30_000)
        expect(badge).to_be_hidden()
        assert "firmware pins" not in page.locator("#scope-info").inner_text()

        page.select_option("#drive-select", "firmware")
        expect(badge).to_be_visible(timeout=60_000)
        expect(badge).to_contain_text("firmware · MCU")
        expect(page.locator("#scope-info")).to_contain_text("firmware pins", timeout=30_000)
        assert http.get("/api/state").json()["drive"] == "firmware"
        page.screenshot(path=str(tmp_path / "firmware-drive.png"))

        http.put("/api/sim/drive", json={"drive": "model"})  # from elsewhere: the page follows
        expect(badge).to_be_hidden(timeout=30_000)
        expect(page.locator("#drive-select")).to_have_value("model")
        expect(page.locator("#scope-info")).not_to_contain_text("firmware pins", timeout=30_000)
        browser.close()
        assert errors == [], f"JavaScript errors on the page: {errors}"
