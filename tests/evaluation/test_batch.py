"""The batch evaluator gives exactly the numbers `artro run` gives."""

import threading

import numpy as np
import pytest
from mujoco import MjData, rollout

from app.evaluation import BatchEvaluator, Cancelled, Job, same_results
from app.evaluation._frames import start_at_rest
from app.evaluation._open_loop import control_sequence
from app.sim.frame_loop import FrameLoop
from app.sim.headless import run
from app.sim.metrics import MOTION_METRICS
from app.sim.planning import plan_frames
from gait import GaitParams, Motion

EVALUATOR = BatchEvaluator(threads=2)
COMPARED = ("fell", *MOTION_METRICS, "sim_s")


def test_batch_metrics_equal_artro_run_for_the_same_parameter_set():
    tuned = GaitParams.from_dict({"short": {"amp_base": 0.5}, "clock": {"freq_hz": 1.2}})
    jobs = [Job(GaitParams(), Motion(a_p=0.07, ca=0.05)), Job(tuned, Motion(a_r=-0.1, a_y=0.1))]
    batch = EVALUATOR.evaluate(jobs, duration_s=8.0, warmup_s=2.0)
    for job, metrics in zip(jobs, batch, strict=True):
        single = run(job.params, job.motion, duration_s=8.0, warmup_s=2.0).metrics
        assert {k: metrics[k] for k in COMPARED} == {k: single[k] for k in COMPARED}


def test_a_fall_ends_the_measurement_as_in_artro_run():
    falls = Job(
        GaitParams.from_dict({"shift": {"amp_base": 0.4, "amp_lateral": 2.0}}),
        Motion(a_r=0.3, a_p=0.3, a_y=0.6),
    )
    (metrics,) = EVALUATOR.evaluate([falls], duration_s=10.0, warmup_s=1.0)
    single = run(falls.params, falls.motion, duration_s=10.0, warmup_s=1.0).metrics
    assert metrics["fell"] and single["fell"]
    assert metrics["fall_time_s"] == single["fall_time_s"] < 10.0


