"""The scope of a robot of bus servos shows its bus (docs/BUS.md): each frame's sync write (its
packet, bytes, time on the wire, the step its goals act at, each servo's goal), and no pulses;
a TDM-PWM robot's frames carry no bus."""

from __future__ import annotations

from pathlib import Path

from app.robots.cad_import import import_robot, write_import
from hardware.servo_bus import STEPS_PER_TURN
from tests.testing.cad_support import op3_like
from tests.testing.server_harness import client, running_server, wait_for


def bus_robot(tmp_path: Path) -> Path:
    """An OP3-like biped on XM430-W350 bus servos, imported, its description written."""
    source, target = tmp_path / "op3.xml", tmp_path / "op3.yaml"
    source.write_text(op3_like().to_xml(), encoding="utf-8")
    result = import_robot(source, output=target, forward="+x", servo="XM430-W350", name="op3")
    write_import(result, target, "the test")
    return target


def test_the_scope_of_a_bus_robot_shows_each_frames_sync_write(tmp_path: Path) -> None:
    with running_server(tmp_path / "data", robot=str(bus_robot(tmp_path))) as (url, _app):
        with client(url) as http:
            wait_for(lambda: http.get("/api/scope?frames=2").json()["frames"], "scope frames")
            frame = http.get("/api/scope?frames=1").json()["frames"][-1]
    bus = frame["bus"]
    assert (bus["protocol"], bus["baud"]) == ("dynamixel", 1_000_000)
    assert bus["bytes"] >= 74 and bus["wire_us"] == bus["bytes"] * 10  # 10 bits a byte
    assert bus["step"] == 1  # 0.74 ms on the wire: every goal acts from the frame's step 1
    assert bus["packet"].startswith("ff ff fd 00 fe")  # broadcast sync write
    assert [g["id"] for g in bus["goals"]] == list(range(1, 13))
    assert all(0 <= g["steps"] < STEPS_PER_TURN for g in bus["goals"])
    assert all(not channel["slots"] for channel in frame["channels"])  # no pulse in any slot


def test_a_tdm_robots_frames_carry_no_bus(server, http) -> None:
    wait_for(lambda: http.get("/api/scope?frames=1").json()["frames"], "scope frames")
    assert "bus" not in http.get("/api/scope?frames=1").json()["frames"][-1]
