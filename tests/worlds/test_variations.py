"""Model variations (docs/DESIGN.md §8): each field changes what it claims in the compiled model
and nothing else, the set-point path delays, offsets and plays as stated in any chunking, samples
and names reproduce to the bit, bad input is refused, and a varied world behaves as it should."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.worlds.sampling import DIRECTIONS, SAMPLE_COLUMNS, VariationRanges, parse_range, sample
from app.worlds.servo_path import ServoPath, acting_setpoints, latency_steps
from app.worlds.variations import (
    FIELDS,
    FRICTION_GEOMS,
    NOMINAL,
    Variation,
    parse_variation,
    tilted,
    varied_robot,
    vary_model,
)
from gait import JOINT_NAMES

ROBOT = RobotModel.load()
TIMESTEP_S = float(ROBOT.model.opt.timestep)
#: what `mj_setConst` recomputes after a mass change
SET_CONST = {
    "body_subtreemass",
    "body_invweight0",
    "dof_M0",
    "dof_invweight0",
    "actuator_acc0",
    "light_poscom0",
}


def model_arrays(model: mujoco.MjModel) -> dict[str, bytes]:
    """Every array of the model, its options and statistics, as bytes."""
    out = {}
    for owner, prefix in ((model, ""), (model.opt, "opt."), (model.stat, "stat.")):
        for name in dir(owner):
            if name.startswith("_"):
                continue
            value = getattr(owner, name)
            if isinstance(value, (np.ndarray, float, int)):
                out[prefix + name] = np.asarray(value).tobytes()
    return out


def changed_arrays(a: mujoco.MjModel, b: mujoco.MjModel) -> set[str]:
    before, after = model_arrays(a), model_arrays(b)
    return {k for k in before if before[k] != after[k]}


def bits(v: Variation) -> tuple[str | None, ...]:
    """Every float of a variation as its exact bits."""
    out: list[str | None] = []
    for f in FIELDS:
        value = getattr(v, f)
        values = value if isinstance(value, tuple) else (value,)
        out += [None if x is None else float.hex(x) for x in values]
    return tuple(out)


# --- vary_model -------------------------------------------------------------------------------


def test_the_nominal_variation_gives_an_equal_copy_and_the_robot_model_is_never_changed():
    before = model_arrays(ROBOT.model)
    nominal = vary_model(ROBOT, NOMINAL)
    assert nominal is not ROBOT.model
    assert model_arrays(nominal) == before
    nominal.geom_friction[0, 0] = 0.1  # a copy, not a view
    vary_model(ROBOT, sample(VariationRanges(), 1, seed=3)[0])
    assert model_arrays(ROBOT.model) == before


GEOM = {name: ROBOT.model.geom(name).id for name in FRICTION_GEOMS}
ACT, DOF, TRUNK = ROBOT.actuator_ids, ROBOT.dof_adr, ROBOT.trunk_id
MASS = {"body_mass", "body_inertia"} | SET_CONST


@pytest.mark.parametrize(
    ("field", "value", "changes"),
    [
        ("friction", 0.4, {"geom_friction"}),
        ("trunk_mass_scale", 1.15, MASS),
        ("link_mass_scale", 0.9, MASS),
        ("kp_scale", 1.2, {"actuator_gainprm", "actuator_biasprm"}),
        ("torque_scale", 0.8, {"actuator_forcerange"}),
        ("damping_scale", 1.2, {"dof_damping"}),
        ("frictionloss_scale", 0.8, {"dof_frictionloss"}),
        ("tilt_deg", 3.0, {"opt.gravity"}),
        ("tilt_direction_deg", 45.0, set()),  # no tilt, no change
        ("latency_ms", 40.0, set()),  # these act on the set-points (ServoPath)
        ("deadband_deg", 0.5, set()),
        ("backlash_deg", 1.0, set()),
        ("calibration_deg", (1.5,) * 12, set()),
    ],
)
def test_each_field_changes_what_it_claims_in_the_model_and_nothing_else(field, value, changes):
    nominal = ROBOT.model
    model = vary_model(ROBOT, Variation(**{field: value}))
    assert changed_arrays(nominal, model) == changes
    if field == "friction":
        assert model.geom_friction[list(GEOM.values()), 0].tolist() == [0.4] * 3
        rest = np.delete(np.arange(model.ngeom), list(GEOM.values()))
        assert np.array_equal(model.geom_friction[rest], nominal.geom_friction[rest])
        assert np.array_equal(model.geom_friction[:, 1:], nominal.geom_friction[:, 1:])
    elif field in ("trunk_mass_scale", "link_mass_scale"):
        trunk = field == "trunk_mass_scale"
        bodies = [TRUNK] if trunk else [b for b in range(1, model.nbody) if b != TRUNK]
        scale = np.ones(model.nbody)
        scale[bodies] = value
        assert np.array_equal(model.body_mass, nominal.body_mass * scale)
        assert np.array_equal(model.body_inertia, nominal.body_inertia * scale[:, None])
        assert np.array_equal(model.body_ipos, nominal.body_ipos)  # same centres of mass
    elif field == "kp_scale":
        kp = nominal.actuator_gainprm[ACT, 0]
        assert model.actuator_gainprm[ACT, 0].tolist() == (kp * 1.2).tolist()
        assert model.actuator_biasprm[ACT, 1].tolist() == (-kp * 1.2).tolist()
        assert np.array_equal(model.actuator_biasprm[:, 2], nominal.actuator_biasprm[:, 2])
    elif field == "torque_scale":
        stall = nominal.actuator_forcerange[ACT, 1]
        assert model.actuator_forcerange[ACT, 1].tolist() == (stall * 0.8).tolist()
        assert model.actuator_forcerange[ACT, 0].tolist() == (-stall * 0.8).tolist()
    elif field == "damping_scale":
        assert model.dof_damping[DOF].tolist() == (nominal.dof_damping[DOF] * 1.2).tolist()
        assert not model.dof_damping[:6].any()  # the free joint keeps none
    elif field == "frictionloss_scale":
        assert (
            model.dof_frictionloss[DOF].tolist() == (nominal.dof_frictionloss[DOF] * 0.8).tolist()
        )


def test_a_mass_change_updates_the_constants_that_follow_from_the_masses():
    model = vary_model(ROBOT, Variation(trunk_mass_scale=1.15, link_mass_scale=0.9))
    trunk, total = ROBOT.model.body_mass[TRUNK], ROBOT.total_mass_kg()
    assert model.body_subtreemass[TRUNK] == pytest.approx(1.15 * trunk + 0.9 * (total - trunk))
    for body in range(model.nbody):
        if body not in (0, TRUNK):
            expected = 0.9 * ROBOT.model.body_subtreemass[body]
            assert model.body_subtreemass[body] == pytest.approx(expected, rel=1e-12)
    # the joint-space inertia at qpos0 follows (mj_setConst); the armature is the servo's own
    armature = ROBOT.model.dof_armature[DOF]
    expected = 0.9 * (ROBOT.model.dof_M0[DOF] - armature) + armature
    assert model.dof_M0[DOF] == pytest.approx(expected, rel=1e-12)
    assert varied_robot(ROBOT, Variation(link_mass_scale=0.9)).total_mass_kg() == pytest.approx(
        trunk + 0.9 * (total - trunk)
    )


@pytest.mark.parametrize(("tilt", "direction"), [(3.0, 0.0), (2.5, 90.0), (1.0, 215.0), (30, 359)])
def test_tilt_rotates_gravity_by_the_stated_angle_towards_the_stated_direction(tilt, direction):
    g0 = ROBOT.model.opt.gravity.copy()
    g = vary_model(ROBOT, Variation(tilt_deg=tilt, tilt_direction_deg=direction)).opt.gravity
    assert np.linalg.norm(g) == pytest.approx(np.linalg.norm(g0), rel=1e-15)
    angle = math.degrees(math.acos(np.dot(g, g0) / np.dot(g0, g0)))
    assert angle == pytest.approx(tilt, abs=1e-9)
    heading = math.degrees(math.atan2(g[1], g[0])) % 360.0
    assert heading == pytest.approx(direction, abs=1e-9)  # the floor descends that way
    assert np.array_equal(tilted(g0, 0.0, direction), g0)


def test_a_varied_robot_keeps_its_addresses_and_runs_in_the_frame_loop():
    robot = varied_robot(ROBOT, Variation(friction=0.5, kp_scale=0.9))
    assert robot.actuator_ids is ROBOT.actuator_ids and robot.model is not ROBOT.model
    sim = FrameLoop(robot)
    sim.step_frame()
    assert not sim.fell


# --- the set-point path -----------------------------------------------------------------------


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


# --- samples ----------------------------------------------------------------------------------


def test_the_same_seed_gives_the_same_sample_to_the_bit_and_another_seed_another():
    ranges = VariationRanges()
    first = sample(ranges, 40, seed=7)
    assert [bits(v) for v in sample(ranges, 40, seed=7)] == [bits(v) for v in first]
    assert [v.name for v in sample(ranges, 40, seed=8)] != [v.name for v in first]
    assert sample(ranges, 10, seed=7) == first[:10]  # a prefix of a longer draw
    assert len({v.name for v in first}) == 40
    # the table is PCG64's raw 64-bit stream cut to 53-bit doubles (numpy keeps bit streams
    # stable across versions), and the first row is the first variation
    raw = np.random.PCG64(7).random_raw(2 * len(SAMPLE_COLUMNS))
    u = (raw >> np.uint64(11)) * 2.0**-53
    table = np.random.Generator(np.random.PCG64(7)).random((2, len(SAMPLE_COLUMNS)))
    assert table.tobytes() == u.tobytes()
    assert first[0].friction == round(0.4 + 0.6 * u[0], 3)
    assert first[0].calibration_deg[-1] == round(-1.5 + 3.0 * u[len(SAMPLE_COLUMNS) - 1], 2)
    # on every machine: the first variation of seed 0, as printed by this code on numpy 2.4
    assert sample(ranges, 1, seed=0)[0].name.startswith(
        "friction=0.782,trunk_mass_scale=0.931,link_mass_scale=0.908,kp_scale=0.807,"
    )


def test_samples_fill_their_ranges_and_narrowing_one_range_keeps_the_other_draws():
    ranges = VariationRanges().with_range("push_n_s", 0.2, 1.0)  # (no push by default)
    drawn = sample(ranges, 400, seed=11)
    for field in FIELDS:
        low, high = getattr(ranges, field)
        values = np.array([getattr(v, field) for v in drawn], dtype=float)
        if field in DIRECTIONS:
            high = 360.0 - 0.1
        assert values.min() >= low and values.max() <= high, field
        assert values.min() < low + 0.05 * (high - low) and values.max() > high - 0.05 * (
            high - low
        ), field
    narrow = sample(ranges.with_range("friction", 0.3, 0.3).with_range("latency_ms", 5, 9), 400, 11)
    assert {v.friction for v in narrow} == {0.3}
    assert {v.latency_ms for v in narrow} <= {5.0, 6.0, 7.0, 8.0, 9.0}
    for a, b in zip(drawn, narrow, strict=True):
        assert dataclasses.replace(a, friction=0.3, latency_ms=b.latency_ms) == b


def test_the_sensors_draws_leave_the_physics_draws_and_no_push_leaves_no_push_fields():
    """The sensors' errors come from a stream of their own: widening or narrowing their ranges
    leaves the physics drawn for a seed as they were; without a push its time and direction
    stay at 0, so a variation's name does not carry them."""
    plain = sample(VariationRanges(), 50, seed=3)
    other = (
        VariationRanges()
        .with_range("gyro_noise_deg_s", 0.0, 1.0)
        .with_range("imu_delay_ms", 0.0, 40.0)
    )
    assert [v.physics for v in sample(other, 50, seed=3)] == [v.physics for v in plain]
    assert all(v.push_n_s == v.push_time_s == v.push_direction_deg == 0.0 for v in plain)
    assert all("push" not in v.name for v in plain)
    assert all(v.physics.is_nominal is False and v.imu_delay_ms >= 2.0 for v in plain)


