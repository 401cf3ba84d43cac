"""The robustness report's servo advice (docs/DESIGN.md §7, §12): a case whose failing runs sat
at a servo's torque limit for longer than its passing runs is torque-bound; eq (1) then asks
1.2 x its stall torque, the weakest servo of the table that gives it is named, and the robot
with it swapped in still adds up."""

from __future__ import annotations

import pytest
import yaml

from app.analysis.servo_advice import MIN_LIMIT_SHARE, advised_robot, servo_advice, torque_bound
from app.assets import builtin_robots_dir
from app.robots.library import load_description
from app.robots.model import RobotModel
from app.robots.servos import rating_at, servo_table
from app.robots.swap import mirror, smallest_servo, with_servo, write_description
from app.sim.headless import AT_LIMIT
from app.study.robust_report import _servo_lines
from gait import JOINT_NAMES

ARTRO = load_description("artro")
MG996R_NM = 11.0 * 0.0980665  # at 6 V (models/servos.yaml)
STALL = [MG996R_NM] * 12
KNEES = [JOINT_NAMES.index("l_knee"), JOINT_NAMES.index("r_knee")]


def run_with_peaks(at_stall: list[int], fell: bool = False, share: float = 0.1) -> dict:
    """A run whose `at_stall` servos reached their stall torque and ended `share` of its frames
    there (the others 1 %)."""
    peaks = [0.4 * MG996R_NM] * 12
    shares = [0.01] * 12
    for j in at_stall:
        peaks[j] = MG996R_NM  # the actuator's force limit: the most it gives
        shares[j] = share
    return {"fell": fell, "peak_torque_nm": peaks, "at_limit_share": shares}


def test_the_weakest_servo_that_gives_the_torque_is_chosen():
    assert smallest_servo(0.5, 6.0).name == "MG995"  # 0.98 N·m at 6 V, the MG996R 1.08
    choice = smallest_servo(1.2 * MG996R_NM, 6.0)
    assert choice.name == "DS3218" and choice.stall_torque_nm > 1.2 * MG996R_NM
    assert smallest_servo(5.0, 6.0) is None  # none of the table is that strong


def test_failing_runs_that_sit_longer_at_the_knees_limit_are_torque_bound():
    """Every run touches the knees' limit at each step; failing runs that sit there for more of
    their frames than the passing runs (by LIMIT_Z standard errors) are held back by them."""
    failed = [run_with_peaks(KNEES, share=s) for s in (0.28, 0.30, 0.32)] + [run_with_peaks([])]
    passed = [run_with_peaks(KNEES, share=s) for s in (0.10, 0.12, 0.14)]
    nominal = run_with_peaks(KNEES, share=0.12)
    t = torque_bound(failed[:3], passed, nominal, STALL)
    assert t["bound"] and t["joints"] == ["l_knee", "r_knee"]
    assert t["at_limit_share"]["l_knee"] == pytest.approx([0.30, 0.12])
    assert (t["failing_runs"], t["at_stall_runs"], t["reference"]) == (3, 3, "passing runs")
    # one failing run elsewhere spreads them: 0.23 against 0.12 is within two standard errors
    assert not torque_bound(failed, passed, nominal, STALL)["bound"]
    assert torque_bound(failed, passed, nominal, STALL)["at_stall_runs"] == 3
    assert t["peak_nm"] == pytest.approx(MG996R_NM)
    # as long at the limit as the passing runs: at their stall torque, but not what fails them
    alike = [run_with_peaks(KNEES, share=s) for s in (0.10, 0.12, 0.14)]
    assert not torque_bound(alike, passed, nominal, STALL)["bound"]
    assert torque_bound(alike, passed, nominal, STALL)["at_stall_runs"] == 3
    # longer, but seldom at all (under MIN_LIMIT_SHARE): not bound
    seldom = [run_with_peaks(KNEES, share=s) for s in (0.03, 0.04, 0.04)]
    quiet = [run_with_peaks(KNEES, share=0.0), run_with_peaks(KNEES, share=0.001)]
    assert MIN_LIMIT_SHARE > 0.04 and not torque_bound(seldom, quiet, nominal, STALL)["bound"]
    assert torque_bound([], passed, nominal, STALL) is None


def test_with_fewer_than_two_passing_runs_the_nominal_run_is_the_reference():
    failed = [run_with_peaks(KNEES, share=s) for s in (0.28, 0.30, 0.32)]
    t = torque_bound(failed, [run_with_peaks(KNEES)], run_with_peaks(KNEES, share=0.12), STALL)
    assert t["bound"] and t["reference"] == "the nominal run"
    assert t["at_limit_share"]["r_knee"] == pytest.approx([0.30, 0.12])
    high = run_with_peaks(KNEES, share=0.30)  # the nominal robot is there as long
    assert not torque_bound(failed, [], high, STALL)["bound"]


def test_a_weaker_servo_reaches_its_stall_torque_at_its_own_limit():
    """A variation's torque_scale lowers the servos' force range (docs/DESIGN.md §12): a run at
    0.85 is at its stall torque at 0.85 x the described one, which the described figure never
    reaches."""
    weak = run_with_peaks([])
    for j in KNEES:
        weak["peak_torque_nm"][j] = 0.85 * MG996R_NM
    nominal = run_with_peaks([])
    assert torque_bound([weak], [], nominal, STALL)["at_stall_runs"] == 0
    assert torque_bound([weak], [], nominal, STALL, [0.85])["at_stall_runs"] == 1
    assert torque_bound([weak], [], nominal, STALL, [0.9])["at_stall_runs"] == 0
    assert AT_LIMIT > 0.98


