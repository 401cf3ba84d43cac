"""The path plot in a real Chromium after a long curved walk of the real simulation: every pixel of
the blue trace lies on the walked path, and the walked path is drawn all along (issue 18, item 1).
uPlot's linear() path merges points per pixel column from four per column on and draws a path
that turns back as vertical lines; the plot draws the points in their order instead."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image, ImageDraw, ImageFilter
from playwright.sync_api import sync_playwright

from tests.testing.browser_support import SIZE_IDS, SIZES, open_page, rgb
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, client, running_server, wait_for

MAX_POINTS = 2000  # GET /api/path thins the actual path to this many points (path_tracker.py)
NEAR_PX = 3  # a trace pixel this close to the walked path is on it (line width, antialiasing)


def blue_trace(img: np.ndarray) -> np.ndarray:
    """Pixels of the actual path's blue (#4dabf7) over the dark plot; not the orange prediction,
    the white robot, the yellow anchor or the grey grid and labels."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (b > 90) & (b - r > 50) & (b - g > 20)


def expected_trace(shape: tuple[int, int], points: list[tuple[float, float]]) -> np.ndarray:
    """The walked path as a 1-pixel polyline on an image of the canvas' size."""
    canvas = Image.new("L", (shape[1], shape[0]), 0)
    ImageDraw.Draw(canvas).line(points, fill=255, width=1)
    return np.asarray(canvas) > 0


def dilate(mask: np.ndarray, px: int) -> np.ndarray:
    image = Image.fromarray(mask.astype(np.uint8) * 255)
    return np.asarray(image.filter(ImageFilter.MaxFilter(2 * px + 1))) > 0


def to_pixels(rows: list[list[float]], view: dict) -> list[tuple[float, float]]:
    """Data (x, y) in metres -> canvas pixels, as uPlot's linear scales place them."""
    (x0, x1), (y0, y1), box = view["x"], view["y"], view["box"]
    return [
        (
            box["left"] + (x - x0) / (x1 - x0) * box["width"],
            box["top"] + (y1 - y) / (y1 - y0) * box["height"],
        )
        for _t, x, y, *_ in rows
    ]


@pytest.mark.slow
def test_a_long_curved_walk_is_drawn_where_the_data_says(tmp_path):
    with (
        running_server(tmp_path) as (base_url, _app),
        client(base_url) as http,
        sync_playwright() as p,
    ):
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        http.patch("/api/params", json={"motion": {"a_p": 0.07, "a_r": 0.0, "a_y": 0.0, "ca": 0.1}})
        http.put("/api/sim/speed", json={"speed": 4.0})
        http.post("/api/sim/reset")  # the walk starts here: a circle and more
        with (
            open_page(browser, base_url, *SIZES[0]) as big,
            open_page(browser, base_url, *SIZES[1]) as small,
        ):
            pages = {SIZE_IDS[0]: big, SIZE_IDS[1]: small}
            for page in pages.values():
                page.locator("#path-cycles").uncheck()  # only the two paths and the marks
                page.wait_for_function("window.artro.path && window.artro.path.view")
            columns = max(
                page.evaluate("window.artro.path.view.columns") for page in pages.values()
            )
            # more points than four per pixel column: where uPlot's linear() merges them
            need = 4 * columns + 40
            assert need < MAX_POINTS, f"the plot is {columns} px wide: no test of merging"
            wait_for(
                lambda: len(http.get("/api/path").json()["actual"]) >= need,
                f"{need} path samples",
                attempts=6000,
            )
            http.post("/api/sim/pause")  # taken by the simulation thread between frames:
            wait_for(lambda: http.get("/api/state").json()["paused"], "the walk paused")
            path = http.get("/api/path").json()  # no sample after this one
            assert len(path["actual"]) >= need
            for size, page in pages.items():
                page.wait_for_function(
                    "t => window.artro.path.lastT === t", arg=path["actual"][-1][0]
                )
                _drawn_as_walked(page, path, size)
        browser.close()


def _drawn_as_walked(page, path: dict, size: str) -> None:
    view = page.evaluate("window.artro.path.view")
    canvas = page.locator("#path-plot canvas")
    img = rgb(canvas.screenshot())
    points = to_pixels(path["actual"], view)
    assert len(points) > 4 * view["columns"], "fewer points than the test is about"
    drawn = blue_trace(img)
    walked = expected_trace(img.shape[:2], points)
    # the robot's triangle covers the newest part of the path, the anchor mark its start
    covered = np.zeros_like(walked)
    yy, xx = np.mgrid[: img.shape[0], : img.shape[1]]
    anchor = path["anchor"]
    marks = [points[-1], *to_pixels([[0, anchor["x_m"], anchor["y_m"]]], view)]
    for mx, my in marks:
        covered |= (xx - mx) ** 2 + (yy - my) ** 2 < 22**2
    stray = drawn & ~dilate(walked, NEAR_PX)
    assert drawn.sum() > 300, f"{size}: hardly any blue trace drawn"
    assert stray.sum() <= 0.005 * drawn.sum(), (
        f"{size}: {stray.sum()} of {drawn.sum()} trace pixels lie off the walked path"
    )
    reached = walked & ~covered
    missed = reached & ~dilate(drawn, 2)
    assert missed.sum() <= 0.02 * reached.sum(), (
        f"{size}: {missed.sum()} of {reached.sum()} pixels of the walked path are not drawn"
    )
