"""The set-point path of a varied world (`app/worlds/servo_path.py`, docs/DESIGN.md §8): latency in
whole physics steps, calibration offsets, dead band and backlash as stated, to the bit in any
chunking and from whole frames (`acting_setpoints`). Split from test_variations.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.robots.model import RobotModel
from app.worlds.servo_path import ServoPath, acting_setpoints, latency_steps
from app.worlds.variations import NOMINAL, Variation

TIMESTEP_S = float(RobotModel.load().model.opt.timestep)


def piecewise_commands(rng: np.random.Generator, frames: int, steps: int = 20) -> np.ndarray:
    """Set-points as the frame loop makes them: each servo switches once per frame, at its own
    step, to a new value (sometimes a small reversal, sometimes the same value)."""
    out = np.empty((frames * steps, 12))
    value = rng.uniform(-0.5, 0.5, 12)
    for f in range(frames):
        switch = rng.integers(0, steps, 12)
        new = value + rng.choice([-0.05, -0.004, 0.0, 0.003, 0.06], 12)
        rows = np.arange(steps)[:, None]
        out[f * steps : (f + 1) * steps] = np.where(rows >= switch, new, value)
        value = new
    return out


@pytest.mark.parametrize(
    ("latency_ms", "timestep_s", "steps"),
    [(0.0, 1e-3, 0), (0.49, 1e-3, 0), (0.5, 1e-3, 1), (1.0, 1e-3, 1), (40.0, 1e-3, 40),
     (40.4, 1e-3, 40), (59.6, 1e-3, 60), (60.0, 1e-3, 60), (41.0, 2e-3, 21)],
)  # fmt: skip
def test_latency_is_rounded_to_whole_physics_steps(latency_ms, timestep_s, steps):
    assert latency_steps(latency_ms, timestep_s) == steps


@pytest.mark.parametrize("latency_ms", [1.0, 20.0, 40.0, 59.6])
def test_latency_shifts_the_output_by_exactly_that_many_steps(latency_ms):
    x = piecewise_commands(np.random.default_rng(1), frames=10)
    initial = np.linspace(-0.2, 0.2, 12)
    out = ServoPath(Variation(latency_ms=latency_ms), TIMESTEP_S, initial)(x)
    k = round(latency_ms)
    assert np.array_equal(out[k:], x[:-k])
    assert np.array_equal(out[:k], np.tile(initial, (k, 1)))  # the initial set-point holds


def test_calibration_adds_its_offset_to_each_joint():
    cal = tuple(np.linspace(-1.5, 1.5, 12))
    x = piecewise_commands(np.random.default_rng(2), frames=3)
    out = ServoPath(Variation(calibration_deg=cal), TIMESTEP_S, x[0])(x)
    assert np.array_equal(out, x + np.radians(cal))


def one_servo(path: ServoPath, values_deg: list[float]) -> list[float]:
    """Feed servo 0 the given commands (one step each), return its outputs in degrees."""
    x = np.zeros((len(values_deg), 12))
    x[:, 0] = np.radians(values_deg)
    return [round(math.degrees(v), 9) for v in path(x)[:, 0]]


@pytest.mark.parametrize(
    "variation",
    [Variation(deadband_deg=0.4, backlash_deg=0.6), Variation(backlash_deg=1.0),
     Variation(deadband_deg=1.0)],
)  # fmt: skip
def test_dead_band_and_backlash_hold_small_reversals_and_follow_large_moves(variation):
    """Full play width 1°: the output holds inside ±0.5° of it and trails a move by 0.5°."""
    path = ServoPath(variation, TIMESTEP_S, np.zeros(12))
    assert one_servo(path, [0.3, -0.4, 0.0]) == [0.0, 0.0, 0.0]  # inside the band: held
    assert one_servo(path, [5.0, 5.0]) == [4.5, 4.5]  # a large move, followed 0.5° short
    assert one_servo(path, [4.2, 4.05]) == [4.5, 4.5]  # reversals smaller than the play
    assert one_servo(path, [3.0, 3.0]) == [3.5, 3.5]  # a larger one: trails on the other side
    assert one_servo(path, [3.4, 3.9]) == [3.5, 3.5]
    assert one_servo(path, [6.0]) == [5.5]


def test_the_nominal_path_passes_every_bit_through():
    rng = np.random.default_rng(3)
    x = piecewise_commands(rng, frames=5)
    x[0, :3] = (-0.0, 5e-324, -1e300)
    path = ServoPath(NOMINAL, TIMESTEP_S, x[0])
    out = np.vstack([path(x[:33]), path(x[33:34]), path(x[34:])])
    assert out.view(np.uint64).tobytes() == x.view(np.uint64).tobytes()
    assert out is not x


path_parts = st.builds(
    Variation,
    latency_ms=st.sampled_from([0.0, 1.0, 7.0, 20.0, 33.0, 60.0]),
    deadband_deg=st.sampled_from([0.0, 0.1, 0.5]),
    backlash_deg=st.sampled_from([0.0, 0.3, 1.0, 4.0]),
    calibration_deg=st.sampled_from([(0.0,) * 12, tuple(np.linspace(-1.5, 1.5, 12))]),
)


@settings(max_examples=60, deadline=None)
@given(
    variation=path_parts,
    seed=st.integers(0, 2**32 - 1),
    cuts=st.lists(st.integers(0, 200), max_size=8),
)
def test_any_chunking_gives_the_same_output_to_the_bit(variation, seed, cuts):
    x = piecewise_commands(np.random.default_rng(seed), frames=10)
    whole = ServoPath(variation, TIMESTEP_S, x[0])(x)
    path = ServoPath(variation, TIMESTEP_S, x[0])
    parts = [path(part) for part in np.split(x, sorted(cuts))]
    assert np.concatenate(parts).tobytes() == whole.tobytes()
    frames = ServoPath(variation, TIMESTEP_S, x[0])  # as the live loop feeds it: 20 steps a call
    assert np.concatenate([frames(f) for f in np.split(x, 10)]).tobytes() == whole.tobytes()


@settings(max_examples=40, deadline=None)
@given(
    width_deg=st.sampled_from([0.1, 1.0, 4.0]),
    seed=st.integers(0, 2**32 - 1),
    frames=st.integers(1, 12),
)
def test_the_play_equals_its_definition_applied_step_by_step_to_the_bit(width_deg, seed, frames):
    """ServoPath works only at the steps where a command changes; the definition clips the
    output into the band around the command at every step."""
    x = piecewise_commands(np.random.default_rng(seed), frames=frames)
    path = ServoPath(Variation(backlash_deg=width_deg), TIMESTEP_S, x[0])
    half = 0.5 * math.radians(width_deg)
    out, expected = x[0].copy(), np.empty_like(x)
    for k, command in enumerate(x):
        out = np.minimum(np.maximum(out, command - half), command + half)
        expected[k] = out
    assert path(x).tobytes() == expected.tobytes()


def sent_per_step(initial, setpoint, substep, steps):
    """The step-level set-points the frame loop sends: in frame f each servo sends the last
    frame's set-point until its substep, then frame f's (at step `steps`: never this frame)."""
    out = np.empty((len(setpoint) * steps, 12))
    previous = initial
    for f, (value, at) in enumerate(zip(setpoint, substep, strict=True)):
        local = np.arange(steps)[:, None]
        out[f * steps : (f + 1) * steps] = np.where(local >= at, value, previous)
        previous = value
    return out


@settings(max_examples=60, deadline=None)
@given(
    variation=path_parts,
    seed=st.integers(0, 2**32 - 1),
    frames=st.integers(1, 12),
    edge_share=st.sampled_from([0.0, 0.2, 0.5]),
)
def test_acting_setpoints_from_frames_equal_the_path_of_every_step_to_the_bit(
    variation, seed, frames, edge_share
):
    """The batch builds what the servos act on from each frame's switches; the path fed every
    step gives the same bits -- frame-end switches (step 20) and repeated values included."""
    rng = np.random.default_rng(seed)
    initial = rng.uniform(-0.5, 0.5, 12)
    setpoint = initial + np.cumsum(rng.choice([-0.05, -0.004, 0.0, 0.003, 0.06], (frames, 12)), 0)
    substep = rng.integers(0, 20, (frames, 12))
    edge = rng.random((frames, 12))
    substep[edge < edge_share] = 20  # at the frame's end, often met by the next frame's step 0
    substep[edge > 1.0 - edge_share] = 0
    sent = sent_per_step(initial, setpoint, substep, 20)
    expected = ServoPath(variation, TIMESTEP_S, initial)(sent)
    got = acting_setpoints(variation, TIMESTEP_S, initial, setpoint, substep, 20)
    assert got.shape == expected.shape
    assert np.ascontiguousarray(got).tobytes() == expected.tobytes()


def test_acting_setpoints_refuse_a_switch_outside_the_frame_and_a_wrong_shape():
    with pytest.raises(ValueError, match=r"substep must lie in 0\.\.20"):
        acting_setpoints(
            NOMINAL, TIMESTEP_S, np.zeros(12), np.zeros((2, 12)), np.full((2, 12), 21), 20
        )
    with pytest.raises(ValueError, match=r"shape \(n, 12\)"):
        acting_setpoints(
            NOMINAL, TIMESTEP_S, np.zeros(12), np.zeros((2, 11)), np.zeros((2, 11)), 20
        )
