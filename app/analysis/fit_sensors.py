"""What a fit compares (docs/FIT.md): the IMU's errors fitted in closed form to a replay read
without them (its mount tilt from the accelerometer by linearised least squares, the gyro's bias
as the mean difference), and the standardised residuals of the replay against a recording, with
a loss robust to outliers (soft L1)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from app.analysis.identify_replay import Traces
from app.sim.sensors import ACCEL_M_S2_PER_COUNT, GYRO_RAD_S_PER_COUNT, mount_rotation

#: the residual each channel's unit stands for: what a good model still misses of a walking
#: robot (contacts, the servos' small departures), not the sensors' noise, which is far below
SCALES = {"gyro": 0.05, "accel": 0.3, "fsr": 0.5, "present": 0.01}
#: the noise a recording's channel carries at best (rms): the default gyro noise's upper bound
#: (0.1 °/s) with one count's quantisation, one accelerometer count, the FSR's 10-bit ADC at
#: ~20 N full scale (docs/SENSORS.md)
NOISE = {
    "gyro": math.hypot(math.radians(0.1), GYRO_RAD_S_PER_COUNT / math.sqrt(12)),
    "accel": ACCEL_M_S2_PER_COUNT / math.sqrt(12),
    "fsr": 20.0 / 1024 / math.sqrt(12),
    "present": 2 * math.pi / 4096 / math.sqrt(12),
}


@dataclass(frozen=True)
class ImuErrors:
    """The IMU's errors as the variation fields name them (docs/DESIGN.md §8)."""

    imu_tilt_bias_deg: float = 0.0
    imu_tilt_direction_deg: float = 0.0
    gyro_bias_deg_s: float = 0.0

    def to_imu(self) -> NDArray[np.float64]:
        return mount_rotation(self.imu_tilt_bias_deg, self.imu_tilt_direction_deg).T


def _tilt_step(seen: NDArray[np.float64], recorded: NDArray[np.float64]) -> NDArray[np.float64]:
    """The small rotation w = θ·axis (horizontal axis) that best turns `seen` (n, 3) into
    `recorded`: recorded ≈ seen + seen × w, linear in (w_x, w_y)."""
    vx, vy, vz = seen[:, 0], seen[:, 1], seen[:, 2]
    zero = np.zeros_like(vx)
    a = np.concatenate([np.stack([zero, -vz], 1), np.stack([vz, zero], 1), np.stack([-vy, vx], 1)])
    b = (recorded - seen).T.reshape(-1)
    w, *_ = np.linalg.lstsq(a, b, rcond=None)
    return np.array([w[0], w[1], 0.0])


def fit_imu(replay: Traces, recorded: Traces, *, bias: bool = True, tilt: bool = True) -> ImuErrors:
    """The IMU errors that make the error-free `replay` read most like `recorded`: the mount's
    tilt from the accelerometer (two Gauss-Newton steps), then the gyro's one bias on every axis
    as the mean remaining difference; a field not asked for stays 0."""
    errors = ImuErrors()
    if tilt:
        for _ in range(2):
            turned = replay.accel @ errors.to_imu().T
            w = _tilt_step(turned, recorded.accel)
            total = _as_vector(errors) + w
            theta = float(np.hypot(total[0], total[1]))
            direction = math.degrees(math.atan2(-total[0], total[1])) % 360.0 if theta else 0.0
            errors = ImuErrors(math.degrees(theta), direction)
    if bias:
        turned = replay.gyro @ errors.to_imu().T
        b = float(np.mean(recorded.gyro - turned))
        errors = ImuErrors(errors.imu_tilt_bias_deg, errors.imu_tilt_direction_deg, math.degrees(b))
    return errors


def _as_vector(errors: ImuErrors) -> NDArray[np.float64]:
    t, d = math.radians(errors.imu_tilt_bias_deg), math.radians(errors.imu_tilt_direction_deg)
    return np.array([-math.sin(d) * t, math.cos(d) * t, 0.0])


