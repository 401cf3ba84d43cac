"""The robot import on the page (docs/DESIGN.md §16) in a real headless Chromium: a CAD file
picked in the World panel is imported, its mapping shown as a table, the robot select gains it and
the robot is switched to; Undo goes back; a file the gait cannot drive, dropped, is refused."""

import re

import httpx
import pytest
from playwright.sync_api import expect, sync_playwright

from tests.testing.browser_support import SIZES, shot_path
from tests.testing.cad_support import artro_mjcf
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server


@pytest.mark.parametrize(("width", "height"), SIZES)
def test_a_file_picked_is_imported_mapped_and_switched_to_and_undo_goes_back(
    tmp_path, width, height
):
    with (
        running_server(tmp_path / "data") as (base_url, _app),
        httpx.Client(base_url=base_url, timeout=10) as http,
        sync_playwright() as p,
    ):
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": width, "height": height})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(base_url + "/")
        badge, select = page.locator("#robot-badge"), page.locator("#robot-select")
        message = page.locator("#robot-message")
        expect(badge).to_have_text("robot artro", timeout=30_000)

        # a leg of five joints, dropped on the box: refused, naming the joint, in an error's colour
        page.locator("#robot-import").dispatch_event("drop", {"dataTransfer": page.evaluate_handle(
            """text => {
              const dropped = new DataTransfer();
              dropped.items.add(new File([text], "five.xml", { type: "application/xml" }));
              return dropped;
            }""",
            artro_mjcf(renamed=False, drop="l_ankle_roll"),
        )})  # fmt: skip
        expect(message).to_contain_text("not imported", timeout=60_000)
        expect(message).to_contain_text("l_ankle_pitch")
        expect(message).to_have_class(re.compile(r"\berror\b"))
        expect(page.locator("#robot-mapping")).to_be_hidden()
        expect(select.locator("option")).to_have_text(["artro", "micro"])

        page.locator("#robot-import-file").set_input_files(files=[{
            "name": "darwin-legs.xml", "mimeType": "application/xml",
            "buffer": artro_mjcf().encode(),
        }])  # fmt: skip
        expect(message).to_contain_text("imported darwin-legs.xml as darwin-legs", timeout=60_000)
        expect(message).to_contain_text("now darwin-legs")
        rows = page.locator("#robot-mapping-table tbody tr")
        expect(rows).to_have_count(12)
        expect(rows.first.locator("td")).to_have_text(["l_hip_yaw", "j_pelvis_l", "+1",
                                                        "0.000", "0.00°"])  # fmt: skip
        expect(page.locator("#robot-mapping-caption")).to_contain_text("1.65 kg")
        expect(select).to_have_value("darwin-legs")
        expect(badge).to_have_text("robot darwin-legs")
        assert http.get("/api/state").json()["robot"] == "darwin-legs"
        lines = page.locator("#robot-import").evaluate(
            """box => new Set([...box.children].filter((c) => !c.hidden).map((c) => {
              const b = c.getBoundingClientRect();
              return Math.round((b.top + b.bottom) / 2);
            })).size"""
        )
        assert lines == 1, "the import's controls take one line"
        page.add_style_tag(content=".topbar { visibility: hidden; }")  # sticky: not over the shot
        page.locator("#world-panel").screenshot(
            path=str(shot_path(f"robot-import-{width}.png", tmp_path))
        )

        page.click("#params-undo")  # the switch, one change
        expect(badge).to_have_text("robot artro", timeout=30_000)
        expect(select).to_have_value("artro")
        assert http.get("/api/params").json()["robot"] == "artro"
        assert "darwin-legs" in [o.get_attribute("value") for o in select.locator("option").all()]
        expect(page.locator("#robot-mapping")).to_be_hidden()  # artro is described, not imported

        select.select_option("darwin-legs")  # the loaded robot's mapping, from GET /api/robot
        expect(badge).to_have_text("robot darwin-legs", timeout=30_000)
        expect(rows).to_have_count(12)
        expect(rows.nth(3).locator("td").nth(1)).to_have_text("j_tibia_l")
        browser.close()
        assert errors == [], f"JavaScript errors on the page: {errors}"
