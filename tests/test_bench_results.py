"""bench/RESULTS.md is what bench/results_page.py renders from bench/results/*.json, every
results file is a whole document of a bench that exists, and the helper the benches write with
(bench/results.py) keeps JSON valid and standard output clean with `--json -`."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"


def load_module(name: str) -> ModuleType:
    """A module of bench/ (a folder of scripts, no package)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCH / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_script(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=120
    )


def test_the_page_is_what_the_results_render():
    done = run_script("bench/results_page.py", "--check")
    assert done.returncode == 0, (
        done.stdout + "\n(a bench run without --json writes bench/results/<bench>.json: "
        "render the page again, or remove the file if no result should be kept)"
    )


def test_every_results_file_is_a_whole_document_of_a_bench():
    page = load_module("results_page")
    names = page.benches()
    for path in sorted((BENCH / "results").glob("*.json")):
        doc = json.loads(path.read_text(encoding="utf-8"))
        assert doc["bench"] == path.stem and path.stem in names, path
        assert doc["command"].startswith(f"python bench/{path.stem}.py"), path
        assert "--json" not in doc["command"] and "json" not in doc["arguments"], path
        assert doc["headline"] and doc["figures"], path
        env = doc["environment"]
        for key in ("python", "mujoco", "numpy", "project_version", "finished_utc"):
            assert env[key], (path, key)
        assert env["machine"]["cpu_model"] and env["machine"]["logical_cpus"] >= 1, path


def test_a_bench_writes_a_document_the_page_shows(tmp_path):
    results = tmp_path / "results"
    done = run_script(
        "bench/bench_session.py", "--frames", "5", "--json", str(results / "bench_session.json")
    )
    assert done.returncode == 0, done.stderr
    assert "live robot frame" in done.stdout  # the text is printed as before
    doc = json.loads((results / "bench_session.json").read_text(encoding="utf-8"))
    assert doc["command"] == "python bench/bench_session.py --frames 5"
    assert doc["arguments"] == {"frames": 5}
    page_file = tmp_path / "RESULTS.md"
    rendered = run_script(
        "bench/results_page.py", "--results", str(results), "--out", str(page_file)
    )
    assert rendered.returncode == 0, rendered.stderr
    page = page_file.read_text(encoding="utf-8")
    assert "## bench_session" in page and "`python bench/bench_session.py --frames 5`" in page
    assert f"MuJoCo {doc['environment']['mujoco']}" in page
    for figure in doc["headline"]:
        assert f"| {figure} |" in page
    no_result = page.split("## No result yet", 1)[1]
    assert "`bench_batch`" in no_result and "`bench_session`" not in no_result
    check = run_script(
        "bench/results_page.py", "--results", str(results), "--out", str(page_file), "--check"
    )
    assert check.returncode == 0, check.stdout
    page_file.write_text(page.replace("bench_session", "bench_sessions"), encoding="utf-8")
    stale = run_script(
        "bench/results_page.py", "--results", str(results), "--out", str(page_file), "--check"
    )
    assert stale.returncode == 1 and "run python bench/results_page.py" in stale.stdout


def test_json_to_standard_output_leaves_the_text_on_standard_error():
    done = run_script("bench/bench_session.py", "--frames", "5", "--json", "-")
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)  # standard output holds the document alone
    assert doc["bench"] == "bench_session" and doc["command"].endswith("--frames 5")
    assert "live robot frame" in done.stderr


def test_figures_become_plain_json():
    results = load_module("results")
    figures = {
        "nan": math.nan,
        "inf": -math.inf,
        "numpy": np.float64(1.0 / 3.0),
        "array": np.arange(3),
        "pair": (True, np.bool_(False)),
        "big": 123456789.0,
    }
    assert results.plain(figures) == {
        "nan": None,
        "inf": None,
        "numpy": 0.333333,
        "array": [0, 1, 2],
        "pair": [True, False],
        "big": 123457000.0,
    }
    assert results.command("ca_response", ["--a", "1", "--json", "out.json", "--b=two words"]) == (
        "python bench/ca_response.py --a 1 '--b=two words'"
    )
    assert results.command("ca_response", ["--json=-", "--c"]) == "python bench/ca_response.py --c"
