"""The scope of a robot of bus servos, in a real headless Chromium (docs/BUS.md): under the
idle TDM lines, each frame's sync write: its bytes and time on the wire drawn within the
frame, the step its goals act at, each servo's goal and the packet's bytes."""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import expect, sync_playwright

from tests.server.test_server_bus_scope import bus_robot
from tests.testing.browser_support import shot_path
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server


def test_the_scope_shows_a_bus_robots_sync_write(tmp_path: Path) -> None:
    with (
        running_server(tmp_path / "data", robot=str(bus_robot(tmp_path))) as (base_url, _app),
        sync_playwright() as p,
    ):
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1600, "height": 1000})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(base_url + "/")
        strip = page.locator("#scope-bus")
        expect(strip).to_be_visible(timeout=30_000)
        expect(page.locator("#scope-title")).to_have_text("Servo bus and scope")
        expect(strip.locator(".bus-line")).to_contain_text("Dynamixel 2.0 sync write: 74 bytes")
        expect(strip.locator(".bus-line")).to_contain_text("acts at step 1 of the frame")
        expect(strip.locator(".bus-goal")).to_have_count(12)
        width = strip.locator(".bus-packet").evaluate("e => e.style.width")
        assert width == "3.7%", width  # 0.74 ms of the 20 ms frame
        page.locator("#scope-panel").screenshot(path=str(shot_path("bus-scope.png", tmp_path)))
        browser.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"
