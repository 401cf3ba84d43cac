"""Forward kinematics of the built-in ArtRo model, generated from models/robots/artro.yaml,
against the leg interface (docs/DESIGN.md §3, §7)."""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.robots import build_spec, load_description
from app.robots.model import RobotModel
from gait import ARTRO_LEG, JOINT_NAMES, leg_to_joint_angles

ROBOT = RobotModel.load()
SIDES = (("l", 1.0), ("r", -1.0))  # roll and yaw axes are mirrored on the right leg


def rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def pose(legs: np.ndarray, eta_min: float = 0.875) -> mujoco.MjData:
    """The model with the trunk at the origin, upright, and the legs set by the leg interface."""
    data = mujoco.MjData(ROBOT.model)
    data.qpos[:7] = (0, 0, 0, 1, 0, 0, 0)
    data.qpos[ROBOT.qpos_adr] = leg_to_joint_angles(legs, eta_min)
    mujoco.mj_kinematics(ROBOT.model, data)
    return data


def test_names_masses_and_leg_lengths_match_the_gait():
    m = ROBOT.model
    for name in JOINT_NAMES:
        assert m.joint(name).type == mujoco.mjtJoint.mjJNT_HINGE
        assert m.actuator(name).trntype == mujoco.mjtTrn.mjTRN_JOINT
    for site in ("l_hip", "r_hip", "l_ankle", "r_ankle", "l_sole", "r_sole", "imu"):
        m.site(site)
    geometry = ROBOT.measured_leg_geometry()
    assert geometry.upper_m == pytest.approx(ARTRO_LEG.upper_m, abs=1e-12)
    assert geometry.lower_m == pytest.approx(ARTRO_LEG.lower_m, abs=1e-12)
    # masses add up: 12 servos of 55 g, brackets, feet, abdomen and the upper-body dummy
    assert ROBOT.total_mass_kg() == pytest.approx(1.65)
    spec = build_spec(load_description("artro"))
    servos = [g for g in spec.geoms if g.name.endswith("_servo")]
    assert len(servos) == 12
    assert sum(g.mass for g in servos) == pytest.approx(12 * 0.055)


def test_standing_pose_is_the_one_line_axis_design():
    data = pose(np.zeros((2, 6)))
    for side, _ in SIDES:
        hip, ankle, sole = (data.site(f"{side}_{s}").xpos for s in ("hip", "ankle", "sole"))
        yaw_axis_point = data.body(f"{side}_hip_yaw_link").xpos
        np.testing.assert_allclose(hip[:2], yaw_axis_point[:2], atol=1e-12)
        np.testing.assert_allclose(ankle[:2], hip[:2], atol=1e-12)
        np.testing.assert_allclose(sole[:2], hip[:2], atol=1e-12)


leg_values = st.lists(st.floats(-0.5, 0.5), min_size=5, max_size=5)


@settings(max_examples=60, deadline=None)
@given(left=leg_values, right=leg_values, gamma=st.tuples(st.floats(-1, 0), st.floats(-1, 0)))
def test_forward_kinematics_realises_leg_and_foot_angles(left, right, gamma):
    legs = np.array([[*left, gamma[0]], [*right, gamma[1]]])
    data = pose(legs)
    for leg, (side, mirror) in zip(legs, SIDES, strict=True):
        roll, pitch, yaw, foot_roll, foot_pitch, g = leg
        hip, ankle = data.site(f"{side}_hip").xpos, data.site(f"{side}_ankle").xpos
        eta = 1 + (1 - 0.875) * g  # eq (2)
        # hip -> ankle distance = eta * (L_UL + L_LL)
        assert np.linalg.norm(ankle - hip) == pytest.approx(eta * ARTRO_LEG.max_length_m)
        # hip -> ankle line = leg angle (yaw, then roll, then pitch, as the joints are stacked)
        leg_frame = rot_z(mirror * yaw) @ rot_x(mirror * roll)
        expected_dir = leg_frame @ rot_y(-pitch) @ np.array([0, 0, -1.0])
        np.testing.assert_allclose(
            (ankle - hip) / np.linalg.norm(ankle - hip), expected_dir, atol=1e-9
        )
        # sole orientation relative to the trunk = foot angle: the pitch joints add up to the
        # foot pitch, the roll joints to the foot roll (eqs 7-9)
        expected_sole = leg_frame @ rot_y(-foot_pitch) @ rot_x(mirror * (foot_roll - roll))
        sole = data.site(f"{side}_sole").xmat.reshape(3, 3)
        np.testing.assert_allclose(sole, expected_sole, atol=1e-9)


@pytest.mark.parametrize("side", ["l", "r"])
def test_pure_sagittal_and_pure_lateral_foot_angles_are_exact_tilts(side):
    """Pitch only: the sole pitches by the foot pitch (toe up > 0). Roll only: it rolls by the
    foot roll, outer edge up for positive roll on either leg."""
    k = 0 if side == "l" else 1
    legs = np.zeros((2, 6))
    legs[k] = [0.0, 0.2, 0.0, 0.0, 0.15, -0.6]
    sole = pose(legs).site(f"{side}_sole").xmat.reshape(3, 3)
    toe = sole[:, 0]
    assert np.arctan2(toe[2], toe[0]) == pytest.approx(0.15)
    legs[k] = [0.1, 0.0, 0.0, 0.08, 0.0, -0.3]
    sole = pose(legs).site(f"{side}_sole").xmat.reshape(3, 3)
    outward = sole[:, 1] * (1 if side == "l" else -1)  # the foot's outward axis
    assert np.arctan2(outward[2], np.hypot(outward[0], outward[1])) == pytest.approx(0.08)
