"""The dashboard's "Tune for this robot" job (docs/DESIGN.md §10, §12): `artro tune --robot` on
the robot in use, run as a child process, its study in DATA/studies, followed through its events
(`app.analysis.robot_tune`); the result, saved as the preset tuned-ROBOT, loaded as one undoable
change (source "tune"). Cancelled, the child is stopped and nothing is loaded."""

from __future__ import annotations

import dataclasses
import os
import queue
import subprocess
import sys
import threading
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from app.analysis.cases import CASES
from app.analysis.robot_start import START_RECIPE
from app.analysis.robot_tune import (
    RESULT,
    RUNS,
    START,
    TRIAL,
    read_event,
    shortest_duration_s,
    study_file,
    study_name,
    tuned_name,
)
from app.params.presets import PresetStore, builtin_presets, check_name
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
from app.server.jobs.registry import Job, Jobs, Reporter, StaleVersion, on_robot
from app.server.param_store import ParameterStore, Snapshot
from gait.params import describe_fields, group_class

Kind = Literal["tune"]  # its jobs' `kind` (app/server/jobs/results.py)
KIND: Kind = "tune"


class WrongRobot(ValueError):
    """The tune was asked for another robot than the one the dashboard shows."""


@dataclass(frozen=True)
class TuneBudget:
    """How big a tune is: the start's recipe (`START_RECIPE`) unless made smaller or larger."""

    generations: int = START_RECIPE.generations
    popsize: int = START_RECIPE.popsize
    duration_s: float = START_RECIPE.duration_s
    warmup_s: float = START_RECIPE.warmup_s
    cases: tuple[str, ...] = ()  # only these paper cases (and the CA pairs at their a_p); (): all

    def check(self) -> None:
        """ValueError, saying what is allowed, for cases not in the paper or runs too short for
        a whole gait cycle of the slowest clock the recipe may try after the warm-up."""
        known = [c.name for c in CASES]
        if unknown := [c for c in self.cases if c not in known]:
            raise ValueError(f"unknown cases {unknown}; allowed: {', '.join(known)}")
        slowest = next(
            m["min"] for f, _d, m in describe_fields(group_class("clock")) if f == "freq_hz"
        )
        need = shortest_duration_s(slowest, self.warmup_s)
        if self.duration_s < need:
            raise ValueError(
                f"duration_s {self.duration_s:g} leaves no whole gait cycle after warmup_s "
                f"{self.warmup_s:g} at {slowest:g} Hz, the slowest clock the tune may try (it "
                f"tunes clock.freq_hz): allowed: duration_s of at least {need:g}"
            )


