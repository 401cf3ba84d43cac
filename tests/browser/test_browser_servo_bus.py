"""`artro serve --servo-bus pty` in a real headless Chromium (docs/BUS.md): while a
`dynamixel_sdk` program sync-writes goals, the status bar says "driven by the bus" with the
port, packet rate, errors and latency, and the scope shows the goals' sync write."""

from __future__ import annotations

import threading
from pathlib import Path

import dynamixel_sdk as dxl
from playwright.sync_api import expect, sync_playwright

from hardware.servo_bus import angle_to_steps
from tests.server.test_server_servo_bus import CROUCH_RAD
from tests.testing.browser_support import shot_path
from tests.testing.server_harness import CHROMIUM, CHROMIUM_ARGS, client, running_server

FRAME_S = 0.02  # the program writes its goals once a frame, as a builder's loop does


def _program(port_path: str, stop: threading.Event) -> None:
    """A builder's program: a crouch (hip pitch, knee, ankle pitch bent), sync-written each
    frame."""
    port = dxl.PortHandler(port_path)
    packets = dxl.PacketHandler(2.0)
    assert port.openPort() and port.setBaudRate(1_000_000)
    write = dxl.GroupSyncWrite(port, packets, 116, 4)
    goals = angle_to_steps(CROUCH_RAD)
    for servo_id, steps in enumerate(goals.tolist(), 1):
        write.addParam(servo_id, list(int(steps).to_bytes(4, "little")))
    try:
        while not stop.is_set():
            write.txPacket()
            stop.wait(FRAME_S)  # the program's own pace, not a synchronisation
    finally:
        port.closePort()


def test_the_page_shows_the_robot_driven_by_the_bus(tmp_path: Path) -> None:
    stop = threading.Event()
    with (
        running_server(tmp_path / "data", servo_bus="pty") as (base_url, _app),
        sync_playwright() as p,
    ):
        with client(base_url) as http:
            port_path = http.get("/api/bus").json()["port"]
        program = threading.Thread(target=_program, args=(port_path, stop), daemon=True)
        program.start()
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1600, "height": 1000})
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        try:
            page.goto(base_url + "/")
            block = page.locator("#bus-status")
            expect(block).to_be_visible(timeout=30_000)
            expect(page.locator("#bus-port")).to_have_text(port_path)
            expect(page.locator("#bus-state")).to_have_text("driven by the bus", timeout=30_000)
            expect(page.locator("#bus-traffic")).to_contain_text("packets/s · 0 errors · latency")
            strip = page.locator("#scope-bus")
            expect(strip).to_be_visible(timeout=30_000)
            expect(strip.locator(".bus-line")).to_contain_text("Dynamixel 2.0 sync write")
            expect(strip.locator(".bus-goal").nth(3)).to_contain_text("#4 1657")  # the knee
            page.locator("header").screenshot(path=str(shot_path("servo-bus-status.png", tmp_path)))
            page.screenshot(path=str(shot_path("servo-bus-page.png", tmp_path)))
        finally:
            stop.set()
            program.join(10)
            browser.close()
    assert errors == [], f"JavaScript errors on the page: {errors}"
