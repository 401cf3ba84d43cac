"""What a crash or a second process can do to a study (docs/DESIGN.md §12), and what the tuner
does about it: one writer at a time -- a lock file beside a study in a file (`WriterLock`), a
lease in a study on a database server (`WriterLease`), a Ctrl-C held back until a write is whole
(`whole_write`) -- and a journal whose last entry a crash cut short resumes from its whole entries
(`mend_journal`)."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # not on Windows: the study is then not locked
    fcntl = None  # type: ignore[assignment]  # no module: None stands for it

LOCK_SUFFIX = ".writer"  # Optuna's journal keeps its own short-lived `.lock` beside the file


@contextlib.contextmanager
def whole_write() -> Iterator[None]:
    """A Ctrl-C during the block acts at its end. Optuna's journal lock, interrupted between its
    rename and its unlink, raised FileNotFoundError instead and could leave its lock file for the
    next run to wait out. Only the main thread receives signals; elsewhere this does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    asked: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: asked.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if asked and callable(previous):  # the default handler raises KeyboardInterrupt
        previous(signal.SIGINT, None)


class StudyBusy(ValueError):
    """Another process is writing the study."""


class WriterLock:
    """The right to write the study at `path`: `path` + ".writer", locked (flock) while held,
    with the holder's PID in it for the message to the next one. A lock file left by a process
    that died is not locked any more and is taken over."""

    def __init__(self, path: str | Path) -> None:
        self.study = Path(path)
        # beside the file itself: a study reached through a link has one lock
        self.path = Path(f"{self.study.resolve()}{LOCK_SUFFIX}")
        self._fd: int | None = None

    def acquire(self) -> None:
        """Take the lock, or StudyBusy naming the study, the lock file and the holder's PID."""
        if fcntl is None:
            return
        for _ in range(10):  # the file can be removed by its releasing holder as we open it
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.read(fd, 64).decode(errors="replace").strip() or "unknown"
                os.close(fd)
                raise StudyBusy(
                    f"another tune (PID {holder}) is writing the study {self.study} (lock "
                    f"{self.path}); wait until it ends, or use another --study file"
                ) from None
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
                self._fd = fd
                return
            os.close(fd)  # we locked a file its holder had just removed: take the new one
        raise StudyBusy(f"the lock {self.path} of the study {self.study} keeps changing hands")

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)  # while still locked: nobody holds a removed file
        finally:
            os.close(self._fd)
            self._fd = None

    def __del__(self) -> None:  # a store dropped without `close` lets the next writer in
        self.release()


#: a lease not renewed for this long is a dead writer's: a candidate's runs take minutes at most
LEASE_S = 600.0


class WriterLease:
    """The right to write a study kept on a database server (PostgreSQL, MySQL: no file to
    lock): the study's user attribute `writer` names the holder (host, PID, a token) and when it
    last renewed the lease; the writer renews it with each trial (`renew`). A lease older than
    LEASE_S is a crashed writer's and is taken over. The attribute is written, then read back:
    of two that wrote at once, the one whose token stayed holds the study."""

    def __init__(self, study: Any, where: str) -> None:
        self.study, self.where = study, where
        self.token = uuid.uuid4().hex
        self.held = False

    def _mine(self, now: float) -> dict[str, Any]:
        return {"token": self.token, "host": socket.gethostname(), "pid": os.getpid(),
                "renewed": now}  # fmt: skip

    def _busy(self, other: dict[str, Any], now: float) -> StudyBusy:
        age = max(0.0, now - float(other.get("renewed", 0.0)))
        return StudyBusy(
            f"another tune (PID {other.get('pid')} on {other.get('host')}) is writing the study "
            f"in {self.where} (its lease renewed {age:.0f} s ago); wait until it ends (or "
            f"{LEASE_S:.0f} s after it stopped), or use another --study or --study-name"
        )

    def acquire(self) -> None:
        """Take the lease, or StudyBusy naming the holder."""
        now = time.time()
        held = self.study.user_attrs.get("writer")
        if held and held.get("token") != self.token and now - held.get("renewed", 0) < LEASE_S:
            raise self._busy(held, now)
        self.study.set_user_attr("writer", self._mine(now))
        after = self.study.user_attrs.get("writer") or {}
        if after.get("token") != self.token:
            raise self._busy(after, now)
        self.held = True

    def renew(self) -> None:
        if self.held:
            self.study.set_user_attr("writer", self._mine(time.time()))

    def release(self) -> None:
        if self.held:
            self.held = False
            self.study.set_user_attr("writer", None)


