"""The balance feedback laws on top of the open-loop gait, once per 20 ms frame: sensor readings
in (gyro, accelerometer, the soles' forces -- nothing else), corrections of the 12 joint angles
and of a_y out. Pure numpy in float32, as the firmware computes them (docs/DESIGN.md §4)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gait.attitude import accel_tilt, complementary_step, starts_attitude
from gait.feedback_params import TiltParams, YawRateParams
from gait.params import LAW_GROUPS, GaitParams, Motion
from gait.timing import timing_step

F32 = np.float32
#: joint indices in `gait.JOINT_NAMES` order, per leg (left, right)
HIP_ROLL, HIP_PITCH, ANKLE_PITCH, ANKLE_ROLL = (1, 7), (2, 8), (4, 10), (5, 11)
OUTWARD = np.array([1.0, -1.0], dtype=F32)  # +y is outward for the left foot, inward for the right


def _both_legs(joint: tuple[int, int]) -> slice:
    """A joint's two columns (left, right: one leg's six apart) as a slice of the 12."""
    return slice(joint[0], None, joint[1] - joint[0])


_ANKLE_PITCHES, _HIP_PITCHES = _both_legs(ANKLE_PITCH), _both_legs(HIP_PITCH)
_ANKLE_ROLLS, _HIP_ROLLS = _both_legs(ANKLE_ROLL), _both_legs(HIP_ROLL)


def any_law_on(params: GaitParams) -> bool:
    """False: the open-loop gait, to the bit."""
    return any(getattr(params, group).enabled for group in LAW_GROUPS)


def laws_on(params: GaitParams) -> list[str]:
    """The groups of the laws `params` switches on."""
    return [group for group in LAW_GROUPS if getattr(params, group).enabled]


@dataclass(frozen=True)
class Reading:
    """What the laws read: the IMU in its axes (ROS: x forward, y left, z up; pitch rate > 0
    leans forward, roll rate > 0 lowers the right side) and each sole's four forces."""

    gyro_rad_s: NDArray[np.float32]  # (3,)
    accel_m_s2: NDArray[np.float32]  # (3,)
    fsr_n: NDArray[np.float32]  # (2, 4) left foot first, corners fl, fr, bl, br


@dataclass(frozen=True)
class State:
    """A run's law state (float32): the attitude estimate and each law's filter and integral."""

    started: bool = False
    pitch_rad: np.float32 = field(default_factory=F32)
    roll_rad: np.float32 = field(default_factory=F32)
    tilt_error: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    tilt_integral: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    yaw_error: np.float32 = field(default_factory=F32)
    yaw_integral: np.float32 = field(default_factory=F32)
    cop_integral: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    cop_last: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))
    timing_error: np.float32 = field(default_factory=F32)


@dataclass(frozen=True)
class Output:
    """One frame's corrections, and each law's share (for the dashboard and the tests)."""

    joint_delta_rad: NDArray[np.float32]  # (12,) added to the gait's joint angles
    a_y_delta: np.float32  # added to the (ramped) a_y
    tilt_rad: NDArray[np.float32]  # (2,) pitch and roll trim
    damping_rad: NDArray[np.float32]  # (12,)
    cop_rad: NDArray[np.float32]  # (2,) the support foot's ankle pitch and roll (outward)
    support: int  # the support foot (0 left, 1 right), -1: neither carries min_load_n
    attitude_rad: NDArray[np.float32] = field(default_factory=lambda: _zeros(2))  # estimate
    freq_delta_hz: np.float32 = field(default_factory=F32)  # added to the clock's frequency


def _zeros(n: int) -> NDArray[np.float32]:
    return np.zeros(n, dtype=F32)


def _low_pass(value: NDArray[np.float32], target: NDArray[np.float32], dt_s: float, tau_s: float):
    return value + (target - value) * F32(dt_s / (tau_s + dt_s))


def _clip(value: NDArray[np.float32] | np.float32, limit: np.float32) -> NDArray[np.float32]:
    """`value` within [-limit, limit]: np.clip's bits, without its wrapper's cost per frame."""
    return np.minimum(np.maximum(value, -limit), limit)


def _dead_band(error: NDArray[np.float32], width: float) -> NDArray[np.float32]:
    return np.sign(error) * np.maximum(np.abs(error) - F32(width), F32(0.0))


