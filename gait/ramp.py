"""The motion ramp, seed 004's start-up phase (its Fig. 3) for every change of the motion vector
and CA (docs/DESIGN.md §4): each component moves toward its target by at most rate * dt per step."""

from __future__ import annotations

import math

from gait.params import GaitParams, Motion

#: A remaining distance within this fraction of one step is closed in that step, so float
#: rounding in the running sum never costs an extra step (0.07 / 0.001 is 70.00000000000001).
SNAP_FRACTION = 1e-6
#: Which rate of the `ramp` group limits which motion component.
RATE_FIELDS = {"a_r": "amp_rad_s", "a_p": "amp_rad_s", "a_y": "yaw_rad_s", "ca": "ca_per_s"}


def _toward(current: float, target: float, max_step: float) -> float:
    """`current` moved toward `target` by at most `max_step`; exactly `target` once within reach."""
    delta = target - current
    if abs(delta) <= max_step * (1.0 + SNAP_FRACTION):
        return target
    return current + math.copysign(max_step, delta)


def ramp_rates(params: GaitParams) -> dict[str, float]:
    """The largest change per second of each motion component: a_r and a_p share
    `ramp.amp_rad_s` (rad/s), a_y has `ramp.yaw_rad_s` (rad/s), CA `ramp.ca_per_s` (1/s)."""
    return {name: getattr(params.ramp, rate) for name, rate in RATE_FIELDS.items()}


def ramp_motion(current: Motion, target: Motion, params: GaitParams, dt_s: float) -> Motion:
    """The motion the gait gets `dt_s` after `current` when `target` is requested.

    Seed 004 starts its walk with a phase "in which the speed is increased constantly ... to
    prevent robot's instability due to initial acceleration"; here every change of motion is
    treated so. Pure: the caller keeps the current motion (the frame loop, once per frame).

    Each component moves toward its target by at most its rate (`params.ramp`) times `dt_s`,
    never past it, and lands on it exactly. With `ramp.enabled` off the target passes at once.
    """
    if not (math.isfinite(dt_s) and dt_s >= 0.0):
        raise ValueError(f"dt_s must be a finite time >= 0, got {dt_s!r}")
    if not params.ramp.enabled or current == target:
        return target
    return Motion(
        **{
            name: _toward(getattr(current, name), getattr(target, name), rate * dt_s)
            for name, rate in ramp_rates(params).items()
        }
    )


def ramp_steps(current: Motion, target: Motion, params: GaitParams, dt_s: float) -> int:
    """How many steps of `dt_s` `ramp_motion` takes from `current` to `target`: the largest
    ceil(|delta| / (rate * dt)) over the components (up to SNAP_FRACTION), 0 if already there."""
    if not (math.isfinite(dt_s) and dt_s > 0.0):
        raise ValueError(f"dt_s must be a finite time > 0, got {dt_s!r}")
    if not params.ramp.enabled or current == target:
        return 0
    steps = 0
    for name, rate in ramp_rates(params).items():
        delta = abs(getattr(target, name) - getattr(current, name))
        if delta > 0.0:
            steps = max(steps, 1, math.ceil(delta / (rate * dt_s) - SNAP_FRACTION))
    return steps
