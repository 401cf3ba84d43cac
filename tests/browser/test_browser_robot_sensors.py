"""A linked robot's sensors in the Sensors panel, in a real headless Chromium (issue 30, item
5): while frames arrive as `artro link` forwards them, the attitude, gyro and tilt trim plots
draw the robot's series beside the simulation's, each labelled, and a line says how the
robot's IMU is; a stale IMU is said; when the frames stop, the panel is the simulation's alone
again. A screenshot is kept (ARTRO_SCREENSHOTS) to look at."""

from __future__ import annotations

import math
import threading

import httpx
import pytest
from playwright.sync_api import expect, sync_playwright

from tests.testing.browser_support import SIZE_IDS, SIZES, open_page, rgb, shot_path, wait_until
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server

ROBOT_PITCH = (165, 216, 255)  # "robot: pitch" (#a5d8ff)


class FakeLink:
    """Posts frames as `artro link` does, every 150 ms, until stopped: the robot leaning
    forward and back 6° at 0.5 Hz, rolling 3°, its tilt trim answering."""

    def __init__(self, base_url: str) -> None:
        self.http = httpx.Client(base_url=base_url, timeout=10)
        self.status = ["imu_present"]
        self.failures = 0
        self.frame = 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _frame(self, n: int) -> dict:
        pitch = math.radians(6.0) * math.sin(2 * math.pi * 0.5 * n * 0.02)
        return {
            "frame": n,
            "status": list(self.status),
            "imu_failures": self.failures,
            "laws": ["tilt"],
            "support": 0,
            "attitude_rad": [pitch, math.radians(3.0)],
            "gyro_rad_s": [0.0, 0.3 * math.cos(2 * math.pi * 0.5 * n * 0.02), 0.0],
            "accel_m_s2": [0.0, 0.0, 9.81],
            "fsr_n": [[3.0, 3.0, 3.0, 3.0], [0.0, 0.0, 0.0, 0.0]],
            "tilt_rad": [-0.3 * pitch, 0.0],
            "a_y_delta": 0.0,
            "cop_rad": [0.0, 0.0],
        }

    def _run(self) -> None:
        while not self.stop.is_set():
            frames = [self._frame(n) for n in range(self.frame, self.frame + 8)]
            self.frame += 8
            self.http.post("/api/sensors/robot", json={"frames": frames}).raise_for_status()
            self.stop.wait(0.15)  # the link's pace, not a synchronisation

    def __enter__(self) -> FakeLink:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.thread.join(30)
        self.http.close()


@pytest.mark.slow
def test_the_panel_draws_the_robots_series_beside_the_simulations(tmp_path):
    width, height = SIZES[0]
    with running_server(tmp_path) as (base_url, _app), sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        with open_page(browser, base_url, width, height) as page:
            panel = page.locator("#sensors-panel")
            panel.scroll_into_view_if_needed()
            legend = page.locator("#sensors-attitude .u-legend")
            expect(legend).to_contain_text("pitch, estimated", timeout=20_000)
            robot_line = page.locator("#sensors-robot")
            expect(robot_line).to_be_hidden()  # no robot linked: nothing extra
            expect(legend).not_to_contain_text("robot")
            attitude = page.locator("#sensors-attitude canvas")
            assert _pixels(attitude.screenshot(), ROBOT_PITCH) == 0

            with FakeLink(base_url) as link:
                expect(robot_line).to_be_visible(timeout=10_000)
                expect(robot_line).to_contain_text(
                    "robot: IMU ok · 0 IMU failures · laws on: tilt trim · frame"
                )
                expect(legend).to_contain_text("robot: pitch")
                expect(legend).to_contain_text("sim: pitch, estimated")
                expect(page.locator("#sensors-laws-plot .u-legend")).to_contain_text(
                    "robot: tilt trim pitch"
                )
                expect(page.locator("#sensors-gyro .u-legend")).to_contain_text("robot: yaw rate z")
                # the robot's pitch is drawn: its colour, over a second of frames or more
                wait_until(
                    page,
                    lambda: link.frame > 60 and _pixels(attitude.screenshot(), ROBOT_PITCH) > 150,
                    "the robot's pitch drawn",
                )
                for (w, h), name in zip(SIZES, SIZE_IDS, strict=True):
                    page.set_viewport_size({"width": w, "height": h})
                    panel.scroll_into_view_if_needed()
                    expect(robot_line).to_be_in_viewport()
                    panel.screenshot(path=str(shot_path(f"sensors-robot-{name}.png", tmp_path)))
                link.status = ["imu_present", "imu_stale", "imu_nack"]
                link.failures = 3
                expect(robot_line).to_contain_text("robot: IMU stale: no acknowledge · 3 IMU")
                expect(robot_line).to_have_class("small robot-warn")
            # the frames stopped: after 2 s the panel is the simulation's alone
            expect(robot_line).to_be_hidden(timeout=10_000)
            expect(legend).not_to_contain_text("robot")
            expect(legend).to_contain_text("pitch, estimated")
        browser.close()


def _pixels(png: bytes, colour: tuple[int, int, int]) -> int:
    image = rgb(png)
    return int((abs(image - colour).sum(axis=-1) < 40).sum())