def expected_tilt(tilt: TiltParams, motion: Motion) -> NDArray[np.float32]:
    """(pitch, roll) the trunk is expected to have walking `motion`, rad: (2,), or (K, 2) for a
    motion whose fields hold one value per run (K,)."""
    pitch = tilt.pitch_offset_rad + tilt.pitch_per_a_p * motion.a_p
    roll = tilt.roll_per_a_r * motion.a_r
    out = np.empty((*np.shape(pitch), 2), dtype=F32)  # each rounded to float32 as it is put
    out[..., 0], out[..., 1] = pitch, roll
    return out


def commanded_turn_rate(yaw: YawRateParams, motion: Motion) -> np.float32:
    """The turn rate a_y and CA command, rad/s counter-clockwise: turn_per_a_y * a_y plus eq
    (13)'s -2 CA V / b with V = speed_per_a_p * a_p (one per run for a motion of runs)."""
    speed = yaw.speed_per_a_p * motion.a_p
    return F32(yaw.turn_per_a_y * motion.a_y - 2.0 * motion.ca * speed / yaw.axle_m)


def support_cop(
    fsr_n: NDArray[np.float32], positions_m: NDArray[np.float32], min_load_n: float
) -> tuple[int, NDArray[np.float32]]:
    """The foot that carries more (-1 if neither carries `min_load_n`) and its centre of
    pressure (x forward, y outward) from the sole centre, m."""
    support, cop = support_cops(fsr_n[None], positions_m, min_load_n)
    return int(support[0]), cop[0]


def support_cops(
    fsr_n: NDArray[np.float32], positions_m: NDArray[np.float32], min_load_n: float
) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
    """`support_cop` of K runs at once: fsr_n (K, 2, 4), positions_m (4, 2) or each run's
    (K, 4, 2); the support feet (K,) and their centres of pressure (K, 2)."""
    load = fsr_n.sum(axis=-1)  # (K, 2)
    runs = np.arange(len(fsr_n))
    foot = np.argmax(load, axis=-1)
    carried = load[runs, foot]
    carries = (carried > 0) & ~(carried < F32(min_load_n))  # with min_load_n 0, no 0 / 0
    on = fsr_n[runs, foot][:, None, :]  # (K, 1, 4)
    with np.errstate(invalid="ignore", divide="ignore"):
        cop = (on @ positions_m)[:, 0, :] / np.where(carries, carried, F32(1.0))[:, None]
    cop = np.stack([cop[:, 0], cop[:, 1] * OUTWARD[foot]], axis=-1).astype(F32)
    return np.where(carries, foot, -1), np.where(carries[:, None], cop, F32(0.0))


@dataclass(frozen=True)
class States:
    """K runs' law states at once (`State`'s fields, each with a leading run axis)."""

    started: NDArray[np.bool_]  # (K,)
    pitch_rad: NDArray[np.float32]  # (K,)
    roll_rad: NDArray[np.float32]  # (K,)
    tilt_error: NDArray[np.float32]  # (K, 2)
    tilt_integral: NDArray[np.float32]  # (K, 2)
    yaw_error: NDArray[np.float32]  # (K,)
    yaw_integral: NDArray[np.float32]  # (K,)
    cop_integral: NDArray[np.float32]  # (K, 2)
    cop_last: NDArray[np.float32]  # (K, 2)
    timing_error: NDArray[np.float32]  # (K,)

    @classmethod
    def of(cls, states: Sequence[State]) -> States:
        return cls(
            **{
                f.name: np.array([getattr(s, f.name) for s in states], dtype=_STATE_DTYPES[f.name])
                for f in dataclasses.fields(cls)
            }
        )

    @classmethod
    def fresh(cls, runs: int) -> States:
        return cls.of([State()] * runs)

    def take(self, runs: NDArray[np.bool_] | NDArray[np.int64]) -> States:
        """The states of the runs `runs` selects (a mask or indices)."""
        return States(**{f.name: getattr(self, f.name)[runs] for f in dataclasses.fields(self)})

    def run(self, k: int) -> State:
        fields = {f.name: getattr(self, f.name)[k] for f in dataclasses.fields(self)}
        started = bool(fields.pop("started"))
        copied = {n: (v.copy() if np.ndim(v) else v) for n, v in fields.items()}
        return State(started=started, **copied)


_STATE_DTYPES = {
    f.name: (np.bool_ if f.name == "started" else F32) for f in dataclasses.fields(State)
}


