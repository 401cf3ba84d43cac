"""The set-point path of a varied robot: what 12 servos act on, step by step, given what they
were sent -- latency, calibration offset, and dead band plus backlash as a play operator
(docs/DESIGN.md §13). One `ServoPath` per run; chunks of any size give the same output.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from app.core.variations import Variation
from gait import JOINT_NAMES

N_SERVOS = len(JOINT_NAMES)


def latency_steps(latency_ms: float, timestep_s: float) -> int:
    """The delay in whole physics steps: latency_ms / timestep rounded half up."""
    return math.floor(latency_ms * 1e-3 / timestep_s + 0.5)


class ServoPath:
    """A stateful filter from the set-points sent to the 12 servos to what they act on.

    Per physics step and servo, in this order:
      1. latency: the set-point of `delay_steps` steps before (`latency_steps`); before the
         run's first step the initial set-point holds.
      2. calibration: + `calibration_deg` of the joint (the servo's zero is off by it).
      3. dead band and backlash, one play operator of full width w = deadband + backlash
         (two plays in series are one play of the summed width): the output holds until the
         command leaves the band [out - w/2, out + w/2], then trails it at the band's edge,
         out = clip(out, x - w/2, x + w/2); it starts at the initial set-point (+ offset).
         So a reversal smaller than w is not followed at all, a move larger than w is followed
         w/2 short, and a held command ends up w/2 behind on the side it came from -- the
         lost motion of a servo that ignores small pulse changes and of gears whose teeth must
         cross their gap before the output turns.
    Not modelled: the output shaft's free play under load (with a load torque that reverses,
    a real joint swings through the gap with no servo torque; that needs a separate hinge in
    the model), the dead band's zero stiffness for small errors (the actuator keeps its kp
    about the shifted target), and any dependence on speed or temperature.

    Args:
        variation: the `Variation`; only latency, calibration, dead band, backlash matter here.
        timestep_s: the physics step, s.
        initial_rad: (12,) the set-points in force before the first step (`gait.JOINT_NAMES`).

    `__call__` takes the next chunk of steps, (n, 12) in rad, and returns (n, 12); feeding a
    run in one chunk or in any split gives the same bits. A variation without these parts
    passes every value through unchanged. ValueError for a wrong shape.
    """

    def __init__(self, variation: Variation, timestep_s: float, initial_rad: ArrayLike) -> None:
        initial = np.array(initial_rad, dtype=np.float64)
        if initial.shape != (N_SERVOS,):
            raise ValueError(f"initial_rad must have shape ({N_SERVOS},), got {initial.shape}")
        self.delay_steps = latency_steps(variation.latency_ms, timestep_s)
        self.offset_rad = np.radians(np.array(variation.calibration_deg, dtype=np.float64))
        self.has_offset = bool(np.any(self.offset_rad))
        self.half_width_rad = 0.5 * math.radians(variation.deadband_deg + variation.backlash_deg)
        self.passthrough = self.delay_steps == 0 and not self.has_offset and not self.half_width_rad
        self._queue = np.tile(initial, (self.delay_steps, 1))  # the last delay_steps inputs
        start = initial + self.offset_rad if self.has_offset else initial
        self._last_command = start.copy()  # the play's input at the last step
        self._output = start.copy()  # the play's output at the last step

    def __call__(self, ctrl_rad: ArrayLike) -> NDArray[np.float64]:
        x = np.array(ctrl_rad, dtype=np.float64)  # a copy: the caller's array is left alone
        if x.ndim != 2 or x.shape[1] != N_SERVOS:
            raise ValueError(f"ctrl_rad must have shape (n, {N_SERVOS}), got {x.shape}")
        if self.passthrough or len(x) == 0:
            return x
        if self.delay_steps:
            joined = np.concatenate([self._queue, x])
            x, self._queue = joined[: len(x)], joined[len(x) :].copy()
        if self.has_offset:
            x = x + self.offset_rad
        if self.half_width_rad:
            x = self._play(x)
        return x

    def _play(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The play operator over the chunk, sequential only over the steps where a servo's
        command changes (a command that repeats leaves the output where it is). No array of
        the chunk's size is sorted or summed: a 10 s run plans in a fraction of a millisecond
        (docs/DESIGN.md §14)."""
        n = len(x)
        changed = np.empty(x.shape, dtype=bool)
        np.not_equal(x[0], self._last_command, out=changed[0])
        np.not_equal(x[1:], x[:-1], out=changed[1:])
        servo, row = np.nonzero(changed.T)  # each servo's changes, in step order
        per_servo = np.bincount(servo, minlength=N_SERVOS)
        first = np.cumsum(per_servo) - per_servo  # where each servo's changes start in `row`
        n_events = int(per_servo.max())
        held = np.empty((n_events + 1, N_SERVOS))  # output after k changes, per servo
        held[0] = self._output
        if n_events:
            # each servo's k-th new command; after its last one, its last command repeats
            events = np.tile(x[-1], (n_events, 1))
            events[np.arange(len(servo)) - first[servo], servo] = x[row, servo]
            low, high = events - self.half_width_rad, events + self.half_width_rad
            out = self._output.copy()
            for k in range(n_events):
                np.maximum(out, low[k], out=out)
                np.minimum(out, high[k], out=out)
                held[k + 1] = out
        result = np.empty_like(x)
        for j in range(N_SERVOS):  # held[k] from the k-th change up to the next one
            rows = row[first[j] : first[j] + per_servo[j]]
            spans = np.diff(rows, prepend=0, append=n)
            result[:, j] = np.repeat(held[: per_servo[j] + 1, j], spans)
        self._last_command = x[-1].copy()
        self._output = held[n_events].copy()
        return result
