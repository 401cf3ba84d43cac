"""The motion ramp and the pfs engine in the simulation: frame loop, batch run, `artro run`."""

import numpy as np
import pytest

from app.evaluation import BatchEvaluator, Job
from app.sim.frame_loop import FrameLoop
from app.sim.headless import run
from app.sim.metrics import MOTION_METRICS
from app.sim.planning import FRAME_S
from gait import GaitParams, Motion, joint_angles, ramp_steps

STEP = Motion(a_p=0.07, ca=0.1)
COMPARED = ("fell", *MOTION_METRICS, "sim_s")


def test_a_step_from_standing_to_a_curve_in_one_frame_walks_on():
    """The motion jumps from 0 to a_p = 0.07 with CA = 0.1 between two frames; the gait gets it
    through the ramp (70 frames for a_p at 0.05 rad/s, 50 for CA) and the robot walks on."""
    params = GaitParams()
    sim = FrameLoop(params=params, motion=Motion())
    for _ in range(100):  # 2 s on the spot
        sim.step_frame()
    x0, y0, _yaw = sim.trunk_pose()
    sim.set_gait(motion=STEP)
    records = [sim.step_frame() for _ in range(400)]  # 8 s
    assert not sim.fell
    applied = [r.motion for r in records]
    assert applied[0] == Motion(a_p=0.001, ca=0.002)
    n = ramp_steps(Motion(), STEP, params, FRAME_S)
    assert n == 70 and applied[n - 2] != STEP and applied[n - 1] == STEP == applied[-1]
    steps = np.diff([m.a_p for m in applied[:n]])
    assert np.all(steps > 0) and np.all(steps <= 0.05 * FRAME_S * (1 + 1e-6))
    x, y, _yaw = sim.trunk_pose()
    assert x - x0 > 0.03 and np.hypot(x - x0, y - y0) > 0.04  # walked on: > 0.5 cm/s


def test_a_new_target_mid_ramp_ramps_on_from_where_the_gait_is():
    sim = FrameLoop(motion=Motion())
    sim.set_gait(motion=Motion(a_p=0.1))
    for _ in range(10):
        sim.step_frame()
    assert sim.motion_now.a_p == pytest.approx(0.01)
    sim.set_gait(motion=Motion(a_p=-0.1))
    assert sim.step_frame().motion.a_p == pytest.approx(0.009)
    off = GaitParams.from_dict({"ramp": {"enabled": False}})
    sim.set_gait(params=off)
    assert sim.step_frame().motion == Motion(a_p=-0.1)


def test_batch_gives_the_frame_loops_metrics_for_a_ramped_start_and_for_pfs():
    """The batch evaluator plans the same ramp and the same pfs start-up as the frame loop."""
    pfs = GaitParams(engine="pfs")
    jobs = [
        Job(GaitParams(), STEP, start_motion=Motion()),
        Job(pfs, Motion(a_p=0.05, ca=-0.05)),
    ]
    batch = BatchEvaluator(threads=2).evaluate(jobs, duration_s=4.0, warmup_s=1.0)
    for job, metrics in zip(jobs, batch, strict=True):
        single = run(
            job.params, job.motion, duration_s=4.0, warmup_s=1.0, start_motion=job.start_motion
        ).metrics
        assert {k: metrics[k] for k in COMPARED} == {k: single[k] for k in COMPARED}


def test_the_pfs_engine_starts_in_its_mean_pose_and_grows_its_oscillation():
    params = GaitParams(engine="pfs")
    sim = FrameLoop(params=params, motion=Motion(a_p=0.05))
    standing = joint_angles(params, Motion(a_p=0.05), 0.0, startup=0.0)
    np.testing.assert_allclose(sim.data.ctrl[sim.robot.actuator_ids], standing, atol=1e-12)
    early = [sim.step_frame().setpoint for _ in range(25)]  # 0.5 s: gain <= 0.25
    late = [sim.step_frame().setpoint for _ in range(150)][-50:]  # 3 s on: full amplitude
    knee = 3
    assert np.ptp([q[knee] for q in early]) < 0.5 * np.ptp([q[knee] for q in late])
    assert not sim.fell


@pytest.mark.parametrize("ramp", [True, False])
def test_the_ramp_keeps_a_sudden_sideways_step_from_throwing_the_robot(ramp):
    """From stepping on the spot to a_r = 0.15 in one frame: thrown over within a second and a
    half without the ramp; with it (3 s to get there) the robot walks on."""
    params = GaitParams.from_dict({"ramp": {"enabled": ramp}})
    sim = FrameLoop(params=params, motion=Motion())
    for _ in range(50):
        sim.step_frame()
    sim.set_gait(motion=Motion(a_r=0.15))
    for _ in range(400 if ramp else 75):
        sim.step_frame()
        if sim.fell:
            break
    assert sim.fell is not ramp


def test_switching_to_pfs_mid_walk_starts_its_start_up_phase():
    """The first pfs frame after a switch from behnke is the pfs mean pose (gain 0), not the full
    oscillation; it then grows as after a reset."""
    sim = FrameLoop(motion=Motion(a_p=0.05))
    for _ in range(60):
        sim.step_frame()
    pfs = GaitParams(engine="pfs")
    sim.set_gait(params=pfs)
    first = sim.step_frame()
    mean_pose = joint_angles(pfs, Motion(a_p=0.05), first.phase, startup=0.0)
    np.testing.assert_allclose(first.setpoint, mean_pose, atol=np.radians(0.1))
    assert sim.engine_start_frame == 60
    for _ in range(40):
        record = sim.step_frame()
    half = joint_angles(pfs, Motion(a_p=0.05), record.phase, startup=40 * FRAME_S / 2.0)
    np.testing.assert_allclose(record.setpoint, half, atol=np.radians(0.1))
