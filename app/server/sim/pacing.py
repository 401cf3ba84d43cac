"""Pacing of the simulation thread (docs/DESIGN.md §10): frame k is due at anchor + k * 20 ms /
speed on the wall clock; more than MAX_CATCHUP_FRAMES behind, the debt is dropped, counted and
shown ("behind"), never hidden; the real-time factor is measured over the last RTF_WINDOW_S."""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable

from app.sim.planning import FRAME_S

MAX_CATCHUP_FRAMES = 5  # at most 100 ms of simulated time is run back to back
RTF_WINDOW_S = 2.0
SPEED_RANGE = (0.25, 4.0)  # x real time
BEHIND_SHOWN_S = 2.0  # "behind" stays set this long after frames were dropped

Clock = Callable[[], float]  # monotonic seconds


class Pacer:
    """Keeps the frame loop on the wall clock; the simulation thread's alone.

    Per turn of the loop: `frames_due()` frames are run (each followed by `frame_done()`), then
    the thread waits `wait_s()` or until woken. `restart()` anchors the schedule at now: after a
    pause, a reset, a new speed, a switch of the drive."""

    def __init__(self, clock: Clock = time.monotonic) -> None:
        self._clock = clock
        self.speed = 1.0  # x real time, within SPEED_RANGE
        self.frames_dropped = 0  # frames never simulated because the thread fell behind
        self._behind_at_s = -math.inf  # when frames were last dropped
        self._anchor_s = clock()
        self._frames_since_anchor = 0
        self._rtf_window: deque[tuple[float, float]] = deque()  # (wall time, simulated time)

    def restart(self) -> None:
        """Frame 1 of a new schedule is due one frame from now: nothing is owed."""
        self._anchor_s, self._frames_since_anchor = self._clock(), 0

    def set_speed(self, speed: float) -> None:
        """Run at `speed` x real time from now (the caller checked SPEED_RANGE)."""
        self.speed = speed
        self.restart()

    def frames_due(self) -> int:
        """The frames owed by now, at most MAX_CATCHUP_FRAMES: a larger debt is dropped, counted
        in `frames_dropped` and shown as `behind` for BEHIND_SHOWN_S."""
        now_s = self._clock()
        elapsed_frames = math.floor((now_s - self._anchor_s) * self.speed / FRAME_S)
        due = elapsed_frames - self._frames_since_anchor
        if due > MAX_CATCHUP_FRAMES:
            dropped = due - MAX_CATCHUP_FRAMES
            self.frames_dropped += dropped
            self._behind_at_s = now_s
            self._frames_since_anchor += dropped
            due = MAX_CATCHUP_FRAMES
        return max(due, 0)

    def frame_done(self) -> None:
        self._frames_since_anchor += 1

    def wait_s(self) -> float:
        """Wall time until the next frame is due (0 when it is due already)."""
        next_due_s = self._anchor_s + (self._frames_since_anchor + 1) * FRAME_S / self.speed
        return max(0.0, next_due_s - self._clock())

    def behind(self) -> bool:
        """Frames were dropped within the last BEHIND_SHOWN_S."""
        return self._clock() - self._behind_at_s < BEHIND_SHOWN_S

    # --- the real-time factor -----------------------------------------------------------------

    def sample(self, sim_time_s: float) -> None:
        """Note the simulated time now; samples older than RTF_WINDOW_S go (two always stay)."""
        now_s = self._clock()
        window = self._rtf_window
        window.append((now_s, sim_time_s))
        while len(window) > 2 and now_s - window[0][0] > RTF_WINDOW_S:
            window.popleft()

    def clear_rtf(self) -> None:
        """The simulated time restarts (a reset): a ratio across it would mean nothing."""
        self._rtf_window.clear()

    def rtf(self) -> float | None:
        """Simulated over wall time across the window; None without two samples apart."""
        window = self._rtf_window
        if len(window) < 2 or window[-1][0] <= window[0][0]:
            return None
        return (window[-1][1] - window[0][1]) / (window[-1][0] - window[0][0])