def test_the_advice_names_the_servo_for_the_joints_at_their_limit():
    passed, nominal = [run_with_peaks(KNEES), run_with_peaks(KNEES)], run_with_peaks(KNEES)
    failed = [run_with_peaks(KNEES, share=0.3), run_with_peaks(KNEES, share=0.32)]
    bound = torque_bound(failed, passed, nominal, STALL)
    free = torque_bound([run_with_peaks(KNEES), run_with_peaks(KNEES)], passed, nominal, STALL)
    report = {
        "cases": [
            {"case": "sideways right", "torque": bound},
            {"case": "forward", "torque": free},
            {"case": "on the spot", "torque": None},
        ]
    }
    advice = servo_advice(report, ARTRO, STALL)
    assert advice["cases"] == ["sideways right"]
    (group,) = advice["groups"]
    assert group["joints"] == ["l_knee", "r_knee"] and group["servo_now"] == "MG996R"
    assert group["need_nm"] == pytest.approx(1.2 * MG996R_NM)
    assert group["servo"] == "DS3218"
    assert servo_advice({"cases": report["cases"][1:]}, ARTRO, STALL) is None


def mixed_robot(tmp_path):
    """ArtRo with MG995 servos and an MG90S on each hip yaw (issue 56's robot)."""
    doc = yaml.safe_load((builtin_robots_dir() / "artro.yaml").read_text(encoding="utf-8"))
    doc["name"], doc["servo"] = "mixed", "MG995"
    doc.pop("total_mass_kg")
    doc["joints"]["l_hip_yaw"], doc["joints"]["r_hip_yaw"] = {"servo": "MG90S"}, {"servo": "MG90S"}
    path = tmp_path / "mixed.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return RobotModel.load(path)


def test_the_advice_is_per_servo_each_with_its_own_torque_and_symmetric(tmp_path):
    """Issue 56: `bench robust` said "eq (1) asks 1.18 N·m of l_hip_yaw, l_knee, r_knee (1.2 x
    the 0.98 N·m they reached)" of an MG90S hip yaw (0.22 N·m) and MG995 knees (0.98), and its
    robot file put a DS3218 on the left hip yaw only."""
    robot = mixed_robot(tmp_path)
    stall = robot.model.actuator_forcerange[robot.actuator_ids, 1].tolist()  # the model's own
    at_limit = [JOINT_NAMES.index(j) for j in ("l_hip_yaw", "l_knee", "r_knee")]
    failed = [run_with_peaks(at_limit, share=s) for s in (0.28, 0.30, 0.32)]
    passed = [run_with_peaks(at_limit, share=s) for s in (0.10, 0.12, 0.14)]
    bound = torque_bound(failed, passed, run_with_peaks(at_limit), stall)
    assert bound["joints"] == ["l_hip_yaw", "l_knee", "r_knee"]
    advice = servo_advice({"cases": [{"case": "forward", "torque": bound}]}, robot.description,
                          stall)  # fmt: skip
    yaw, knees = advice["groups"]
    mg90s, mg995 = (rating_at(servo_table()[n], 6.0, n)[0] for n in ("MG90S", "MG995"))
    assert yaw["joints"] == ["l_hip_yaw", "r_hip_yaw"] and yaw["servo_now"] == "MG90S"
    assert yaw["stall_nm"] == pytest.approx(mg90s, abs=1e-6)
    assert yaw["need_nm"] == pytest.approx(1.2 * mg90s, abs=1e-6)
    assert knees["joints"] == ["l_knee", "r_knee"] and knees["servo_now"] == "MG995"
    assert knees["need_nm"] == pytest.approx(1.2 * mg995, abs=1e-6)
    for g in (yaw, knees):
        assert g["servo_stall_nm"] >= g["need_nm"]
    text = "\n".join(_servo_lines({"cases": [], "servo_advice": advice}))
    assert f"of l_hip_yaw, r_hip_yaw (1.2 x the {mg90s:.2f} N·m their MG90S reached)" in text
    assert f"of l_knee, r_knee (1.2 x the {mg995:.2f} N·m their MG995 reached)" in text
    advised = advised_robot(robot.description, advice)
    again = RobotModel.load(write_description(advised, tmp_path / "advised.yaml"))
    assert again.name == "mixed-advised"
    limits = dict(
        zip(JOINT_NAMES, again.model.actuator_forcerange[again.actuator_ids, 1], strict=True)
    )
    for joint in JOINT_NAMES:  # both legs alike, each joint with its group's servo
        assert again.description.joint_servo(joint) == again.description.joint_servo(mirror(joint))
        group = next((g for g in advice["groups"] if joint in g["joints"]), None)
        want = robot.description.joint_servo(joint) if group is None else group["servo"]
        assert again.description.joint_servo(joint) == want, joint
        assert limits[joint] >= (group["need_nm"] if group else 0.0) - 1e-9


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
