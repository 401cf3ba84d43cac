"""The A/B ghost: a second parameter set walking beside the live robot, phase-locked (the
simulation thread's `Ghost`, real MuJoCo) and its API on a real server."""

from __future__ import annotations

import dataclasses
import math

import httpx
import numpy as np

from app.params.presets import builtin_presets
from app.server.param_store import ParameterStore
from app.server.sim.ghost import BESIDE_M, Ghost
from app.server.sim.sim_commands import RemoveGhost, Reset, SetGhost
from app.server.sim.sim_thread import SimThread
from app.sim.frame_loop import FrameLoop
from app.worlds.variations import Variation
from gait import GaitParams, Motion
from tests.testing.server_harness import wait_for


def walking(preset: str = "tuned", a_p: float = 0.07) -> FrameLoop:
    pset = builtin_presets()[preset]
    return FrameLoop(params=pset.gait, motion=Motion(a_p=a_p))


def test_a_ghost_of_the_same_set_walks_beside_in_step_every_frame() -> None:
    live = walking()
    for _ in range(20):
        live.step_frame()
    ghost = Ghost(live, live.params, "version 1")
    x0, y0, _ = live.trunk_pose()
    gx0, gy0, _ = ghost.loop.trunk_pose()
    assert abs(math.hypot(gx0 - x0, gy0 - y0) - BESIDE_M) < 0.01  # beside it, to the left
    assert gy0 > y0
    for _ in range(150):
        record = live.step_frame()
        phase_before = ghost.loop.phase
        ghost.step(live, live.motion, record.phase)
        assert abs(phase_before - record.phase) < 1e-9  # the same phase in the same frame
    assert ghost.phase_locked and ghost.status().note == ""
    assert ghost.loop.trunk_pose()[0] - gx0 > 0.03  # it walked forward
    status = ghost.status()
    assert status.live is not None and status.ghost is not None
    # the ghost started from rest, the live robot mid-walk: alike, not the same
    assert status.ghost.speed_cm_s > 1.0 and status.live.speed_cm_s > 1.0


def test_a_ghost_with_another_clock_is_reported_not_phase_locked() -> None:
    live = walking()
    ghost = Ghost(live, builtin_presets()["paper"].gait, "preset paper")
    for _ in range(5):
        ghost.step(live, live.motion, live.step_frame().phase)
    status = ghost.status()
    assert not status.phase_locked and "not phase-locked" in status.note
    assert "1 Hz" in status.note


def test_a_clock_changed_and_changed_back_leaves_the_ghost_out_of_phase() -> None:
    live = walking()
    ghost = Ghost(live, live.params, "version 1")
    clock = live.params.clock
    faster = dataclasses.replace(live.params, clock=dataclasses.replace(clock, freq_hz=1.0))
    for params in (faster, live.params):
        live.set_gait(params=params)
        for _ in range(10):
            ghost.step(live, live.motion, live.step_frame().phase)
    status = ghost.status()
    assert not status.phase_locked and "apart since a clock change" in status.note
    ghost.place_beside(live)  # what a reset does
    ghost.step(live, live.motion, live.step_frame().phase)
    assert ghost.status().phase_locked


def test_a_pushed_ghost_falls_alone() -> None:
    live = walking()
    ghost = Ghost(live, live.params, "version 1")
    trunk = live.robot.model.body("trunk").id
    for k in range(200):
        phase = live.step_frame().phase
        ghost.loop.data.xfrc_applied[trunk, 1] = 20.0 if k < 25 else 0.0  # a hard shove left
        ghost.step(live, live.motion, phase)
    assert ghost.status().fell and not live.fell
    frozen = ghost.loop.frame_index
    ghost.step(live, live.motion, live.step_frame().phase)
    assert ghost.loop.frame_index == frozen  # a fallen ghost stays where it fell


