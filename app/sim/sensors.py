"""The sensors as the robot has them (docs/DESIGN.md §8, §15): an MPU-6050 class IMU on the trunk
(gyro ±250 °/s, accelerometer ±2 g, quantised as the part quantises) and four force sensors under
each sole (MuJoCo's touch rule, `fsr_forces`), read once per 20 ms frame with a variation's errors:
the IMU's tilt, the gyro's bias and seeded noise, the IMU's delay, the force sensors' gain."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from app.robots.model import RobotModel
from app.sim.force_sensors import fsr_forces, fsr_forces_of
from app.worlds.servo_path import latency_steps
from app.worlds.variations import NOMINAL, Variation
from gait import feedback
from gait.attitude import G_M_S2 as GRAVITY_M_S2
from hardware.fsr import as_read

#: MPU-6050 at its most sensitive ranges: 131 counts per °/s (±250 °/s), 16384 per g (±2 g)
GYRO_RAD_S_PER_COUNT = math.radians(1.0 / 131.0)
ACCEL_M_S2_PER_COUNT = GRAVITY_M_S2 / 16384.0
COUNT_RANGE = (-32768, 32767)  # a signed 16-bit register


def rest_accelerometers(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Every accelerometer's row of `data.sensordata` as it reads at rest in the pose `data`
    holds (forward kinematics done): the specific force -gravity in its site's frame, the
    floor's tilt with it. A run's robot is placed a hair above the floor (`stand`), where MuJoCo
    reads free fall (~0 g); the rows before its first step are the IMU of a robot that stood
    there at rest, as a robot does before it walks (docs/DESIGN.md §15)."""
    up = -np.asarray(model.opt.gravity, dtype=float)
    for s in np.flatnonzero(model.sensor_type == mujoco.mjtSensor.mjSENS_ACCELEROMETER):
        adr, site = model.sensor_adr[s], model.sensor_objid[s]
        data.sensordata[adr : adr + 3] = data.site_xmat[site].reshape(3, 3).T @ up


