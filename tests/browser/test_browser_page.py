"""What a newcomer hits on the page (issue 18), in a real headless Chromium (how it looks at both
window sizes, what it does at one each), against a real server with the viser 3D view: every
control of the path panel and the header in view, one undo per drag or key burst, and the smaller
defects of item 5."""

from __future__ import annotations

import re

import httpx
import numpy as np
import pytest
from playwright.sync_api import Page, expect, sync_playwright

from tests.server.test_server_gait_ramp import largest_step
from tests.testing.browser_support import (
    BOTH_SIZES,
    CUT_OFF,
    HEADER_AT_ITS_FULLEST,
    LARGE,
    LINES,
    SMALL,
    open_page,
    shot_path,
)
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server, wait_for

ERROR = re.compile(r"\berror\b")
OK = re.compile(r"\bok\b")


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


@pytest.fixture
def walking(server):
    """The robot walks forward with `tuned`; put back afterwards."""
    _base, http = server
    http.post("/api/presets/tuned/load")
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})
    http.post("/api/sim/resume")
    yield http
    http.post("/api/sim/resume")
    http.put("/api/path/axle", json={"axle_m": None})


def cut_off(page: Page, selector: str) -> list[str]:
    return page.locator(selector).evaluate(CUT_OFF)


# --- item 2: the path panel's buttons and the header ----------------------------------------------


def _header_fits(page: Page, state: str) -> None:
    for value in page.locator(".topbar .stat .value").all():
        assert value.evaluate(LINES) == 1, f"{state}: {value.text_content()!r} wraps"
    fullest = page.evaluate(HEADER_AT_ITS_FULLEST)
    assert all(n == 1 for _text, n in fullest["lines"]), f"{state}, every badge: {fullest}"
    assert all(fits for _part, fits in fullest["fits"]), f"{state}, every badge: {fullest}"
    assert fullest["outside"] == [], f"{state}, every badge: {fullest}"
    for control in ("#sim-step", "#sim-reset", "#speed-select", "#drive-select"):
        assert cut_off(page, control) == [], f"{state}: {control} cut off"


@BOTH_SIZES
def test_calibrate_ca_its_result_and_the_header_are_all_in_view(
    server, walking, browser, width, height
):
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        page.wait_for_function("window.artro.path && window.artro.path.actual > 0")
        panel = page.locator(".path-panel")
        sizes = panel.evaluate(
            "e => [e.scrollWidth, e.clientWidth, e.scrollHeight, e.clientHeight]"
        )
        assert sizes[0] <= sizes[1] and sizes[2] <= sizes[3], f"the path panel clips: {sizes}"
        for control in ("#anchor-speed", "#path-anchor", "#axle-cm", "#axle-set", "#axle-fit"):
            assert cut_off(page, control) == [], control
        assert cut_off(page, "#ca-calibrate") == []
        page.locator("#ca-calibrate").scroll_into_view_if_needed()
        expect(page.locator("#ca-calibrate")).to_be_in_viewport(ratio=1)
        # a result line (here the server's refusal of an axle) wraps inside the panel
        page.locator("#axle-cm").fill("0")
        page.locator("#axle-set").click()
        message = page.locator("#path-message")
        expect(message).to_have_class(ERROR, timeout=10_000)
        assert len(message.text_content() or "") > 30
        assert cut_off(page, "#path-message") == []
        _header_fits(page, "running")
        page.locator("#sim-pause").click()
        expect(page.locator("#paused-badge")).to_be_visible(timeout=10_000)
        _header_fits(page, "paused")
        page.locator("#sim-resume").click()
        expect(page.locator("#paused-badge")).to_be_hidden(timeout=10_000)


# a narrow window (a netbook, a tablet, a zoomed page): the panels stack, none over another
COVERED = """selectors => selectors.filter(sel => {
  const el = document.querySelector(sel);
  el.scrollIntoView({block: "center"});
  const r = el.getBoundingClientRect();
  const hit = document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2);
  return !(hit && (hit === el || el.contains(hit) || hit.contains(el)));
})"""
NARROW_CONTROLS = ["#anchor-speed", "#path-anchor", "#axle-cm", "#axle-set", "#axle-fit",
                   "#ca-calibrate", "#scope-mode-single", "#scope-mode-roll", "#scope-mode-cycle",
                   "#scope-freeze", "#scope-servos", "#sim-time", "#sim-rtf"]  # fmt: skip


