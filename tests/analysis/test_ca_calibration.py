"""`artro calibrate-ca`: K and b_eff from curve walks (the solver against a known response, then
one real calibration)."""

import json
import math

import pytest

from app.analysis.ca_calibration import CalibrationError, calibrate_ca
from app.cli import main
from app.evaluation import Job
from app.params.formats import load_parameter_set
from gait import GaitParams, Motion

SPEED_CM_S, FEET_CM = 3.0, 10.0
TARGET = math.degrees(-2 * 0.03 / 0.10)  # eq (13): deg/s per unit CA


class Response:
    """A stand-in for the batch evaluator: theta_dot = drift + slope(K) CA, deg/s."""

    def __init__(self, slope, drift=0.3, falls_at=None):
        self.slope, self.drift, self.falls_at = slope, drift, falls_at
        self.jobs: list[Job] = []

    def evaluate(self, jobs, *, duration_s, warmup_s=5.0, progress=None):
        self.jobs += jobs
        out = []
        for job in jobs:
            k, ca = job.params.steer.yaw_per_ca, job.motion.ca
            out.append(
                {
                    "fell": self.falls_at == (k, ca),
                    "forward_cm_s": SPEED_CM_S,
                    "feet_distance_cm": FEET_CM,
                    "turn_deg_s": self.drift + self.slope(k) * ca,
                }
            )
        if progress:
            progress(len(jobs), len(jobs))
        return out


def test_a_linear_response_is_solved_in_one_step():
    """CA alone turns at 40 % of eq (13), each 0.1 of K adds 50 %: K = 0.12 and b_eff = b."""
    response = Response(lambda k: TARGET * (0.4 + 5.0 * k))
    lines = []
    result = calibrate_ca(GaitParams(), Motion(), response, say=lines.append)
    assert result.yaw_per_ca == pytest.approx(0.12)
    assert result.gain == pytest.approx(1.0) and result.converged
    assert result.axle_eff_m == pytest.approx(0.10)
    assert result.axle_eff_without_m == pytest.approx(0.10 / 0.4)
    assert result.target_slope_deg_s == pytest.approx(TARGET)
    assert [t.yaw_per_ca for t in result.trials] == [0.0, 0.15, 0.12]
    # walked forward at 0.07 (it stood), at CA = -0.1, 0, +0.1; one batch, then one check
    assert {j.motion.a_p for j in response.jobs} == {0.07}
    assert {j.motion.ca for j in response.jobs} == {-0.1, 0.0, 0.1}
    assert len(response.jobs) == 5 + 2 and result.sim_s == 7 * 20.0
    assert any("runs done" in line for line in lines) and any("K = +0.1200" in x for x in lines)


def test_a_bent_response_takes_secant_steps():
    response = Response(lambda k: TARGET * (0.4 + 4.0 * k + 6.0 * k * k))
    result = calibrate_ca(GaitParams(), Motion(a_p=0.05), response, iterations=4)
    assert result.converged and abs(result.gain - 1.0) <= 0.1
    assert 0.4 + 4.0 * result.yaw_per_ca + 6.0 * result.yaw_per_ca**2 == pytest.approx(1, abs=0.1)
    assert {j.motion.a_p for j in response.jobs} == {0.05}


def test_no_answer_is_said_as_such():
    with pytest.raises(CalibrationError, match="K does not change"):
        calibrate_ca(GaitParams(), Motion(), Response(lambda k: TARGET * 0.4))
    with pytest.raises(CalibrationError, match=r"fell at \(K, CA\) = \[\(0.15, 0.1\)\]"):
        calibrate_ca(GaitParams(), Motion(), Response(lambda k: TARGET, falls_at=(0.15, 0.1)))


def test_artro_calibrate_ca_on_the_real_model(tmp_path, capsys):
    """Short walks of the paper gait: the fitted K steers it at least as eq (13) says within the
    tolerance or is reported as not converged; the written parameter set carries K."""
    out = tmp_path / "steered.json"
    args = ["calibrate-ca", "--duration", "8", "--warmup", "2", "--iterations", "1"]
    args += ["--direction", "forward"]
    assert main([*args, "--threads", "2", "--json", "-o", str(out)]) == 0
    captured = capsys.readouterr()
    (result,) = json.loads(captured.out).values()
    assert "runs done" in captured.err and "K = +0.1500" in captured.err
    k = result["yaw_per_ca"]
    assert load_parameter_set(out).gait.steer.yaw_per_ca == k
    assert [t["yaw_per_ca"] for t in result["trials"]][:2] == [0.0, 0.15]
    assert result["feet_m"] > 0.05 and result["speed_m_s"] > 0.0
    # the chosen K turns the robot the way CA asks, closer to eq (13) than CA alone
    gains = {t["yaw_per_ca"]: t["gain"] for t in result["trials"]}
    assert gains[k] > 0 and abs(gains[k] - 1) <= abs(gains[0.0] - 1)
    assert result["axle_eff_m"] == pytest.approx(result["feet_m"] / gains[k])


def test_a_step_that_overshot_is_kept_to_bracket_the_next():
    """`paper` backward: K = 0 and 0.15 both turned short of eq (13), the secant overshot to
    K = 1.0 (1821 %), and the next secant, through the two nearest (0 and 0.15), went back to
    1.0: the calibration stopped at -10 %. The next K is drawn between the trials on either side."""
    from app.analysis.ca_calibration import Trial, _secant_pair

    target = math.radians(6.07)
    trials = [Trial(0.0, -1.75, 0.0), Trial(0.15, -0.61, 0.0), Trial(1.0, 110.59, 0.0)]
    (k_a, _), (k_b, _) = _secant_pair(trials, target)
    assert (k_a, k_b) == (0.15, 1.0)
    (k_a, _), (k_b, _) = _secant_pair(trials[:2], target)  # none above: the two nearest
    assert {k_a, k_b} == {0.0, 0.15}
