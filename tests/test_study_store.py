"""The study store (docs/DESIGN.md §12): Optuna's journal file by default, an RDB URL on
request; settings fixed at creation; and `optuna-dashboard FILE` opens it, offline."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from app.study.study_store import StudyStore
from tests.server_harness import free_port, wait_for

SETTINGS = {"names": ["clock.freq_hz"], "popsize": 2, "seed": 1}


def fill(store: StudyStore) -> None:
    for k, (value, loss) in enumerate([(0.8, 1.5), (1.1, 0.7)]):
        values = {"clock.freq_hz": (value, 0.3, 2.0)}
        store.record(0, [(value - 0.3) / 1.7], values, loss, {"nominal": {"forward": {"k": k}}})


@pytest.mark.parametrize("kind", ["journal", "sqlite"])
def test_trials_come_back_from_the_store_alone(tmp_path, kind):
    where = tmp_path / "study.log" if kind == "journal" else f"sqlite:///{tmp_path / 'study.db'}"
    fill(StudyStore(where, SETTINGS))
    again = StudyStore(where, SETTINGS).recorded()  # a new process would do just this
    assert [r["loss"] for r in again[0]] == [1.5, 0.7]
    assert again[0][1]["metrics"] == {"nominal": {"forward": {"k": 1}}}
    with pytest.raises(ValueError, match="other settings"):
        StudyStore(where, {**SETTINGS, "seed": 2})


def test_optuna_dashboard_opens_the_journal_offline(tmp_path):
    journal = tmp_path / "study.log"
    fill(StudyStore(journal, SETTINGS))
    port = free_port()
    dashboard = Path(sys.executable).parent / "optuna-dashboard"
    server = subprocess.Popen(
        [str(dashboard), str(journal), "--host", "127.0.0.1", "--port", str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=5) as http:

            def studies() -> list | None:
                if server.poll() is not None:
                    raise AssertionError(server.stderr.read().decode()[-2000:])
                try:
                    return http.get("/api/studies").json()["study_summaries"]
                except httpx.TransportError:
                    return None

            found = wait_for(studies, "optuna-dashboard lists the study", attempts=1200)
            assert [s["study_name"] for s in found] == ["artro-tune"]
            page = http.get("/dashboard")
            assert page.status_code == 200
            scripts = re.findall(r'src="([^"]+)"', page.text)
            assert scripts and all(s.startswith("/") for s in scripts)  # nothing from the web
            for script in scripts:
                assert http.get(script).status_code == 200
    finally:
        server.terminate()
        server.wait(30)