@pytest.mark.parametrize(("width", "height"), [(1024, 600), (800, 1280)])
def test_a_narrow_window_stacks_the_panels_and_covers_no_control(
    server, browser, width, height, tmp_path
):
    """At 1100 px or less the left column had a fixed height: the Path panel ran over the
    scope's buttons and servo chips (and they over its own), and the header's status spilt
    out of its bar, the sim time cut off."""
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        expect(page.locator("#scope-servos input")).to_have_count(12, timeout=30_000)
        assert page.evaluate(COVERED, NARROW_CONTROLS) == []
        page.evaluate("window.scrollTo(0, 0)")
        for stat in ("#sim-time", "#sim-rtf"):
            expect(page.locator(stat)).to_be_in_viewport(ratio=1)
        assert page.evaluate("document.documentElement.scrollWidth") <= width
        page.screenshot(path=shot_path(f"narrow-{width}x{height}.png", tmp_path), full_page=True)
        # the recording import is reached from the keyboard (its input was display: none)
        page.locator("#replay-vcd").focus()
        page.keyboard.press("Tab")
        assert page.evaluate("document.activeElement.id") == "replay-import"


@SMALL
def test_the_keyboard_skips_to_a_panel_and_moves_the_scope_cursors(
    server, browser, width, height, tmp_path
):
    """Crossing the 3D view by Tab took 31 presses; the scope's cursors were mouse-only."""
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        expect(page.locator("#scope-fps")).not_to_have_text("—", timeout=30_000)  # a frame drawn
        page.keyboard.press("Tab")  # the first stop: the skip links, shown once focused
        first = page.locator(".skip-links a").first
        expect(first).to_be_focused()
        expect(first).to_be_in_viewport(ratio=1)
        page.screenshot(path=shot_path("skip-link.png", tmp_path))
        page.keyboard.press("Enter")
        assert page.evaluate("document.activeElement.id") == "drive-panel"
        page.keyboard.press("Tab")  # on into the panel, not back to the header
        inside = "document.getElementById('drive-panel').contains(document.activeElement)"
        assert page.evaluate(inside)
        readout = page.locator("#scope-cursors")
        page.locator("#scope-canvas").focus()
        page.keyboard.press("a")
        for _ in range(3):
            page.keyboard.press("ArrowRight")
        expect(readout).to_have_text("A 10.030 ms")  # mid-frame, then 3 × 10 µs
        page.keyboard.press("b")
        page.keyboard.press("Shift+ArrowLeft")
        expect(readout).to_have_text(re.compile(r"^A 10\.030 ms\s+B 9\.900 ms\s+Δt -130\.0 µs"))
        page.keyboard.press("Escape")
        expect(readout).to_contain_text("keys (scope focused)")


# --- item 3: one drag or one burst of key presses is one undo step -------------------------------


def _a_p(http: httpx.Client) -> float:
    return http.get("/api/params").json()["motion"]["a_p"]


@LARGE
def test_one_drag_or_one_key_burst_is_one_undo_step(server, walking, browser, width, height):
    base_url, http = server
    http.patch("/api/params", json={"motion": {"a_p": 0.0, "a_r": 0.0, "a_y": 0.0, "ca": 0.0}})
    with open_page(browser, base_url, width, height) as page:
        slider = page.locator("#motion-a_p")
        expect(slider).to_have_value("0", timeout=10_000)
        before = http.get("/api/params").json()["version"]
        slider.focus()
        for _ in range(10):  # the key held down: auto-repeat, 0.005 each
            page.keyboard.down("ArrowRight")
        page.keyboard.up("ArrowRight")
        expect(page.locator("#motion-a_p-number")).to_have_value("0.05")
        wait_for(lambda: _a_p(http) == 0.05, "a_p = 0.05 in the store")
        assert http.get("/api/params").json()["version"] > before + 1  # several versions
        page.locator("#params-undo").click()
        wait_for(lambda: _a_p(http) == 0.0, "one undo back to a_p = 0")
        expect(slider).to_have_value("0", timeout=10_000)
        # a drag along the track: one undo step as well
        box = slider.bounding_box()
        assert box is not None
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        page.mouse.move(x, y)
        page.mouse.down()
        for i in range(1, 13):
            page.mouse.move(x + i * box["width"] * 0.02, y)
        page.mouse.up()
        dragged = wait_for(lambda: (v := _a_p(http)) > 0.03 and v, "a_p dragged up")
        wait_for(lambda: _a_p(http) == float(slider.input_value()), "the drag's last value sent")
        assert dragged > 0.03
        page.locator("#params-undo").click()
        wait_for(lambda: _a_p(http) == 0.0, "one undo back to a_p = 0 after the drag")