# --- text -------------------------------------------------------------------------------------


def test_the_cli_text_names_the_non_nominal_fields_only():
    v = parse_variation("friction=0.4, latency_ms=40,cal.l_knee=1.2,tilt_deg=2")
    assert v == Variation(
        friction=0.4,
        latency_ms=40.0,
        tilt_deg=2.0,
        calibration_deg=tuple(1.2 if j == "l_knee" else 0.0 for j in JOINT_NAMES),
    )
    assert v.to_text() == v.name == "friction=0.4,latency_ms=40,tilt_deg=2,cal.l_knee=1.2"
    assert NOMINAL.to_text() == "" and NOMINAL.name == "nominal" and NOMINAL.is_nominal
    assert parse_variation("nominal") == parse_variation("") == NOMINAL
    assert Variation(calibration_deg=(-0.0,) * 12).is_nominal  # -0.0 is stored as 0.0


finite = {"allow_nan": False, "allow_infinity": False}
variations = st.builds(
    Variation,
    friction=st.none() | st.floats(0.01, 1.0),
    trunk_mass_scale=st.floats(0.1, 5.0),
    link_mass_scale=st.floats(0.1, 3.0) | st.just(1.0),
    kp_scale=st.floats(0.1, 3.0),
    torque_scale=st.floats(0.1, 1.2),
    damping_scale=st.just(1.0) | st.floats(0.1, 10.0),
    frictionloss_scale=st.floats(0.5, 2.0),
    latency_ms=st.floats(0.0, 200.0),
    deadband_deg=st.floats(0.0, 1.0),
    backlash_deg=st.just(0.0) | st.floats(0.0, 5.0),
    tilt_deg=st.floats(0.0, 45.0),
    tilt_direction_deg=st.floats(0.0, 360.0, exclude_max=True),
    calibration_deg=st.tuples(*[st.just(0.0) | st.floats(-45.0, 45.0)] * 12),
)