@dataclass(frozen=True)
class SensorReading:
    """What the robot's sensors report for one frame: the IMU in its own axes (x forward, y
    left, z up when level) and each sole's four forces, left foot first, corners as
    `app.robots.model_parts.FSR_CORNERS` (front-left, front-right, back-left, back-right)."""

    gyro_rad_s: NDArray[np.float64]  # (3,)
    accel_m_s2: NDArray[np.float64]  # (3,) specific force: +g up at rest
    fsr_n: NDArray[np.float64]  # (2, 4)

    def centre_of_pressure_m(self, positions_m: NDArray[np.float64]) -> NDArray[np.float64]:
        """(2, 2) each sole's centre of pressure (x, y) from its sole centre, m, the force-
        weighted mean of the sensor positions `positions_m` (4, 2); NaN for a foot that carries
        nothing."""
        total = self.fsr_n.sum(axis=1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(total > 0.0, (self.fsr_n @ positions_m) / total, np.nan)

    def for_laws(self) -> feedback.Reading:
        """The reading as the laws take it (float32, as the firmware holds it)."""
        return feedback.Reading(
            gyro_rad_s=self.gyro_rad_s.astype(np.float32),
            accel_m_s2=self.accel_m_s2.astype(np.float32),
            fsr_n=self.fsr_n.astype(np.float32),
        )


def quantised(values: NDArray[np.float64], per_count: float) -> NDArray[np.float64]:
    """`values` as the part reports them: whole counts of `per_count`, within 16 bits."""
    low, high = COUNT_RANGE
    counts = np.minimum(np.maximum(np.round(np.asarray(values) / per_count), low), high)
    return counts * per_count


def mount_rotation(tilt_deg: float, direction_deg: float) -> NDArray[np.float64]:
    """The IMU's axes in the trunk's, tilted by tilt_deg toward direction_deg (counter-clockwise
    from the trunk's x axis): the IMU then reads as if the trunk leant that way (3, 3)."""
    t, d = math.radians(tilt_deg), math.radians(direction_deg)
    axis = np.array([-math.sin(d), math.cos(d), 0.0])  # direction 0: about y, a forward lean
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(t) * k + (1.0 - math.cos(t)) * (k @ k)


class Sensors:
    """One run's sensors on `robot` with `variation`'s errors. The gyro's noise comes from a
    generator seeded by the variation (`Variation.noise_seed`): a run read anew from its start
    reads the same bits, in any process."""

    def __init__(self, robot: RobotModel, variation: Variation = NOMINAL) -> None:
        v = variation
        self.timestep_s = float(robot.model.opt.timestep)
        self.delay_steps = latency_steps(v.imu_delay_ms, self.timestep_s)  # half up, as the servos
        self._to_imu = mount_rotation(v.imu_tilt_bias_deg, v.imu_tilt_direction_deg).T
        self._gyro_bias = math.radians(v.gyro_bias_deg_s)
        self._gyro_noise = math.radians(v.gyro_noise_deg_s)
        self._fsr_gain = v.fsr_gain
        self._rng = np.random.Generator(np.random.PCG64(v.noise_seed))
        self._gyro = slice(robot.gyro_adr, robot.gyro_adr + 3)
        self._accel = slice(robot.accel_adr, robot.accel_adr + 3)
        self._robot = robot

    @property
    def steps_needed(self) -> int:
        """How many of the last physics steps' sensor rows `read` needs."""
        return self.delay_steps + 1

    def read(
        self, rows: NDArray[np.float64], data: mujoco.MjData, *, forces: bool = True
    ) -> SensorReading:
        """The reading after the last physics step, from `rows` (k, nsensordata), MuJoCo's
        sensordata after each of the last k steps (k ≥ `steps_needed`), and `data` as that step
        left it: the IMU as it was `delay_steps` steps before, the force sensors now (zeros
        unless `forces`: a reader that needs none spares their cost). Draws the gyro's noise of
        one reading."""
        if len(rows) < self.steps_needed:
            raise ValueError(
                f"the IMU's delay needs the last {self.steps_needed} steps' sensor rows, got "
                f"{len(rows)}"
            )
        noise = self._rng.standard_normal(3) * self._gyro_noise
        gyro, accel = imu_readings(
            rows[-1 - self.delay_steps][None], self._to_imu[None], self._gyro_bias, noise[None],
            self._gyro, self._accel,
        )  # fmt: skip
        return SensorReading(
            gyro_rad_s=gyro[0],
            accel_m_s2=accel[0],
            fsr_n=as_read(self._fsr_gain * fsr_forces(self._robot, data))
            if forces
            else np.zeros((2, 4)),
        )


def imu_readings(
    imu_rows: NDArray[np.float64],
    to_imu: NDArray[np.float64],
    gyro_bias_rad_s: float | NDArray[np.float64],
    gyro_noise_rad_s: NDArray[np.float64],
    gyro: slice,
    accel: slice,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """K runs' IMU as the part reports it: from each run's sensordata row (K, nsensordata) at
    its delay, the gyro's and accelerometer's rows (`gyro`, `accel`) turned into the IMU's axes
    (`to_imu`, (K, 3, 3)), the gyro's bias (K,) and drawn noise (K, 3) added, quantised
    (`quantised`): the gyro (K, 3) and accelerometer (K, 3). Each run's numbers are those of
    that run alone (`Sensors.read` is the run of one)."""
    bias = np.asarray(gyro_bias_rad_s, dtype=np.float64).reshape(-1, 1)
    turned_gyro = (to_imu @ imu_rows[:, gyro, None])[:, :, 0]
    turned_accel = (to_imu @ imu_rows[:, accel, None])[:, :, 0]
    return (
        quantised(turned_gyro + bias + gyro_noise_rad_s, GYRO_RAD_S_PER_COUNT),
        quantised(turned_accel, ACCEL_M_S2_PER_COUNT),
    )


#: a bank draws each run's gyro noise for this many readings at once (a generator's normals
#: drawn in one call are those drawn one reading at a time, in order: the same bits)
NOISE_BLOCK = 64


class SensorBank:
    """K runs' sensors at once (a lane's group of closed-loop runs): `Sensors` of each run
    (robot, variation), read together from the sensor rows of their last physics steps. Each
    run reads the bits it reads alone, its noise from its own generator (`NOISE_BLOCK`
    readings drawn at a time)."""

    def __init__(self, robots: Sequence[RobotModel], variations: Sequence[Variation]) -> None:
        runs = [Sensors(robot, v) for robot, v in zip(robots, variations, strict=True)]
        self._runs = runs
        self.delay_steps = np.array([r.delay_steps for r in runs])
        self._to_imu = np.stack([r._to_imu for r in runs])
        self._gyro_bias = np.array([r._gyro_bias for r in runs])
        self._gyro_noise = np.array([r._gyro_noise for r in runs])
        self._gyro, self._accel = runs[0]._gyro, runs[0]._accel
        if any((r._gyro, r._accel) != (self._gyro, self._accel) for r in runs):
            raise ValueError("the runs' models must hold the IMU at the same sensordata rows")
        self._noise = np.empty((len(runs), 0, 3))  # each run's drawn, not yet read
        self._read = 0
        self._needed = int(self.delay_steps.max()) + 1

    def keep(self, runs: NDArray[np.bool_]) -> None:
        """Go on with the runs where `runs` (K,) is True."""
        self._runs = [r for r, kept in zip(self._runs, runs, strict=True) if kept]
        self.delay_steps, self._to_imu = self.delay_steps[runs], self._to_imu[runs]
        self._gyro_bias, self._gyro_noise = self._gyro_bias[runs], self._gyro_noise[runs]
        self._noise = self._noise[runs]
        self._needed = int(self.delay_steps.max(initial=0)) + 1

    @property
    def steps_needed(self) -> int:
        """How many of the last physics steps' sensor rows `read_imu` needs."""
        return self._needed

    @property
    def imu_columns(self) -> int:
        """How many leading columns of a sensordata row `read_imu` reads (the IMU's rows)."""
        return max(self._gyro.stop, self._accel.stop)

    def read_imu(
        self, rows: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Each run's gyro and accelerometer (K, 3) from `rows` (K, k, ≥ `imu_columns`), the
        sensor rows after each run's last k steps (k ≥ `steps_needed`), each at its own delay;
        draws each run's gyro noise of one reading."""
        if rows.shape[1] < self.steps_needed:
            raise ValueError(
                f"the IMUs' delays need the last {self.steps_needed} steps' sensor rows, got "
                f"{rows.shape[1]}"
            )
        if self._read == self._noise.shape[1]:
            draws = [r._rng.standard_normal((NOISE_BLOCK, 3)) for r in self._runs]
            self._noise, self._read = np.stack(draws), 0
        noise = self._noise[:, self._read]
        self._read += 1
        at = rows[np.arange(len(rows)), rows.shape[1] - 1 - self.delay_steps]
        return imu_readings(
            at, self._to_imu, self._gyro_bias, noise * self._gyro_noise[:, None], self._gyro,
            self._accel,
        )  # fmt: skip

    def fsr_all(self, datas: Sequence[mujoco.MjData]) -> NDArray[np.float64]:
        """Every run's force sensors (K, 2, 4), each from its `datas` entry as its last step
        left it, times its gain, in the ADC's steps (`hardware.fsr.as_read`)."""
        forces = fsr_forces_of([r._robot for r in self._runs], datas)
        return as_read(np.array([r._fsr_gain for r in self._runs])[:, None, None] * forces)
