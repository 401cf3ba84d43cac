"""Model variations (docs/DESIGN.md §8): each field changes what it claims in the compiled model
and nothing else, the set-point path delays, offsets and plays as stated in any chunking, samples
and names reproduce to the bit, bad input is refused, and a varied world behaves as it should."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.robots.model import RobotModel
from app.sim.frame_loop import FrameLoop
from app.worlds.sampling import VariationRanges, parse_range, sample
from app.worlds.servo_path import ServoPath
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
