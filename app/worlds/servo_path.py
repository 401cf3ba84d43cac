"""The set-point path of a varied robot: what 12 servos act on, step by step, given what they
were sent -- latency, calibration offset, and dead band plus backlash as a play operator
(docs/DESIGN.md §8). `ServoPaths` for many runs at once, `ServoPath` for one; chunks of any size
give the same output. `acting_setpoints`: a fresh path's output from the frames' switches alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from app.worlds.variations import Variation
from gait import JOINT_NAMES

N_SERVOS = len(JOINT_NAMES)
_SERVOS = np.arange(N_SERVOS)


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
        self._paths = ServoPaths([variation], timestep_s, initial[None])  # the one of many
        self.delay_steps = int(self._paths.delay_steps[0])
        self.offset_rad = self._paths.offset_rad[0]
        self.has_offset = bool(self._paths.has_offset[0])
        self.half_width_rad = float(self._paths.half_width_rad[0])
        self.passthrough = self.delay_steps == 0 and not self.has_offset and not self.half_width_rad

    @property
    def _output(self) -> NDArray[np.float64]:
        """The play's output at the last step (at first the initial set-point + offset)."""
        return self._paths._output[0]

    def __call__(self, ctrl_rad: ArrayLike) -> NDArray[np.float64]:
        x = np.array(ctrl_rad, dtype=np.float64)  # a copy: the caller's array is left alone
        if x.ndim != 2 or x.shape[1] != N_SERVOS:
            raise ValueError(f"ctrl_rad must have shape (n, {N_SERVOS}), got {x.shape}")
        return x if self.passthrough else self._paths(x[None])[0]


class _RunsPaths:
    """What K runs' servo paths share, however they are fed: each run's delay, calibration
    offset and play, and the play's output at the last step."""

    def __init__(
        self, variations: Sequence[Variation], timestep_s: float, initial_rad: ArrayLike
    ) -> None:
        initial = np.array(initial_rad, dtype=np.float64)
        if initial.shape != (len(variations), N_SERVOS):
            raise ValueError(
                f"initial_rad must have shape ({len(variations)}, {N_SERVOS}), got {initial.shape}"
            )
        self.delay_steps = np.array([latency_steps(v.latency_ms, timestep_s) for v in variations])
        offset = [np.radians(np.array(v.calibration_deg, dtype=np.float64)) for v in variations]
        self.offset_rad = np.stack(offset)
        self.has_offset = np.any(self.offset_rad != 0.0, axis=1)
        widths = [0.5 * math.radians(v.deadband_deg + v.backlash_deg) for v in variations]
        self.half_width_rad = np.array(widths)
        self._played = self.half_width_rad != 0.0
        self._all_offset = bool(self.has_offset.all())
        self._output = np.where(self.has_offset[:, None], initial + self.offset_rad, initial)

    def keep(self, runs: NDArray[np.bool_]) -> None:
        """Go on with the runs where `runs` (K,) is True."""
        self.delay_steps, self.offset_rad = self.delay_steps[runs], self.offset_rad[runs]
        self.has_offset, self.half_width_rad = self.has_offset[runs], self.half_width_rad[runs]
        self._all_offset = bool(self.has_offset.all())
        self._played, self._output = self._played[runs], self._output[runs]

    def _calibrated(
        self, x: NDArray[np.float64], offset: NDArray[np.float64], has: NDArray[np.bool_]
    ) -> NDArray[np.float64]:
        """x plus each run's calibration offset (runs without one as they are)."""
        if self._all_offset:  # the same bits as the where below, one pass fewer
            return x + offset
        return np.where(has, x + offset, x) if self.has_offset.any() else x