def mend_journal(path: str | Path) -> str | None:
    """Cut an Optuna journal back to its whole entries when its end is damaged (a crash cut the
    last line short, or a later write was appended to such a line); the cut bytes go to a file
    beside it. Returns the sentence that says so, else None. ValueError when the file's first
    line is no journal entry (it is no journal: nothing is moved)."""
    from optuna.storages.journal import JournalFileSymlinkLock

    path = Path(path)
    if not path.exists() or path.stat().st_size == 0:
        return None
    lock = JournalFileSymlinkLock(str(path))  # Optuna's, held while an entry is appended
    lock.acquire()
    try:
        return _mend(path)
    finally:
        lock.release()


def _mend(path: Path) -> str | None:
    data = path.read_bytes()
    good = 0  # bytes of whole entries Optuna applies, from the start
    entries = 0
    replay = _Replay()
    why = ""  # why the first line that is not such an entry is not
    for line in data.splitlines(keepends=True):
        if not line.endswith(b"\n") or not _is_entry(line):
            break
        if why := replay.refusal(line):
            break
        good += len(line)
        entries += 1
    if good == len(data):
        return None
    if entries == 0:
        raise ValueError(
            f"{path} is not an Optuna journal (its first line is not a journal entry"
            f"{f': {why}' if why else ''}); allowed for --study: a journal file written by artro "
            f"tune, a new file, or an RDB URL such as sqlite:///FILE"
        )
    aside = path.with_name(f"{path.name}.damaged-{time.strftime('%Y%m%d-%H%M%S')}")
    aside.write_bytes(data[good:])
    with path.open("r+b") as f:
        f.truncate(good)
        f.flush()
        os.fsync(f.fileno())
    rest = data[good:].splitlines(keepends=True)
    later = sum(line.endswith(b"\n") and _is_entry(line) for line in rest[1:])
    damaged = f"an entry Optuna cannot apply ({why})" if why else "a damaged entry"
    if not later:
        cause = f"at line {entries + 1}" if why else "(a crash while writing?)"
        return (
            f"the study journal {path} ended in {damaged} {cause}: kept its {entries} whole "
            f"entries, moved the last {len(data) - good} bytes to {aside}"
        )
    return (
        f"the study journal {path} has {damaged} at line {entries + 1}, with {later} "
        f"whole entries after it (edited, or written by another program?): kept the "
        f"{entries} before it; it and everything after it ({len(data) - good} bytes) moved "
        f"to {aside}; the candidates recorded there are simulated again"
    )


def _is_entry(line: bytes) -> bool:
    try:
        entry = json.loads(line)
    except (ValueError, UnicodeDecodeError):
        return False
    return isinstance(entry, dict) and "op_code" in entry


class _Replay:
    """The journal's entries applied as Optuna applies them when it opens the journal, one line
    at a time, so that a line it cannot apply (an unknown op_code, a field missing) is named
    instead of ending the tune in a traceback. Optuna's own replay (it has no public one), as
    a reader that wrote none of the entries."""

    def __init__(self) -> None:
        from optuna.storages.journal._storage import JournalOperation, JournalStorageReplayResult

        self._operations = {int(op) for op in JournalOperation}
        self._result = JournalStorageReplayResult(f"artro-mend-{uuid.uuid4()}-")

    def refusal(self, line: bytes) -> str:
        """Apply the entry `line` (a JSON object with an op_code); why Optuna cannot, else ""."""
        entry = json.loads(line)
        op = entry["op_code"]
        if isinstance(op, bool) or not isinstance(op, int) or op not in self._operations:
            allowed = f"{min(self._operations)} to {max(self._operations)}"
            return f"op_code {op!r}, where Optuna's journal has the operations {allowed}"
        try:
            self._result.apply_logs([entry])
        except KeyError as exc:
            return f"op_code {op} without {exc.args[0] if exc.args else 'a field it needs'}"
        except Exception as exc:  # what else Optuna cannot apply: a bad value, a bad state
            return f"op_code {op}: {exc or type(exc).__name__}"
        return ""
