"""The actual trunk path and the differential-drive prediction beside it (docs/DESIGN.md §4).

Fed by the simulation thread, read with `PathTracker.view()`; the prediction is `gait.steering`'s
exact unicycle, seed 004 eqs (9), (12)–(13), with V, b and its anchor as §4 says.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.sim.metrics import mean_body_velocity
from gait import Pose2D, predict_path, turn_radius_m, turn_rate_rad_s

SAMPLE_EVERY_FRAMES = 5  # 10 Hz path samples
MAX_SAMPLES = 6000  # 10 minutes at 10 Hz
MEASURE_CYCLES = 2  # speeds are measured over the last two whole gait cycles
HORIZON_S = 10.0  # the prediction runs this far ahead of the present
NOMINAL_AXLE_M = 0.09  # until the feet have been measured: the hip spacing of the model


@dataclass(frozen=True)
class Anchor:
    t_s: float
    pose: Pose2D


class PathTracker:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._samples: deque[tuple[float, float, float, float]] = deque(maxlen=MAX_SAMPLES)
        self._feet: deque[float] = deque(maxlen=MAX_SAMPLES)
        self._raw_yaw = 0.0
        self._yaw_unwrapped = 0.0
        self._anchor: Anchor | None = None
        self._manual_speed: float | None = None
        self._axle: tuple[float, str] | None = None  # (b in m, "manual" | "fitted")
        self._axle_serial = 0  # counts the axle settings: a fit applies only onto its own
        self._ca = 0.0
        self._freq_hz = 1.0

    # --- fed by the simulation thread -----------------------------------------------------------

    def clear(self) -> None:
        with self._lock:
            self._samples.clear()
            self._feet.clear()
            self._anchor = None

    def add(self, t_s: float, pose: tuple[float, float, float], feet_m: float) -> None:
        x, y, yaw = pose
        with self._lock:
            if self._samples:
                step = math.remainder(yaw - self._raw_yaw, 2.0 * math.pi)
                self._yaw_unwrapped += step
            else:
                self._yaw_unwrapped = yaw
            self._raw_yaw = yaw
            self._samples.append((t_s, x, y, self._yaw_unwrapped))
            self._feet.append(feet_m)
            if self._anchor is None:
                self._anchor = Anchor(t_s, Pose2D(x, y, self._yaw_unwrapped))

    def set_gait(self, ca: float, freq_hz: float) -> None:
        with self._lock:
            self._ca, self._freq_hz = ca, freq_hz

    def reanchor(self, speed_m_s: float | None = None) -> None:
        """Start the prediction at the latest pose; a speed fixes V by hand, None measures it."""
        with self._lock:
            self._manual_speed = speed_m_s
            if self._samples:
                t, x, y, yaw = self._samples[-1]
                self._anchor = Anchor(t, Pose2D(x, y, yaw))
            else:
                self._anchor = None

    def set_axle(
        self, axle_m: float | None, source: str = "manual", *, only_onto: int | None = None
    ) -> bool:
        """Use this axle b for the prediction; None goes back to the measured feet distance.
        With `only_onto` (an `axle_serial`), only if the axle was not set since: False then."""
        if axle_m is not None and not (math.isfinite(axle_m) and axle_m > 0.0):
            raise ValueError(f"the axle must be a length > 0 m, got {axle_m}")
        with self._lock:
            if only_onto is not None and only_onto != self._axle_serial:
                return False
            self._axle = None if axle_m is None else (float(axle_m), source)
            self._axle_serial += 1
            return True

    @property
    def axle_serial(self) -> int:
        """How many times the axle was set: what a fit started at applies onto."""
        return self._axle_serial

    # --- read by anyone ---------------------------------------------------------------------------

    def view(self, max_points: int = 2000) -> dict[str, Any]:
        with self._lock:
            samples = np.array(self._samples, dtype=float).reshape(-1, 4)
            feet = np.array(self._feet, dtype=float)
            anchor, manual, ca, freq = self._anchor, self._manual_speed, self._ca, self._freq_hz
            axle_set = self._axle
        measured = _recent_motion(samples, freq)
        feet_m = float(feet[-len(measured["window"]) :].mean()) if len(feet) else NOMINAL_AXLE_M
        feet_m = feet_m if feet_m > 1e-3 else NOMINAL_AXLE_M
        axle, axle_source = (feet_m, "feet") if axle_set is None else axle_set
        speed = manual if manual is not None else measured["forward_m_s"]
        predicted = np.zeros((0, 4))
        if anchor is not None and len(samples):
            span = samples[-1, 0] - anchor.t_s + HORIZON_S
            t_rel = np.linspace(0.0, span, 200)
            predicted = predict_path(anchor.pose, speed, ca, axle, t_rel)
            predicted[:, 0] += anchor.t_s
        stride = max(1, math.ceil(len(samples) / max_points))
        actual = samples[::-1][::stride][::-1]  # thin out, always keeping the newest sample
        radius = turn_radius_m(ca, axle)
        return {
            "actual": actual.round(5).tolist(),
            "predicted": predicted.round(5).tolist(),
            "anchor": None
            if anchor is None
            else {
                "t_s": anchor.t_s,
                "x_m": anchor.pose.x_m,
                "y_m": anchor.pose.y_m,
                "yaw_rad": anchor.pose.yaw_rad,
            },
            "speed_m_s": speed,
            "speed_source": "manual" if manual is not None else "measured",
            "axle_m": axle,
            "axle_source": axle_source,
            "feet_m": feet_m,
            "ca": ca,
            "turn_radius_m": None if math.isinf(radius) else radius,
            "predicted_turn_deg_s": math.degrees(float(turn_rate_rad_s(ca, speed, axle))) + 0.0,
            "actual_turn_deg_s": math.degrees(measured["turn_rad_s"]),
            "actual_forward_m_s": measured["forward_m_s"],
            "actual_lateral_m_s": measured["lateral_m_s"],
        }


def _recent_motion(samples: np.ndarray, freq_hz: float) -> dict[str, Any]:
    """Mean body-frame velocities over the last MEASURE_CYCLES whole cycles (or what there is)."""
    if len(samples) < 2:
        return {"forward_m_s": 0.0, "lateral_m_s": 0.0, "turn_rad_s": 0.0, "window": samples}
    t_end = samples[-1, 0]
    cycles = min(MEASURE_CYCLES, math.floor((t_end - samples[0, 0]) * freq_hz + 1e-9))
    start = t_end - cycles / freq_hz if cycles >= 1 else samples[0, 0]
    window = samples[samples[:, 0] >= start - 1e-9]
    if len(window) < 2:
        window = samples[-2:]
    forward, lateral, turn = mean_body_velocity(
        window[:, 0], window[:, 1], window[:, 2], window[:, 3], freq_hz
    )
    return {"forward_m_s": forward, "lateral_m_s": lateral, "turn_rad_s": turn, "window": window}
