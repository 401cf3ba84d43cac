"""Variations in the runs (docs/DESIGN.md §8): a varied run in the batch evaluator equals the
same run frame by frame to the bit, runs that differ only in model values share one rollout,
and a variation changes the walk the way it claims."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.evaluation import BatchEvaluator, Job
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.sim.headless import run
from app.worlds.variations import NOMINAL, parse_variation
from gait import Motion

ROOT = Path(__file__).resolve().parents[2]
TUNED = builtin_presets()["tuned"].gait
FORWARD = Motion(a_p=0.07)
ROBOT = RobotModel.load()


def test_a_varied_run_is_the_same_in_the_batch_and_frame_by_frame():
    variation = parse_variation(
        "friction=0.5,kp_scale=0.9,latency_ms=20,backlash_deg=0.6,cal.l_knee=1"
    )
    live = run(TUNED, FORWARD, duration_s=6.0, warmup_s=2.0, robot=ROBOT, variation=variation)
    (batch,) = BatchEvaluator(ROBOT, threads=1).evaluate(
        [Job(TUNED, FORWARD, variation=variation)], duration_s=6.0, warmup_s=2.0
    )
    for key in ("fell", "forward_cm_s", "lateral_cm_s", "turn_deg_s", "gyro_rms", "sim_s"):
        assert batch[key] == live.metrics[key], key


def test_a_weaker_servo_is_at_its_own_limit_the_same_in_the_batch_and_frame_by_frame():
    """`at_limit_share` counts a frame when a servo ends it at 99 % of the run's own force
    limit (torque_scale 0.85 of the described one), alike in `artro run` and the lanes."""
    weak = parse_variation("torque_scale=0.85")
    live = run(TUNED, FORWARD, duration_s=4.0, warmup_s=1.0, robot=ROBOT, variation=weak)
    batch, strong = BatchEvaluator(ROBOT, threads=1).evaluate(
        [Job(TUNED, FORWARD, variation=weak), Job(TUNED, FORWARD)], duration_s=4.0, warmup_s=1.0
    )
    assert batch["at_limit_share"] == live.metrics["at_limit_share"]
    assert batch["peak_torque_nm"] == live.metrics["peak_torque_nm"]
    stall = ROBOT.model.actuator_forcerange[ROBOT.actuator_ids, 1]
    assert max(batch["peak_torque_nm"]) <= 0.85 * stall.max() + 1e-9  # never past its own limit
    assert sum(batch["at_limit_share"]) > sum(strong["at_limit_share"]) > 0.0


def test_runs_of_other_variations_in_one_chunk_keep_their_own_results():
    jobs = [
        Job(TUNED, FORWARD),
        Job(TUNED, FORWARD, variation=parse_variation("friction=0.15")),
        Job(TUNED, FORWARD, variation=parse_variation("torque_scale=0.8")),
    ]
    together = BatchEvaluator(ROBOT, threads=2).evaluate(jobs, duration_s=12.0, warmup_s=4.0)
    alone = [
        BatchEvaluator(ROBOT, threads=1).evaluate([j], duration_s=12.0, warmup_s=4.0)[0]
        for j in jobs
    ]
    for a, b in zip(together, alone, strict=True):
        assert a["forward_cm_s"] == b["forward_cm_s"] and a["fell"] == b["fell"]
    nominal, slippery, _weak = together
    assert nominal["forward_cm_s"] > 2.0
    # on a floor of friction 0.15 the same gait slips: slower (1.66 against 2.98 cm/s), or falls
    assert slippery["fell"] or slippery["forward_cm_s"] < 0.8 * nominal["forward_cm_s"]


def test_the_nominal_variation_changes_nothing_to_the_bit():
    plain = BatchEvaluator(ROBOT, threads=1).evaluate([Job(TUNED, FORWARD)], duration_s=4.0)
    named = BatchEvaluator(ROBOT, threads=1).evaluate(
        [Job(TUNED, FORWARD, variation=NOMINAL)], duration_s=4.0
    )
    assert plain[0]["forward_cm_s"] == named[0]["forward_cm_s"]


def test_a_latency_delays_the_servos_by_that_many_milliseconds():
    """The knee's actuator force follows the set-point 30 ms later on a 30 ms variation."""
    from app.sim.frame_loop import FrameLoop

    def knee_ctrl(variation_text: str) -> np.ndarray:
        sim = FrameLoop(ROBOT, TUNED, FORWARD, variation=parse_variation(variation_text))
        knee = int(ROBOT.actuator_ids[3])
        out = []
        for _ in range(40):
            sim.step_frame()
            out.append(sim.data.ctrl[knee])
        return np.array(out)

    nominal, late = knee_ctrl(""), knee_ctrl("latency_ms=40")
    # frame-end samples: 40 ms late is exactly two 20 ms frames
    np.testing.assert_array_equal(late[2:], nominal[:-2])


def test_artro_run_vary_names_the_variation():
    out = subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--motion", "0,0.07,0", "--duration", "3",
         "--warmup", "1", "--vary", "friction=0.4,latency_ms=40", "--json"],
        capture_output=True, text=True, cwd=ROOT,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    metrics = json.loads(out.stdout)
    assert metrics["variation"] == "friction=0.4,latency_ms=40" and metrics["robot"] == "artro"
    bad = subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--vary", "friction=1.5"],
        capture_output=True, text=True, cwd=ROOT,
    )  # fmt: skip
    assert bad.returncode == 2 and "friction must be ≥ 0.01 and ≤ 1" in bad.stderr


@pytest.mark.parametrize("text", ["", "tilt_deg=2,tilt_direction_deg=90"])
def test_a_varied_robot_stands_in_the_frame_loop(text):
    from app.sim.frame_loop import FrameLoop

    sim = FrameLoop(ROBOT, TUNED, Motion(), variation=parse_variation(text))
    for _ in range(50):
        sim.step_frame()
    assert not sim.fell
