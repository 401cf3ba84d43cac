"""Runs the executor tests share: `tuned` walking four ways on floors of rising friction, so
every run differs and a result out of order shows."""

from app.core.evaluation import Job
from app.core.variations import parse_variation
from app.params.presets import builtin_presets
from gait import Motion

TUNED = builtin_presets()["tuned"].gait
MOTIONS = (Motion(a_p=0.07), Motion(a_r=0.1), Motion(a_y=0.2), Motion(a_p=0.07, ca=0.1))


def varied_jobs(n: int) -> list[Job]:
    return [
        Job(TUNED, MOTIONS[i % 4], variation=parse_variation(f"friction={0.5 + 0.04 * i:.2f}"))
        for i in range(n)
    ]
