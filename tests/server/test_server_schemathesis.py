"""schemathesis runs every check against the live server's OpenAPI: statuses, error shapes,
content types, Allow headers, schema-valid input accepted and invalid input refused; 0 failures.
Bounded by the example count (and a fixed seed), not by the clock. The coverage phase (every
field's boundaries) draws nothing at random: it runs once, the seeded phases under both seeds."""

import subprocess
import sys
from pathlib import Path

import pytest

from tests.testing.server_harness import client, running_server

CONFIG = Path(__file__).with_name("schemathesis.toml")
SCHEMATHESIS = Path(sys.executable).with_name("schemathesis")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("seed", "phases"),
    [(1, "examples,coverage,fuzzing,stateful"), (7, "examples,fuzzing,stateful")],
)
def test_schemathesis_finds_nothing(tmp_path, seed, phases):
    with running_server(tmp_path) as (base_url, _app):
        command = [
            str(SCHEMATHESIS),
            "--config-file",
            str(CONFIG),
            "run",
            f"{base_url}/openapi.json",
            # every check runs by default; `--checks all` would also override the config file's
            # per-operation settings (CLI options come first), e.g. use_after_free on a job
            "--phases",
            phases,
            "--max-examples",
            "10",
            "--seed",
            str(seed),
            "--workers",
            "1",
            "--suppress-health-check",
            "all",
            "--no-color",
        ]
        run = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, timeout=900)
        with client(base_url) as http:  # and the server is still well
            assert http.get("/api/health").json()["status"] == "ok"
    summary = run.stdout[run.stdout.rfind("SUMMARY") :]
    assert run.returncode == 0, run.stdout[-6000:]
    assert "generated" in summary and "failure" not in summary, summary