@settings(max_examples=300, deadline=None)
@given(variations)
def test_the_text_reads_back_to_the_bit(v):
    text = v.to_text()
    assert bits(parse_variation(text)) == bits(v)
    assert parse_variation(v.name) == v
    assert text.count("=") == len(v.departures())


# --- refusals ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"friction": 0.0}, "friction must be ≥ 0.01 and ≤ 1"),
        ({"friction": 1.2}, "friction must be ≥ 0.01 and ≤ 1"),
        ({"friction": math.nan}, "friction must be ≥ 0.01 and ≤ 1"),
        # a floor too: friction 1e-6 blew the physics up at every start, a kp of 1e-300 was taken
        ({"friction": 5e-324}, "friction must be ≥ 0.01 and ≤ 1"),
        ({"kp_scale": 0.0}, "kp_scale must be ≥ 0.1"),
        ({"kp_scale": 1e-300}, "kp_scale must be ≥ 0.1"),
        ({"damping_scale": 0.05}, "damping_scale must be ≥ 0.1"),
        ({"trunk_mass_scale": -1.0}, "trunk_mass_scale must be ≥ 0.1"),
        ({"link_mass_scale": math.inf}, "link_mass_scale must be ≥ 0.1"),
        ({"torque_scale": 1.5}, "torque_scale must be ≥ 0.1 and ≤ 1.2"),
        ({"latency_ms": -1.0}, "latency_ms must be ≥ 0"),
        ({"deadband_deg": -0.1}, "deadband_deg must be ≥ 0"),
        ({"backlash_deg": math.inf}, "backlash_deg must be ≥ 0"),
        ({"tilt_deg": 46.0}, "tilt_deg must be ≥ 0 and ≤ 45"),
        ({"tilt_direction_deg": 360.0}, "tilt_direction_deg must be ≥ 0 and < 360"),
        ({"calibration_deg": (0.0,) * 11}, "calibration_deg needs 12 values"),
        ({"calibration_deg": (0.0,) * 11 + (math.nan,)}, "cal.r_ankle_roll must be ≥ -45"),
        # every field has a physical upper bound (a latency of 1e308 ms killed the server)
        ({"latency_ms": 1e308}, "latency_ms must be ≥ 0 and ≤ 200"),
        ({"latency_ms": 201.0}, "latency_ms must be ≥ 0 and ≤ 200"),
        ({"kp_scale": 5.01}, "kp_scale must be ≥ 0.1 and ≤ 5"),
        ({"trunk_mass_scale": 1e10}, "trunk_mass_scale must be ≥ 0.1 and ≤ 5"),
        ({"link_mass_scale": 3.5}, "link_mass_scale must be ≥ 0.1 and ≤ 3"),
        ({"damping_scale": 1e300}, "damping_scale must be ≥ 0.1 and ≤ 10"),
        ({"frictionloss_scale": 11.0}, "frictionloss_scale must be ≥ 0.1 and ≤ 10"),
        ({"deadband_deg": 10.5}, "deadband_deg must be ≥ 0 and ≤ 10"),
        ({"backlash_deg": 90.0}, "backlash_deg must be ≥ 0 and ≤ 10"),
        ({"calibration_deg": (0.0,) * 11 + (46.0,)}, "cal.r_ankle_roll must be ≥ -45 and ≤ 45"),
    ],
)
def test_bad_values_are_refused_naming_the_field_and_its_range(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Variation(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"friction": "0.4"}, "friction"), ({"kp_scale": True}, "kp_scale"),
     ({"calibration_deg": "1.5"}, "calibration_deg")],
)  # fmt: skip
def test_values_that_are_no_numbers_are_refused(kwargs, field):
    with pytest.raises(TypeError, match=field):
        Variation(**kwargs)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("friction", "'friction' is not key=value"),
        ("fricton=0.4", "unknown variation field 'fricton'; known: friction, "),
        ("calibration_deg=1", "unknown variation field 'calibration_deg'"),
        ("friction=0.4,friction=0.5", "friction is given twice"),
        ("cal.l_knee=1,cal.l_knee=2", "cal.l_knee is given twice"),
        ("cal.knee=1", "unknown joint in 'cal.knee'; joints: l_hip_yaw"),
        ("latency_ms=40ms", "latency_ms: '40ms' is not a number"),
        ("friction=2", "friction must be ≥ 0.01 and ≤ 1"),
        ("fsr_gain=0_5", "fsr_gain: '0_5' is not a number"),  # not 5: a typo of 0.5
        ("cal.l_knee=inf", "cal.l_knee must be ≥ -45 and ≤ 45"),
        ("latency_ms=1e308", "latency_ms must be ≥ 0 and ≤ 200"),
    ],
)
def test_bad_text_is_refused_naming_the_item(text, message):
    with pytest.raises(ValueError, match=message):
        parse_variation(text)


