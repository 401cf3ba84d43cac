"""The real-time simulation thread of `artro serve`: paces the frame loop to the wall clock.

This thread alone owns the `FrameLoop` (and so its MjData). Everyone else talks to it through
the parameter store (changes are picked up at the next frame boundary) and a command queue
(pause, resume, reset, single step, speed, re-anchor). Pacing: frame k of a run is due at
wall time anchor + k * 20 ms / speed. When the machine falls behind by more than
MAX_CATCHUP_FRAMES, the debt is dropped instead of chased (no spiral of death): the loop
re-anchors, counts the dropped frames and reports that it is behind. The real-time factor is
measured over a sliding window of wall time.

The thread never dies of a frame: an exception or a physics blow-up is reported in the status
and the robot is reset.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
import traceback
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.core.frame_loop import FRAME_S, FrameLoop, HardwareSetup
from app.core.robot import RobotModel
from app.server.param_store import ParameterStore, Snapshot
from app.server.path_tracker import SAMPLE_EVERY_FRAMES, PathTracker
from app.server.scope_feed import ScopeFeed

log = logging.getLogger(__name__)

MAX_CATCHUP_FRAMES = 5  # at most 100 ms of simulated time is run back to back
RTF_WINDOW_S = 2.0
SPEED_RANGE = (0.25, 4.0)
BEHIND_SHOWN_S = 2.0  # "behind" stays set this long after frames were dropped


@dataclass(frozen=True)
class BodyPoses:
    """A copy of the bodies' world poses for the 3D view (never the live MjData)."""

    serial: int
    xpos: np.ndarray
    xmat: np.ndarray


