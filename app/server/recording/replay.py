"""Replay a recording: the live simulation pauses, a position in the recording gives the 3D
view its poses (forward kinematics of the recorded qpos on this module's own MjData) and the
scope its frame (docs/DESIGN.md §10). Called from HTTP and viewer threads, under one lock.
"""

from __future__ import annotations

import math
import queue
import threading
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from app.server.feeds.scope_frames import frame_to_dict
from app.server.recording.recorder import Recorder, Recording
from app.server.sim.live_robot import model_name
from app.server.sim.sim_commands import Control, PauseForReplay, Resume, Step
from app.server.sim.sim_thread import SimThread
from hardware import TdmConfig


class NothingRecorded(ValueError):
    """A replay was asked for before any frame was recorded."""


class OtherRobot(ValueError):
    """A recording made on another robot than the one loaded: its poses and pulses are that
    robot's."""


class Replaying(RuntimeError):
    """The live simulation may not run while a replay owns the 3D view and the scope."""


PAUSE_ANSWER_S = 2.0  # a frame is 20 ms; a simulation thread stuck longer answers by status

#: what would run the live simulation under the replay's views
RUNS_LIVE = Resume | Step


@dataclass(frozen=True)
class ReplayPoses:
    """The bodies' poses at the replay position (the same fields the 3D view reads live)."""

    serial: int
    xpos: np.ndarray
    xmat: np.ndarray
    ghost_xpos: None = None
    ghost_xmat: None = None
    model: mujoco.MjModel | None = None  # the robot's model they are poses of


class Replay:
    def __init__(self, model: mujoco.MjModel, recorder: Recorder, sim: SimThread) -> None:
        self.model, self.recorder, self.sim = model, recorder, sim
        self._data = mujoco.MjData(model)  # this module's alone, under the lock
        self._lock = threading.Lock()
        self.recording: Recording | None = None  # what is replayed; None: live
        self.origin = "live"  # "live": the session's ring; "file": an imported recording
        self.index = 0
        self._serial = 0
        self._poses: ReplayPoses | None = None
        self._resume_after = False

    @property
    def active(self) -> bool:
        return self.recording is not None

    def poses(self) -> ReplayPoses | None:
        return self._poses

    def enter(self, index: int | None = None, recording: Recording | None = None) -> None:
        """Replay `recording` (default: the session so far) at `index` (default: its last
        frame, or where the replay is). NothingRecorded, OtherRobot (a file of another robot
        than the one loaded), or IndexError with the allowed range; nothing changes then."""
        with self._lock:
            new = recording is not None or self.recording is None
            rec = recording if recording is not None else self.recording
            if rec is None:
                rec = self.recorder.recording()
            if len(rec) == 0:
                raise NothingRecorded("nothing recorded yet: let the simulation run first")
            loaded = model_name(self.sim.model)
            if recording is not None and rec.model and rec.model != loaded:
                raise OtherRobot(
                    f"recorded on the robot {rec.model!r}; the robot in use is {loaded!r}: "
                    f"switch to {rec.model!r} (PUT /api/robot), then import it"
                )
            if index is None:
                index = len(rec) - 1 if new else self.index
            self._check(rec, index)
            if self.model is not self.sim.model:  # the robot was switched since the last replay
                self.model, self._data = self.sim.model, mujoco.MjData(self.sim.model)
            if self.recording is None:  # from live: pause it, resume it when leaving
                self._resume_after = not self._pause_live()
            if new:
                self.origin = "live" if recording is None else "file"
            self.recording = rec
            self._show(index)

    def _pause_live(self) -> bool:
        """Pause the live simulation; whether it was paused already, as the simulation thread
        took the pause (after every command sent before it), else as its status says."""
        pause = PauseForReplay()
        self.sim.send(pause)
        try:
            return pause.was_paused.get(timeout=PAUSE_ANSWER_S if self.sim.alive else 0)
        except queue.Empty:  # a simulation thread not running: its last status
            return self.sim.status().paused

    def live_command(self, command: Control) -> None:
        """Send a command to the live simulation; Replaying (nothing sent) for one that would run
        it while a replay is shown (resume, step): leave the replay first."""
        with self._lock:  # as `enter` pauses and `leave` resumes: one order
            if self.recording is not None and isinstance(command, RUNS_LIVE):
                raise Replaying(
                    f"a replay is shown: {command.name} would run the live simulation under "
                    "it; go back to live first (POST /api/recording/live, 'Back to live'), "
                    "which resumes it"
                )
            self.sim.send(command)

    def leave(self) -> None:
        """Back to the live simulation (resumed if it was running before the replay)."""
        with self._lock:
            if self.recording is None:
                return
            self.recording, self._poses = None, None
            if self._resume_after:
                self.sim.send(Resume())

    def frame_message(self, index: int, tdm: TdmConfig) -> dict[str, Any]:
        """The scope frame at `index` of the replayed recording (or, live, of the session so
        far), with the Mega board's channels and I2C where the recorder kept them;
        IndexError with the allowed range."""
        rec = self.recording or self.recorder.recording()
        self._check(rec, index)
        board = rec.boards[index] if index < len(rec.boards) else None  # a file keeps none
        return {
            "index": index,
            "frame": int(rec.frame[index]),
            "t_s": round(float(rec.sim_t_s[index]), 6),
            "session_t_s": round(float(rec.t_s[index]), 6),
            "phase_rad": float(rec.phase[index]),
            "params_version": int(rec.version[index]),
            "source": "firmware" if rec.drive[index] else "model",
            "recorded": True,
            **frame_to_dict(rec.ocr[index].astype(np.int32), tdm),
            **(board.message() if board is not None else {}),  # the Mega's, as it was live
        }

    def status(self) -> dict[str, Any]:
        with self._lock:  # the recording and the index together
            rec, index, origin = self.recording, self.index, self.origin
        if rec is None:
            return {"active": False}
        return {
            "active": True,
            "origin": origin,
            "index": index,
            "frames": len(rec),
            "session_t_s": float(rec.t_s[index]),
            "t_s": float(rec.sim_t_s[index]),
            "frame": int(rec.frame[index]),
        }

    @staticmethod
    def _check(rec: Recording, index: int) -> None:
        if not 0 <= index < len(rec):
            raise IndexError(
                f"index must be 0 to {len(rec) - 1} (the recorded frames), got {index}"
            )

    def _show(self, index: int) -> None:
        rec = self.recording
        assert rec is not None
        self.index = index
        self._data.qpos[:] = rec.qpos[index]
        quat = self._data.qpos[3:7]
        norm = math.sqrt(float(quat @ quat))
        if norm > 0.0:
            quat /= norm  # float32 storage: renormalise the trunk orientation
        mujoco.mj_kinematics(self.model, self._data)
        self._serial += 1
        self._poses = ReplayPoses(
            self._serial, self._data.xpos.copy(), self._data.xmat.copy(), model=self.model
        )
