"""The MuJoCo Warp executor (docs/GPU.md) on Warp's CPU device: its metrics against the lanes'
on the same jobs within the stated tolerances, the same pass verdicts, job order, falls,
cancellation, the variations per world, and the errors for feedback laws and a model field
that cannot be batched (choosing the backend: test_warp_backend_choice.py).

Real MuJoCo Warp throughout (the gpu extra, which `scripts/setup.sh --test` installs): the
module's fixture compiles the kernels once (about a minute from an empty kernel cache on one
core, decision 0042) and runs one batch of six worlds."""

from __future__ import annotations

import copy
import dataclasses
import threading

import numpy as np
import pytest

from app.analysis.robust_cases import RobustCase, passes
from app.evaluation import (
    BatchEvaluator,
    Cancelled,
    ExecutorError,
    Job,
    same_results,
)
from app.evaluation._warp import AGREEMENT, WarpEvaluator
from app.evaluation._warp_model import _per_world_fields_put, per_world_fields
from app.params.presets import builtin_presets
from app.robots.model import RobotModel
from app.worlds.sampling import VariationRanges, sample
from app.worlds.variations import parse_variation, varied_robot
from gait import GaitParams, Motion, feedback
from tests.testing.evaluation_support import assert_same_traces

DURATION_S, WARMUP_S = 2.5, 1.0
FORWARD, TURN, CURVE = Motion(a_p=0.07), Motion(a_y=0.2), Motion(a_p=0.07, ca=0.1)
#: (job, the robust case it is judged as, index of its nominal run)
STUDY = (
    (Job(GaitParams(), FORWARD), RobustCase("forward", FORWARD, "forward", 1.0), 0),
    (Job(GaitParams(), TURN), RobustCase("turn", TURN, "turn", -1.0), 1),
    (Job(GaitParams(), CURVE), RobustCase("curve", CURVE, "curve", -1.0), 2),
    (Job(GaitParams(), Motion(a_r=0.1)), RobustCase("side", Motion(a_r=0.1), "lateral", -1.0), 3),
    (
        Job(GaitParams(), FORWARD, variation=parse_variation("friction=0.5,kp_scale=1.2")),
        RobustCase("forward", FORWARD, "forward", 1.0),
        0,
    ),
    (
        Job(
            GaitParams(),
            TURN,
            variation=parse_variation(
                "trunk_mass_scale=1.3,tilt_deg=2,latency_ms=10,push_n_s=0.3,push_time_s=1.2"
            ),
        ),
        RobustCase("turn", TURN, "turn", -1.0),
        1,
    ),
)
JOBS = [job for job, _case, _nominal in STUDY]


@pytest.fixture(scope="module")
def robot():
    return RobotModel.load()


@pytest.fixture(scope="module")
def warp(robot):
    """The executor on Warp's CPU device and what one call over STUDY gave, with its
    callbacks as they were called."""
    evaluator = WarpEvaluator(robot, device="cpu")
    calls: list[tuple] = []
    traces: list = []
    results = evaluator.evaluate(
        JOBS,
        duration_s=DURATION_S,
        warmup_s=WARMUP_S,
        traces=traces,
        progress=lambda done, total: calls.append(("progress", done, total)),
        on_result=lambda index, _metrics: calls.append(("result", index)),
    )
    return evaluator, results, traces, calls


@pytest.fixture(scope="module")
def lanes(robot):
    return BatchEvaluator(robot, threads=2).evaluate(JOBS, duration_s=DURATION_S, warmup_s=WARMUP_S)


@pytest.mark.slow
def test_metrics_agree_with_the_lanes_within_the_stated_tolerances(warp, lanes):
    """Float32 physics is not bit-equal to MuJoCo's: each metric within AGREEMENT, the motion
    metrics for the runs that walked (a fallen run's are measured through its fall)."""
    _evaluator, results, _traces, _calls = warp
    off = []
    for i, (got, want) in enumerate(zip(results, lanes, strict=True)):
        assert got["fell"] == want["fell"] and got["blew_up"] == want["blew_up"], i
        for key, tolerance in AGREEMENT.items():
            if got["fell"] and key not in ("sim_s", "fall_time_s"):
                continue
            a, b = got.get(key), want.get(key)
            assert (a is None) == (b is None), (i, key)
            if a is not None and np.max(np.abs(np.subtract(a, b))) > tolerance:
                off.append((i, key, a, b))
    assert not off, off


