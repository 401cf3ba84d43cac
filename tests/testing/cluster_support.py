"""A Dask cluster on this machine's loopback, a test helper: a real `dask scheduler` and
`dask worker` processes (one thread each), for the tests and `bench/bench_cluster.py`
(docs/CLUSTER.md says how to start them on other machines)."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

DASK = Path(sys.executable).parent / "dask"


class LoopbackCluster:
    """Start with `workers` worker processes; `address` once the scheduler is up; `close` ends
    every process. Use as a context manager."""

    def __init__(self, workers: int) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="artro-dask-")
        self.file = Path(self._dir.name) / "scheduler.json"
        self.scheduler = self._start(
            "scheduler", "--port", "0", "--dashboard-address", ":0", "--no-show"
        )
        self.workers = [self.start_worker() for _ in range(workers)]
        self._wait_for_address()

    def _start(self, role: str, *args: str) -> subprocess.Popen:
        command = [str(DASK), role, "--scheduler-file", str(self.file), "--host", "127.0.0.1"]
        return subprocess.Popen(
            [*command, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )

    def start_worker(self) -> subprocess.Popen:
        return self._start(
            "worker", "--nthreads", "1", "--no-nanny", "--memory-limit", "0", "--no-dashboard"
        )

    def _wait_for_address(self) -> None:
        """Bounded wait for the scheduler's file (polls, returns as soon as it is written)."""
        gate = threading.Event()
        for _ in range(1200):
            if self.file.exists() and self.file.read_text().strip():
                return
            if self.scheduler.poll() is not None:
                raise RuntimeError("dask scheduler exited at start")
            gate.wait(0.05)
        raise RuntimeError("dask scheduler did not start within a minute")

    @property
    def address(self) -> str:
        return json.loads(self.file.read_text())["address"]

    def close(self) -> None:
        for proc in [*self.workers, self.scheduler]:
            if proc.poll() is None:
                proc.kill()
            proc.wait(30)
        self._dir.cleanup()

    def __enter__(self) -> LoopbackCluster:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
