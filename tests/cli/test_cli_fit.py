"""`artro run --script identify --record` and `artro fit` as a builder runs them (docs/FIT.md):
a simulated recording fitted, the fitted robot and its report written, the fitted robot walked
by `artro run`; bad input refused with a sentence and exit status 2, nothing written."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import yaml

ARTRO = [sys.executable, "-m", "app.cli"]
TRUTH = "tilt_deg=1.2,tilt_direction_deg=40,gyro_bias_deg_s=0.25"

pytestmark = pytest.mark.slow


def artro(*args: str, cwd) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*ARTRO, *args], capture_output=True, text=True, timeout=900, cwd=cwd)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    here = tmp_path_factory.mktemp("fit")
    out = artro("run", "--script", "identify", "--record", "rec.json", "--vary", TRUTH, cwd=here)
    assert out.returncode == 0, out.stderr
    assert "recorded identify (60 s, 3000 frames)" in out.stdout
    return here


@pytest.fixture(scope="module")
def fitted(folder):
    out = artro("fit", "rec.json", "--fields", "tilt,gyro_bias_deg_s", "--budget", "40",
                "--workers", "1", "--json", cwd=folder)  # fmt: skip
    return out


def test_the_fit_writes_the_fitted_robot_and_its_report(folder, fitted):
    assert fitted.returncode == 0, fitted.stderr
    summary = json.loads(fitted.stdout)
    assert summary["converged"] and summary["source"] == "simulation"
    assert summary["fields"]["gyro_bias_deg_s"]["value"] == pytest.approx(0.25, abs=0.1)
    assert summary["fields"]["gyro_bias_deg_s"]["truth"] == pytest.approx(0.25)
    assert "% of the search" in fitted.stderr  # progress
    description = yaml.safe_load((folder / "rec-fitted.yaml").read_text())
    assert description["name"] == "artro"
    assert "tilt_deg=" in description["fitted"]["variation"]
    report = (folder / "rec-fit" / "report.md").read_text()
    assert "| gyro_bias_deg_s |" in report and "artro tune --robot" in report
    assert (folder / "rec-fit" / "traces.png").stat().st_size > 10_000


def test_the_fitted_robot_walks_its_fit(folder, fitted):
    out = artro("run", "--robot", "rec-fitted.yaml", "--duration", "2", "--warmup", "0",
                "--json", cwd=folder)  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "is fitted to rec.json: walking its fit" in out.stderr
    fitted_variation = yaml.safe_load((folder / "rec-fitted.yaml").read_text())["fitted"]
    assert json.loads(out.stdout)["variation"] == fitted_variation["variation"]


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["nothing.json"], "cannot read nothing.json"),
        (["rec.json", "--robot", "micro"], "recorded on the robot 'artro'"),
        (["rec.json", "--fields", "mass"], "unknown field 'mass': choose from latency_ms"),
        (["rec.json", "--fix", "kp=1"], "unknown variation field 'kp'"),
        (["rec.json", "--budget", "3"], "budget must be a whole number 10 to 5000"),
        (["rec.json", "--wait-workers", "5"], "--cluster's workers; give both"),
        (["rec.json", "--cluster", "http://host:8786"], "unsupported scheduler address"),
    ],
)
def test_bad_input_is_refused(folder, args, said):
    out = artro("fit", *args, "-o", "bad.yaml", cwd=folder)
    assert out.returncode == 2, out.stderr
    assert said in out.stderr
    assert not (folder / "bad.yaml").exists()
