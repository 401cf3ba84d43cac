"""The study store (docs/DESIGN.md §12): Optuna's journal file by default, an RDB URL on
request; settings fixed at creation; and `optuna-dashboard FILE` opens it, offline. What cannot
be a store is refused in one sentence (exit status 2), and one tune writes a study at a time."""

from __future__ import annotations

import io
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import httpx
import optuna
import pytest

from app.cli import main
from app.study.study_files import StudyBusy, whole_write
from app.study.study_store import StudyStore, open_storage
from tests.testing.server_harness import free_port, wait_for
from tests.testing.signal_support import ctrl_c_raises

ROOT = Path(__file__).resolve().parents[2]
#: a tune that opens its study before it simulates anything
TUNE = ["tune", "--tune", "swing.v", "--cases", "forward", "--generations", "1", "--popsize", "2",
        "--duration", "2", "--warmup", "0.5", "--threads", "1"]  # fmt: skip

SETTINGS = {"names": ["clock.freq_hz"], "popsize": 2, "seed": 1}


def fill(store: StudyStore) -> None:
    for k, (value, loss) in enumerate([(0.8, 1.5), (1.1, 0.7)]):
        values = {"clock.freq_hz": (value, 0.3, 2.0)}
        store.record(0, [(value - 0.3) / 1.7], values, loss, {"nominal": {"forward": {"k": k}}})


@pytest.mark.parametrize("kind", ["journal", "sqlite"])
def test_trials_come_back_from_the_store_alone(tmp_path, kind):
    where = tmp_path / "study.log" if kind == "journal" else f"sqlite:///{tmp_path / 'study.db'}"
    with StudyStore(where, SETTINGS) as store:
        fill(store)
    with StudyStore(where, SETTINGS) as store:  # a new process would do just this
        again = store.recorded()
    assert [r["loss"] for r in again[0]] == [1.5, 0.7]
    assert again[0][1]["metrics"] == {"nominal": {"forward": {"k": 1}}}
    with pytest.raises(ValueError, match="other settings"):
        StudyStore(where, {**SETTINGS, "seed": 2})


def test_a_ctrl_c_during_a_write_acts_once_the_candidate_is_written_whole(tmp_path):
    """Run as a background job (SIGINT ignored from the start) it failed: the test sets the
    disposition it relies on."""
    where = tmp_path / "study.log"
    store = StudyStore(where, SETTINGS)
    reached = []
    with ctrl_c_raises():
        with pytest.raises(KeyboardInterrupt):
            with whole_write():
                os.kill(os.getpid(), signal.SIGINT)  # without the hold, KeyboardInterrupt is here
                reached.append("after the signal")
                fill(store)
        store.close()
        assert reached == ["after the signal"]
        assert not Path(f"{where}.lock").exists()  # Optuna's journal lock is not left behind
        with StudyStore(where, SETTINGS) as again:
            assert [r["loss"] for r in again.recorded()[0]] == [1.5, 0.7]
        with whole_write():  # a block without a signal ends as it would without the hold
            pass
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_write_where_ctrl_c_is_ignored_goes_on_and_leaves_it_ignored(tmp_path):
    """A tune started as a background job (SIGINT ignored) is not ended by a SIGINT during a
    write, and the hold puts the ignoring back."""
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with StudyStore(tmp_path / "study.log", SETTINGS) as store:
            with whole_write():
                os.kill(os.getpid(), signal.SIGINT)
                fill(store)
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            assert [r["loss"] for r in store.recorded()[0]] == [1.5, 0.7]
    finally:
        signal.signal(signal.SIGINT, before)


def refused(args: list[str], capsys) -> str:
    """The one line `artro` says when it refuses `args` with exit status 2 (no traceback: an
    exception would leave `main` and fail the test)."""
    with pytest.raises(SystemExit) as exit_:
        main(args)
    assert exit_.value.code == 2
    said = capsys.readouterr().err.strip().splitlines()[-1]
    assert said.startswith(f"artro {args[0]}: error: ")
    return said


@pytest.mark.parametrize(
    ("study", "what"),
    [
        ("foo://bar", "unknown study URL scheme 'foo'"),
        ("sqlite:///", "names no database file"),
        ("sqlite:///:memory:", "names no database file"),
        ("", "an empty study file name"),
        ("postgresql://artro:secret@127.0.0.1:1/db", "postgresql://artro:***@127.0.0.1:1/db"),
        ("mysql://artro@127.0.0.1:1/db", "mysql://artro@127.0.0.1:1/db"),
        ("sqlite:///{tmp}/not-a-db.db", "cannot be opened (file is not a database)"),
        ("sqlite:///{tmp}/a-file/t.db", "cannot make the study's folder"),
        ("{tmp}/not-a-db.db", "is not an Optuna journal"),
        ("{tmp}", "is a folder, not a study file"),
        ("/dev/full", "/dev/full is not a regular file"),  # read for ever: 24 GB and killed
        ("sqlite:////dev/null", "/dev/null is not a regular file"),
    ],
)
def test_what_cannot_be_a_study_store_is_refused_in_a_sentence(tmp_path, capsys, study, what):
    """Issue 33: tracebacks (OperationalError, ImportError, NoSuchModuleError, DatabaseError)
    and an empty sqlite path that kept nothing without a word."""
    (tmp_path / "not-a-db.db").write_text("hello\n")
    (tmp_path / "a-file").write_text("")
    study = study.format(tmp=tmp_path)
    said = refused([*TUNE, "--study", study, "--out", str(tmp_path / "o.json")], capsys)
    assert what in said and "allowed for --study:" in said
    assert "secret" not in said


