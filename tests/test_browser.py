"""The dashboard in a real headless Chromium (Debian's `chromium`, driven by Playwright), against a
real server with the viser 3D view running."""

import json
import re

import httpx
import pytest
from playwright.sync_api import expect, sync_playwright

from tests.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server

ERROR = re.compile(r"\berror\b")
OK = re.compile(r"\bok\b")


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory):
    """(page, http client) of the dashboard page loaded in headless Chromium."""
    with running_server(tmp_path_factory.mktemp("data"), viewer=True) as (base_url, _app):
        with sync_playwright() as p, httpx.Client(base_url=base_url, timeout=10) as http:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            context = browser.new_context(
                viewport={"width": 1600, "height": 1000}, accept_downloads=True
            )
            page = context.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            http.patch("/api/params", json={"motion": {"a_p": 0.07}})  # walk: pulses change
            page.goto(base_url + "/")
            yield page, http
            assert errors == [], f"JavaScript errors on the page: {errors}"
            browser.close()


def test_the_scope_redraws_with_changing_pulse_widths(dashboard):
    page, _http = dashboard
    page.wait_for_function("window.artro && window.artro.framesReceived > 5", timeout=30_000)
    canvas = page.locator("#scope-canvas")
    expect(canvas).to_be_visible()

    def hip_roll_pulse() -> tuple[int, float]:
        """The left hip roll follows the lateral shift, a cosine: it changes in every frame."""
        frame = page.evaluate("window.artro.lastFrame")
        slots = {s["servo"]: s for ch in frame["channels"] for s in ch["slots"]}
        return frame["frame"], slots["l_hip_roll"]["pulse_us"]

    first_frame, first_pulse = hip_roll_pulse()
    first_image = canvas.evaluate("c => c.toDataURL()")
    # a few frames later the pulse is different, and so is the picture
    page.wait_for_function(f"window.artro.lastFrame.frame > {first_frame + 5}", timeout=10_000)
    _, later_pulse = hip_roll_pulse()
    assert later_pulse != first_pulse
    page.wait_for_function(
        "img => document.getElementById('scope-canvas').toDataURL() !== img",
        arg=first_image,
        timeout=10_000,
    )
    expect(page.locator("#scope-fps")).not_to_be_empty()


def test_a_parameter_changed_through_the_api_moves_the_viser_slider(dashboard):
    page, http = dashboard
    viser = page.frame_locator("#viser-frame")
    label = viser.locator("label", has_text="(+ forward)")
    expect(label).to_be_visible(timeout=30_000)
    slider = viser.locator(f'[id="{label.get_attribute("for")}"] [role="slider"]')
    assert http.patch("/api/params", json={"motion": {"a_p": 0.12}}).status_code == 200
    expect(slider).to_have_attribute("aria-valuenow", "0.12", timeout=10_000)
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})
    expect(slider).to_have_attribute("aria-valuenow", "0.07", timeout=10_000)


def test_a_viser_slider_change_reaches_the_store_once_without_echo(dashboard):
    page, http = dashboard
    viser = page.frame_locator("#viser-frame")
    label = viser.locator("label", has_text="(+ steps right)")
    expect(label).to_be_visible(timeout=30_000)
    row = label.locator("xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]")
    number = row.locator("input.mantine-NumberInput-input")
    version = http.get("/api/params").json()["version"]
    number.fill("0.05")
    number.press("Enter")
    # the page's own parameter panel polls the API: it shows the value once the store has it
    expect(page.locator("#param-a_r")).to_contain_text("0.050", timeout=10_000)
    after = http.get("/api/params").json()
    assert after["motion"]["a_r"] == pytest.approx(0.05)
    assert after["version"] == version + 1  # one change, no echo back from the slider
    slider = viser.locator(f'[id="{label.get_attribute("for")}"] [role="slider"]')
    expect(slider).to_have_attribute("aria-valuenow", "0.05")
    http.patch("/api/params", json={"motion": {"a_r": 0.0}})


def test_an_exported_file_reimports_to_the_same_parameters(dashboard, tmp_path):
    page, http = dashboard
    http.patch("/api/params", json={"motion": {"ca": 0.04}, "gait": {"swing": {"v": 2.3}}})
    exported = http.get("/api/params").json()
    with page.expect_download() as download_info:
        page.locator("#export-json").click()
    path = tmp_path / "exported.json"
    download_info.value.save_as(path)
    document = json.loads(path.read_text())
    assert document["gait"]["swing"]["v"] == 2.3 and document["project_version"]
    http.post("/api/presets/paper/load")  # change everything back to the paper values
    assert http.get("/api/params").json()["gait"]["swing"]["v"] == 2.0
    page.locator("#import-file").set_input_files(str(path))
    # the page says "importing…" first; wait for its verdict
    expect(page.locator("#import-message")).to_have_class(OK, timeout=10_000)
    expect(page.locator("#import-message")).to_contain_text("imported")
    after = http.get("/api/params").json()
    assert (after["motion"], after["gait"]) == (exported["motion"], exported["gait"])


def test_a_bad_import_shows_the_servers_reason(dashboard, tmp_path):
    page, http = dashboard
    before = http.get("/api/params").json()
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"gait": {"swing": {"v": 99}}}))
    page.locator("#import-file").set_input_files(str(bad))
    message = page.locator("#import-message")
    expect(message).to_have_class(ERROR, timeout=10_000)
    expect(message).to_contain_text("swing")
    assert http.get("/api/params").json() == before


def test_the_prediction_axle_set_on_the_page(dashboard):
    page, http = dashboard
    page.locator("#axle-cm").fill("25")
    page.locator("#axle-set").click()
    expect(page.locator("#path-message")).to_have_class(OK, timeout=10_000)
    assert http.get("/api/path").json()["axle_m"] == 0.25
    expect(page.locator("#path-readout-bsrc")).to_have_text("(manual)", timeout=10_000)
    expect(page.locator("#path-readout-b")).to_have_text("25.0 cm")
    page.locator("#axle-cm").fill("0")  # the server refuses it and says what is allowed
    page.locator("#axle-set").click()
    expect(page.locator("#path-message")).to_have_class(ERROR, timeout=10_000)
    expect(page.locator("#path-message")).to_contain_text("0.01")
    assert http.get("/api/path").json()["axle_m"] == 0.25
    page.locator("#axle-cm").fill("")
    page.locator("#axle-set").click()
    expect(page.locator("#path-readout-bsrc")).to_have_text("(feet)", timeout=10_000)
