"""What `--cluster` refuses or reports, in one sentence with exit status 2 (issue 33): an address
of another form (as it is parsed, for every command that takes one), a port that answers HTTP or
accepts and never answers (within the connect timeout, not never), a scheduler with no worker
(said at once, waited on as long as `--wait-workers` asks). No Dask client is left to print a
traceback at exit. Real sockets, a real `dask scheduler` and `dask worker`."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from app.cli import main
from app.evaluation._dask import CONNECT_TIMEOUT_S, ClusterEvaluator
from app.robots.model import RobotModel
from tests.testing.cluster_support import LoopbackCluster

ROOT = Path(__file__).resolve().parents[2]
ROBOT = RobotModel.load()
#: a tune that reaches its cluster before it simulates anything
TUNE = ["tune", "--tune", "swing.v", "--cases", "forward", "--generations", "1", "--popsize", "2",
        "--duration", "2", "--warmup", "0.5"]  # fmt: skip
COMMANDS = (["tune"], ["bench", "robust"], ["calibrate-ca"], ["serve"])


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c))
@pytest.mark.parametrize(
    ("address", "what"),
    [
        ("tls://127.0.0.1:8786", "unsupported scheduler address 'tls://127.0.0.1:8786'"),
        ("ucx://127.0.0.1:8786", "unsupported scheduler address 'ucx://127.0.0.1:8786'"),
        ("http://x", "unsupported scheduler address 'http://x'"),
        ("", "an empty scheduler address"),
        ("tcp://127.0.0.1:99999", "the port in 'tcp://127.0.0.1:99999' is invalid: a port is 1 to"),
        ("tcp://127.0.0.1:0", "the port in 'tcp://127.0.0.1:0' is invalid: a port is 1 to 65535"),
        ("127.0.0.1", "'127.0.0.1' is not HOST:PORT"),
    ],
)
def test_an_address_of_another_form_is_refused_as_it_is_parsed(capsys, command, address, what):
    """Issue 33: tls:// was a TypeError traceback, http:// a traceback 20 s after its sentence,
    an empty address ran locally without a word, port 99999 waited for a timeout."""
    with pytest.raises(SystemExit) as exit_:
        main([*command, "--cluster", address])
    assert exit_.value.code == 2
    said = capsys.readouterr().err.strip().splitlines()[-1]
    assert said.startswith(f"artro {command[0]}: error: argument --cluster: {what}")
    assert "allowed for --cluster: tcp://HOST:PORT" in said


@contextmanager
def listening(answer: bytes | None) -> Iterator[int]:
    """A TCP server on loopback that accepts every connection and, once it has read from one,
    answers `answer` (an HTTP server's reply) or, with None, never answers. Yields its port."""
    server = socket.create_server(("127.0.0.1", 0))
    held: list[socket.socket] = []

    def reply(conn: socket.socket) -> None:
        try:
            conn.recv(65536)
            conn.sendall(answer or b"")
        except OSError:
            pass

    def accept() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return  # closed
            held.append(conn)
            if answer is not None:
                threading.Thread(target=reply, args=(conn,), daemon=True).start()

    threading.Thread(target=accept, daemon=True).start()
    try:
        yield server.getsockname()[1]
    finally:
        server.shutdown(socket.SHUT_RDWR)
        server.close()
        for conn in held:
            conn.close()


def tune_on(address: str, tmp_path: Path, *extra: str) -> subprocess.CompletedProcess:
    """`artro tune --cluster address` in its own process, as a user runs it; bounded far above
    what it may take, so that a hang fails the test instead of stalling the suite."""
    files = ["--study", str(tmp_path / "study.log"), "--out", str(tmp_path / "o.json")]
    command = [sys.executable, "-m", "app.cli", *TUNE, "--cluster", address, *extra, *files]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr[-3000:]
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
    return done


def test_a_port_that_answers_http_is_no_scheduler(tmp_path):
    """Issue 33: a port that answers HTTP gave no output for over 150 s."""
    http = b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\nConnection: close\r\n\r\nok"
    with listening(http) as port:
        done = tune_on(f"tcp://127.0.0.1:{port}", tmp_path)
    said = done.stderr.strip().splitlines()[-1]
    assert said == (
        f"artro tune: error: the server at tcp://127.0.0.1:{port} is not a Dask scheduler (its "
        "answer is not Dask's protocol); is that the scheduler's port (8786 by default, not its "
        "dashboard's)?"
    )  # no exception's name (it said "MemoryError")


@pytest.mark.slow
def test_a_port_that_accepts_and_never_answers_fails_within_the_connect_timeout(tmp_path):
    """Issue 33: a port that accepts and never answers gave no output for over 150 s."""
    with listening(None) as port:
        done = tune_on(f"tcp://127.0.0.1:{port}", tmp_path)
    assert done.stderr.strip().splitlines()[-1] == (
        f"artro tune: error: something at tcp://127.0.0.1:{port} accepts connections but gives "
        f"no Dask scheduler's answer within {CONNECT_TIMEOUT_S} s; is that the scheduler's port "
        f"(8786 by default)?"
    )


def test_a_closed_port_is_said_at_once(tmp_path):
    with listening(None) as port:
        pass  # closed again: nothing listens there now
    done = tune_on(f"127.0.0.1:{port}", tmp_path)
    assert done.stderr.strip().splitlines()[-1] == (
        f"artro tune: error: no Dask scheduler answers at tcp://127.0.0.1:{port}: "
        f"Connection refused"
    )


@pytest.mark.slow
def test_a_scheduler_without_a_worker_says_so_and_waits_as_long_as_asked(tmp_path):
    """Issue 33: with no worker, over 90 s passed after the first line with nothing said."""
    with LoopbackCluster(workers=0) as cluster:
        address = cluster.address
        done = tune_on(address, tmp_path, "--wait-workers", "2")
    lines = done.stderr.strip().splitlines()
    assert (
        f"connected to the Dask scheduler at {address}; no worker connected yet, "
        f"waiting up to 2 s (--wait-workers)"
    ) in lines
    assert lines[-1] == (
        f"artro tune: error: no worker connected to the Dask scheduler at {address} "
        f"within 2 s; start one (dask worker {address}, docs/CLUSTER.md) or wait longer "
        f"with --wait-workers SECONDS"
    )


@pytest.mark.slow
def test_a_worker_that_comes_while_waited_on_is_taken():
    said: list[str] = []
    with LoopbackCluster(workers=0) as cluster:
        address = cluster.address

        def say(line: str) -> None:
            said.append(line)
            if "no worker connected yet" in line:
                cluster.workers.append(cluster.start_worker())

        evaluator = ClusterEvaluator(address, ROBOT, wait_workers_s=300, say=say)
        try:
            assert evaluator.workers() == 1
        finally:
            evaluator.close()
    assert said == [
        f"connected to the Dask scheduler at {address}; no worker connected yet, "
        f"waiting up to 300 s (--wait-workers)",
        f"a worker connected to {address}; going on",
    ]


@pytest.mark.slow
def test_the_dashboards_robustness_job_waits_for_a_worker_as_long_as_serve_was_told(tmp_path):
    """`artro serve --cluster ... --wait-workers S`: the robustness job on a scheduler with no
    worker fails after S seconds saying so, the server well (issue 33: serve had no option)."""
    from tests.testing.server_harness import client, running_server, wait_for

    with LoopbackCluster(workers=0) as cluster:
        address = cluster.address
        with running_server(tmp_path, cluster=address, wait_workers_s=1.0) as (url, _):
            with client(url) as http:
                job = http.post("/api/jobs/robustness", json={"samples": 4}).json()
                done = wait_for(
                    lambda: (
                        (j := http.get(f"/api/jobs/{job['id']}").json())["status"]
                        in ("failed", "done")
                        and j
                    ),
                    "the job ends",
                )
                assert http.get("/api/health").json()["status"] == "ok"
    assert done["status"] == "failed"
    assert f"no worker connected to the Dask scheduler at {address} within 1 s" in (done["error"])
