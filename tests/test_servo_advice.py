"""The robustness report's servo advice (docs/DESIGN.md §7, §12): a case whose failing runs had
a servo at its stall torque is torque-bound; eq (1) then asks 1.2 x that torque, the weakest
servo of the table that gives it is named, and the robot with it swapped in still adds up."""

from __future__ import annotations

import pytest

from app.analysis.robustness import AT_STALL, servo_advice, torque_bound
from app.robots.library import load_description
from app.robots.model import RobotModel
from app.robots.servos import servo_table
from app.robots.swap import smallest_servo, with_servo, write_description
from gait import JOINT_NAMES

ARTRO = load_description("artro")
MG996R_NM = 11.0 * 0.0980665  # at 6 V (models/servos.yaml)
STALL = [MG996R_NM] * 12
KNEES = [JOINT_NAMES.index("l_knee"), JOINT_NAMES.index("r_knee")]


def run_with_peaks(at_stall: list[int], fell: bool = False) -> dict:
    peaks = [0.4 * MG996R_NM] * 12
    for j in at_stall:
        peaks[j] = MG996R_NM  # the actuator's force limit: the most it gives
    return {"fell": fell, "peak_torque_nm": peaks}


def test_the_weakest_servo_that_gives_the_torque_is_chosen():
    assert smallest_servo(0.5, 6.0).name == "MG995"  # 0.98 N·m at 6 V, the MG996R 1.08
    choice = smallest_servo(1.2 * MG996R_NM, 6.0)
    assert choice.name == "DS3218" and choice.stall_torque_nm > 1.2 * MG996R_NM
    assert smallest_servo(5.0, 6.0) is None  # none of the table is that strong


def test_failures_with_the_knees_at_their_limit_are_torque_bound():
    failed = [run_with_peaks(KNEES), run_with_peaks(KNEES), run_with_peaks([])]
    t = torque_bound(failed, STALL)
    assert t["bound"] and t["joints"] == ["l_knee", "r_knee"]
    assert (t["failing_runs"], t["at_stall_runs"]) == (3, 2)
    assert t["peak_nm"] == pytest.approx(MG996R_NM)
    below = [run_with_peaks([]) for _ in range(3)]  # failing, but no servo near its limit
    assert not torque_bound(below, STALL)["bound"]
    just_under = run_with_peaks([])
    just_under["peak_torque_nm"][KNEES[0]] = 0.98 * MG996R_NM
    assert AT_STALL > 0.98 and not torque_bound([just_under], STALL)["bound"]
    assert torque_bound([], STALL) is None


def test_the_advice_names_the_servo_for_the_joints_at_their_limit():
    bound = torque_bound([run_with_peaks(KNEES)], STALL)
    free = torque_bound([run_with_peaks([])], STALL)
    report = {
        "cases": [
            {"case": "sideways right", "torque": bound},
            {"case": "forward", "torque": free},
            {"case": "on the spot", "torque": None},
        ]
    }
    advice = servo_advice(report, STALL, 6.0)
    assert advice["cases"] == ["sideways right"] and advice["joints"] == ["l_knee", "r_knee"]
    assert advice["need_nm"] == pytest.approx(1.2 * MG996R_NM)
    assert advice["servo"] == "DS3218"
    assert servo_advice({"cases": report["cases"][1:]}, STALL, 6.0) is None


def test_the_swapped_robot_adds_up_and_carries_the_new_servos(tmp_path):
    swapped = with_servo(ARTRO, ["l_knee", "r_knee"], "DS3218")
    table = servo_table()
    difference = 2 * (table["DS3218"].mass_kg - table["MG996R"].mass_kg)
    assert swapped.total_mass_kg == pytest.approx(ARTRO.total_mass_kg + difference)
    robot = RobotModel.load(write_description(swapped, tmp_path / "swapped.yaml"))
    assert robot.total_mass_kg() == pytest.approx(swapped.total_mass_kg, abs=1e-6)
    limits = robot.model.actuator_forcerange[robot.actuator_ids, 1]
    for i, joint in enumerate(JOINT_NAMES):
        expected = 2.0 if joint.endswith("knee") else MG996R_NM
        assert limits[i] == pytest.approx(expected, abs=0.01), joint


@pytest.mark.parametrize(
    ("joints", "servo", "says"),
    [(["l_knee"], "DS9999", "unknown servo"), (["knee"], "DS3218", "joints must be")],
)
def test_a_bad_swap_says_what_is_allowed(joints, servo, says):
    with pytest.raises(ValueError, match=says):
        with_servo(ARTRO, joints, servo)