# --- item 4: a preset loaded mid-walk is ramped in, and the page says so ------------------------


def _walk(http: httpx.Client, seconds: float) -> None:
    until = http.get("/api/state").json()["sim_time_s"] + seconds
    wait_for(
        lambda: http.get("/api/state").json()["sim_time_s"] >= until,
        f"{seconds} s more walking",
        attempts=3000,
    )


@SMALL
def test_a_preset_loaded_mid_walk_is_ramped_in_and_said_so(server, walking, browser, width, height):
    base_url, http = server
    http.patch("/api/params", json={"motion": {"a_p": 0.05, "ca": 0.1}})
    http.post("/api/sim/reset")
    with open_page(browser, base_url, width, height) as page:
        expect(page.locator("#preset-keep-motion")).to_be_checked()
        _walk(http, 5.0)
        page.locator('button[data-preset="paper"]', has_text="Load").click()
        message = page.locator("#preset-message")
        expect(message).to_contain_text("ramped in over 2 s", timeout=10_000)
        expect(message).to_contain_text("motion kept")
        loaded = http.get("/api/params").json()
        assert loaded["name"] == "paper" and loaded["motion"]["a_p"] == 0.05
        _walk(http, 6.5)
    rec = http.get("/api/recording/export").json()["columns"]
    ocr, versions = np.array(rec["ocr"]), np.array(rec["version"])
    k = int(np.argmax(versions >= loaded["version"]))
    before, after = largest_step(ocr[k - 200 : k]), largest_step(ocr[k + 110 : k + 300])
    ramp = largest_step(ocr[k - 1 : k + 110])
    assert ramp <= 1.1 * max(before, after), f"pulses jumped {ramp} ticks (walking: {before})"
    assert not http.get("/api/state").json()["fell"]


# --- item 5: the smaller defects ------------------------------------------------------------------


def _type_into(page: Page, selector: str, text: str) -> None:
    """As a person does: click, select what is there, type, Enter."""
    page.locator(selector).click()
    page.keyboard.press("Control+a")
    page.keyboard.type(text)
    page.keyboard.press("Enter")


@LARGE
def test_typed_values_that_cannot_be_applied_say_why_and_change_nothing(
    server, walking, browser, width, height
):
    base_url, http = server
    with open_page(browser, base_url, width, height) as page:
        number, message = page.locator("#motion-a_p-number"), page.locator("#motion-message")
        expect(number).to_have_value("0.07", timeout=10_000)
        before = http.get("/api/params").json()
        _type_into(page, "#motion-a_p-number", "abc")  # letters: the field would go blank
        expect(message).to_have_class(ERROR)
        expect(message).to_contain_text("not a number")
        expect(number).to_have_value("0.07")
        _type_into(page, "#motion-a_p-number", "5")  # out of range
        expect(message).to_contain_text("5 not applied")
        expect(message).to_contain_text("-0.3 to 0.3")
        expect(number).to_be_focused()
        expect(number).to_have_value("0.07")  # the value in use, though the field has the focus
        expect(page.locator("#motion-a_p")).to_have_value("0.07")
        assert http.get("/api/params").json()["version"] == before["version"]
        # the by-hand fields answer in their own unit and name, never in metres or API names
        path_message = page.locator("#path-message")
        page.locator("#axle-cm").fill("0")
        page.locator("#axle-set").click()
        expect(path_message).to_have_class(ERROR)
        expect(path_message).to_contain_text("b = 0 cm not applied")
        expect(path_message).to_contain_text("1 to 200 cm")
        page.locator("#anchor-speed").fill("80")
        page.locator("#path-anchor").click()
        expect(path_message).to_contain_text("V = 80 cm/s not applied")
        expect(path_message).to_contain_text("-50 to 50 cm/s")
        assert "axle_m" not in (path_message.text_content() or "")
        # junk in "b by hand" keeps the b in use
        page.locator("#axle-cm").fill("25")
        page.locator("#axle-set").click()
        expect(path_message).to_have_class(OK)
        _type_into(page, "#axle-cm", "1e")
        page.locator("#axle-set").click()
        expect(path_message).to_have_class(ERROR)
        expect(path_message).to_contain_text("not a number")
        path = http.get("/api/path").json()
        assert (path["axle_m"], path["axle_source"]) == (0.25, "manual")