def test_a_run_stops_rolling_out_after_the_call_it_fell_in_and_measures_the_same(monkeypatch):
    """Runs roll out SEGMENT_FRAMES frames per call, each call from the last one's state and
    warm start; a run that falls stops after its call. Metrics and traces equal those of one
    call over the whole run, to the bit."""
    from app.evaluation import _lanes as batch
    from tests.testing.evaluation_support import assert_same_traces

    falls = Job(
        GaitParams.from_dict({"shift": {"amp_base": 0.4, "amp_lateral": 2.0}}),
        Motion(a_r=0.3, a_p=0.3, a_y=0.6),
    )
    jobs = [falls, Job(GaitParams(), Motion(a_p=0.07, ca=0.05))]
    segmented, traces = BatchEvaluator(threads=2), []
    got = segmented.evaluate(jobs, duration_s=6.0, warmup_s=1.0, traces=traces)
    assert got[0]["fell"] and not got[1]["fell"]
    fall_frame = round(got[0]["fall_time_s"] / 0.02)
    called = -(-fall_frame // batch.SEGMENT_FRAMES) * batch.SEGMENT_FRAMES
    assert called < 300 and segmented.frames_rolled == called + 300

    monkeypatch.setattr(batch, "SEGMENT_FRAMES", 10**6)  # one call per run, to its end
    whole, whole_traces = BatchEvaluator(threads=2), []
    expected = whole.evaluate(jobs, duration_s=6.0, warmup_s=1.0, traces=whole_traces)
    assert whole.frames_rolled == 600
    assert same_results(got, expected)
    assert_same_traces(traces, whole_traces)


def test_the_control_switches_at_each_falling_edge():
    robot, motion = EVALUATOR.robot, Motion(a_p=0.1, a_y=0.2)
    sim = FrameLoop(robot, motion=motion)
    start = start_at_rest(robot, MjData(robot.model), sim.params, motion)
    frames, steps = 5, sim.steps_per_frame
    plan = plan_frames(
        sim.params, sim.motion, sim.hardware, start.phase, frames, steps, sim.timestep_s
    )
    ctrl = control_sequence(robot, start, plan).reshape(frames, steps, -1)
    act = sim.robot.actuator_ids
    assert start.phase == sim.phase and start.standing_height_m == sim.standing_height_m
    assert np.array_equal(start.ctrl, sim.data.ctrl)  # the frame loop's start, to the bit
    previous = start.ctrl[act]
    for k in range(frames):
        for servo, actuator in enumerate(act):
            switch = plan.substep[k, servo]  # the first step on or after the pulse's falling edge
            np.testing.assert_array_equal(ctrl[k, :switch, actuator], previous[servo])
            np.testing.assert_array_equal(ctrl[k, switch:, actuator], plan.setpoint[k, servo])
        previous = plan.setpoint[k]


def test_progress_is_reported():
    calls = []
    EVALUATOR.evaluate(
        [Job(GaitParams(), Motion())] * 3,
        duration_s=0.2,
        warmup_s=0.0,
        progress=lambda done, total: calls.append((done, total)),
    )
    assert calls[-1] == (3, 3)


@pytest.mark.parametrize("duration", [0.02, 0.5])
def test_short_runs(duration):
    (metrics,) = EVALUATOR.evaluate([Job(GaitParams(), Motion())], duration_s=duration, warmup_s=0)
    assert metrics["sim_s"] == pytest.approx(duration) and not metrics["fell"]


def test_a_blown_up_frame_ends_the_run_unsampled():
    # a real one-second rollout, then a NaN in the state after frame 11's last step, as a
    # blow-up leaves it: frames 1-10 are sampled, the run counts 11 frames, fell and blew up
    job = Job(GaitParams(), Motion(a_p=0.07))
    starts, controls, initial, _models = EVALUATOR._plan([job], 50)
    states, sensors = rollout.rollout(EVALUATOR.model, MjData(EVALUATOR.model), initial, controls)
    steps = EVALUATOR.steps_per_frame
    original = states[0, 11 * steps - 1, 3]  # time, then qpos: the trunk's height
    states[0, 11 * steps - 1, 3] = np.nan
    metrics, trace = EVALUATOR._measure(states[0], sensors[0], starts[0], job, 50, 0.1)
    assert metrics["fell"] and metrics["blew_up"] and "fall_time_s" in metrics
    assert metrics["sim_s"] == pytest.approx(11 * 0.02) and len(trace.t_s) == 10
    states[0, 11 * steps - 1, 3] = original
    clean, whole = EVALUATOR._measure(states[0], sensors[0], starts[0], job, 50, 0.1)
    assert not clean["fell"] and len(whole.t_s) == 50
    assert whole.x_m[:10] == trace.x_m and whole.feet_distance_m[:10] == trace.feet_distance_m


def test_reused_output_arrays_change_no_result():
    """Each lane rolls out into arrays it keeps from run to run: a call of many runs, calls of
    other lengths in between, and one run per evaluator all give the same metrics and traces."""
    from app.evaluation import same_results
    from app.worlds.sampling import VariationRanges, sample

    worlds = sample(VariationRanges(), 19, seed=5)
    jobs = [Job(GaitParams(), Motion(a_p=0.07, ca=0.01 * (i % 5)), variation=w)
            for i, w in enumerate(worlds)]  # fmt: skip
    evaluator = BatchEvaluator(threads=2)
    traces: list = []
    together = evaluator.evaluate(jobs, duration_s=1.5, warmup_s=0.5, traces=traces)
    evaluator.evaluate(jobs[:3], duration_s=0.7, warmup_s=0.2)  # other lengths in between
    alone_traces: list = []
    alone = [
        BatchEvaluator(threads=1).evaluate([j], duration_s=1.5, warmup_s=0.5, traces=alone_traces)[
            0
        ]
        for j in jobs[::6]
    ]
    again = evaluator.evaluate(jobs, duration_s=1.5, warmup_s=0.5)
    assert same_results(together, again) and same_results(together[::6], alone)
    for a, b in zip(traces[::6], alone_traces, strict=True):
        assert np.array_equal(a.x_m, b.x_m) and np.array_equal(a.gyro_rad_s, b.gyro_rad_s)
    assert len({m["forward_cm_s"] for m in together}) > 10


def test_a_cancel_stops_before_the_next_run_and_keeps_what_finished_in_order():
    evaluator = BatchEvaluator(threads=2)
    jobs = [Job(GaitParams(), Motion(a_p=0.01 * i)) for i in range(8)]
    cancel, kept = threading.Event(), []

    def on_result(index, metrics):
        kept.append((index, metrics))
        cancel.set()  # after the first result

    with pytest.raises(Cancelled, match="cancelled after 1 of 8 runs"):
        evaluator.evaluate(jobs, duration_s=0.4, warmup_s=0.1, cancel=cancel, on_result=on_result)
    assert [index for index, _m in kept] == [0]
    # the lanes gave their MjData and arrays back: the same evaluator runs on, to the same bits
    again = evaluator.evaluate(jobs[:3], duration_s=0.4, warmup_s=0.1)
    assert again[0]["forward_cm_s"] == kept[0][1]["forward_cm_s"]


def test_arrays_a_lane_would_roll_out_unchecked_are_checked_first():
    """A lane calls `rollout` unchecked, so the run's arrays are checked once before: a wrong
    shape, dtype or order is a ValueError naming the array, and nothing is rolled out."""
    from app.evaluation._lane_kit import LaneKit, check_rollout_arrays

    robot = EVALUATOR.robot
    kit = LaneKit(robot.model)
    robot_, start, control = EVALUATOR._plan_run(Job(GaitParams(), Motion()), 3, kit.data)
    state_out, sensor_out = (np.zeros_like(a) for a in kit.output(control.shape[0]))
    check_rollout_arrays(robot.model, start, control, state_out, sensor_out)  # passes
    bad = {
        "control": (control[:, :-1], state_out),
        "control ": (np.asfortranarray(control), state_out),
        "state output": (control, state_out[:, :-1]),
        "state output ": (control, state_out.astype(np.float32)),
    }
    for name, (ctrl, states) in bad.items():
        before = states.copy()
        with pytest.raises(ValueError, match=f"^{name.strip()} must be a C-ordered float64"):
            EVALUATOR._roll_out(kit.rollout, robot_, kit.data, start, ctrl, states, sensor_out)
        assert np.array_equal(states, before)
