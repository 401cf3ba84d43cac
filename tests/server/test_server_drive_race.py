"""A switch to the firmware drive raced by a switch to the pfs engine (issue 18, item 7): the
firmware boots for the set it was asked with; if the set names pfs by the time the simulation
thread takes the firmware over, the switch is refused (409 over HTTP) and the model drives on.
Never does the firmware drive a set it refuses."""

from __future__ import annotations

import dataclasses
import threading

import httpx
import pytest

from app.server.sim.emulated_controller import EmulatedController
from app.server.sim.sim_commands import DriveRefused, SwitchDrive
from tests.testing.server_harness import client, wait_for


def handed_over(sim, command):
    """Hand `command`'s controller to the simulation thread (a SwitchDrive, or the controller
    alone); its status once it has decided (the firmware drives, or a refusal is said)."""
    sim.send(command if isinstance(command, SwitchDrive) else SwitchDrive(command))

    def verdict():
        s = sim.status()
        return (s.drive == "firmware" or any("not started" in e for e in s.errors)) and s

    return wait_for(verdict, "the simulation thread's verdict")


def test_a_firmware_booted_for_behnke_is_refused_once_the_set_names_pfs(sim_thread):
    """The race, step by step: the firmware boots for the behnke set (as `switch_drive` does in
    the HTTP thread), the set becomes pfs and the simulation applies it, then the booted firmware
    is handed over."""
    sim, store = sim_thread
    controller = EmulatedController.boot(store.snapshot(), sim.hardware)
    changed = store.update({"gait": {"engine": "pfs"}}, "test")
    wait_for(lambda: sim.status().params_version_applied == changed.version, "pfs applied")
    command = SwitchDrive(controller)
    status = handed_over(sim, command)
    assert status.drive == "model", "the firmware drives a pfs set it refuses"
    assert command.answer.wait(30) and command.answer.reason == "unsupported_engine"
    assert any("runs the behnke gait engine" in e and "'pfs'" in e for e in status.errors)
    frame = status.frame
    wait_for(lambda: sim.status().frame > frame + 10, "the model drives on")


def test_the_drive_route_raced_by_pfs_ends_with_the_model_driving(server, http):
    """Over HTTP, however the race falls out: refused at once (409), or switched and then ended
    by the pfs set; the model drives the pfs set in the end."""
    for _attempt in range(5):
        http.put("/api/sim/drive", json={"drive": "model"})
        http.patch("/api/params", json={"gait": {"engine": "behnke"}})
        wait_for(lambda: http.get("/api/state").json()["drive"] == "model", "the model drive")
        answers: dict[str, httpx.Response] = {}

        def switch(answers: dict[str, httpx.Response] = answers) -> None:
            with client(server[0]) as other:
                answers["drive"] = other.put("/api/sim/drive", json={"drive": "firmware"})

        thread = threading.Thread(target=switch)
        thread.start()
        engine = http.patch("/api/params", json={"gait": {"engine": "pfs"}})
        thread.join(60)
        assert engine.status_code == 200 and engine.json()["gait"]["engine"] == "pfs"
        drive = answers["drive"]
        assert drive.status_code in (200, 409), drive.text
        if drive.status_code == 409:
            assert "behnke" in drive.json()["message"] and "pfs" in drive.json()["message"]
        wait_for(
            lambda: http.get("/api/state").json()["drive"] == "model",
            "the model drives the pfs set",
        )
    http.patch("/api/params", json={"gait": {"engine": "behnke"}})


def test_a_firmware_booted_for_one_robot_never_drives_another(sim_thread):
    """A drive switch raced by a switch of robots (13 of 13 tries once ended with the firmware
    of one robot's legs driving the other): the firmware booted for ArtRo is refused when handed
    over after the simulation took the micro robot; booting for a set that names another robot
    than the one simulated is refused at once."""
    sim, store = sim_thread
    controller = sim.live.boot_firmware(store.snapshot())
    micro = store.replace(store.snapshot().parameter_set(), "test", robot="micro")
    wait_for(lambda: sim.status().robot == "micro", "the simulation took the micro robot")
    command = SwitchDrive(controller)
    status = handed_over(sim, command)
    assert status.drive == "model", "ArtRo's firmware drives the micro robot"
    assert any("built for the robot 'artro'; the robot is now 'micro'" in e for e in status.errors)
    assert command.answer.wait(30) and command.answer.reason == "robot_changed"  # not an engine's
    not_simulated = dataclasses.replace(micro, robot="artro")  # as if the store moved on
    with pytest.raises(DriveRefused, match="the robot is changing to 'artro'") as refused:
        sim.live.boot_firmware(not_simulated)
    assert refused.value.reason == "robot_changed"  # over HTTP the error's type, not an engine's