@pytest.mark.slow
def test_pass_verdicts_agree_with_the_lanes(warp, lanes):
    _evaluator, results, _traces, _calls = warp
    verdicts = [
        (passes(case, results[i], results[n]), passes(case, lanes[i], lanes[n]))
        for i, (_job, case, n) in enumerate(STUDY)
    ]
    assert [w for w, _ in verdicts] == [c for _, c in verdicts]
    assert {w for w, _ in verdicts} == {True, False}  # the study has both verdicts to agree on


@pytest.mark.slow
def test_results_and_callbacks_come_in_job_order(warp):
    evaluator, results, traces, calls = warp
    n = len(JOBS)
    assert calls == [c for i in range(n) for c in (("result", i), ("progress", i + 1, n))]
    assert len(results) == len(traces) == n
    assert [len(t.t_s) for t in traces] == [round(m["sim_s"] / 0.02) for m in results]
    assert evaluator.compile_s is not None and evaluator.world_steps == n * 2500


@pytest.mark.slow
def test_a_fallen_world_stops_counting_at_its_fall(warp, lanes):
    _evaluator, results, traces, _calls = warp
    fell = [i for i, m in enumerate(results) if m["fell"]]
    assert fell == [i for i, m in enumerate(lanes) if m["fell"]] == [5]  # the pushed one
    assert results[5]["sim_s"] == results[5]["fall_time_s"] < DURATION_S
    assert traces[5].t_s[-1] == pytest.approx(results[5]["fall_time_s"])


@pytest.mark.slow
def test_the_segments_change_no_bit(robot):
    """The controls go up and the frame ends come back per segment, the next segment launched
    before the last is measured: one segment of the whole run and segments of 7 frames (the
    last one short) give the same metrics and traces to the bit."""
    jobs, runs = [JOBS[0], JOBS[4]], []
    for frames in (60, 7):
        traces: list = []
        evaluator = WarpEvaluator(robot, device="cpu", segment_frames=frames, host_processes=1)
        results = evaluator.evaluate(jobs, duration_s=1.2, warmup_s=0.3, traces=traces)
        runs.append((results, traces))
    (whole, whole_traces), (cut, cut_traces) = runs
    assert same_results(cut, whole) and not any(m["fell"] for m in whole)
    assert_same_traces(cut_traces, whole_traces)


@pytest.mark.slow
def test_cancel_stops_the_batch_between_segments(robot):
    """The pushed world falls in the first segment of 5 frames; its result sets `cancel`; the
    segment already in flight (launched before the first one's worlds were measured) is the
    last one stepped."""
    falls = Job(GaitParams(), Motion(), variation=parse_variation("push_n_s=3,push_time_s=0.02"))
    evaluator = WarpEvaluator(robot, device="cpu", segment_frames=5)
    cancel, seen = threading.Event(), []

    def on_result(index, metrics):
        seen.append((index, metrics["fell"]))
        cancel.set()

    with pytest.raises(Cancelled, match="after 1 of 2 runs"):
        evaluator.evaluate(
            [falls, Job(GaitParams(), Motion())],
            duration_s=2.0,
            warmup_s=0.5,
            cancel=cancel,
            on_result=on_result,
        )
    assert seen == [(0, True)]
    assert evaluator.world_steps == 2 * 5 * 20 * 2


def test_a_cancel_set_before_the_call_runs_nothing(robot):
    cancel = threading.Event()
    cancel.set()
    evaluator = WarpEvaluator(robot, device="cpu")
    with pytest.raises(Cancelled):
        evaluator.evaluate(JOBS[:2], duration_s=1.0, cancel=cancel)
    assert evaluator.world_steps == 0


def test_the_cop_law_is_refused_naming_the_cpu_backend(robot):
    """The CoP law reads the soles' force sensors, computed from MjData's contacts, which a
    Warp batch does not model: refused before anything is stepped."""
    closed = Job(GaitParams.from_dict({"cop": {"enabled": True}}), FORWARD)
    evaluator = WarpEvaluator(robot, device="cpu")
    with pytest.raises(ExecutorError, match=r"job 1 has the CoP law on.*--backend cpu"):
        evaluator.evaluate([JOBS[0], closed], duration_s=1.0)
    assert evaluator.world_steps == 0