@SMALL
def test_the_scope_badge_says_fallen_and_paused(server, walking, browser, width, height):
    base_url, http = server
    with open_page(browser, base_url, width, height) as page:
        badge = page.locator("#scope-run")
        expect(badge).to_have_text("RUN", timeout=10_000)
        # from standing, this throws `tuned` within ~1 s (test_browser.py's fall test)
        http.patch("/api/params", json={"motion": {"a_p": 0.3, "a_r": 0.3, "a_y": 0.6}})
        http.post("/api/sim/reset")
        wait_for(lambda: http.get("/api/state").json()["fell"], "the robot falls")
        expect(badge).to_have_text("FALLEN", timeout=10_000)
        http.patch("/api/params", json={"motion": {"a_p": 0.0, "a_r": 0.0, "a_y": 0.0}})
        http.post("/api/sim/reset")
        expect(badge).to_have_text("RUN", timeout=10_000)
        http.post("/api/sim/pause")
        expect(badge).to_have_text("PAUSED", timeout=10_000)
        http.post("/api/sim/resume")
        expect(badge).to_have_text("RUN", timeout=10_000)


@BOTH_SIZES
def test_a_new_page_shows_the_ghost_that_walks(server, walking, browser, width, height):
    base_url, http = server
    assert http.put("/api/ghost", json={"preset": "tuned"}).status_code == 200
    try:
        with open_page(browser, base_url, width, height) as page:
            expect(page.locator("#ghost-state")).to_contain_text("preset tuned", timeout=10_000)
            expect(page.locator("#ghost-source")).to_have_value("preset:tuned")
    finally:
        http.delete("/api/ghost")
    http.patch("/api/params", json={"motion": {"a_p": 0.06}})  # a version made by an edit
    http.patch("/api/params", json={"motion": {"a_p": 0.07}})
    with open_page(browser, base_url, width, height) as page:  # no ghost: another set than ours
        expect(page.locator("#ghost-state")).to_have_text("no ghost", timeout=10_000)
        expect(page.locator("#ghost-source")).to_have_value("preset:paper")
        # the versions say who made them in words (`walking` loaded a preset, then edited it)
        labels = page.locator("#ghost-source option").all_inner_texts()
        made_by = [label.rsplit(" (", 1)[-1] for label in labels]
        assert {"preset loaded)", "edit or undo)"} <= set(made_by), made_by


@LARGE
def test_a_failed_recording_import_stays_said(server, walking, browser, width, height, tmp_path):
    base_url, _http = server
    bad = tmp_path / "not-a-recording.json"
    bad.write_text('{"format": "artro-recording", "format_version": 1, "columns": {}}')
    with open_page(browser, base_url, width, height) as page:
        expect(page.locator("#replay-info")).to_contain_text("recorded", timeout=10_000)
        # the page's timers from here on are Playwright's: a minute passes at once. (expect()
        # polls with the page's animation frames, which the clock holds: read the text directly)
        page.clock.install()
        page.locator("#replay-import").set_input_files(str(bad))
        message = page.locator("#replay-message")

        def said() -> str:
            text = message.text_content() or ""
            return "not imported" in text and message.is_visible() and text

        text = wait_for(said, "the import's refusal on the page")
        assert "not-a-recording.json" in text and "columns" in text
        page.clock.fast_forward(60_000)
        assert said() == text, "the refusal went away"


