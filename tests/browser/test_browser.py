"""The dashboard in a real headless Chromium (Debian's `chromium`, driven by Playwright), against a
real server with the viser 3D view running."""

import contextlib
import io
import json
import re
from collections.abc import Iterator

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import FrameLocator, Page, expect, sync_playwright

from tests.testing.browser_support import BOTH_SIZES, LARGE, SMALL, shot_path, wait_until
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server, wait_for

ERROR = re.compile(r"\berror\b")
OK = re.compile(r"\bok\b")


SIZES = [(1600, 1000), (1280, 720)]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """(base_url, http client) of a live server with the viser 3D view."""
    with running_server(tmp_path_factory.mktemp("data"), viewer=True) as (base_url, _app):
        with httpx.Client(base_url=base_url, timeout=10) as http:
            yield base_url, http


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield browser
        browser.close()


@contextlib.contextmanager
def open_page(browser, base_url: str, width: int, height: int) -> Iterator[Page]:
    """A fresh page of the dashboard at this window size; fails on any JavaScript error."""
    context = browser.new_context(viewport={"width": width, "height": height})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(base_url + "/")
    yield page
    context.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"


@pytest.fixture(scope="module")
def dashboard(server, browser):
    """(page, http client) of the dashboard page at 1600 x 1000, the robot walking."""
    base_url, http = server
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})  # walk: pulses change
    context = browser.new_context(viewport={"width": 1600, "height": 1000}, accept_downloads=True)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(base_url + "/")
    yield page, http
    context.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"


def expand_viser_panel(viser: FrameLocator) -> None:
    """The 3D view's control panel starts minimized at the right edge: open it."""
    rail = viser.locator('[data-dock-tab="viser-control-panel"]')
    label = viser.locator("label", has_text="(+ forward)")
    expect(rail.or_(label).first).to_be_visible(timeout=30_000)
    if not label.is_visible():
        rail.click()


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


@BOTH_SIZES
def test_the_scope_labels_its_pulses_in_one_style(server, browser, width, height, tmp_path):
    """Every slot note of a frame begins in one wording, full servo names where they all fit,
    the short form where one does not (issue 33: at 1280x720 "l hip_yaw" stood beside
    "L HipR")."""
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        page.wait_for_function("window.artro && window.artro.framesReceived > 5", timeout=30_000)
        canvas = page.locator("#scope-canvas")
        labels = wait_until(
            page,
            lambda: (
                canvas.evaluate("c => c.dataset.slotLabels && JSON.parse(c.dataset.slotLabels)")
                or None
            ),
            "the scope's slot notes",
        )
        canvas.screenshot(path=shot_path(f"scope-labels-{width}.png", tmp_path))
    assert len(labels) == 12, labels
    full = [re.fullmatch(r"[lr]_[a-z_]+", x) is not None for x in labels]
    short = [re.fullmatch(r"[LR] [A-Z][a-z]+[A-Z]?", x) is not None for x in labels]
    assert all(full) or all(short), labels


def test_a_parameter_changed_through_the_api_moves_the_viser_slider(dashboard):
    page, http = dashboard
    viser = page.frame_locator("#viser-frame")
    expand_viser_panel(viser)
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
    expand_viser_panel(viser)
    label = viser.locator("label", has_text="(+ steps right)")
    expect(label).to_be_visible(timeout=30_000)
    row = label.locator("xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]")
    number = row.locator("input.mantine-NumberInput-input")
    version = http.get("/api/params").json()["version"]
    number.fill("0.05")
    number.press("Enter")
    # the page's motion controls poll the API: they show the value once the store has it
    expect(page.locator("#motion-a_r-number")).to_have_value("0.05", timeout=10_000)
    expect(page.locator("#motion-a_r")).to_have_value("0.05")
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
    page.locator("#axle-cm").fill("0")  # refused, saying what is allowed in the field's unit
    page.locator("#axle-set").click()
    expect(page.locator("#path-message")).to_have_class(ERROR, timeout=10_000)
    expect(page.locator("#path-message")).to_contain_text("1 to 200 cm")
    assert http.get("/api/path").json()["axle_m"] == 0.25
    page.locator("#axle-cm").fill("")
    page.locator("#axle-set").click()
    expect(page.locator("#path-readout-bsrc")).to_have_text("(feet)", timeout=10_000)


# --- the first ten minutes (issue 9) --------------------------------------------------------------

