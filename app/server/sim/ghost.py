"""The A/B ghost: a second parameter set walking beside the live robot, phase-locked, with the
same motion vector, for comparison (docs/DESIGN.md §10). Owned by the simulation thread: its own
FrameLoop and MjData of the same model; others read the published `GhostStatus` and poses.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np

from app.sim.frame_loop import FrameLoop
from app.sim.planning import FRAME_S
from gait import GaitParams, Motion

BESIDE_M = 0.35  # the ghost starts this far to the live robot's left
METRICS_WINDOW_S = 10.0  # speed, turn rate and gyro RMS over the last 10 s
MIN_WINDOW_S = 2.0  # fewer seconds than this: no metrics yet
#: phases this close count as one: well above the rounding of the firmware's walking clock
#: (its 32-bit step drifts < 1e-9 rad a frame), far below a clock change's gap
PHASE_LOCK_RAD = 1e-3


@dataclass(frozen=True)
class WalkMetrics:
    """Speed along the heading, turn rate and trunk gyro RMS over the window."""

    speed_cm_s: float
    turn_deg_s: float  # counter-clockwise +
    gyro_rms_deg_s: float


@dataclass(frozen=True)
class GhostStatus:
    source: str  # "preset tuned", "version 12"
    params: GaitParams  # the ghost's gait
    phase_locked: bool
    note: str  # why not phase-locked, or ""
    fell: bool
    window_s: float  # seconds both walked (up to METRICS_WINDOW_S)
    live: WalkMetrics | None
    ghost: WalkMetrics | None

    def delta(self) -> WalkMetrics | None:
        """ghost - live, or None before both have metrics."""
        if self.live is None or self.ghost is None:
            return None
        return WalkMetrics(
            *(g - v for g, v in zip(_values(self.ghost), _values(self.live), strict=True))
        )


def _values(m: WalkMetrics) -> tuple[float, float, float]:
    return m.speed_cm_s, m.turn_deg_s, m.gyro_rms_deg_s


class _Track:
    """Per frame: time, trunk x, y, yaw (unwrapped) and |gyro|^2, over the window."""

    def __init__(self) -> None:
        self.rows: deque[tuple[float, float, float, float, float]] = deque(
            maxlen=round(METRICS_WINDOW_S / FRAME_S) + 1
        )

    def add(self, t: float, pose: tuple[float, float, float], gyro: np.ndarray) -> None:
        x, y, yaw = pose
        if self.rows:
            last = self.rows[-1][3]
            yaw = last + math.remainder(yaw - last, 2.0 * math.pi)
        self.rows.append((t, x, y, yaw, float(gyro @ gyro)))

    def metrics(self) -> WalkMetrics | None:
        if len(self.rows) < 2 or self.rows[-1][0] - self.rows[0][0] < MIN_WINDOW_S:
            return None
        t0, x0, y0, yaw0, _ = self.rows[0]
        t1, x1, y1, yaw1, _ = self.rows[-1]
        dt, heading = t1 - t0, 0.5 * (yaw0 + yaw1)
        along = (x1 - x0) * math.cos(heading) + (y1 - y0) * math.sin(heading)
        gyro_ms = sum(r[4] for r in self.rows) / len(self.rows)
        return WalkMetrics(
            100.0 * along / dt, math.degrees((yaw1 - yaw0) / dt), math.degrees(math.sqrt(gyro_ms))
        )

    def seconds(self) -> float:
        return self.rows[-1][0] - self.rows[0][0] if len(self.rows) >= 2 else 0.0


class Ghost:
    """The second robot. Created and stepped by the simulation thread only."""

    def __init__(self, live: FrameLoop, params: GaitParams, source: str) -> None:
        self.source = source
        self.params = params
        self.live_freq_hz = live.params.clock.freq_hz
        self.loop = FrameLoop(  # the same robot in the same world (docs/DESIGN.md §8)
            robot=live.nominal_robot,
            params=params,
            motion=live.motion,
            hardware=live.hardware,
            variation=live.variation,
        )
        self._live_track, self._ghost_track = _Track(), _Track()
        self.place_beside(live)

    def place_beside(self, live: FrameLoop) -> None:
        """Stand the ghost at the live robot's phase, BESIDE_M to its left, same heading."""
        self.loop.set_gait(motion=live.motion)
        self.loop.reset(live.phase, start_motion=live.motion_now)
        x, y, yaw = live.trunk_pose()
        data = self.loop.data
        data.qpos[0] = x - BESIDE_M * math.sin(yaw)
        data.qpos[1] = y + BESIDE_M * math.cos(yaw)
        data.qpos[3:7] = (math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0))
        mujoco.mj_forward(self.loop.model, data)
        self.loop.placed()  # its IMU at rest facing that way, on the world's floor
        self._live_track, self._ghost_track = _Track(), _Track()
        self.phase_gap_rad = 0.0

    @property
    def phase_locked(self) -> bool:
        """Same clock and, in the last frame, the same phase (a clock changed and changed back
        leaves the phases apart until the next reset)."""
        same_clock = self.params.clock.freq_hz == self.live_freq_hz
        return same_clock and self.phase_gap_rad < PHASE_LOCK_RAD

    def step(self, live: FrameLoop, motion: Motion, live_phase: float) -> None:
        """The frame the live robot just made at `live_phase`, with the motion the live robot
        was asked for."""
        self.live_freq_hz = live.params.clock.freq_hz
        if self.loop.fell:
            return
        if motion != self.loop.motion:
            self.loop.set_gait(motion=motion)
        record = self.loop.step_frame()
        self.phase_gap_rad = abs(math.remainder(record.phase - live_phase, 2.0 * math.pi))
        if not live.fell and not self.loop.fell:
            t = live.time_s
            self._live_track.add(t, live.trunk_pose(), live.gyro())
            self._ghost_track.add(t, self.loop.trunk_pose(), self.loop.gyro())

    def status(self) -> GhostStatus:
        locked = self.phase_locked
        if locked:
            note = ""
        elif self.params.clock.freq_hz != self.live_freq_hz:
            note = (
                f"not phase-locked: its clock is {self.params.clock.freq_hz:g} Hz, "
                f"the live robot's {self.live_freq_hz:g} Hz"
            )
        else:
            note = f"not phase-locked: {self.phase_gap_rad:.2f} rad apart since a clock change"
        return GhostStatus(
            source=self.source,
            params=self.params,
            phase_locked=locked,
            note=note,
            fell=self.loop.fell,
            window_s=self._ghost_track.seconds(),
            live=self._live_track.metrics(),
            ghost=self._ghost_track.metrics(),
        )
