"""The motion ramp (seed 004's start-up phase, docs/DESIGN.md §4): a rate limit on every change of
the motion vector and CA."""

import dataclasses
import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gait import GaitParams, Motion, RampParams, ramp_motion, ramp_steps
from gait.ramp import SNAP_FRACTION, ramp_rates

FRAME_S = 0.02
COMPONENTS = ("a_r", "a_p", "a_y", "ca")


def motions() -> st.SearchStrategy[Motion]:
    amp = st.floats(-0.3, 0.3)
    return st.builds(Motion, a_r=amp, a_p=amp, a_y=st.floats(-0.6, 0.6), ca=st.floats(-0.5, 0.5))


@st.composite
def ramps(draw: st.DrawFn) -> GaitParams:
    rate = st.floats(0.005, 1.0)
    ramp = RampParams(amp_rad_s=draw(rate), yaw_rad_s=draw(rate), ca_per_s=draw(rate))
    return dataclasses.replace(GaitParams(), ramp=ramp)


def walk(start: Motion, target: Motion, params: GaitParams, dt_s: float) -> list[Motion]:
    """Every motion from `start` to `target`, one per step (start included)."""
    out = [start]
    while out[-1] != target:
        assert len(out) < 200_000, "the ramp never arrives"
        out.append(ramp_motion(out[-1], target, params, dt_s))
    return out


@settings(max_examples=60, deadline=None)
@given(start=motions(), target=motions(), params=ramps(), dt_s=st.floats(0.005, 0.05))
def test_rate_limited_monotone_and_arrives_in_the_counted_steps(
    start: Motion, target: Motion, params: GaitParams, dt_s: float
) -> None:
    path = walk(start, target, params, dt_s)
    rates = ramp_rates(params)
    for name in COMPONENTS:
        values = [getattr(m, name) for m in path]
        lo, hi = sorted((getattr(start, name), getattr(target, name)))
        limit = rates[name] * dt_s * (1.0 + SNAP_FRACTION)
        for before, after in itertools.pairwise(values):
            assert abs(after - before) <= limit  # change per step <= rate * dt
            assert lo <= after <= hi  # never overshoots, never turns back
            assert abs(getattr(target, name) - after) <= abs(getattr(target, name) - before)
    deltas = {n: abs(getattr(target, n) - getattr(start, n)) for n in COMPONENTS}
    expected = max(
        [0] + [max(1, math.ceil(d / (rates[n] * dt_s) - 1e-6)) for n, d in deltas.items() if d]
    )
    assert len(path) - 1 == expected == ramp_steps(start, target, params, dt_s)


def test_a_normal_slider_move_from_standing() -> None:
    """0 -> a_p 0.07 takes 1.4 s at the default 0.05 rad/s: 70 frames, the last one exact."""
    params, target = GaitParams(), Motion(a_p=0.07, ca=0.1)
    path = walk(Motion(), target, params, FRAME_S)
    assert len(path) - 1 == 70 == ramp_steps(Motion(), target, params, FRAME_S)
    assert path[1] == Motion(a_p=0.001, ca=0.002)
    assert path[50].ca == 0.1 and path[49].ca < 0.1  # CA arrives after 1 s
    assert path[-1] == target


def test_switched_off_or_arrived_it_passes_the_target_through() -> None:
    off = GaitParams.from_dict({"ramp": {"enabled": False}})
    target = Motion(a_r=0.3, a_y=-0.6, ca=0.5)
    assert ramp_motion(Motion(), target, off, FRAME_S) is target
    assert ramp_steps(Motion(), target, off, FRAME_S) == 0
    assert ramp_motion(target, Motion(0.3, 0.0, -0.6, 0.5), GaitParams(), FRAME_S) == target
    assert ramp_motion(Motion(), target, GaitParams(), 0.0) == Motion()


@pytest.mark.parametrize("dt_s", [-0.02, math.nan, math.inf])
def test_bad_time_steps_are_refused(dt_s: float) -> None:
    with pytest.raises(ValueError, match="dt_s"):
        ramp_motion(Motion(), Motion(a_p=0.1), GaitParams(), dt_s)