def test_ranges_are_set_by_name_and_checked():
    ranges = VariationRanges().with_range(*parse_range("friction=0.3:0.6"))
    assert ranges.friction == (0.3, 0.6) and ranges.kp_scale == (0.8, 1.2)
    with pytest.raises(ValueError, match=r"range of variation field friction must be ≥ 0\.01"):
        ranges.with_range("friction", 0.0, 0.5)
    with pytest.raises(ValueError, match=r"range of torque_scale: low 1.0 > high 0.9"):
        ranges.with_range("torque_scale", 1.0, 0.9)
    with pytest.raises(ValueError, match="range of variation field latency_ms must be ≥ 0"):
        ranges.with_range("latency_ms", -5, 5)
    with pytest.raises(ValueError, match="unknown variation field 'mass'"):
        ranges.with_range("mass", 0.9, 1.1)
    with pytest.raises(ValueError, match="must be name=low:high"):
        parse_range("friction=0.3")
    assert VariationRanges().with_range("tilt_direction_deg", 90, 360).tilt_direction_deg[1] == 360


# --- physics ----------------------------------------------------------------------------------


def push_sideways(variation: Variation, force_n: float = 3.0) -> float:
    """Lateral slide of the standing robot (m) after a 0.3 s push at the trunk, 0.2 s later."""
    model = vary_model(ROBOT, variation)
    sim = FrameLoop(ROBOT)  # standing, set-points held; its MjData fits the varied copy
    mujoco.mj_step(model, sim.data, 300)
    y0 = float(sim.data.qpos[1])
    sim.data.xfrc_applied[TRUNK, 1] = force_n
    mujoco.mj_step(model, sim.data, 300)
    sim.data.xfrc_applied[:] = 0.0
    mujoco.mj_step(model, sim.data, 200)
    return float(sim.data.qpos[1]) - y0


