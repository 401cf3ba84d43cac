"""Which single error of the sensors breaks a closed-loop gait (docs/DESIGN.md §15): each alone,
every case of `artro bench robust`, judged by its rule, as `robust_factors.py` does for the
model's departures.

    python bench/sensor_factors.py [--presets robust] [--duration 20] [--warmup 4]
        [--robot artro] [--json PATH]

Two errors a robot has that the variation ranges leave out are tried too: the IMU read ~17 ms
late (the firmware samples it in slot 3, 12.5 ms before the frame ends, through its 4.8 ms
low-pass; the nominal model reads it at the frame's end) and an accelerometer never calibrated
(its zero-g offset, ±50 mg: ±2.9°; the firmware calibrates the gyro only). Writes
bench/results/sensor_factors.json, or --json PATH (bench/results.py).
"""

from __future__ import annotations

from robust_factors import measure

from app.worlds.sampling import VariationRanges
from app.worlds.variations import Variation

ROBOT_IMU_DELAY_MS = 17.0
UNCALIBRATED_TILT_DEG = 2.9


def sensor_worlds(ranges: VariationRanges | None = None) -> list[Variation]:
    """Every sensor error alone: the IMU's delay (the robot's, the range's end), the gyro's bias
    (both ends) and noise, the IMU's tilt (the range's end ahead, left, behind and right; an
    uncalibrated part's ahead and behind), the forces' gain (both ends)."""
    ranges = ranges or VariationRanges()
    worlds = [Variation(imu_delay_ms=d) for d in (ROBOT_IMU_DELAY_MS, ranges.imu_delay_ms[1])]
    worlds += [Variation(gyro_bias_deg_s=b) for b in ranges.gyro_bias_deg_s]
    worlds.append(Variation(gyro_noise_deg_s=ranges.gyro_noise_deg_s[1]))
    worlds += [
        Variation(imu_tilt_bias_deg=ranges.imu_tilt_bias_deg[1], imu_tilt_direction_deg=d)
        for d in (0.0, 90.0, 180.0, 270.0)
    ]
    worlds += [
        Variation(imu_tilt_bias_deg=UNCALIBRATED_TILT_DEG, imu_tilt_direction_deg=d)
        for d in (0.0, 180.0)
    ]
    return worlds + [Variation(fsr_gain=g) for g in ranges.fsr_gain]


def main() -> None:
    measure("sensor_factors", sensor_worlds(), __doc__, "robust")


if __name__ == "__main__":
    main()
