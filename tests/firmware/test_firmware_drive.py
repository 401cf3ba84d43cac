"""The firmware drive: the emulated ATmega128 makes the pulses and the simulated servos read them
off its pins; parameter changes travel over its emulated UART (frame loop, simulation thread and
a real server)."""

from __future__ import annotations

import math

import httpx
import numpy as np
import pytest

from app.firmware.pulses import FirmwarePulses
from app.params.document import ParameterSet
from app.robots.model import RobotModel
from app.server.param_store import ParameterStore
from app.server.sim.emulated_controller import EmulatedController
from app.server.sim.sim_commands import Reset
from app.sim.frame_loop import FrameLoop
from app.sim.frame_record import PinFrame
from gait import GaitParams, Motion
from hardware import TICK_US, US_PER_DEG
from tests.testing.firmware_support import preset
from tests.testing.server_harness import running_server, wait_for

ONE_TICK_RAD = math.radians(TICK_US / US_PER_DEG)


def pins_of(frame) -> PinFrame:
    return PinFrame(frame.phase_rad, frame.ocr, frame.edges, frame.saturated, False, Motion())


def test_the_servos_read_the_firmwares_pins_and_walk_as_the_model_does() -> None:
    doc = preset("tuned", a_p=0.07, ca=0.05)
    params, motion = GaitParams.from_dict(doc["gait"]), Motion(**doc["motion"])
    model = FrameLoop(params=params, motion=motion)
    pins = FrameLoop(params=params, motion=motion)
    firmware = FirmwarePulses(doc)
    try:
        worst = 0.0
        for _ in range(150):  # 3 s, several gait cycles
            by_model = model.step_frame()
            by_pins = pins.step_pins(pins_of(firmware.next_frame()))
            worst = max(worst, float(np.abs(by_pins.setpoint - by_model.setpoint).max()))
            assert by_pins.phase == pytest.approx(by_model.phase, abs=1e-6)
            assert by_pins.pin_edges is not None
    finally:
        firmware.close()
    assert worst <= ONE_TICK_RAD + 1e-12  # float32 on the MCU: at most a tick apart
    (x_model, y_model, _), (x_pins, y_pins, _) = model.trunk_pose(), pins.trunk_pose()
    assert x_pins > 0.05  # it walked forward
    assert math.hypot(x_pins - x_model, y_pins - y_model) < 2e-3


def test_a_servo_whose_output_carried_no_pulse_keeps_its_set_point() -> None:
    loop = FrameLoop(params=GaitParams(), motion=Motion())
    firmware = FirmwarePulses(preset("paper"))
    try:
        frame = firmware.next_frame()
    finally:
        firmware.close()
    held = loop.data.ctrl[loop.robot.actuator_ids].copy()
    names, initial, lines = frame.edges.names, frame.edges.initial, frame.edges.edges
    silent = tuple(0 if n.startswith("OC1") else i for n, i in zip(names, initial, strict=True))
    quiet = tuple(() if n.startswith("OC1") else line for n, line in zip(names, lines, strict=True))
    edges = type(frame.edges)(names, silent, quiet)
    record = loop.step_pins(
        PinFrame(frame.phase_rad, frame.ocr, edges, frame.saturated, False, Motion())
    )
    channel = np.asarray(loop.hardware.tdm.channel_map.channel_index)
    on_timer1 = channel < 3
    assert np.array_equal(record.setpoint[on_timer1], held[on_timer1])
    assert not np.array_equal(record.setpoint[~on_timer1], held[~on_timer1])


def test_the_simulation_thread_switches_to_the_firmware_and_sends_it_changes(sim_thread) -> None:
    sim, store = sim_thread
    sim.switch_drive("firmware")
    status = wait_for(
        lambda: (s := sim.status()).drive == "firmware" and s.frame > 20 and s, "firmware"
    )
    assert status.firmware is not None and 0 < status.firmware.busy_cycles_max < 320_000
    assert status.resets == 1  # the MCU boots at its start phase: the robot starts over
    changed = store.update({"motion": {"a_p": 0.03}}, "test")
    acked = wait_for(
        lambda: (f := sim.status().firmware) and f.params_version_acked == changed.version and f,
        "the firmware to acknowledge the change",
    )
    assert acked.naks == 0 and acked.sets_in_flight == 0
    # the whole set at 57600 baud takes a few frames on the wire; the ACK names the first frame
    latency = sim.status().param_latency_frames
    assert latency.count >= 1 and 1 <= latency.max <= 15
    assert [f["source"] for f in sim.scope.recent(3)] == ["firmware"] * 3
    sim.switch_drive("model")
    wait_for(lambda: sim.status().drive == "model", "the model drive")
    assert sim.status().resets == 1  # back to the model the robot walks on


def test_a_burst_of_versions_sends_one_set_at_a_time_and_the_newest_next() -> None:
    """150 law switches in 2 s had each gone whole onto the emulated UART: the MCU replayed
    stale sets for 13 s. One set is on the wire at a time; a newer version replaces any that
    waited, and its latency counts from when it was asked for."""
    store = ParameterStore(ParameterSet.from_dict(preset("tuned", a_p=0.06)))
    controller = EmulatedController.boot(store.snapshot(), RobotModel.load().hardware())
    try:
        versions = [store.update({"motion": {"a_p": 0.01 * (k % 7)}}, "test") for k in range(30)]
        for snapshot in versions:
            controller.send(snapshot)
        forced, latencies = [], []
        for _ in range(100):
            _pins, problems, reached = controller.next_pins()
            assert problems == []
            latencies += reached
            forced.append(controller.status().params_version_acked)
            if forced[-1] == versions[-1].version:
                break
        status = controller.status()
    finally:
        controller.close()
    assert status.sets_skipped == 28 and status.sets_in_flight == 0  # the first and the last went
    assert set(forced) == {versions[0].version - 1, versions[0].version, versions[-1].version}
    assert len(latencies) == 2 and latencies[1] > latencies[0]  # the last waited for the first