def test_low_friction_lets_a_pushed_robot_slide_where_the_nominal_floor_holds_it():
    """3 N sideways exceeds what the soles hold at friction 0.15 (0.15·m·g = 2.4 N for the
    1.65 kg robot) and is far below it at the model's 0.7 (11.3 N)."""
    slide_low, slide_nominal = (push_sideways(Variation(friction=f)) for f in (0.15, 0.7))
    assert slide_low > 0.01  # > 1 cm
    assert slide_nominal < 0.004  # the joints give a little; the feet stay
    assert slide_low > 5 * slide_nominal


def joint_response(latency_ms: float, step_rad: float) -> np.ndarray:
    """l_hip_pitch angle of the standing robot per 1 ms step, its set-point stepped at 200 ms."""
    sim = FrameLoop(ROBOT)
    initial = sim.data.ctrl[ACT].copy()
    commands = np.tile(initial, (400, 1))
    commands[200:, 2] += step_rad
    ctrl = ServoPath(Variation(latency_ms=latency_ms), TIMESTEP_S, initial)(commands)
    angle = []
    for row in ctrl:
        sim.data.ctrl[ACT] = row
        mujoco.mj_step(ROBOT.model, sim.data)
        angle.append(sim.data.qpos[ROBOT.qpos_adr[2]])
    return np.array(angle)


def test_a_40_ms_latency_delays_a_joints_response_by_40_ms():
    still, prompt, late = (joint_response(ms, step) for ms, step in [(0, 0), (0, 0.1), (40, 0.1)])
    first_move = [int(np.argmax(a != still)) for a in (prompt, late)]
    assert first_move == [200, 240]
    halfway = [int(np.argmax(np.abs(a - still) > 0.05)) for a in (prompt, late)]
    assert halfway[1] - halfway[0] == 40