def test_a_reset_stands_the_ghost_beside_the_live_robot_again() -> None:
    store = ParameterStore(builtin_presets()["tuned"])
    store.update({"motion": {"a_p": 0.07}}, "test")
    sim = SimThread(store)
    sim.publish_poses = True
    sim.start()
    try:
        sim.send(SetGhost(GaitParams(), "paper defaults"))
        wait_for(lambda: (g := sim.ghost_status()) and g.window_s > 2.5, "ghost metrics")
        sim.send(Reset())
        poses = wait_for(
            lambda: (p := sim.body_poses()) and sim.status().resets == 1 and p, "the reset"
        )
        assert poses.ghost_xpos is not None
        trunk = sim.model.body("trunk").id
        assert abs(poses.ghost_xpos[trunk, 1] - poses.xpos[trunk, 1] - BESIDE_M) < 0.05
        assert abs(poses.ghost_xpos[trunk, 0] - poses.xpos[trunk, 0]) < 0.05
        sim.send(RemoveGhost())
        wait_for(lambda: sim.ghost_status() is None, "no ghost")
    finally:
        sim.stop()


def test_the_ghost_api_round_trip_and_its_refusals(http: httpx.Client) -> None:
    try:
        assert http.get("/api/ghost").json()["enabled"] is False
        reply = http.patch(
            "/api/params", json={"motion": {"a_p": 0.07}, "gait": {"swing": {"v": 2.5}}}
        )
        assert reply.status_code == 200, reply.text
        versions = [v["version"] for v in http.get("/api/ghost").json()["versions"]]
        assert len(versions) >= 2
        for bad, status, words in (
            ({"preset": "nope"}, 404, ["paper", "tuned"]),
            ({"version": 10_000}, 404, [str(versions[0])]),
            ({}, 422, ["preset", "version"]),
            ({"preset": "paper", "version": versions[0]}, 422, ["preset", "version"]),
        ):
            reply = http.put("/api/ghost", json=bad)
            assert reply.status_code == status, (bad, reply.text)
            assert all(w in reply.text for w in words), reply.text
        assert http.get("/api/ghost").json()["enabled"] is False  # nothing changed
        earlier = versions[1]
        assert http.put("/api/ghost", json={"version": earlier}).status_code == 200
        state = wait_for(
            lambda: (
                (s := http.get("/api/ghost").json())["enabled"]
                and s["metrics"]["delta"] is not None
                and s
            ),
            "the ghost's metrics",
        )
        assert state["source"] == f"version {earlier}" and state["phase_locked"]
        assert [d["field"] for d in state["diff"]] == ["swing.v"]
        assert state["metrics"]["ghost"]["speed_cm_s"] != 0.0
        assert http.delete("/api/ghost").status_code == 200
        wait_for(lambda: not http.get("/api/ghost").json()["enabled"], "the ghost gone")
    finally:
        http.delete("/api/ghost")


def test_a_ghost_turned_to_the_live_heading_reads_its_imu_in_that_pose() -> None:
    """On a tilted floor gravity leans in the body's frame by the heading: the ghost's sensor
    rows, once filled at heading 0 before it was turned, now read it as it stands."""
    pset = builtin_presets()["robust"]
    live = FrameLoop(
        params=pset.gait,
        motion=Motion(a_p=0.03, a_y=0.3),
        variation=Variation(tilt_deg=3.0, tilt_direction_deg=90.0),
    )
    for _ in range(100):
        live.step_frame()
    assert abs(live.trunk_pose()[2]) > 0.3  # turned
    ghost = Ghost(live, live.params, "version 1")
    model, data = ghost.loop.model, ghost.loop.data
    site = model.sensor_objid[model.sensor_adr.tolist().index(live.robot.accel_adr)]
    at_rest = data.site_xmat[site].reshape(3, 3).T @ -model.opt.gravity
    rows = np.array(ghost.loop.sensing.rows)[:, live.robot.accel_adr : live.robot.accel_adr + 3]
    np.testing.assert_allclose(rows, np.broadcast_to(at_rest, rows.shape), atol=1e-9)
