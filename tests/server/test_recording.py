"""Record and replay: the ring buffer, forward kinematics of recorded poses, the file and VCD
round trips (real FrameLoop, real MuJoCo), and the API on a real server."""

from __future__ import annotations

import json

import httpx
import mujoco
import numpy as np
import pytest

from app.firmware.conformance import split_frames
from app.firmware.emulator import Edges
from app.firmware.vcd import VCD_NAMES, edges_of_frames, vcd_text
from app.params.presets import builtin_presets
from app.server.param_store import ParameterStore
from app.server.recording.recorder import Recorder
from app.server.recording.recording_file import recording_from_json
from app.server.recording.replay import Replay
from app.server.sim.sim_thread import SimThread
from app.sim.frame_loop import FrameLoop
from gait import Motion
from hardware import HardwareSetup, frame_edges
from tests.testing.server_harness import wait_for


@pytest.fixture(scope="module")
def walked():
    """A walk of 60 frames recorded into a 40-frame ring, with the bodies' poses at each frame's
    end (forward kinematics of the full-precision state)."""
    loop = FrameLoop(params=builtin_presets()["tuned"].gait, motion=Motion(a_p=0.07))
    recorder = Recorder(loop.model.nq, "artro", capacity=40)
    xpos = []
    for k in range(60):
        record = loop.step_frame()
        recorder.add(record, loop.data.qpos, version=1 + k // 30)
        exact = mujoco.MjData(loop.model)
        exact.qpos[:] = loop.data.qpos
        mujoco.mj_kinematics(loop.model, exact)
        xpos.append(exact.xpos.copy())
        if k == 30:
            recorder.event("params", version=2, source="test", changed=["motion.a_p"])
    return loop, recorder, xpos


def test_the_ring_keeps_the_last_frames_in_order(walked) -> None:
    _loop, recorder, _xpos = walked
    rec = recorder.recording()
    assert len(rec) == 40 and rec.frame.tolist() == list(range(20, 60))
    assert np.allclose(np.diff(rec.t_s), 0.02) and rec.version.tolist()[-1] == 2
    assert [e["kind"] for e in rec.events] == ["params"] and rec.events[0]["source"] == "test"
    summary = recorder.summary()  # what the pages poll: the same, without a copy of the ring
    assert summary["frames"] == 40 and summary["events"] == list(rec.events)
    assert summary["first_t_s"] == rec.t_s[0] and summary["last_t_s"] == rec.t_s[-1]


def test_recorded_poses_give_back_the_bodies_where_they_were(walked) -> None:
    loop, recorder, xpos = walked
    rec = recorder.recording()
    data = mujoco.MjData(loop.model)
    for i in (0, 17, 39):
        data.qpos[:] = rec.qpos[i]
        data.qpos[3:7] /= np.linalg.norm(data.qpos[3:7])
        mujoco.mj_kinematics(loop.model, data)
        assert np.max(np.abs(data.xpos - xpos[rec.frame[i]])) < 1e-5  # float32 storage


def test_a_recording_file_reads_back_the_same(walked) -> None:
    loop, recorder, _ = walked
    rec = recorder.recording()
    again = recording_from_json(json.loads(json.dumps(rec.to_json())), loop.model.nq)
    for name in ("frame", "t_s", "sim_t_s", "phase", "qpos", "ocr", "version", "drive"):
        assert np.array_equal(getattr(again, name), getattr(rec, name)), name
    assert again.events == rec.events
    broken = rec.to_json()
    broken["columns"]["ocr"] = broken["columns"]["ocr"][:-1]
    with pytest.raises(ValueError, match=r"columns\.ocr: has 39 frames"):
        recording_from_json(broken, loop.model.nq)
    with pytest.raises(ValueError, match="not an ArtRo recording"):
        recording_from_json({"format": "wav"}, loop.model.nq)


def test_the_vcd_carries_the_nine_lines_of_the_recorded_pulses(walked) -> None:
    _, recorder, _ = walked
    rec = recorder.recording()
    tdm = HardwareSetup().tdm
    frames = [frame_edges(ocr, tdm) for ocr in rec.ocr[:5]]
    edges = edges_of_frames(frames)
    text = vcd_text(edges, 0)
    for name in VCD_NAMES:
        assert f" {name} $end" in text
    # cut back into frames, the trace is each frame's edges again
    again = split_frames(Edges(edges.cycle, edges.line, edges.level), 0, 5)
    assert again == frames


def test_replay_pauses_the_simulation_and_shows_a_recorded_pose() -> None:
    store = ParameterStore(builtin_presets()["tuned"])
    store.update({"motion": {"a_p": 0.07}}, "test")
    sim = SimThread(store)
    sim.start()
    try:
        wait_for(lambda: len(sim.recorder.recording()) > 50, "frames recorded")
        replay = Replay(sim.model, sim.recorder, sim)
        replay.enter(10)
        wait_for(lambda: sim.status().paused, "the pause")
        first = replay.poses()
        replay.enter(40)
        assert replay.poses().serial > first.serial
        trunk = sim.model.body("trunk").id
        assert replay.poses().xpos[trunk, 0] > first.xpos[trunk, 0]  # it walked on between
        with pytest.raises(IndexError, match="index must be 0 to"):
            replay.enter(10**6)
        assert replay.index == 40  # nothing changed
        replay.leave()
        wait_for(lambda: not sim.status().paused, "the resume")
    finally:
        sim.stop()


def test_a_replay_entered_just_after_a_pause_leaves_the_simulation_paused() -> None:
    """The replay decides whether to resume on leaving from the simulation thread's own answer
    to its pause, which comes after every command sent before it; the published status, up to a
    frame old, said "running" just after a pause and the replay's leaving resumed it."""
    from app.server.sim.sim_commands import Pause, Resume

    store = ParameterStore(builtin_presets()["tuned"])
    sim = SimThread(store)
    sim.start()
    try:
        wait_for(lambda: len(sim.recorder.recording()) > 20, "frames recorded")
        replay = Replay(sim.model, sim.recorder, sim)
        for _ in range(5):
            sim.send(Pause())  # the user's pause, not yet in the status
            replay.enter(5)
            assert not replay._resume_after, "a paused simulation would be resumed on leaving"
            replay.leave()
            sim.send(Resume())
            wait_for(lambda: not sim.status().paused, "running again")
            replay.enter(5)  # from a running simulation: resumed on leaving
            assert replay._resume_after
            replay.leave()
            wait_for(lambda: not sim.status().paused, "resumed by the replay's leaving")
    finally:
        sim.stop()


def test_the_recording_api(http: httpx.Client) -> None:
    try:
        wait_for(lambda: http.get("/api/recording").json()["frames"] > 30, "frames")
        bad = http.post("/api/recording/replay", json={"index": 10**7})
        assert bad.status_code == 404 and "index must be 0 to" in bad.text
        assert http.get("/api/recording").json()["replay"]["active"] is False
        status = http.post("/api/recording/replay", json={"index": 3}).json()
        assert status["active"] and status["index"] == 3 and status["origin"] == "live"
        assert wait_for(lambda: http.get("/api/state").json()["paused"], "paused")
        frame = http.get("/api/recording/frame/3").json()
        assert frame["recorded"] and len(frame["lines"]) == 9
        assert http.get(f"/api/recording/frame/{status['frames']}").status_code == 404
        exported = http.get("/api/recording/export")
        assert (
            exported.status_code == 200 and "attachment" in exported.headers["content-disposition"]
        )
        vcd = http.get("/api/recording/export.vcd").text
        assert "$var wire 1 ! OC1A $end" in vcd and "SEL2" in vcd
        back = http.post(
            "/api/recording/import",
            content=exported.content,
            headers={"content-type": "application/json"},
        ).json()
        assert back["origin"] == "file" and back["frames"] == status["frames"]
        assert http.get("/api/recording/frame/3").json()["lines"] == frame["lines"]
        broken = http.post(
            "/api/recording/import",
            content=b'{"format": "artro-recording", "format_version": 1, "columns": {}}',
            headers={"content-type": "application/json"},
        )
        assert broken.status_code == 422 and "columns.frame: missing" in broken.text
        assert broken.json()["detail"][0]["loc"] == ["body", "columns", "frame"]
        assert http.get("/api/recording").json()["replay"]["origin"] == "file"  # unchanged
        assert http.post("/api/recording/live").json() == {"active": False}
        wait_for(lambda: not http.get("/api/state").json()["paused"], "resumed")
    finally:
        http.post("/api/recording/live")