ROBOT_MIN_PIXELS = 100  # the box is ~380 px at both sizes; covered by a panel: 0-4


def robot_pixels(png: bytes) -> int:
    """Pixels of the brown box on the robot's trunk (MJCF material "dummy", rgba 0.55 0.35 0.20):
    no other colour in the 3D view is like it, and the follow camera keeps it in the middle."""
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    brown = (r - b > 45) & (r > g + 15) & (g > b + 10) & (r > 70) & (r < 230)
    return int(brown.sum())


@pytest.mark.slow
@pytest.mark.parametrize(("width", "height"), SIZES, ids=lambda v: str(v))
def test_the_robot_and_the_motion_controls_are_in_view_at_once(server, browser, width, height):
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        for key in ("a_p", "a_r", "a_y", "ca"):
            expect(page.locator(f"#motion-{key}")).to_be_in_viewport(timeout=10_000)
        frame = page.locator("#viser-frame")
        expect(frame).to_be_in_viewport()
        box = frame.bounding_box()
        assert box and box["width"] >= 576, "narrower, viser switches to its phone layout"
        viser = page.frame_locator("#viser-frame")
        expect(viser.locator('[data-dock-tab="viser-control-panel"]')).to_be_visible(timeout=30_000)
        wait_until(
            page,
            lambda: robot_pixels(frame.screenshot()) >= ROBOT_MIN_PIXELS,
            f"the robot drawn in the middle of the 3D view at {width}x{height}",
        )


def test_the_page_motion_controls_drive_the_simulation(dashboard):
    page, http = dashboard
    http.patch("/api/params", json={"motion": {"a_p": 0.0, "ca": 0.0}})
    slider = page.locator("#motion-a_p")
    expect(slider).to_have_value("0", timeout=10_000)
    slider.focus()
    for _ in range(4):
        slider.press("ArrowRight")  # a step of 0.005 each
    expect(page.locator("#motion-a_p-number")).to_have_value("0.02")
    params = wait_until(
        page,
        lambda: (p := http.get("/api/params").json())["motion"]["a_p"] == 0.02 and p,
        "a_p = 0.02 in the store",
    )
    wait_until(
        page,
        lambda: http.get("/api/state").json()["params_version_applied"] >= params["version"],
        "the simulation runs with the new motion",
    )
    # the 3D view follows, and nothing echoes back: the version stays
    viser = page.frame_locator("#viser-frame")
    expand_viser_panel(viser)
    label = viser.locator("label", has_text="(+ forward)")
    vslider = viser.locator(f'[id="{label.get_attribute("for")}"] [role="slider"]')
    expect(vslider).to_have_attribute("aria-valuenow", "0.02", timeout=10_000)
    expect(page.locator("#sim-version")).to_have_text(f"v{params['version']}", timeout=10_000)
    assert http.get("/api/params").json()["version"] == params["version"]
    # a typed value, then one outside the preset's known-good band: applied, and marked
    number = page.locator("#motion-ca-number")
    number.fill("0.05")
    number.press("Enter")
    wait_until(page, lambda: http.get("/api/params").json()["motion"]["ca"] == 0.05, "CA 0.05")
    expect(page.locator("#motion-ca-band")).to_contain_text("safe")
    number.fill("0.3")
    number.press("Enter")
    wait_until(page, lambda: http.get("/api/params").json()["motion"]["ca"] == 0.3, "CA 0.3")
    expect(page.locator("#motion-ca-band")).to_contain_text("outside")
    expect(page.locator("#motion-row-ca")).to_have_class(re.compile(r"\boutside\b"))
    http.patch("/api/params", json={"motion": {"a_p": 0.07, "ca": 0.0}})


