"""The scope of the Mega board's firmware drive, in a real headless Chromium (docs/BOARDS.md): the
PCA9685's channels of the chosen servos drawn as pulses, the slots named by what the Mega does in
them, the PCA9685's own period marked, and a lane of the I²C bus with each transaction a box in
time labelled with its part, address, register and bytes."""

from __future__ import annotations

import json
from pathlib import Path

from playwright.sync_api import expect, sync_playwright

from hardware import SERVO_NAMES
from tests.testing.browser_support import shot_path
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, running_server, wait_for


def test_the_scope_draws_the_megas_channels_and_its_i2c_lane(tmp_path: Path) -> None:
    data = tmp_path / "data"
    with (
        running_server(data, drive="firmware", board="mega2560-pca9685") as (base_url, _app),
        sync_playwright() as p,
    ):
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1600, "height": 1000})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.goto(base_url + "/")
        expect(page.locator("#scope-title")).to_have_text(
            "PCA9685 and I²C scope (Mega board)", timeout=30_000
        )
        canvas = page.locator("#scope-canvas")
        boxes = wait_for(lambda: json.loads(canvas.get_attribute("data-i2c-boxes") or "[]"),
                         "the I²C lane drawn")  # fmt: skip
        # the PCA9685's write at the frame's start, the IMU's burst in slot 3
        assert boxes == ["PCA9685 0x40 W reg 0x06 · 50 B", "MPU-6050 0x68 W+R reg 0x3b · 17 B"]
        drawn = lambda name: json.loads(canvas.get_attribute(f"data-{name}") or "[]")  # noqa: E731
        # the scope's servo check boxes show and hide the channels' lanes
        pwm = {servo: f"PWM{n}" for n, servo in enumerate(SERVO_NAMES)}
        default = [pwm[s] for s in SERVO_NAMES if s in ("l_hip_pitch", "l_knee", "r_hip_pitch",
                                                         "r_knee")]  # fmt: skip
        wait_for(lambda: drawn("pwm-lanes") == default, "the default four servos' channels")
        page.locator("#scope-servos-none").click()
        wait_for(lambda: drawn("pwm-lanes") == [], "no channel lane once None is chosen")
        page.locator("#servo-r_ankle_roll").check()
        wait_for(lambda: drawn("pwm-lanes") == [pwm["r_ankle_roll"]], "r_ankle_roll's channel")
        page.locator("#scope-servos-all").click()
        wait_for(lambda: drawn("pwm-lanes") == [f"PWM{n}" for n in range(12)], "all twelve")
        # the slots' headers say what the Mega does in them (the frame's `slots`)
        assert drawn("slot-labels") == ["slot 0 · PCA9685 write", "slot 1", "slot 2",
                                        "slot 3 · IMU + FSR read", "slot 4 · plan next frame",
                                        "slot 5", "slot 6", "slot 7"]  # fmt: skip
        # where the PCA9685's own period began, said to be its oscillator's
        periods = wait_for(lambda: drawn("pca-periods"), "the PCA9685's period marked")
        assert all(p.startswith(("PCA9685 period begins at ", "period begins ")) and
                   "own oscillator" in p and "11.5 µs earlier each frame" in p
                   for p in periods), periods  # fmt: skip
        page.locator("#scope-panel").screenshot(path=str(shot_path("mega-scope.png", tmp_path)))
        browser.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"
