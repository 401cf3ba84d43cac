"""What the browser tests share: the two window sizes, a fresh page that fails on any JavaScript
error, polling in page time, and what the eye would check (a control fully in view, one line)."""

from __future__ import annotations

import contextlib
import io
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Browser, Page

#: ARTRO_SCREENSHOTS=DIR keeps the browser tests' screenshots there, to be looked at
SHOTS = Path(os.environ["ARTRO_SCREENSHOTS"]) if os.environ.get("ARTRO_SCREENSHOTS") else None
SIZES = [(1600, 1000), (1280, 720)]
SIZE_IDS = ["1600x1000", "1280x720"]
#: A test of how the page looks (what is in view, what fits) runs at both sizes; a test of what
#: the page does runs at one, the tests taking turns, so both sizes meet every kind of control
BOTH_SIZES = pytest.mark.parametrize(("width", "height"), SIZES, ids=SIZE_IDS)
LARGE = pytest.mark.parametrize(("width", "height"), SIZES[:1], ids=SIZE_IDS[:1])
SMALL = pytest.mark.parametrize(("width", "height"), SIZES[1:], ids=SIZE_IDS[1:])


@contextlib.contextmanager
def open_page(browser: Browser, base_url: str, width: int, height: int) -> Iterator[Page]:
    """A fresh page of the dashboard at this window size; fails on any JavaScript error."""
    context = browser.new_context(viewport={"width": width, "height": height})
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(base_url + "/")
    try:
        yield page
    finally:
        context.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"


def wait_until(page: Page, condition, what: str, attempts: int = 150):
    """Poll `condition()` (every 200 ms of page time) until it returns something truthy."""
    for _ in range(attempts):
        result = condition()
        if result:
            return result
        page.wait_for_timeout(200)
    raise AssertionError(f"never happened: {what}")


def rgb(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


#: The part of an element cut off by the window's width or by an ancestor that clips (overflow
#: other than visible): [] when the whole box can be seen (scrolling the page vertically).
CUT_OFF = """el => {
  const cuts = [];
  const box = el.getBoundingClientRect();
  if (box.width === 0 || box.height === 0) return ["not rendered"];
  if (box.left < -0.5 || box.right > document.documentElement.clientWidth + 0.5) {
    cuts.push(`window width: ${box.left.toFixed(0)}..${box.right.toFixed(0)}`);
  }
  for (let p = el.parentElement; p && p !== document.documentElement; p = p.parentElement) {
    const style = getComputedStyle(p);
    if (style.overflowX === "visible" && style.overflowY === "visible") continue;
    const clip = p.getBoundingClientRect();
    if (box.left < clip.left - 0.5 || box.right > clip.right + 0.5 ||
        box.top < clip.top - 0.5 || box.bottom > clip.bottom + 0.5) {
      cuts.push(`${p.className || p.tagName}: ${clip.left.toFixed(0)}..${clip.right.toFixed(0)}`
        + ` x ${clip.top.toFixed(0)}..${clip.bottom.toFixed(0)}`);
    }
  }
  return cuts;
}"""

#: How many lines of text an element's content takes.
LINES = """el => {
  const range = document.createRange();
  range.selectNodeContents(el);
  const rects = [...range.getClientRects()].filter(r => r.width > 0);
  return new Set(rects.map(r => Math.round(r.top))).size;
}"""


#: The header with every badge it can show while running (behind, the firmware drive, errors),
#: measured in the same task so that no poll hides them first: how many lines each number takes,
#: and whether the status and the controls keep within their places.
HEADER_AT_ITS_FULLEST = """() => {
  const shown = {"behind-badge": "behind real time", "drive-badge": "firmware · MCU 24 %",
                 "errors-badge": "12 errors"};
  const before = {};
  for (const [id, text] of Object.entries(shown)) {
    const el = document.getElementById(id);
    before[id] = [el.hidden, el.textContent];
    el.hidden = false;
    el.textContent = text;
  }
  const range = document.createRange();
  const lines = [...document.querySelectorAll(".topbar .stat .value")].map((el) => {
    range.selectNodeContents(el);
    const rects = [...range.getClientRects()].filter((r) => r.width > 0);
    return [el.textContent, new Set(rects.map((r) => Math.round(r.top))).size];
  });
  const fits = [".topbar", ".topbar .status", ".topbar .controls"].map((sel) => {
    const el = document.querySelector(sel);
    return [sel, el.scrollWidth <= el.clientWidth && el.scrollHeight <= el.clientHeight];
  });
  const bar = document.querySelector(".topbar").getBoundingClientRect();
  const out = (el) => {
    const b = el.getBoundingClientRect();
    return b.top < bar.top || b.bottom > bar.bottom;
  };
  const outside = [...document.querySelectorAll(".topbar .badge:not([hidden]), .topbar .stat")]
    .filter(out)
    .map((el) => el.id || el.textContent);
  for (const [id, [hidden, text]] of Object.entries(before)) {
    const el = document.getElementById(id);
    el.hidden = hidden;
    el.textContent = text;
  }
  return { lines, fits, outside };
}"""


def shot_path(name: str, fallback: Path) -> Path:
    """Where the screenshot `name` goes: SHOTS if set, else `fallback` (a test's tmp_path)."""
    folder = SHOTS or fallback
    folder.mkdir(parents=True, exist_ok=True)
    return folder / name
