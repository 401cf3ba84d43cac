"""The dashboard's "Fit to a recording" job (docs/FIT.md, "On the dashboard"): `artro fit REC
--robot <the robot in use> --json` run as a child process on a recording checked before it
starts, followed through its progress lines; the result is the fit's summary and its report."""

from __future__ import annotations

import json
import os
import queue
import re
import signal
import subprocess
import sys
import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

from app.analysis import identify_record
from app.robots import builtin_robot_names
from app.robots.library import description_json
from app.robots.model import RobotModel
from app.server.jobs.child_process import (
    LOG_LINES,
    STOP_WAIT_S,
    child_threads,
    next_line,
    pump_lines,
)
from app.server.jobs.registry import Job, Jobs, Reporter
from app.worlds.variations import NOMINAL, parse_variation

Kind = Literal["fit"]  # its jobs' `kind` (app/server/jobs/results.py)
KIND: Kind = "fit"
#: the child's progress line (app/cli/fit.py)
PROGRESS = re.compile(r"fit: (\d+) % of the search, best loss ([-+0-9.eE]+|nan), (.*) left")
FIELDS_RE = re.compile(r"[a-z_]+(,[a-z_]+)*")


class FitRunner:
    """Starts fit jobs on the robot in use, one at a time (a job of kind "fit"); each job's
    files in DATA/fits: NAME.json (the recording), NAME-fitted.yaml, NAME-fit/ (the report)."""

    def __init__(
        self,
        jobs: Jobs,
        data_dir: Path,
        robot_now: Callable[[], RobotModel],
        workers: int = 0,
        cluster: str | None = None,
        wait_workers_s: float | None = None,
    ) -> None:
        self.jobs, self.folder, self.robot_now = jobs, data_dir / "fits", robot_now
        self.workers = workers or min(4, child_threads())  # the live simulation keeps a core
        # `artro serve --cluster`: the replays on its workers, as the robustness job's runs
        self.on_cluster = [] if cluster is None else ["--cluster", cluster]
        if cluster is not None and wait_workers_s is not None:
            self.on_cluster += ["--wait-workers", f"{wait_workers_s:g}"]
        self.latest: Job | None = None
        self._lock = threading.Lock()
        self._fitted: dict[str, str] = {}  # a fit's variation (its name) -> the job that fitted it

    def check(self, text: str) -> identify_record.Recording:
        """The recording `text`, whole and of the robot in use; RecordingError saying why not."""
        recording = identify_record.parse(text, "the recording")
        robot = self.robot_now()
        identify_record.check_robot(recording, robot.name, robot.total_mass_kg(), "the recording")
        return recording

    def start(self, text: str, fields: str | None = None, budget: int | None = None) -> Job:
        """Fit `text` (checked first: RecordingError) on the robot in use; ValueError for
        fields or a budget `artro fit` would refuse; JobBusy while a fit runs."""
        if fields is not None and not FIELDS_RE.fullmatch(fields):
            raise ValueError(f"fields {fields!r}: allowed: names such as gyro_bias_deg_s,kp_scale")
        if budget is not None and not 10 <= budget <= 5000:
            raise ValueError(f"budget {budget}: allowed: 10 to 5000 replays")
        self.check(text)
        model = self.robot_now()
        options = ([] if fields is None else ["--fields", fields]) + (
            [] if budget is None else ["--budget", str(budget)]
        )
        job = self.jobs.start(
            KIND, lambda progress: self._work(progress, model, text, options), robot=model.name
        )
        self.latest = job
        return job

    def report_dir(self, job_id: str) -> Path:
        """Where job `job_id`'s report is (it may not exist)."""
        return self.folder / f"{job_id}-fit"

    def fitted_by(self, variation: str) -> str | None:
        """The job whose fit `variation` (a variation's name) is, if one is."""
        with self._lock:
            return self._fitted.get(variation)

    def _work(
        self, progress: Reporter, model: RobotModel, text: str, options: list[str]
    ) -> dict[str, Any]:
        job: Job = progress.job
        self.folder.mkdir(parents=True, exist_ok=True)
        rec = self.folder / f"{job.id}.json"
        rec.write_text(text, encoding="utf-8")
        out = self.folder / f"{job.id}-fitted.yaml"
        detail: dict[str, Any] = {"robot": model.name, "percent": 0, "best_loss": None,
                                  "left": None, "recording": str(rec)}  # fmt: skip
        job.detail = dict(detail)
        cmd = [sys.executable, "-m", "app.cli", "fit", str(rec), "--robot",
               self._robot_arg(model), "--json", "-o", str(out),
               "--workers", str(self.workers), *self.on_cluster, *options]  # fmt: skip
        env = os.environ | {"PYTHONUNBUFFERED": "1"}
        child = subprocess.Popen(
            cmd,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            env=env,
            cwd=self.folder,
            start_new_session=True,
        )  # fmt: skip (its own process group: its replaying workers end with it)
        detail["pid"] = child.pid
        job.detail = dict(detail)
        lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=pump_lines, args=(child, lines), name=f"artro-{job.id}-out",
                         daemon=True).start()  # fmt: skip
        log: deque[str] = deque(maxlen=LOG_LINES)
        result: dict[str, Any] | None = None
        try:
            while (line := next_line(lines, progress)) is not None:
                if line.startswith("{"):
                    result = json.loads(line)
                elif seen := PROGRESS.search(line):
                    detail |= {"percent": int(seen[1]), "best_loss": float(seen[2]),
                               "left": seen[3]}  # fmt: skip
                    job.detail = dict(detail)
                    progress(min(0.99, int(seen[1]) / 100))
                elif line.strip():
                    log.append(line.rstrip())
            code = child.wait()
        finally:
            _stop_group(child)
        if code not in (0, 1) or result is None:
            said = " | ".join(log) or "no output"
            raise RuntimeError(f"artro fit stopped (exit status {code}) before a result: {said}")
        folder = Path(result["report"]).parent
        name = parse_variation(result["variation"]).name if result["variation"] else NOMINAL.name
        with self._lock:
            self._fitted[name] = job.id
        progress(1.0)
        return result | {"robot": model.name, "world": name, "report_dir": str(folder),
                         "traces": f"/api/fit/{job.id}/traces.png"}  # fmt: skip

    def _robot_arg(self, model: RobotModel) -> str:
        """A built-in robot's name, or the description in use written beside the fits."""
        if model.name in builtin_robot_names():
            return model.name
        path = self.folder / f"{model.name}.robot.yaml"
        path.write_text(description_json(model.description), "utf-8")
        return str(path)


def _stop_group(child: subprocess.Popen[str]) -> None:
    """The child and its workers ended: asked (SIGTERM to its group), killed after STOP_WAIT_S.
    A child that ended by itself has closed its workers."""
    if child.poll() is not None:
        return
    os.killpg(child.pid, signal.SIGTERM)
    try:
        child.wait(STOP_WAIT_S)
    except subprocess.TimeoutExpired:
        pass
    try:
        os.killpg(child.pid, signal.SIGKILL)  # the child, or a worker left behind
    except ProcessLookupError:
        pass
    child.wait()
