"""`artro tune` resumes: from its study store without simulating again, from a journal cut
short by a crash, after a kill mid-generation, and after Ctrl-C (said in a sentence)."""

import signal
import subprocess
import sys

import pytest

from app.analysis.cases import JUDGED_RUNS
from app.study.study_store import StudyStore
from app.study.tune import Tuner
from tests.testing.signal_support import with_sigint_default
from tests.testing.tune_support import (
    EVALUATOR,
    NAMES,
    POOR,
    ROOT,
    SETTINGS,
    Counting,
    store,
    trials_in,
)


def test_resuming_replays_the_store_without_simulating(tmp_path):
    first = Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS)
    first.run(2, store(tmp_path, first), progress=None)
    Counting.runs = 0
    again = Tuner(POOR, NAMES, evaluator=Counting(threads=1), **SETTINGS)
    again.run(2, store(tmp_path, again), progress=None)  # both generations come from the store
    assert Counting.runs == 0
    assert again.best[0] == first.best[0] and again.generation == 2
    fewer = Tuner(POOR, NAMES, evaluator=Counting(threads=1), **SETTINGS)
    with (
        store(tmp_path, fewer) as held,
        pytest.raises(ValueError, match="holds 2 generations, more than the 1 asked for"),
    ):
        fewer.run(1, held, progress=None)  # it would choose among the first only
    assert Counting.runs == 0 and fewer.best is None
    other = Tuner(POOR, NAMES, evaluator=EVALUATOR, **{**SETTINGS, "seed": 4})
    with pytest.raises(ValueError, match="other settings"):
        store(tmp_path, other)


def test_a_journal_cut_short_by_a_crash_resumes_from_its_whole_entries(tmp_path, capsys):
    """Issue 33: a crash that cut the journal's last line made every finished trial unreadable
    ("Expecting ':' delimiter") once the resumed tune appended to it."""
    journal = tmp_path / "study.log"
    first = Tuner(POOR, NAMES, evaluator=EVALUATOR, **SETTINGS)
    with StudyStore(journal, first.settings) as kept:
        first.run(1, kept, progress=None)
    data = journal.read_bytes()
    last = data.rstrip(b"\n").rfind(b"\n") + 1  # the last candidate's trial
    cut = last + (len(data) - last) // 2
    journal.write_bytes(data[:cut])
    Counting.runs = 0
    again = Tuner(POOR, NAMES, evaluator=Counting(threads=2), **SETTINGS)
    with StudyStore(journal, again.settings) as resumed:
        again.run(1, resumed, progress=None)
    said = capsys.readouterr().err
    assert f"the study journal {journal} ended in a damaged entry" in said
    assert Counting.runs == len(JUDGED_RUNS)  # only the cut candidate ran again
    trials = trials_in(journal)
    assert len(trials) == 4 and again.best[0] == first.best[0]
    (aside,) = tmp_path.glob("study.log.damaged-*")
    assert aside.read_bytes() == data[last:cut]


@pytest.mark.slow
def test_a_study_killed_mid_generation_resumes_without_losing_a_finished_evaluation(tmp_path):
    study_file = tmp_path / "killed.log"
    command = [
        sys.executable, "-m", "app.cli", "tune", "--tune", ",".join(NAMES), "--generations", "1",
        "--popsize", "6", "--duration", "7", "--warmup", "1", "--seed", "3", "--study",
        str(study_file), "--out", str(tmp_path / "out.json"), "--threads", "2",
    ]  # fmt: skip
    tuner = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    finished_before = 0
    for _ in range(3000):  # bounded: until some, not all, candidates of the generation are in
        if study_file.exists():
            try:
                finished_before = len(trials_in(study_file))
            except KeyError:  # the tuner is still creating the study in the file
                finished_before = 0
            if finished_before >= 1:
                tuner.send_signal(signal.SIGKILL)
                break
        try:
            tuner.wait(0.1)
            break
        except subprocess.TimeoutExpired:
            pass
    tuner.wait(60)
    kept = trials_in(study_file)
    assert 1 <= len(kept) <= 6, tuner.stderr.read()
    before = {tuple(t.user_attrs["unit"]): t.value for t in kept}
    resumed = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    after = trials_in(study_file)
    assert len(after) == 6  # the generation is whole, each candidate once
    units = [tuple(t.user_attrs["unit"]) for t in after]
    assert len(set(units)) == 6
    for unit, value in before.items():  # what finished before the kill was kept, not redone
        assert [t.value for t in after if tuple(t.user_attrs["unit"]) == unit] == [value]


@pytest.mark.slow
def test_ctrl_c_ends_a_tune_in_a_sentence_and_the_study_resumes(tmp_path):
    study_file = tmp_path / "interrupted.log"
    command = [
        sys.executable, "-m", "app.cli", "tune", "--tune", "swing.v,short.amp_base",
        "--generations", "3", "--popsize", "4", "--duration", "4", "--warmup", "1", "--seed",
        "3", "--cases", "forward", "--study", str(study_file), "--out",
        str(tmp_path / "out.json"), "--threads", "2",
    ]  # fmt: skip
    # Ctrl-C as from a terminal, though the suite runs as a background job (SIGINT ignored)
    tuner = subprocess.Popen(
        with_sigint_default(command), cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    for _ in range(3000):  # bounded: until a candidate is in the study
        try:
            if study_file.exists() and trials_in(study_file):
                break
        except KeyError:  # the study is still being made in the file
            pass
        try:
            tuner.wait(0.1)
            break
        except subprocess.TimeoutExpired:
            pass
    assert tuner.poll() is None, "the tune ended before it could be interrupted"
    tuner.send_signal(signal.SIGINT)
    said = tuner.communicate(timeout=120)[1].decode()
    assert tuner.returncode == 130, said[-2000:]
    assert "Traceback" not in said
    assert said.strip().splitlines()[-1] == (
        f"artro tune: interrupted; the study {study_file} keeps every candidate that finished: "
        "the same command resumes it"
    )
    kept = len(trials_in(study_file))
    resumed = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    assert 1 <= kept <= len(trials_in(study_file)) == 12