@BOTH_SIZES
def test_a_band_not_measured_for_the_set_is_named_and_drawn_apart(
    server, browser, width, height, tmp_path
):
    """`pfs` has no measured band of its own (data/safe-bands.json): the motion rows say
    "unmeasured" and shade the band grey, where `tuned`'s measured band reads "safe" in green
    (issue 33: a band marked not measured looked like a measured one)."""
    base_url, http = server
    band = "#motion-a_p-band"
    shade = "e => getComputedStyle(e).getPropertyValue('--band').trim()"
    try:
        assert http.post("/api/presets/pfs/load").status_code == 200
        with open_page(browser, base_url, width, height) as page:
            expect(page.locator(band)).to_contain_text("unmeasured", timeout=10_000)
            expect(page.locator("#motion-row-a_p")).to_have_class(re.compile(r"\bunmeasured\b"))
            grey = page.locator("#motion-a_p").evaluate(shade)
            for key in ("a_p", "a_r", "a_y", "ca"):  # the longer word fits its column
                cell = page.locator(f"#motion-{key}-band")
                assert cell.evaluate("e => e.scrollWidth <= e.clientWidth + 1"), key
                box, panel = cell.bounding_box(), page.locator(".motion-rows").bounding_box()
                assert box["x"] + box["width"] <= panel["x"] + panel["width"] + 1, key
            page.locator(".motion-rows").screenshot(path=shot_path(f"band-{width}.png", tmp_path))
            assert http.post("/api/presets/tuned/load").status_code == 200
            expect(page.locator(band)).to_contain_text("safe", timeout=10_000)
            expect(page.locator("#motion-row-a_p")).not_to_have_class(re.compile("unmeasured"))
            assert page.locator("#motion-a_p").evaluate(shade) != grey
    finally:
        http.post("/api/presets/tuned/load")
        http.patch("/api/params", json={"motion": {"a_p": 0.07}})


def test_the_first_steps_line_goes_once_the_robot_walks(server, browser):
    base_url, http = server
    http.patch("/api/params", json={"motion": {"a_p": 0.0, "a_r": 0.0, "a_y": 0.0, "ca": 0.0}})
    with open_page(browser, base_url, 1280, 720) as page:
        hint = page.locator("#first-steps")
        expect(hint).to_be_visible(timeout=10_000)
        expect(hint).to_be_in_viewport()
        page.locator("#motion-a_p").focus()
        page.locator("#motion-a_p").press("ArrowRight")
        expect(hint).to_be_hidden(timeout=10_000)
        assert http.get("/api/params").json()["motion"]["a_p"] == 0.005
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})


# --- falls ----------------------------------------------------------------------------------------


def test_a_fall_is_shown_and_reset_with_motion_0_recovers(dashboard):
    page, http = dashboard
    # from standing, this throws `tuned` within ~1 s (`artro run --motion 0.3,0.3,0.6`)
    http.patch("/api/params", json={"motion": {"a_p": 0.3, "a_r": 0.3, "a_y": 0.6, "ca": 0.0}})
    http.post("/api/sim/reset")
    notice = page.locator("#fall-notice")
    wait_until(page, lambda: http.get("/api/state").json()["fell"], "the robot falls", 150)
    expect(notice).to_be_visible(timeout=10_000)  # a_r = 0.3 throws `tuned` within ~1 s
    expect(page.locator("#sim-rtf")).to_have_text("fallen — stopped")
    expect(page.locator("#fall-what")).to_contain_text("a_r +0.300, a_y +0.600")
    expect(page.locator("#path-readout-v")).to_have_text("—")
    expect(page.locator("#path-readout-lat")).to_have_text("—")
    # undoing the motion that threw it: the notice names the motion now in use
    page.locator("#params-undo").click()
    expect(page.locator("#fall-now")).to_contain_text("a_r 0.000", timeout=10_000)
    expect(page.locator("#fall-reset")).to_contain_text("new motion")
    page.locator("#params-redo").click()
    expect(page.locator("#fall-now")).to_be_hidden(timeout=10_000)
    page.locator("#fall-reset-zero").click()
    expect(notice).to_be_hidden(timeout=15_000)
    expect(page.locator("#sim-rtf")).to_contain_text("running", timeout=10_000)
    motion = http.get("/api/params").json()["motion"]
    assert motion == {"a_r": 0.0, "a_p": 0.0, "a_y": 0.0, "ca": 0.0}
    state = http.get("/api/state").json()
    assert not state["fell"] and state["resets"] >= 1
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})


def test_a_page_opened_after_a_fall_names_the_motion_and_no_first_steps(server, browser):
    """A robot that fell on the spot before the page opened: the notice said "walking —" and
    the "walks on the spot" hint stood beside it."""
    base_url, http = server
    # from standing, this throws `tuned` within ~1 s (as the test above); then the motion 0
    http.patch("/api/params", json={"motion": {"a_p": 0.3, "a_r": 0.3, "a_y": 0.6, "ca": 0.0}})
    http.post("/api/sim/reset")
    try:
        wait_for(lambda: http.get("/api/state").json()["fell"], "the robot falls", 600)
        http.patch("/api/params", json={"motion": {"a_p": 0.0, "a_r": 0.0, "a_y": 0.0, "ca": 0.0}})
        with open_page(browser, base_url, 1280, 720) as page:
            expect(page.locator("#fall-notice")).to_be_visible(timeout=10_000)
            expect(page.locator("#fall-what")).to_contain_text(
                "walking a_p 0.000, a_r 0.000, a_y 0.000, CA 0.000", timeout=10_000
            )
            expect(page.locator("#first-steps")).to_be_hidden()  # motion 0: it would show
    finally:
        http.post("/api/sim/reset")
        http.patch("/api/params", json={"motion": {"a_p": 0.07}})