@BOTH_SIZES
def test_the_hint_names_what_is_there_and_red_servos_are_explained(
    server, walking, browser, width, height
):
    base_url, _http = server
    with open_page(browser, base_url, width, height) as page:
        hint = page.locator(".param-extra span.dim", has_text="every other constant")
        expect(hint).to_contain_text('"Control panel"')
        assert "☰" not in (hint.text_content() or "")
        viser = page.frame_locator("#viser-frame")
        tab = viser.locator('[data-dock-tab="viser-control-panel"]')
        expect(tab).to_contain_text("Control panel", timeout=30_000)
        # `tuned` walking: its knees are red; the page says what that means
        expect(page.locator("#servo-body tr.level-critical").first).to_be_visible(timeout=30_000)
        note = page.locator("#servo-note")
        expect(note).to_be_visible(timeout=10_000)
        critical = page.locator("#servo-body tr.level-critical").first.get_attribute("data-servo")
        expect(note).to_contain_text(critical or "?")
        expect(note).to_contain_text("expected")
        expect(note).to_contain_text("motion 0 still steps")


@SMALL
def test_what_a_hostile_user_types_is_refused_in_words_and_kept(
    server, walking, browser, width, height
):
    """A save over one's own preset asks first; a name the server would refuse is refused here
    with the rule; a push with no direction is no push; a World text the server refused stays in
    the field to be mended."""
    base_url, http = server
    http.put("/api/presets/mine")
    mine = http.get("/api/presets/mine").json()
    with open_page(browser, base_url, width, height) as page:
        message = page.locator("#preset-message")
        expect(page.locator("#preset-list tr[data-preset='mine']")).to_have_count(1)
        http.patch("/api/params", json={"motion": {"a_p": 0.05}})
        asked: list[str] = []
        page.once("dialog", lambda d: (asked.append(d.message), d.dismiss()))
        page.locator("#preset-name").fill("mine")
        page.locator("#preset-save").click()
        expect(message).to_contain_text("'mine' is kept as it was")
        assert asked == ["Replace your preset 'mine' with the current parameters?"]
        assert http.get("/api/presets/mine").json() == mine
        page.once("dialog", lambda d: d.accept())
        page.locator("#preset-save").click()
        expect(message).to_contain_text("saved the current parameters as 'mine', the set in use")
        assert http.get("/api/presets/mine").json()["motion"]["a_p"] == 0.05
        # saved as: the set in use is named so (it kept the name it was loaded with)
        assert http.get("/api/params").json()["name"] == "mine"
        expect(page.locator("#params-name")).to_have_text("mine", timeout=10_000)
        for name in ("../etc/passwd", "a/b", "x" * 65, "ends."):
            page.locator("#preset-name").fill(name)
            page.locator("#preset-save").click()
            expect(message).to_have_class(ERROR)
            expect(message).to_contain_text("not saved: a preset name is 1 to 64 characters")
        assert "x" * 65 not in [p["name"] for p in http.get("/api/presets").json()["presets"]]
        # a push toward nowhere: refused with what the field takes, nothing pushed
        push_message = page.locator("#push-message")
        before = http.get("/api/state").json()["push"]
        page.locator("#push-direction").fill("")
        page.locator("#push-button").click()
        expect(push_message).to_have_class(ERROR)
        expect(push_message).to_contain_text("no push: toward takes a number -360 to 360")
        assert http.get("/api/state").json()["push"] == before
        # a refused World text stays to be mended
        text = page.locator("#world-text")
        text.fill("friction=abc,latency_ms=40")
        page.locator("#world-text-apply").click()
        expect(page.locator("#world-message")).to_contain_text("not changed")
        page.wait_for_timeout(2500)  # the World panel polls the state every second
        expect(text).to_have_value("friction=abc,latency_ms=40")
    http.delete("/api/presets/mine")