def test_a_set_the_firmware_cannot_run_is_refused_and_ends_the_firmware_drive(sim_thread) -> None:
    sim, store = sim_thread
    store.update({"gait": {"engine": "pfs"}}, "test")
    wait_for(lambda: sim.status().params_version_applied == store.snapshot().version, "pfs")
    with pytest.raises(ValueError, match="runs the behnke gait engine"):
        sim.switch_drive("firmware")
    assert sim.status().drive == "model"
    store.update({"gait": {"engine": "behnke"}}, "test")
    sim.switch_drive("firmware")
    wait_for(lambda: sim.status().drive == "firmware", "firmware")
    store.update({"gait": {"engine": "pfs"}}, "test")  # while the firmware drives
    status = wait_for(lambda: (s := sim.status()).drive == "model" and s, "the fallback")
    assert any("firmware drive ended" in e for e in status.errors)
    frame = status.frame
    wait_for(lambda: sim.status().frame > frame + 10, "the model to drive on")


def test_reset_with_the_firmware_driving_keeps_the_mcu_running(sim_thread) -> None:
    sim, _store = sim_thread
    sim.switch_drive("firmware")
    before = wait_for(lambda: (s := sim.status()).firmware and s.frame > 30 and s, "frames")
    sim.send(Reset())
    after = wait_for(lambda: (s := sim.status()).resets == before.resets + 1 and s, "reset")
    assert after.frame < before.frame  # the simulation restarted
    assert after.firmware.mcu_frame >= before.firmware.mcu_frame  # the MCU did not
    wait_for(lambda: sim.status().frame > 10 and not sim.status().fell, "walking after reset")


def test_the_drive_route_switches_and_refuses_what_it_cannot_do(http: httpx.Client) -> None:
    bad = http.put("/api/sim/drive", json={"drive": "fpga"})
    assert bad.status_code == 422 and "model" in bad.text and "firmware" in bad.text
    assert http.get("/api/state").json()["drive"] == "model"
    version = http.get("/api/params").json()["version"]
    http.patch("/api/params", json={"gait": {"engine": "pfs"}})
    refused = http.put("/api/sim/drive", json={"drive": "firmware"})
    assert refused.status_code == 409 and "behnke" in refused.json()["detail"][0]["msg"]
    http.post("/api/params/undo")
    assert http.get("/api/params").json()["version"] > version
    ok = http.put("/api/sim/drive", json={"drive": "firmware"})
    assert ok.status_code == 200 and ok.json()["drive"] == "firmware"
    state = wait_for(
        lambda: (s := http.get("/api/state").json())["drive"] == "firmware" and s, "state"
    )
    assert state["firmware"]["busy_budget_cycles"] == 128_000
    frames = wait_for(
        lambda: [
            f for f in http.get("/api/scope?frames=5").json()["frames"] if f["source"] == "firmware"
        ],
        "scope frames from the firmware's pins",
    )
    assert {line["name"] for line in frames[-1]["lines"]} >= {"OC1A", "OC3C", "S0", "S2"}
    assert http.put("/api/sim/drive", json={"drive": "model"}).status_code == 200


def test_a_feedback_law_switched_on_runs_on_the_firmware(http: httpx.Client):
    """The firmware runs the laws (docs/DESIGN.md §15): a set that switches one on travels to
    it like any other, the firmware keeps driving, reads the simulated IMU through its TWI and
    trims from it."""
    assert http.put("/api/sim/drive", json={"drive": "firmware"}).status_code == 200
    wait_for(lambda: http.get("/api/state").json()["drive"] == "firmware", "the firmware drives")
    wait_for(  # the server starts with `robust`: its laws run on the firmware
        lambda: (
            http.get("/api/state").json()["firmware"]["laws_on"] == ["tilt", "yaw_rate", "damping"]
        ),
        "the firmware runs robust's laws",
    )
    assert http.post("/api/presets/tuned/load").status_code == 200  # every law off
    http.patch("/api/params", json={"gait": {"tilt": {"enabled": True, "ki_per_s": 2.0}}})
    state = wait_for(
        lambda: (s := http.get("/api/state").json())["firmware"]["laws_on"] == ["tilt"] and s,
        "the firmware runs the tilt trim",
    )
    assert state["drive"] == "firmware" and state["firmware"]["imu_ok"]
    assert state["firmware"]["imu_failures"] == 0
    state = wait_for(
        lambda: (
            (s := http.get("/api/state").json())["firmware"]["tilt_trim_rad"] != [0.0, 0.0] and s
        ),
        "a trim from the emulated IMU",
    )
    assert max(abs(a) for a in state["firmware"]["attitude_rad"]) < 0.5
    assert http.put("/api/sim/drive", json={"drive": "model"}).status_code == 200


@pytest.mark.slow
def test_serve_starts_with_the_firmware_driving(tmp_path) -> None:
    with running_server(tmp_path, drive="firmware") as (base_url, _app):
        with httpx.Client(base_url=base_url, timeout=10) as http:
            state = wait_for(
                lambda: (s := http.get("/api/state").json())["frame"] > 25 and s, "frames"
            )
            assert state["drive"] == "firmware" and state["firmware"]["mcu_frame"] > 25