# --- the path view --------------------------------------------------------------------------------


def test_clear_empties_the_path_plot(dashboard):
    page, http = dashboard
    page.wait_for_function("window.artro.path && window.artro.path.actual > 20", timeout=30_000)
    before = http.get("/api/state").json()["sim_time_s"]
    page.locator("#path-clear").click()
    expect(page.locator("#path-message")).to_have_class(OK, timeout=10_000)
    page.wait_for_function("window.artro.path.actual < 10", timeout=10_000)
    # the path starts again from the next sample (one every 5 frames) after the clear
    path = wait_until(
        page, lambda: (p := http.get("/api/path").json())["actual"] and p, "a sample after it"
    )
    assert path["actual"][0][0] >= before
    # the plot fills again as the robot walks on, and the page shows the per-cycle means
    page.wait_for_function("window.artro.path.actual > 20", timeout=30_000)


def test_an_import_with_four_errors_shows_them_all_with_the_file_name(dashboard, tmp_path):
    page, http = dashboard
    before = http.get("/api/params").json()
    bad = tmp_path / "four-wrong.json"
    wrong = {"motion": {"a_p": 2}, "gait": {"swing": {"v": 99}, "short": {"v": "x"}}}
    wrong["gait"]["load"] = {"v": -1}
    bad.write_text(json.dumps(wrong))
    page.locator("#import-file").set_input_files(str(bad))
    message = page.locator("#import-message")
    expect(message).to_have_class(ERROR, timeout=10_000)
    expect(message).to_contain_text("four-wrong.json")
    expect(message).to_contain_text("4 problems")
    problems = page.locator("#import-problems li")
    expect(problems).to_have_count(4)
    for path in ("motion.a_p", "gait.swing.v", "gait.short.v", "gait.load.v"):
        expect(page.locator("#import-problems")).to_contain_text(path)
    assert http.get("/api/params").json() == before


def test_the_api_docs_render_with_the_network_blocked(server, browser):
    base_url, _http = server
    context = browser.new_context(viewport={"width": 1280, "height": 720})
    blocked: list[str] = []

    def only_localhost(route):
        if route.request.url.startswith(("http://127.0.0.1", "http://localhost", "data:")):
            route.continue_()
        else:
            blocked.append(route.request.url)
            route.abort()

    context.route("**/*", only_localhost)
    page = context.new_page()
    page.goto(base_url + "/docs")
    expect(page.locator(".swagger-ui .info .title")).to_contain_text(
        "ArtRo Gait Studio", timeout=20_000
    )
    expect(page.locator(".opblock-summary-path", has_text="/api/params").first).to_be_visible()
    context.close()
    assert blocked == [], f"/docs asked the network for {blocked}"


def test_a_builtin_preset_loads_with_the_current_motion_kept(dashboard):
    page, http = dashboard
    http.patch("/api/params", json={"motion": {"a_p": 0.05, "a_r": 0.0, "a_y": 0.0, "ca": 0.0}})
    expect(page.locator("#preset-keep-motion")).to_be_checked()
    page.locator('button[data-preset="paper"]', has_text="Load").click()
    expect(page.locator("#preset-message")).to_have_class(OK, timeout=10_000)
    expect(page.locator("#preset-message")).to_contain_text("motion kept")
    params = http.get("/api/params").json()
    assert params["name"] == "paper" and params["motion"]["a_p"] == 0.05
    expect(page.locator("#params-name")).to_have_text("paper", timeout=10_000)
    http.post("/api/presets/tuned/load", params={"keep_motion": "true"})
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})