class TuneRunner:
    """Starts tune jobs on the robot in use, one at a time (a job of kind "tune")."""

    def __init__(
        self,
        jobs: Jobs,
        store: ParameterStore,
        presets: PresetStore,
        robot_now: Callable[[], RobotModel],
        threads: int | None = None,
    ) -> None:
        self.jobs, self.store, self.presets, self.robot_now = jobs, store, presets, robot_now
        self.threads = threads or child_threads()
        self.latest: Job | None = None

    def start(self, budget: TuneBudget, robot: str | None = None) -> Job:
        """Tune the robot in use (`robot`, if given, must be it: WrongRobot otherwise); ValueError
        for a budget `TuneBudget.check` refuses; JobBusy while a tune runs. Nothing changes
        before the job starts."""
        model = self.robot_now()
        if robot is not None and robot != model.name:
            raise WrongRobot(
                f"the tune runs on the robot the dashboard shows, {model.name!r}, not {robot!r}: "
                f"switch to {robot!r} first (PUT /api/robot), or leave robot out"
            )
        budget.check()
        name = check_name(tuned_name(model.name, builtin_presets()))
        study = study_file(self.presets.data_dir, model.name)
        start = self.store.snapshot()
        job = self.jobs.start(
            KIND, lambda progress: self._work(progress, model, name, study, budget, start),
            robot=model.name, from_version=start.version,
        )  # fmt: skip
        self.latest = job
        return job

    def _command(self, model: RobotModel, study: Path, budget: TuneBudget) -> list[str]:
        if model.name in builtin_robot_names():
            robot = model.name
        else:  # the robot the server was started with from a file: its description, written
            # out as the limit on a description measures it, so never over it (issue 56, item 11)
            path = study.with_suffix(".robot.yaml")
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(description_json(model.description), "utf-8")
            robot = str(path)
        cmd = [sys.executable, "-m", "app.cli", "tune", "--robot", robot,
               "--generations", str(budget.generations), "--popsize", str(budget.popsize),
               "--duration", f"{budget.duration_s:g}", "--warmup", f"{budget.warmup_s:g}",
               "--threads", str(self.threads), "--study", str(study),
               "--study-name", study_name(budget.generations, budget.popsize,
                                          budget.duration_s, budget.cases),
               "--events", "-"]  # fmt: skip
        return [*cmd, "--cases", ",".join(budget.cases)] if budget.cases else cmd

    def _work(
        self,
        progress: Reporter,
        model: RobotModel,
        name: str,
        study: Path,
        budget: TuneBudget,
        start: Snapshot,
    ) -> dict[str, Any]:
        job: Job = progress.job
        detail: dict[str, Any] = {"robot": model.name, "name": name, "study": str(study),
                                  "trials": 0, "budget": budget.generations * budget.popsize,
                                  "best_loss": None, "generations": budget.generations}  # fmt: skip
        job.detail = dict(detail)  # a copy each time: a reader never sees it change
        study.parent.mkdir(parents=True, exist_ok=True)
        env = os.environ | {"ARTRO_DATA_DIR": str(self.presets.data_dir), "PYTHONUNBUFFERED": "1"}
        child = subprocess.Popen(
            self._command(model, study, budget), stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True, env=env,
            cwd=study.parent,
        )  # fmt: skip
        detail["pid"] = child.pid
        job.detail = dict(detail)
        lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(
            target=pump_lines, args=(child, lines), name=f"artro-{job.id}-out", daemon=True
        ).start()
        log: deque[str] = deque(maxlen=LOG_LINES)
        result: dict[str, Any] | None = None
        try:
            while (line := next_line(lines, progress)) is not None:
                event = read_event(line)
                if event is None:
                    if line.strip():
                        log.append(line.rstrip())
                    continue
                if event["event"] == RESULT:
                    result = event
                done = _follow(detail, event, budget.generations)
                job.detail = dict(detail)
                progress(None if done is None else max(done, job.progress))
            code = child.wait()
        finally:
            _stop(child)
        if code != 0 or result is None:
            said = " | ".join(log) or "no output"
            raise RuntimeError(f"artro tune stopped (exit status {code}) before a result: {said}")
        return self._load(model.name, name, result, detail, start)

    def _load(
        self, robot: str, name: str, result: dict[str, Any], detail: dict[str, Any], start: Snapshot
    ) -> dict[str, Any]:
        """The saved preset `name` made the parameters in use (its gait, the motion in use
        kept): one undoable change, only on the robot tuned, only while the gait in use is the
        one it started from (a motion moved meanwhile is kept; a gait changed is the user's:
        docs/DESIGN.md §14), and only if a candidate walked every run. Else it stays saved, not
        loaded, and `not_loaded` says why: a tiny tune had replaced a set that walked by one
        that fell in every walking case, and one had undone edits made while it ran."""
        keep = ("loss", "select", "walked", "generations", "trials", "figures", "replaced")
        said = {**{k: result.get(k) for k in keep}, "preset": name, "robot": robot,
                "study": detail["study"], "study_name": detail.get("study_name"),
                "budget": detail["budget"]}  # fmt: skip
        why = None
        if not result.get("walked"):
            why = "no candidate walked every run without a fall (the lowest loss was saved)"
        else:
            pset = self.presets.get(name)
            pset = dataclasses.replace(pset, motion=self.store.snapshot().motion)
            try:
                snap = self.store.replace(pset, "tune", check=_same_gait(start, robot))
            except StaleVersion as exc:
                why = str(exc)
            else:
                return said | {"params_version": snap.version, "applied": True, "not_loaded": None}
        return said | {"params_version": None, "applied": False,
                       "not_loaded": f"{why}: {name!r} is saved, not loaded; the set in use "
                                     "stays (load it from the presets to try it)"}  # fmt: skip


def _same_gait(start: Snapshot, robot: str) -> Callable[[Snapshot], None]:
    """A store check: the robot tuned is in use and its gait is still `start`'s."""

    def check(current: Snapshot) -> None:
        on_robot(robot)(current)
        if current.gait != start.gait:
            raise StaleVersion(
                f"the gait changed while the tune ran (version {start.version} is now "
                f"{current.version}, changed by {current.source})"
            )

    return check


def _follow(detail: dict[str, Any], event: dict[str, Any], generations: int) -> float | None:
    """`detail` brought up to date with `event`; the job's progress 0..1 (None: unchanged)."""
    kind = event["event"]
    if kind == START:
        detail |= {"start": event.get("base"), "study_name": event.get("study_name")}
        detail["budget"] = event.get("budget", detail["budget"])
    elif kind == TRIAL:
        detail |= {"trials": event.get("done", 0), "best_loss": event.get("best"),
                   "last_loss": event.get("loss")}  # fmt: skip
        return min(1.0, detail["trials"] / max(1, detail["budget"]))
    elif kind == RUNS and event.get("total"):
        detail |= {"generation": event.get("generation", 0) + 1, "runs": event.get("done", 0),
                   "runs_total": event["total"], "left_s": event.get("left_s")}  # fmt: skip
        done = event.get("generation", 0) + event.get("done", 0) / event["total"]
        return min(1.0, done / max(1, generations))
    return None


def _stop(child: subprocess.Popen[str]) -> None:
    """The child ended: asked (SIGTERM), then killed after STOP_WAIT_S."""
    if child.poll() is None:
        child.terminate()
        try:
            child.wait(STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()


def cases_of(names: Sequence[str]) -> tuple[str, ...]:
    """The body's cases, trimmed, in their given order, each once."""
    return tuple(dict.fromkeys(n.strip() for n in names if n.strip()))