@dataclass(frozen=True)
class Outputs:
    """K runs' corrections of one frame (`Output`'s fields, each with a leading run axis)."""

    joint_delta_rad: NDArray[np.float32]  # (K, 12)
    a_y_delta: NDArray[np.float32]  # (K,)
    tilt_rad: NDArray[np.float32]  # (K, 2)
    damping_rad: NDArray[np.float32]  # (K, 12)
    cop_rad: NDArray[np.float32]  # (K, 2)
    support: NDArray[np.int64]  # (K,)
    attitude_rad: NDArray[np.float32]  # (K, 2)
    freq_delta_hz: NDArray[np.float32]  # (K,)

    def run(self, k: int) -> Output:
        return Output(
            self.joint_delta_rad[k], self.a_y_delta[k], self.tilt_rad[k], self.damping_rad[k],
            self.cop_rad[k], int(self.support[k]), self.attitude_rad[k], self.freq_delta_hz[k],
        )  # fmt: skip


def restarted(state: State) -> State:
    """`state` with every law's filter and integral zeroed and the attitude estimate kept: the
    laws start anew when the set of laws that step changes (a law switched on or off; on the
    robot also STOP and START, since no law steps while it does not walk: laws.c)."""
    return State(started=state.started, pitch_rad=state.pitch_rad, roll_rad=state.roll_rad)


def step(
    laws: GaitParams,
    state: State,
    reading: Reading,
    motion: Motion,
    fsr_positions_m: NDArray[np.float32],
    dt_s: float,
    *,
    phase_rad: float | None = None,
) -> tuple[State, Output]:
    """One frame of every law that is on, for one run: `step_many` of a single run (the one
    implementation; its docstring says what each law does)."""
    states, outs = step_many(
        laws,
        States.of([state]),
        reading.gyro_rad_s[None],
        reading.accel_m_s2[None],
        reading.fsr_n[None],
        motion,
        fsr_positions_m,
        dt_s,
        phase_rad=phase_rad,
    )
    return states.run(0), outs.run(0)