NESTED_SCROLL = """() => {
  // every visible control whose way to the page passes through a box that scrolls on its own
  const bad = [];
  for (const el of document.querySelectorAll("button, input, select, a.button, label.file")) {
    if (!el.offsetParent) continue;
    for (let p = el.parentElement; p && p !== document.body; p = p.parentElement) {
      const style = getComputedStyle(p);
      if (/(auto|scroll)/.test(style.overflowY) && p.scrollHeight > p.clientHeight + 1) {
        bad.push(el.id || el.textContent.trim());
        break;
      }
    }
  }
  return bad;
}"""


@pytest.mark.parametrize(("width", "height"), SIZES, ids=lambda v: str(v))
def test_every_control_is_reachable_without_nested_scroll_bars(server, browser, width, height):
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        expect(page.locator("#motion-a_p")).to_be_visible(timeout=10_000)
        page.wait_for_function("window.artro.path && window.artro.path.actual > 0")
        assert page.evaluate(NESTED_SCROLL) == []
        for button in ("#axle-set", "#axle-fit", "#path-clear", "#path-anchor"):
            page.locator(button).scroll_into_view_if_needed()
            expect(page.locator(button)).to_be_in_viewport()


def test_the_roll_view_plots_pulse_widths_with_cursors(dashboard):
    page, _http = dashboard
    page.locator("#scope-mode-roll").click()
    page.wait_for_function("window.artro.roll && window.artro.roll.points > 50", timeout=20_000)
    assert page.evaluate("window.artro.roll.series") == 4  # the default servo lanes
    expect(page.locator("#roll-legend")).to_contain_text("l_hip_pitch")
    plot = page.locator("#roll-plot .u-over")
    box = plot.bounding_box()
    assert box is not None
    plot.click(position={"x": box["width"] * 0.3, "y": box["height"] / 2})
    plot.click(position={"x": box["width"] * 0.7, "y": box["height"] / 2})
    cursors = page.locator("#scope-cursors")
    expect(cursors).to_contain_text("Δt")
    expect(cursors).to_contain_text("Hz")
    page.locator("#scope-freeze").click()
    expect(page.locator("#scope-run")).to_have_text("STOP")
    page.locator("#scope-freeze").click()
    page.locator("#scope-mode-single").click()
    expect(page.locator("#scope-canvas")).to_be_visible()


def test_the_cycle_view_lays_the_right_leg_over_the_left(dashboard):
    page, http = dashboard
    http.patch("/api/params", json={"motion": {"a_p": 0.07, "a_r": 0.0, "a_y": 0.0, "ca": 0.0}})
    page.locator("#scope-mode-cycle").click()
    expect(page.locator("#roll-unit")).to_have_value("deg")
    page.wait_for_function("window.artro.cycle && window.artro.cycle.cycles >= 3", timeout=30_000)
    expect(page.locator("#cycle-info")).to_contain_text("whole cycles folded")
    means = page.evaluate("window.artro.cycle.means")
    assert set(means) == {"l_hip_pitch", "l_knee", "r_hip_pitch", "r_knee"}
    left = np.array(means["l_knee"], dtype=float)
    right = np.array(means["r_knee"], dtype=float)
    swing = np.nanmax(left) - np.nanmin(left)
    assert swing > 10  # degrees: the knee bends in every step
    # `tuned` walks mirror-symmetrically: shifted by half a cycle, the right knee follows the left
    assert np.sqrt(np.nanmean((left - right) ** 2)) < 0.25 * swing
    # unshifted, they would be half a cycle apart
    assert np.sqrt(np.nanmean((left - np.roll(right, 25)) ** 2)) > 0.25 * swing
    page.locator("#scope-mode-single").click()


def test_the_servo_load_budget_lists_every_servo_coloured_by_margin(dashboard):
    page, http = dashboard
    rows = page.locator("#servo-body tr")
    expect(rows).to_have_count(12, timeout=30_000)
    page.wait_for_function(
        "parseInt(document.getElementById('servo-frames').textContent) > 25", timeout=30_000
    )
    report = http.get("/api/servos/load").json()
    names = [rows.nth(i).get_attribute("data-servo") for i in range(12)]
    assert names == [j["joint"] for j in report["joints"]]
    for i in range(12):
        assert rows.nth(i).get_attribute("class") in ("level-ok", "level-warn", "level-critical")
    assert "eq (1)" in (page.locator("#servo-table thead").text_content() or "")


def ghost_pixels(png: bytes) -> int:
    """Light blue of the translucent ghost over the white floor (app/server/view/viser_ghost.py);
    the saturated blue of the path line and the dark robot do not count."""
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, b = img[..., 0], img[..., 2]
    return int(((b - r > 25) & (b > 150) & (r > 120)).sum())


