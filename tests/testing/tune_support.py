"""Shared by the tuner's tests (tests/study/test_tune.py, test_tune_resume.py): a deliberately
poor start, the fields and settings of a short tune, its study store, the finished trials in a
store, and the real evaluator counting the runs it simulates."""

from pathlib import Path

import optuna

from app.analysis.cases import JUDGED_RUNS
from app.evaluation import BatchEvaluator, Job
from app.params.document import ParameterSet
from app.study.study_store import StudyStore, open_storage
from app.study.tune import Tuner
from app.study.tune_loss import total_loss
from gait import GaitParams

ROOT = Path(__file__).resolve().parents[2]
EVALUATOR = BatchEvaluator(threads=2)
# a deliberately poor start: a slow clock and almost no foot clearance
POOR = ParameterSet(
    name="poor",
    gait=GaitParams.from_dict(
        {"clock": {"freq_hz": 0.5}, "short": {"amp_base": 0.05}, "leg": {"paper_signs": False}}
    ),
)
NAMES = ("clock.freq_hz", "short.amp_base")
SETTINGS = {"duration_s": 3.0, "warmup_s": 1.0, "popsize": 4, "seed": 3}


def base_loss() -> float:
    jobs = [Job(POOR.gait, motion) for _name, motion in JUDGED_RUNS]
    metrics = EVALUATOR.evaluate(jobs, duration_s=3.0, warmup_s=1.0)
    return total_loss({name: m for (name, _), m in zip(JUDGED_RUNS, metrics, strict=True)}, 3.0)


def store(tmp_path, tuner: Tuner, name: str = "study.log") -> StudyStore:
    return StudyStore(tmp_path / name, tuner.settings)


def trials_in(path: Path, *, study: bool = False):
    """The finished trials of the one tuning study in `path` (or the study itself): a Tuner's
    own (DEFAULT_STUDY) or `artro tune`'s (tune-ROBOT-DIGEST). KeyError while none is made."""
    storage = open_storage(path)
    names = optuna.get_all_study_names(storage)
    if not names:
        raise KeyError("no study yet")
    (name,) = names
    loaded = optuna.load_study(study_name=name, storage=storage)
    return loaded if study else loaded.get_trials(states=(optuna.trial.TrialState.COMPLETE,))


class Counting(BatchEvaluator):
    """The real evaluator, counting the runs it simulates."""

    runs = 0

    def evaluate(self, jobs, **kwargs):
        Counting.runs += len(jobs)
        return super().evaluate(jobs, **kwargs)
