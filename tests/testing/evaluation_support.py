"""Runs the executor tests share -- `tuned` walking four ways on floors of rising friction, every
other run with the feedback laws on, so every run differs and a result out of order shows -- and
their trace comparison."""

import dataclasses

import numpy as np

from app.evaluation import Job
from app.params.presets import builtin_presets
from app.sim.metrics import Trace
from app.worlds.variations import parse_variation
from gait import Motion
from gait.feedback_params import DampingParams, TiltParams, YawRateParams

TUNED = builtin_presets()["tuned"].gait
MOTIONS = (Motion(a_p=0.07), Motion(a_r=0.1), Motion(a_y=0.2), Motion(a_p=0.07, ca=0.1))


#: every other run closes the loop: the laws read noisy, biased, delayed sensors (seeded by the
#: variation), so an executor that loses a law's state or a noise draw shows
CLOSED = dataclasses.replace(
    TUNED,
    tilt=TiltParams(enabled=True, pitch_offset_rad=-0.08),
    yaw_rate=YawRateParams(enabled=True),
    damping=DampingParams(enabled=True),
)


def varied_jobs(n: int) -> list[Job]:
    jobs = []
    for i in range(n):
        world = f"friction={0.5 + 0.04 * i:.2f}"
        if i % 2:
            world += f",gyro_noise_deg_s=0.1,gyro_bias_deg_s=0.3,imu_delay_ms={4 + 2 * i}"
        gait = CLOSED if i % 2 else TUNED
        jobs.append(Job(gait, MOTIONS[i % 4], variation=parse_variation(world)))
    return jobs


TRACE_FIELDS = ("t_s", "x_m", "y_m", "yaw_rad", "gyro_rad_s", "feet_distance_m")


def assert_same_traces(got: list[Trace], local: list[Trace]) -> None:
    """Every field of every trace equals the local threads' to the bit, in job order."""
    assert len(got) == len(local)
    for a, b in zip(got, local, strict=True):
        for name in TRACE_FIELDS:
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