class SimThread:
    def __init__(
        self,
        store: ParameterStore,
        *,
        robot: RobotModel | None = None,
        hardware: HardwareSetup | None = None,
    ) -> None:
        self.store = store
        self.hardware = hardware or HardwareSetup()
        snap = store.snapshot()
        self.sim = FrameLoop(
            robot=robot, params=snap.gait, motion=snap.motion, hardware=self.hardware
        )
        self.scope = ScopeFeed(self.hardware.tdm)
        self.paths = PathTracker()
        self.paths.set_gait(snap.motion.ca, snap.gait.clock.freq_hz)
        self._commands: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._applied = snap
        # (frames done, wall time) when the first not yet applied change entered the store
        self._pending: tuple[int, float] | None = None
        self._status_lock = threading.Lock()
        self._poses: BodyPoses | None = None
        self.publish_poses = False  # set by the 3D view, the only reader of body poses
        self._pose_serial = 0
        self.speed = 1.0
        self.paused = False
        self.frames_dropped = 0
        self.last_behind_wall = -math.inf
        self.errors: deque[str] = deque(maxlen=20)
        self.resets = 0
        # per applied change: frames from entering the store to the frame whose pulses carry it
        self.param_latency_frames: deque[int] = deque(maxlen=100)
        self._rtf_window: deque[tuple[float, float]] = deque()
        self._unsubscribe = store.subscribe(self._on_params)

    # --- lifecycle ------------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="artro-sim", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        self._wake.set()
        self._unsubscribe()
        if self._thread is not None:
            self._thread.join(timeout_s)

    @property
    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # --- commands (any thread) ------------------------------------------------------------------

    def command(self, name: str, value: Any = None) -> None:
        if name not in {"pause", "resume", "reset", "step", "speed", "reanchor"}:
            raise ValueError(f"unknown command {name!r}")
        if name == "speed" and not (SPEED_RANGE[0] <= float(value) <= SPEED_RANGE[1]):
            raise ValueError(f"speed must be {SPEED_RANGE[0]} to {SPEED_RANGE[1]}, got {value}")
        self._commands.put((name, value))
        self._wake.set()

    def _on_params(self, snapshot: Snapshot, changed: frozenset[str], source: str) -> None:
        if self._pending is None:
            self._pending = (self.sim.frame_index, time.monotonic())
        self._wake.set()

    # --- reading (any thread) -------------------------------------------------------------------

    def body_poses(self) -> BodyPoses | None:
        return self._poses

    def status(self) -> dict[str, Any]:
        with self._status_lock:
            window = list(self._rtf_window)
        rtf = None
        if len(window) >= 2 and window[-1][0] > window[0][0]:
            rtf = (window[-1][1] - window[0][1]) / (window[-1][0] - window[0][0])
        sim = self.sim
        x, y, yaw = sim.trunk_pose()
        return {
            "sim_time_s": sim.time_s,
            "frame": sim.frame_index,
            "rtf": rtf,
            "speed": self.speed,
            "paused": self.paused,
            "fell": sim.fell,
            "behind": time.monotonic() - self.last_behind_wall < BEHIND_SHOWN_S,
            "frames_dropped": self.frames_dropped,
            "trunk": {"x_m": x, "y_m": y, "z_m": float(sim.data.qpos[2]), "yaw_rad": yaw},
            "params_version": self.store.snapshot().version,
            "params_version_applied": self._applied.version,
            "param_latency_frames": _summary(self.param_latency_frames),
            "resets": self.resets,
            "scope": {"clients": self.scope.client_count, "dropped": self.scope.dropped},
            "errors": list(self.errors),
            "running": self.alive,
        }

    # --- the thread -----------------------------------------------------------------------------

    def _run(self) -> None:
        wall_anchor = time.monotonic()
        frames_since_anchor = 0
        while not self._stop.is_set():
            try:
                reanchor = self._drain_commands()
                self._apply_params()
                if reanchor or self.paused or self.sim.fell:
                    wall_anchor, frames_since_anchor = time.monotonic(), 0
                if self.paused or self.sim.fell:
                    self._record_rtf()
                    self._wake.wait(0.1)
                    self._wake.clear()
                    continue
                now = time.monotonic()
                due = math.floor((now - wall_anchor) * self.speed / FRAME_S) - frames_since_anchor
                if due > MAX_CATCHUP_FRAMES:
                    self.frames_dropped += due - MAX_CATCHUP_FRAMES
                    self.last_behind_wall = now
                    frames_since_anchor += due - MAX_CATCHUP_FRAMES
                    due = MAX_CATCHUP_FRAMES
                for _ in range(max(due, 0)):
                    self._apply_params()  # also between catch-up frames: no change waits a batch
                    self._frame()
                    frames_since_anchor += 1
                    if self.sim.fell:
                        break
                self._record_rtf()
                next_due = wall_anchor + (frames_since_anchor + 1) * FRAME_S / self.speed
                self._wake.wait(max(0.0, next_due - time.monotonic()))
                self._wake.clear()
            except Exception:  # the server must outlive any frame: report, reset, go on
                self.errors.append(traceback.format_exc(limit=3))
                log.exception("simulation frame failed; resetting")
                self._reset()
                wall_anchor, frames_since_anchor = time.monotonic(), 0

    def _drain_commands(self) -> bool:
        """Apply queued commands; True if the pacing must restart from now."""
        restart = False
        while True:
            try:
                name, value = self._commands.get_nowait()
            except queue.Empty:
                return restart
            if name == "pause":
                self.paused = True
            elif name == "resume":
                self.paused, restart = False, True
            elif name == "reset":
                self._reset()
                restart = True
            elif name == "step":
                self.paused = True
                self._apply_params()
                if not self.sim.fell:
                    self._frame()
            elif name == "speed":
                self.speed, restart = float(value), True
            elif name == "reanchor":
                self.paths.reanchor(value)

    def _apply_params(self) -> None:
        snap = self.store.snapshot()
        if snap.version == self._applied.version:
            return
        old = self._applied
        self.sim.set_gait(snap.gait, snap.motion)
        self.paths.set_gait(snap.motion.ca, snap.gait.clock.freq_hz)
        if snap.motion != old.motion:
            self.paths.reanchor()
        self._applied = snap
        if self._pending is not None:
            # the next frame (number frame_index) is the first built with the change
            self.param_latency_frames.append(self.sim.frame_index - self._pending[0] + 1)
            self._pending = None

    def _frame(self) -> None:
        sim = self.sim
        record = sim.step_frame()
        if sim.blew_up:
            self.errors.append(f"physics blew up at t = {sim.time_s:.2f} s; robot reset")
            self._reset()
            return
        self.scope.publish(record, self._applied.version)
        if record.index % SAMPLE_EVERY_FRAMES == 0:
            self.paths.add(sim.time_s, sim.trunk_pose(), sim.feet_distance_m())
        self._publish_poses()

    def _reset(self) -> None:
        self.sim.reset()
        self.resets += 1
        self.paths.clear()
        self.scope.clear()
        self._publish_poses()

    def _publish_poses(self) -> None:
        """A copy of the body poses for the 3D view: made only when a view exists."""
        if self.publish_poses:
            self._pose_serial += 1
            data = self.sim.data
            self._poses = BodyPoses(self._pose_serial, data.xpos.copy(), data.xmat.copy())

    def _record_rtf(self) -> None:
        now = time.monotonic()
        with self._status_lock:
            self._rtf_window.append((now, self.sim.time_s))
            while len(self._rtf_window) > 2 and now - self._rtf_window[0][0] > RTF_WINDOW_S:
                self._rtf_window.popleft()


def _summary(values: deque[int]) -> dict[str, float | int | None]:
    ordered = sorted(values)
    if not ordered:
        return {"count": 0, "median": None, "max": None}
    return {"count": len(ordered), "median": ordered[len(ordered) // 2], "max": ordered[-1]}