def test_a_sqlite_store_makes_its_folder(tmp_path):
    url = f"sqlite:///{tmp_path / 'new' / 'deeper' / 'study.db'}"
    with StudyStore(url, SETTINGS) as store:
        fill(store)
    with StudyStore(url, SETTINGS) as store:
        assert len(store.recorded()[0]) == 2


@pytest.mark.parametrize("kind", ["journal", "sqlite"])
def test_a_second_writer_is_refused_until_the_first_ends(tmp_path, kind):
    """Issue 33: two tunes on one study file interleaved their trials (24 for 12 candidates).
    The first writer here is another process; killed, it leaves its lock file, which is taken
    over."""
    file = tmp_path / ("study.log" if kind == "journal" else "study.db")
    where = str(file) if kind == "journal" else f"sqlite:///{file}"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys; from app.study.study_store import StudyStore; "
         f"s = StudyStore({where!r}, {SETTINGS!r}); print('held', flush=True); sys.stdin.read()"],
        cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout.readline() == "held\n"
        second = subprocess.run(
            [sys.executable, "-m", "app.cli", *TUNE, "--study", where, "--out",
             str(tmp_path / "o.json")],
            cwd=ROOT, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        assert second.returncode == 2, second.stderr[-2000:]
        assert "Traceback" not in second.stderr
        assert (
            f"another tune (PID {holder.pid}) is writing the study {file}"
            in second.stderr.strip().splitlines()[-1]
        )
        with pytest.raises(StudyBusy):
            StudyStore(where, SETTINGS)
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(60)
    assert Path(f"{file}.writer").exists()  # left behind by the killed writer
    with StudyStore(where, SETTINGS) as store:  # the kernel dropped its lock
        fill(store)
        assert Path(f"{file}.writer").read_text().strip() == str(os.getpid())
    assert not Path(f"{file}.writer").exists()  # a writer that ends removes its lock


def test_optuna_dashboard_opens_the_journal_offline(tmp_path):
    journal = tmp_path / "study.log"
    with StudyStore(journal, SETTINGS) as store:
        fill(store)
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


def test_a_study_on_a_database_server_has_one_writer_by_its_lease(tmp_path):
    """A study on PostgreSQL or MySQL has no file to lock (issue 33: two tunes interleaved):
    `WriterLease` keeps the writer in the study itself. Held here on a real Optuna RDB storage
    (SQLAlchemy on SQLite, the code PostgreSQL's goes through): a second writer is refused naming
    the first, one that ends lets the next in, and a lease a crashed writer left is taken over
    once LEASE_S has passed."""
    import time

    import optuna

    from app.study.study_files import LEASE_S, WriterLease

    url = f"sqlite:///{tmp_path / 'server.db'}"
    study = optuna.create_study(study_name="s", storage=url)
    first, second = WriterLease(study, url), WriterLease(study, url)
    first.acquire()
    with pytest.raises(StudyBusy, match=rf"another tune \(PID {os.getpid()} on .+\) is writing"):
        second.acquire()
    first.renew()
    first.release()
    second.acquire()  # the first ended: the second writes
    assert study.user_attrs["writer"]["token"] == second.token
    crashed = dict(study.user_attrs["writer"], token="crashed", renewed=time.time() - LEASE_S - 1)
    study.set_user_attr("writer", crashed)  # a writer that died a lease ago
    third = WriterLease(study, url)
    third.acquire()
    assert study.user_attrs["writer"]["token"] == third.token
    with pytest.raises(StudyBusy):
        WriterLease(optuna.load_study(study_name="s", storage=url), url).acquire()


def test_a_study_reached_through_a_link_has_the_one_writer(tmp_path):
    """A second tune on a symbolic link to a study being written is refused as on the file
    itself (two writers put 23 trials in a study of 16)."""
    real = tmp_path / "real.log"
    link = tmp_path / "link.log"
    link.symlink_to(real)
    with StudyStore(real, SETTINGS) as store:
        fill(store)
        with pytest.raises(StudyBusy, match="another tune"):
            StudyStore(link, SETTINGS)
    assert not any(tmp_path.glob("*.writer"))


def test_other_settings_are_refused_naming_each_that_differs(tmp_path):
    with StudyStore(tmp_path / "s.log", SETTINGS) as store:
        fill(store)
    other = {**SETTINGS, "popsize": SETTINGS["popsize"] + 1, "extra": 1}
    with pytest.raises(ValueError, match="other settings") as refused_:
        StudyStore(tmp_path / "s.log", other)
    said = str(refused_.value)
    assert f"popsize was {SETTINGS['popsize']!r}, now {SETTINGS['popsize'] + 1!r}" in said
    assert "extra was None, now 1" in said
    assert "seed" not in said  # only what differs


def test_a_journal_damaged_in_its_middle_is_said_so(tmp_path):
    """Not "ended in a damaged entry": a bad line with whole entries after it was no crash at
    the end; what is moved aside is said, and the journal keeps the entries before it."""
    journal = tmp_path / "s.log"
    with StudyStore(journal, SETTINGS) as store:
        fill(store)
    lines = journal.read_bytes().splitlines(keepends=True)
    middle = len(lines) // 2
    journal.write_bytes(b"".join([*lines[:middle], b"{not json\n", *lines[middle:]]))
    said = io.StringIO()
    with StudyStore(journal, SETTINGS, log=said):
        pass
    assert f"has a damaged entry at line {middle + 1}, with {len(lines) - middle} whole" in (
        said.getvalue()
    )
    assert journal.read_bytes().startswith(b"".join(lines[:middle]))  # then what it wrote
    (aside,) = tmp_path.glob("s.log.damaged-*")
    assert aside.read_bytes() == b"".join([b"{not json\n", *lines[middle:]])


#: whole JSON entries Optuna cannot apply (it stopped with a traceback: AssertionError "Should
#: not reach.", KeyError 'study_name'), and what is said of each
UNAPPLIABLE = {
    "an unknown op_code": (
        b'{"op_code": 99, "worker_id": "w"}\n',
        "op_code 99, where Optuna's journal has the operations 0 to 10",
    ),
    "a study made without its name": (
        b'{"op_code": 0, "worker_id": "w", "directions": [1]}\n',
        "op_code 0 without study_name",
    ),
}


@pytest.mark.parametrize("line", UNAPPLIABLE.values(), ids=UNAPPLIABLE.keys())
@pytest.mark.parametrize("at", ["middle", "end"])
def test_a_journal_line_optuna_cannot_apply_is_named_and_moved_aside(tmp_path, line, at):
    """As a damaged line is: the journal keeps the entries before it, the line and what follows
    go aside, and the message names the line and why Optuna cannot apply it."""
    entry, why = line
    journal = tmp_path / "s.log"
    with StudyStore(journal, SETTINGS) as store:
        fill(store)
    lines = journal.read_bytes().splitlines(keepends=True)
    where = len(lines) // 2 if at == "middle" else len(lines)
    journal.write_bytes(b"".join([*lines[:where], entry, *lines[where:]]))
    said = io.StringIO()
    with StudyStore(journal, SETTINGS, log=said) as store:
        kept = store.recorded()
    named = f"an entry Optuna cannot apply ({why}) at line {where + 1}"
    assert named in said.getvalue() and "Traceback" not in said.getvalue()
    (aside,) = tmp_path.glob("s.log.damaged-*")
    assert aside.read_bytes() == b"".join([entry, *lines[where:]])
    assert journal.read_bytes().startswith(b"".join(lines[:where]))
    if at == "end":
        assert [r["loss"] for r in kept[0]] == [1.5, 0.7]


def test_a_journal_whose_first_line_optuna_cannot_apply_is_refused(tmp_path, capsys):
    journal = tmp_path / "s.log"
    journal.write_bytes(UNAPPLIABLE["an unknown op_code"][0])
    said = refused([*TUNE, "--study", str(journal)], capsys)
    assert (
        f"{journal} is not an Optuna journal (its first line is not a journal entry: op_code 99"
        in said
    )
    assert journal.read_bytes() == UNAPPLIABLE["an unknown op_code"][0]  # nothing moved


@pytest.mark.slow
def test_a_tune_of_another_size_starts_its_own_study_in_the_same_file(tmp_path):
    """The README's quick start broke on a second tune: every tune wrote the study "artro-tune"
    of out/tune/study.log, and a tune of another size was refused ("run with other settings").
    Each robot and set of options now has its own study there; the same command resumes it."""
    where = tmp_path / "study.log"
    for popsize in ("2", "3"):
        done = subprocess.run(
            [sys.executable, "-m", "app.cli", *TUNE, "--popsize", popsize, "--study", str(where),
             "--out", str(tmp_path / f"o{popsize}.json")],
            cwd=ROOT, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-2000:]
    names = optuna.get_all_study_names(open_storage(where))
    assert len(names) == 2 and all(re.fullmatch(r"tune-artro-[0-9a-f]{8}", n) for n in names)
    sizes = {optuna.load_study(study_name=n, storage=open_storage(where)).user_attrs["settings"]
             ["popsize"] for n in names}  # fmt: skip
    assert sizes == {2, 3}
