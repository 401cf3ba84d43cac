"""Runs the executor tests share -- `tuned` walking four ways on floors of rising friction, so
every run differs and a result out of order shows -- and their trace comparison."""

import numpy as np

from app.evaluation import Job
from app.params.presets import builtin_presets
from app.sim.metrics import Trace
from app.worlds.variations import parse_variation
from gait import Motion

TUNED = builtin_presets()["tuned"].gait
MOTIONS = (Motion(a_p=0.07), Motion(a_r=0.1), Motion(a_y=0.2), Motion(a_p=0.07, ca=0.1))


def varied_jobs(n: int) -> list[Job]:
    return [
        Job(TUNED, MOTIONS[i % 4], variation=parse_variation(f"friction={0.5 + 0.04 * i:.2f}"))
        for i in range(n)
    ]


TRACE_FIELDS = ("t_s", "x_m", "y_m", "yaw_rad", "gyro_rad_s", "feet_distance_m")


def assert_same_traces(got: list[Trace], local: list[Trace]) -> None:
    """Every field of every trace equals the local threads' to the bit, in job order."""
    assert len(got) == len(local)
    for a, b in zip(got, local, strict=True):
        for name in TRACE_FIELDS:
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