@pytest.mark.slow
@LARGE
def test_the_ghost_walks_beside_the_robot_with_its_differences_listed(
    server, browser, width, height
):
    base_url, http = server
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})
    with open_page(browser, base_url, width, height) as page:
        _ghost_walks(page, http)


def _ghost_walks(page: Page, http: httpx.Client) -> None:
    frame = page.locator("#viser-frame")
    frame.scroll_into_view_if_needed()
    expect(page.frame_locator("#viser-frame").locator("canvas").first).to_be_visible(timeout=30_000)
    without = ghost_pixels(frame.screenshot())
    try:
        page.locator("#ghost-source").select_option("preset:paper")
        page.locator("#ghost-start").click()
        expect(page.locator("#ghost-state")).to_contain_text("preset paper", timeout=10_000)
        expect(page.locator("#ghost-state")).to_contain_text("not phase-locked")  # 1 vs 0.68 Hz
        delta = page.locator("#ghost-metrics tr[data-metric=speed_cm_s] td.ghost-delta")
        expect(delta).not_to_contain_text("—", timeout=30_000)
        fields = page.locator("#ghost-diff tr td:first-child").all_text_contents()
        assert "clock.freq_hz" in fields and len(fields) > 5
        state = http.get("/api/ghost").json()
        assert state["metrics"]["ghost"]["speed_cm_s"] != 0.0  # the ghost walks
        frame.scroll_into_view_if_needed()
        shown = wait_until(
            page,
            lambda: (n := ghost_pixels(frame.screenshot())) > without + 500 and n,
            "the translucent ghost drawn beside the robot in the 3D view",
        )
        page.locator("#ghost-stop").click()
        expect(page.locator("#ghost-state")).to_have_text("no ghost", timeout=10_000)
        # the path's blue dashes, longer by now, add light-blue edges: what counts is that the
        # ghost's ~3 000 pixels are gone, not that the count is back where it started
        wait_until(
            page,
            lambda: ghost_pixels(frame.screenshot()) < max(without + 300, shown // 4),
            "the ghost gone from the 3D view",
        )
    finally:
        http.delete("/api/ghost")


@pytest.mark.slow
@SMALL
def test_a_recording_replays_in_the_scope_and_the_3d_view(server, browser, width, height):
    base_url, http = server
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})
    with open_page(browser, base_url, width, height) as page:
        _recording_replays(page, http)


def _recording_replays(page: Page, http: httpx.Client) -> None:
    frame = page.locator("#viser-frame")
    wait_until(page, lambda: http.get("/api/recording").json()["frames"] > 100, "a recording")
    try:
        page.locator("#replay-enter").click()
        expect(page.locator("#replay-live")).to_be_visible(timeout=10_000)
        expect(page.locator("#scope-info")).to_contain_text("recorded", timeout=10_000)
        assert http.get("/api/state").json()["paused"]
        scrub = page.locator("#replay-scrub")
        frame.scroll_into_view_if_needed()

        def view():
            return np.asarray(Image.open(io.BytesIO(frame.screenshot())).convert("L")).astype(int)

        def moved(a, b):  # pixels that changed; the frame may change height with the layout
            h, w = min(a.shape[0], b.shape[0]), min(a.shape[1], b.shape[1])
            return int((np.abs(a[:h, :w] - b[:h, :w]) > 30).sum())

        before = view()
        for index in (60, 10):  # the 3D view follows the scrub bar one way and back
            scrub.fill(str(index))
            expect(page.locator("#replay-info")).to_contain_text(f"frame {index + 1}/")
            recorded = http.get(f"/api/recording/frame/{index}").json()
            expect(page.locator("#scope-info")).to_contain_text(f"#{recorded['frame']} ")
            (before,) = wait_until(
                page,
                lambda b=before: moved(b, v := view()) > 200 and (v,),
                f"the 3D view showing recorded frame {index}",
            )
        page.locator("#replay-live").click()
        expect(page.locator("#replay-live")).to_be_hidden(timeout=10_000)
        expect(page.locator("#replay-enter")).to_be_focused()  # the focus went on from it
        wait_until(page, lambda: not http.get("/api/state").json()["paused"], "live again")
        expect(page.locator("#scope-info")).not_to_contain_text("recorded", timeout=10_000)
    finally:
        http.post("/api/recording/live")