def as_read(replay: Traces, errors: ImuErrors) -> dict[str, NDArray[np.float64]]:
    """The replay's channels as the IMU with `errors` would read them."""
    to_imu = errors.to_imu()
    return {
        "gyro": replay.gyro @ to_imu.T + math.radians(errors.gyro_bias_deg_s),
        "accel": replay.accel @ to_imu.T,
        "fsr": replay.fsr,
        "present": replay.joints,
    }


def channels(recorded: Traces, present: bool) -> tuple[str, ...]:
    return ("gyro", "accel", "fsr") + (("present",) if present else ())


@dataclass(frozen=True)
class Cycles:
    """Each segment's frames folded onto the gait's cycle: the mean of each of `bins` phase bins
    after the segment's first `skip_frames` (its ramp). A walk's single steps part as soon as
    two robots differ a little (contacts); the mean step does not, so a fit compares these.
    The clock is open loop: frame i lies at phase (i + 1)·f·20 ms from the start, cycles."""

    lengths: tuple[int, ...]
    freq_hz: float
    bins: int = 24
    skip_frames: int = 50

    def fold(
        self, x: NDArray[np.float64], positions: NDArray[np.int64] | None = None
    ) -> NDArray[np.float64]:
        """(n, k) rows at the routine's frames `positions` (default 0..n-1) -> (segments ×
        bins, k) bin means (a bin no row fell in: 0)."""
        at = np.arange(len(x)) if positions is None else positions
        cycle = np.mod((at + 1) * self.freq_hz * 0.02, 1.0)
        which = np.minimum((cycle * self.bins).astype(int), self.bins - 1)
        out = []
        start = 0
        for length in self.lengths:
            first = start + min(self.skip_frames, length // 2)
            rows = (at >= first) & (at < start + length)
            sums = np.zeros((self.bins, x.shape[1]))
            np.add.at(sums, which[rows], x[rows])
            counts = np.bincount(which[rows], minlength=self.bins)[:, None]
            out.append(sums / np.maximum(counts, 1))
            start += length
        return np.concatenate(out)


#: a folded channel's unit is its SCALES times this: a mean over cycles misses less
FOLDED = 0.4


def residuals(
    replay: Traces,
    errors: ImuErrors,
    recorded: Traces,
    present: bool = False,
    cycles: Cycles | None = None,
) -> dict[str, NDArray[np.float64]]:
    """Each channel's residual (recorded − replayed), in units of its `SCALES`: per frame (n, k),
    or folded onto the gait's cycle (`cycles`: segments × bins, k, units SCALES × FOLDED). The
    replay's rows are the recording's frames (`Traces.at`)."""
    read = as_read(replay, errors)
    mine = {
        "gyro": recorded.gyro,
        "accel": recorded.accel,
        "fsr": recorded.fsr,
        "present": recorded.joints,
    }
    if cycles is None:
        return {c: (mine[c] - read[c]) / SCALES[c] for c in channels(recorded, present)}
    at = recorded.positions
    return {
        c: (cycles.fold(mine[c], at) - cycles.fold(read[c], at)) / (SCALES[c] * FOLDED)
        for c in channels(recorded, present)
    }


def soft_l1(parts: dict[str, NDArray[np.float64]]) -> float:
    """The mean over channels of each channel's mean soft-L1 loss 2(√(1 + e²) − 1): a channel
    weighs alike whatever its width, a stretch where the robots parted weighs as a line."""
    return float(np.mean([np.mean(2.0 * (np.sqrt(1.0 + e * e) - 1.0)) for e in parts.values()]))


def rms(parts: dict[str, NDArray[np.float64]]) -> dict[str, float]:
    """Each channel's rms residual in its own unit (rad/s, m/s², N, rad)."""
    return {c: float(np.sqrt(np.mean(e * e))) * SCALES[c] for c, e in parts.items()}