class ServoPaths(_RunsPaths):
    """K runs' servo paths at once (`ServoPath` is one run's), a chunk of the same steps for
    all: each run's output has the bits it has alone (a test holds them equal). The play runs
    first, on the calibrated input, and the latency delays what it puts out (the play is
    time-invariant and starts at rest on the initial set-point, so the order changes no bit):
    at every step -- a repeated command clips the output to where it is -- composed along the
    steps in log2(n) whole-array rounds (`play_outputs`); the delay by a gather from the last
    outputs at each run's delay. `FramePaths` is the same path fed a frame's switches.

    Args:
        variations: each run's `Variation`.
        timestep_s: the physics step, s.
        initial_rad: (K, 12) each run's set-points in force before the first step.
    """

    def __init__(
        self, variations: Sequence[Variation], timestep_s: float, initial_rad: ArrayLike
    ) -> None:
        super().__init__(variations, timestep_s, initial_rad)
        longest = int(self.delay_steps.max(initial=0))
        self._queue = np.repeat(self._output[:, None, :], longest, axis=1)  # the last outputs

    def keep(self, runs: NDArray[np.bool_]) -> None:
        super().keep(runs)
        self._queue = self._queue[runs]

    def __call__(self, ctrl_rad: NDArray[np.float64]) -> NDArray[np.float64]:
        """The next chunk of every run, (K, n, 12) in rad, to (K, n, 12)."""
        x = np.asarray(ctrl_rad, dtype=np.float64)
        if x.ndim != 3 or x.shape[0] != len(self.delay_steps) or x.shape[2] != N_SERVOS:
            raise ValueError(
                f"ctrl_rad must have shape ({len(self.delay_steps)}, n, {N_SERVOS}), got {x.shape}"
            )
        x = self._calibrated(x, self.offset_rad[:, None, :], self.has_offset[:, None, None])
        if self._played.any() and x.shape[1]:
            width = self.half_width_rad[None, :, None]
            steps = x.transpose(1, 0, 2)  # (n, K, 12): the play runs along the steps
            played = play_outputs(self._output, steps - width, steps + width).transpose(1, 0, 2)
            if self._played.all():
                self._output, x = played[:, -1], played
            else:
                self._output = np.where(self._played[:, None], played[:, -1], self._output)
                x = np.where(self._played[:, None, None], played, x)
        return self._delayed(x)

    def _delayed(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """x (K, n, 12) with each run's latency: the outputs of `delay_steps` steps before."""
        n, longest = x.shape[1], self._queue.shape[1]
        if not longest:
            return x
        joined = np.concatenate([self._queue, x], axis=1)
        first = longest - self.delay_steps
        self._queue = joined[:, n:]  # a view: the next call's concatenate copies it
        return joined[np.arange(len(x))[:, None], first[:, None] + np.arange(n)]


class FramePaths(_RunsPaths):
    """K runs' servo paths fed a frame of `steps` physics steps at a time by its switches (a
    lane's group of closed-loop runs): what `ServoPaths` gives for the step-level input, to
    the bit (a test holds them equal), without going along the steps. The play's output
    changes only where its input does (a clip repeated with the same band is the clip), so a
    frame is played from its two values per servo; each servo's output is then constant in
    pieces, and the delayed frame is the last frames' pieces, each starting its run's delay
    later (docs/DESIGN.md §8).

    Args:
        variations, timestep_s, initial_rad: as for `ServoPaths`.
        steps: physics steps per frame.
    """

    def __init__(
        self,
        variations: Sequence[Variation],
        timestep_s: float,
        initial_rad: ArrayLike,
        steps: int,
    ) -> None:
        super().__init__(variations, timestep_s, initial_rad)
        self.steps = steps
        back = -(-int(self.delay_steps.max(initial=0)) // steps)  # frames a delay reaches into
        # each servo's pieces, oldest first: the last `back` frames' two and this frame's two,
        # their values (K, 12, 2 back + 2) and the steps they start at, counted from this
        # frame's start, and the frame's end (K, 12, 2 back + 3); before the run, the output
        # held (from -back frames on)
        self._values = np.repeat(self._output[:, :, None], 2 * back + 2, axis=2)
        self._starts = np.full((*self._output.shape, 2 * back + 3), -back * steps, np.int32)
        self._starts[:, :, -1] = steps
        self._delay = self.delay_steps.astype(np.int32)[:, None, None]
        # the next frame's pieces are this one's moved down by two: written into a second pair
        # of arrays, then swapped (moved in place, numpy copies the overlap twice)
        self._values_next, self._starts_next = self._values.copy(), self._starts.copy()

    def keep(self, runs: NDArray[np.bool_]) -> None:
        super().keep(runs)
        self._values, self._starts = self._values[runs], self._starts[runs]
        self._values_next, self._starts_next = self._values_next[runs], self._starts_next[runs]
        self._delay = self._delay[runs]

    def __call__(
        self,
        sent: NDArray[np.float64],
        setpoint: NDArray[np.float64],
        substep: NDArray[np.int64],
        out: NDArray[np.float64],
    ) -> None:
        """The next frame of every run into `out` (K, steps, 12): servo j of run k is sent
        `sent[k, j]` until step `substep[k, j]` of the frame (0..steps; steps: not in this
        frame) and `setpoint[k, j]` from there on."""
        steps = self.steps
        first = self._calibrated(sent, self.offset_rad, self.has_offset[:, None])
        then = self._calibrated(setpoint, self.offset_rad, self.has_offset[:, None])
        if self._played.any():
            width = self.half_width_rad[:, None]
            kept = np.minimum(np.maximum(self._output, first - width), first + width)
            kept = np.where(substep > 0, kept, self._output)  # switched at step 0: never sent
            moved = np.minimum(np.maximum(kept, then - width), then + width)
            self._output = np.where(substep < steps, moved, kept)
            if self._played.all():
                first, then = kept, moved
            else:
                first = np.where(self._played[:, None], kept, first)
                then = np.where(self._played[:, None], moved, then)
        values, starts = self._values, self._starts
        values[:, :, -2], values[:, :, -1] = first, then
        starts[:, :, -3], starts[:, :, -2] = 0, substep
        # delayed, each piece starts `delay_steps` later; the frame shows its steps 0..steps-1
        shown = starts + self._delay
        np.clip(shown, 0, steps, out=shown)
        counts = shown[:, :, 1:] - shown[:, :, :-1]
        pieces = np.repeat(values.reshape(-1), counts.reshape(-1))  # servo by servo
        out[...] = pieces.reshape(len(values), N_SERVOS, steps).transpose(0, 2, 1)
        # the next frame's: this one's pieces are the last (the ends' columns it writes itself)
        following, following_starts = self._values_next, self._starts_next
        following[:, :, :-2] = values[:, :, 2:]
        np.subtract(starts[:, :, 2:-1], steps, out=following_starts[:, :, :-3])
        self._values, self._values_next = following, values
        self._starts, self._starts_next = following_starts, starts


def play_outputs(
    start: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The play's output after each of K events per servo, (K, 12): out_k = clip(out_k-1,
    low_k, high_k) from out_0 = `start`, with low <= high (an event of (-inf, inf) changes
    nothing). Works in `low` and `high` (the callers' own scratch arrays), overwriting them.

    A clip of a clip is a clip: clip(clip(v, a1, b1), a2, b2) = clip(v, clip(a1, a2, b2),
    clip(b1, a2, b2)). So the events compose in log2(K) whole-array rounds (a prefix scan)
    rather than K Python steps, and since min and max only pick among their inputs, every
    output has the bits of the step-by-step definition (docs/DESIGN.md §8)."""
    span = 1  # after round r, low[k] and high[k] hold events k-2^r+1 .. k composed
    while span < len(low):
        later_low, later_high = low[span:], high[span:]
        earlier_low = np.minimum(np.maximum(low[:-span], later_low), later_high)
        earlier_high = np.minimum(np.maximum(high[:-span], later_low), later_high)
        low[span:], high[span:] = earlier_low, earlier_high
        span *= 2
    return np.minimum(np.maximum(start, low), high)


def acting_setpoints(
    variation: Variation,
    timestep_s: float,
    initial_rad: ArrayLike,
    setpoint: ArrayLike,
    substep: ArrayLike,
    steps_per_frame: int,
) -> NDArray[np.float64]:
    """What a fresh `ServoPath(variation, timestep_s, initial_rad)` returns for the set-points
    sent in n frames, (n * steps_per_frame, 12), to the bit -- built from the <= 12 n switches
    alone, never from the step-level input (docs/DESIGN.md §8).

    Servo j sends `initial_rad[j]` until its first switch; in frame f it switches to
    `setpoint[f, j]` at step `substep[f, j]` of the frame (0 .. steps_per_frame; the last: at
    the next frame's first step, where the next frame's switch at its step 0 overrides it).
    The nominal variation gives the sent set-points themselves. ValueError for a wrong shape
    or a step outside the frame."""
    path = ServoPath(variation, timestep_s, initial_rad)
    sent = np.asarray(setpoint, dtype=np.float64)
    at = np.asarray(substep, dtype=np.int64)
    if sent.ndim != 2 or sent.shape[1] != N_SERVOS or at.shape != sent.shape:
        raise ValueError(
            f"setpoint and substep must both have shape (n, {N_SERVOS}), "
            f"got {sent.shape} and {at.shape}"
        )
    if at.size and (at.min() < 0 or at.max() > steps_per_frame):
        raise ValueError(f"substep must lie in 0..{steps_per_frame} (steps_per_frame)")
    n_frames, n_steps = len(sent), len(sent) * steps_per_frame
    rows = np.arange(n_frames)[:, None] * steps_per_frame + at + path.delay_steps
    superseded = np.zeros(rows.shape, dtype=bool)  # met at its step by the next frame's switch
    np.equal(rows[:-1], rows[1:], out=superseded[:-1])
    held = np.empty((n_frames + 1, N_SERVOS))  # what servo j acts on after its k-th switch
    held[0] = path._output
    command = sent + path.offset_rad if path.has_offset else sent
    if path.half_width_rad:
        ignored = superseded | (rows >= n_steps)
        low = np.where(ignored, -np.inf, command - path.half_width_rad)
        high = np.where(ignored, np.inf, command + path.half_width_rad)
        held[1:] = play_outputs(held[0], low, high)
    else:
        held[1:] = command
    switches = np.minimum(rows, n_steps)  # never decreasing: 0 <= substep <= steps_per_frame
    # every servo has n_frames switches: one repeat of all 12 rows (servo-major), no loop
    counts = np.diff(switches.T, prepend=0, append=n_steps)
    return np.repeat(held.T, counts.ravel()).reshape(N_SERVOS, n_steps).T