@pytest.mark.slow
def test_the_closed_loop_agrees_with_the_lanes(robot):
    """The laws of the `robust` preset (yaw rate, ankle damping) and the tilt trim run per frame
    for every world from its sensors, noisy and delayed, beside an open-loop world in the same
    batch: metrics within AGREEMENT of the lanes' closed loop, the same falls."""
    robust = builtin_presets()["robust"].gait
    laws = dataclasses.replace(robust, tilt=dataclasses.replace(robust.tilt, enabled=True))
    assert feedback.laws_on(laws) == ["tilt", "yaw_rate", "damping"]
    noisy = parse_variation(
        "friction=0.7,kp_scale=0.9,latency_ms=10,imu_tilt_bias_deg=1,gyro_bias_deg_s=0.3,"
        "gyro_noise_deg_s=0.1,imu_delay_ms=12"
    )
    jobs = [
        Job(laws, Motion(a_p=0.07, ca=0.1)),
        Job(laws, TURN, variation=noisy),
        Job(GaitParams(), FORWARD),
    ]
    warp = WarpEvaluator(robot, device="cpu")
    got = warp.evaluate(jobs, duration_s=DURATION_S, warmup_s=WARMUP_S)
    want = BatchEvaluator(robot, threads=2).evaluate(jobs, duration_s=DURATION_S, warmup_s=WARMUP_S)
    assert warp.stage_s["laws"] > 0
    off = []
    for i, (a, b) in enumerate(zip(got, want, strict=True)):
        assert a["fell"] == b["fell"], i
        for key, tolerance in AGREEMENT.items():
            x, y = a.get(key), b.get(key)
            if x is not None and y is not None and np.max(np.abs(np.subtract(x, y))) > tolerance:
                off.append((i, key, x, y))
    assert not off, off


def test_every_variation_of_today_is_held_per_world(robot):
    """Each physics field of a variation changes only fields MuJoCo Warp holds per world; the
    worlds get their own model's values, the nominal world the model's."""
    varied = parse_variation(
        "friction=0.4,trunk_mass_scale=1.5,link_mass_scale=0.8,kp_scale=1.3,torque_scale=0.9,"
        "damping_scale=2,frictionloss_scale=3,tilt_deg=5,tilt_direction_deg=30"
    )
    models = [robot.model, varied_robot(robot, varied).model, robot.model]
    fields = per_world_fields(models)
    assert {
        "geom_friction", "body_mass", "body_inertia", "actuator_gainprm", "actuator_biasprm",
        "actuator_forcerange", "dof_damping", "dof_frictionloss", "opt.gravity",
    } <= set(fields)  # fmt: skip
    for name in ("geom_friction", "body_mass", "dof_damping"):
        for world, model in enumerate(models):
            want = getattr(model, name).astype(np.float32)
            assert np.array_equal(fields[name][world].reshape(want.shape), want), (name, world)
    assert np.allclose(fields["opt.gravity"][1], models[1].opt.gravity)
    assert per_world_fields([robot.model, robot.model]) == {}


def test_the_shortcut_gives_what_putting_every_model_gives(robot):
    """`per_world_fields` reads sampled variations' values from their MjModels (two models put
    on the device, not one per variation): the same fields, the same values, as putting and
    comparing every model; a model that moves a field the probe did not sends it the slow way."""
    models = [robot.model] + [
        varied_robot(robot, v.physics).model for v in sample(VariationRanges(), 6, 3)
    ]
    models.append(robot.model)
    fast, slow = per_world_fields(models), _per_world_fields_put(models)
    assert sorted(fast) == sorted(slow) and "body_mass" in fast
    for name, values in slow.items():
        assert np.array_equal(fast[name].reshape(values.shape), values), name
    only_friction = varied_robot(robot, parse_variation("friction=0.5")).model
    only_damping = varied_robot(robot, parse_variation("damping_scale=2")).model
    mixed = [robot.model, only_friction, only_damping]
    fast, slow = per_world_fields(mixed), _per_world_fields_put(mixed)
    assert sorted(fast) == sorted(slow) and {"geom_friction", "dof_damping"} <= set(fast)
    for name, values in slow.items():
        assert np.array_equal(fast[name].reshape(values.shape), values), name


def test_a_field_that_cannot_be_batched_is_refused_naming_it(robot):
    """The policy (docs/GPU.md): worlds whose models differ in a field without a per-world form
    are refused, not split into batches."""
    other = copy.copy(robot.model)
    other.opt.iterations = robot.model.opt.iterations + 1
    with pytest.raises(ExecutorError, match=r"differ in opt\.iterations.*--backend cpu"):
        per_world_fields([robot.model, other])