def step_many(
    laws: GaitParams,
    state: States,
    gyro_rad_s: NDArray[np.floating],
    accel_m_s2: NDArray[np.floating],
    fsr_n: NDArray[np.floating],
    motion: Motion,
    fsr_positions_m: NDArray[np.float32],
    dt_s: float,
    *,
    phase_rad: float | NDArray[np.floating] | None = None,
) -> tuple[States, Outputs]:
    """One frame of every law that is on (the feedback groups of `laws`) for K runs at once,
    each from its own reading -- the gyro (K, 3), the accelerometer (K, 3), the soles' forces
    (K, 2, 4), as `Reading` holds them -- all walking the same `motion` (the one the gait
    gets). Each run's numbers are those of that run alone, to the bit: every operation is
    elementwise along the run axis.

    Attitude: the complementary filter, started from the accelerometer's tilt at the first
    reading of about 1 g (`starts_attitude`); until then there is no estimate and the tilt trim
    waits (its state unchanged, no trim), the other laws act. Tilt trim: the
    tilt error (estimate - `expected_tilt`), low-passed, past the dead band, integrated (ki) plus
    kp times it, each clamped; pitch trim on both ankles' pitch (toes down for a forward lean),
    roll trim, times `roll_share`, on the hips' roll (left out, right in for a lean to the
    right). Yaw rate: the
    error of the gyro's rate against `commanded_turn_rate`, low-passed, PI, clamped, on a_y
    (a_y > 0 turns clockwise). Damping: ankles and hips against the trunk's pitch and roll
    rates. CoP: the support foot's ankle pitch and roll against its centre of pressure (PID).
    Timing: the clock's frequency against the roll's deviation from its expected swing at
    `phase_rad` (phi_Trunk of the frame planned next, one or (K,); `gait.timing`), waiting for
    the attitude estimate as the tilt trim does."""
    gyro, accel = np.asarray(gyro_rad_s, dtype=F32), np.asarray(accel_m_s2, dtype=F32)
    runs = len(gyro)
    was = state.started
    started = was | starts_attitude(accel)
    first_pitch, first_roll = accel_tilt(accel)
    new_pitch, new_roll = complementary_step(
        state.pitch_rad, state.roll_rad, gyro, accel, dt_s, laws.attitude.tau_s,
        tilt=(first_pitch, first_roll),
    )  # fmt: skip
    attitude = np.empty((runs, 2), dtype=F32)  # (pitch, roll) estimated
    attitude[:, 0] = np.where(was, new_pitch, np.where(started, first_pitch, F32(0.0)))
    attitude[:, 1] = np.where(was, new_roll, np.where(started, first_roll, F32(0.0)))
    pitch, roll = attitude[:, 0].copy(), attitude[:, 1].copy()
    delta = np.zeros((runs, 12), dtype=F32)
    new = {"started": started, "pitch_rad": pitch, "roll_rad": roll}  # the new States

    tilt = np.zeros((runs, 2), dtype=F32)
    if laws.tilt.enabled:
        t = laws.tilt
        error = attitude - expected_tilt(t, motion)
        filtered = _low_pass(state.tilt_error, error, dt_s, t.filter_s)
        past = _dead_band(filtered, t.deadband_rad)
        limit = F32(t.clamp_rad)
        integral = _clip(state.tilt_integral + F32(t.ki_per_s * dt_s) * past, limit)
        trim = _clip(integral + F32(t.kp) * past, limit).astype(F32)
        trim[:, 1] *= F32(t.roll_share)  # 1: the same bits as without the share
        on = started[:, None]  # no estimate, no trim: the state waits
        tilt = np.where(on, trim, F32(0.0))
        new.update(
            tilt_error=np.where(on, filtered, state.tilt_error).astype(F32),
            tilt_integral=np.where(on, integral, state.tilt_integral).astype(F32),
        )
        delta[:, _ANKLE_PITCHES] -= tilt[:, :1]  # toes down against a forward lean
        delta[:, _HIP_ROLLS] += tilt[:, 1:] * OUTWARD

    a_y_delta = np.zeros(runs, dtype=F32)
    if laws.yaw_rate.enabled:
        y = laws.yaw_rate
        error = commanded_turn_rate(y, motion) - gyro[:, 2]
        filtered = _low_pass(state.yaw_error, error, dt_s, y.filter_s)
        limit = F32(y.clamp)
        integral = _clip(state.yaw_integral + F32(y.ki_per_s * dt_s) * filtered, limit)
        a_y_delta = _clip(-(integral + F32(y.kp) * filtered), limit).astype(F32)
        new.update(yaw_error=filtered.astype(F32), yaw_integral=integral.astype(F32))

    damping = np.zeros((runs, 12), dtype=F32)
    if laws.damping.enabled:
        d = laws.damping
        # measured on ArtRo: against a forward pitch rate, toes down and legs back both calm
        # the trunk; against a rate lowering the right side, left out and right in
        damping[:, _ANKLE_PITCHES] = -F32(d.ankle_pitch) * gyro[:, 1:2]
        damping[:, _HIP_PITCHES] = -F32(d.hip_pitch) * gyro[:, 1:2]
        damping[:, _ANKLE_ROLLS] = F32(d.ankle_roll) * gyro[:, :1] * OUTWARD
        damping[:, _HIP_ROLLS] = F32(d.hip_roll) * gyro[:, :1] * OUTWARD
        delta += damping

    cop_out, support = np.zeros((runs, 2), dtype=F32), np.full(runs, -1)
    if laws.cop.enabled:
        c = laws.cop
        support, cop = support_cops(np.asarray(fsr_n, dtype=F32), fsr_positions_m, c.min_load_n)
        on = (support >= 0)[:, None]
        limit = F32(c.clamp_rad)
        integral = _clip(state.cop_integral + F32(c.ki_per_s * dt_s) * cop, limit)
        rate = (cop - state.cop_last) / F32(dt_s)
        pid = _clip(F32(c.kp) * cop + integral + F32(c.kd_s) * rate, limit).astype(F32)
        cop_out = np.where(on, pid, F32(0.0))
        new.update(
            cop_integral=np.where(on, integral, state.cop_integral).astype(F32),
            cop_last=np.where(on, cop, state.cop_last).astype(F32),
        )
        rows, foot = np.flatnonzero(support >= 0), support[support >= 0]
        delta[rows, np.array(ANKLE_PITCH)[foot]] += cop_out[rows, 0]
        delta[rows, np.array(ANKLE_ROLL)[foot]] += cop_out[rows, 1]
    freq_delta = np.zeros(runs, dtype=F32)
    if laws.timing.enabled:
        if phase_rad is None:
            raise ValueError("the timing law reads the gait's phase: give phase_rad")
        error, change = timing_step(
            laws.timing, state.timing_error, roll, motion.a_r, phase_rad, laws.clock.freq_hz, dt_s
        )
        freq_delta = np.where(started, change, F32(0.0)).astype(F32)
        new["timing_error"] = np.where(started, error, state.timing_error).astype(F32)
    outs = Outputs(delta, a_y_delta, tilt, damping, cop_out, support, attitude, freq_delta)
    return States(**{**state.__dict__, **new}), outs
