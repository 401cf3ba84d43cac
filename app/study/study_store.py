"""The tuner's study store (docs/DESIGN.md §12): every evaluated candidate is an Optuna trial,
written the moment its runs are done, in a journal file (default: no server) or any RDB URL;
a study resumes from the store alone, and `optuna-dashboard FILE` opens it. One tune writes a
study at a time; a journal a crash cut short resumes from its whole entries (`study_files`)."""

from __future__ import annotations

import datetime
import hashlib
import json
import re
import sys
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from app.params.presets import name_too_long, not_a_file
from app.study.study_files import WriterLease, WriterLock, mend_journal, whole_write

if TYPE_CHECKING:
    import optuna

DEFAULT_STUDY = "artro-tune"  # a Tuner's own study (tests, scripts); `artro tune`: study_name_for
#: the objective's name in optuna-dashboard
OBJECTIVE = "loss (paper criteria + robust term)"
#: the figures of each nominal run that become user attributes of their own
FIGURES = ("forward_cm_s", "lateral_cm_s", "turn_deg_s")
# optuna is imported where a study is opened (~0.3 s), not by every `artro` command
RDB_DIALECTS = ("sqlite", "postgresql", "mysql")
ALLOWED = (
    "allowed for --study: a journal file path (default out/tune/study.log), sqlite:///FILE, "
    "or postgresql://... or mysql://... with their driver installed"
)


def check_location(where: str | Path) -> str:
    """`where` if it can name a study store, else ValueError saying what is allowed (the form
    only: nothing is opened)."""
    text = str(where)
    if "://" not in text:
        if not text.strip():
            raise ValueError(f"an empty study file name; {ALLOWED}")
        _check_file(Path(text), text)
        return text
    scheme, _, rest = text.partition("://")
    dialect = scheme.split("+")[0].lower()
    if dialect not in RDB_DIALECTS:
        raise ValueError(f"unknown study URL scheme {scheme!r} in {text!r}; {ALLOWED}")
    if dialect == "sqlite":
        path = sqlite_path(text)
        if path is None:
            raise ValueError(
                f"{text!r} names no database file (sqlite:/// then a path; sqlite:///:memory: "
                f"or an empty path would keep nothing); {ALLOWED}"
            )
        _check_file(path, text)
    elif not rest.strip("/"):
        raise ValueError(f"{text!r} names no database server; {ALLOWED}")
    return text


def _check_file(path: Path, text: str) -> None:
    """ValueError unless `path` is a regular file or nothing yet (a folder, a device such as
    /dev/full, a pipe: a study read from one never ends or keeps nothing)."""
    if problem := name_too_long(path):
        raise ValueError(f"{text} {problem}; {ALLOWED}")
    if problem := not_a_file(path):
        raise ValueError(f"{text} {problem}, not a study file; {ALLOWED}")


def sqlite_path(url: str) -> Path | None:
    """The file of a sqlite:///FILE URL (sqlite:////abs/path for an absolute one), None if the
    URL names none (an empty path, :memory:)."""
    rest = url.partition("://")[2]
    if not rest.startswith("/"):
        return None  # sqlite://HOST/... is not a file
    path = rest[1:].partition("?")[0]
    if not path or path == ":memory:" or path.endswith("/"):
        return None
    return Path(path)


def open_storage(where: str | Path) -> optuna.storages.BaseStorage:
    """An RDB for a URL (sqlite:///..., postgresql://...), else a journal file at that path.
    ValueError, saying what is allowed, for what cannot be opened."""
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    text = check_location(where)
    if "://" not in text:
        _make_folder(Path(text).parent)
        return JournalStorage(JournalFileBackend(text))
    return _open_rdb(text)


def _open_rdb(url: str) -> optuna.storages.BaseStorage:
    from optuna.storages import RDBStorage

    dialect = url.partition("://")[0].split("+")[0].lower()
    path = sqlite_path(url) if dialect == "sqlite" else None
    if path is not None:
        _make_folder(path.parent)
    try:
        return RDBStorage(url)
    except ImportError as exc:
        missing = getattr(exc.__cause__, "name", None) or "its driver"
        raise ValueError(
            f"the study URL {_shown(url)!r} needs the database driver {missing}, which is not "
            f"installed (pip install it, or name an installed one: {dialect}+DRIVER://...); "
            f"{ALLOWED}"
        ) from None
    except Exception as exc:  # SQLAlchemy's errors: no server, refused, not a database, ...
        reason = getattr(exc, "orig", None) or exc
        raise ValueError(
            f"the study store {_shown(url)!r} cannot be opened ({reason}); {ALLOWED}"
        ) from None


def _shown(url: str) -> str:
    """The URL as said in a message: its password hidden."""
    return re.sub(r"^([^:/]+://[^:/@]*:)[^@]*@", r"\1***@", url)


def _make_folder(folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(
            f"cannot make the study's folder {folder} ({exc.strerror}); {ALLOWED}"
        ) from None


def figures(metrics: dict[str, Any]) -> dict[str, Any]:
    """A trial's figures as flat user attributes: `<run>.<figure>` of each nominal run
    (`<run>.fell` when it fell), and `robust.pass_share` with --robust."""
    out: dict[str, Any] = {}
    for run, m in metrics.get("nominal", {}).items():
        if m.get("fell"):
            out[f"{run}.fell"] = True
        out |= {f"{run}.{f}": m[f] for f in FIGURES if isinstance(m.get(f), (int, float))}
    robust = metrics.get("robust")
    if robust and robust.get("runs"):
        out["robust.pass_share"] = robust["passed"] / robust["runs"]
    return out


def _said(value: Any) -> str:
    """A setting as a message shows it: numbers to 6 digits (0.5, not 0.5000000000000001)."""
    return f"{value:.6g}" if isinstance(value, float) else repr(value)


def study_name_for(robot: str, settings: dict[str, Any]) -> str:
    """`artro tune`'s study within its store when none is named: one per robot and settings
    (a digest of them), so the same command resumes its study and a tune of another size or
    robot starts its own instead of being refused."""
    digest = hashlib.sha1(json.dumps(settings, sort_keys=True, default=str).encode()).hexdigest()
    return f"tune-{robot}-{digest[:8]}"


class StudyStore:
    """One tuning study: its settings (fixed at creation; other settings are refused) and its
    trials, each with the generation, the candidate's point in the unit box, its loss and the
    metrics of its runs. A study has one writer: a second is refused (`StudyBusy`, a ValueError)
    until `close` or the writer's end (a file's lock; a database server's lease, LEASE_S). A
    journal whose end a crash damaged is cut back to its whole entries first, said on `log`
    (default stderr)."""

    def __init__(
        self,
        where: str | Path,
        settings: dict[str, Any],
        *,
        name: str = DEFAULT_STUDY,
        log: TextIO | None = None,
    ) -> None:
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        self.where = check_location(where)
        journal = "://" not in self.where
        file = Path(self.where) if journal else sqlite_path(self.where)
        self._lock = None if file is None else WriterLock(file)
        self._lease: WriterLease | None = None
        if self._lock is not None and file is not None:  # the one with the other
            _make_folder(file.parent)
            self._lock.acquire()
        try:
            if journal and (said := mend_journal(self.where)):
                print(said, file=log or sys.stderr, flush=True)
            with whole_write():
                self.study = optuna.create_study(
                    study_name=name,
                    storage=open_storage(self.where),
                    direction="minimize",
                    load_if_exists=True,
                )
                self._check_settings(settings, name)
            if self._lock is None:  # a database server: a lease in the study itself
                self._lease = WriterLease(self.study, self.where)
                self._lease.acquire()
        except BaseException:
            self.close()
            raise

    def _check_settings(self, settings: dict[str, Any], name: str) -> None:
        wanted = json.loads(json.dumps(settings))  # as the store gives it back
        found = self.study.user_attrs.get("settings")
        if found is None:
            self.study.set_user_attr("settings", wanted)
        elif found != wanted:
            differ = "; ".join(
                f"{key} was {_said(found.get(key))}, now {_said(wanted.get(key))}"
                for key in sorted(set(found) | set(wanted), key=str)
                if found.get(key) != wanted.get(key)
            )
            raise ValueError(
                f"the study {name!r} in {self.where} was run with other settings ({differ}); "
                f"use another --study file, another --study-name or the same options"
            )

    def close(self) -> None:
        """Let another process write the study."""
        if self._lock is not None:
            self._lock.release()
        if self._lease is not None:
            self._lease.release()

    def __enter__(self) -> StudyStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def recorded(self) -> dict[int, list[dict[str, Any]]]:
        """Finished evaluations by generation: {"unit", "loss", "metrics"} each."""
        from optuna.trial import TrialState

        out: dict[int, list[dict[str, Any]]] = {}
        for trial in self.study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
            attrs = trial.user_attrs
            out.setdefault(int(attrs["generation"]), []).append(
                {"unit": attrs["unit"], "loss": trial.value, "metrics": attrs["metrics"]}
            )
        return out

    def record(
        self,
        generation: int,
        unit: Iterable[float],
        values: dict[str, tuple[float, float, float]],
        loss: float,
        metrics: dict[str, Any],
        *,
        started_s: float | None = None,
    ) -> None:
        """One finished candidate: `values` maps each tuned field to (value, low, high); it
        started at `started_s` (Unix s; default: now) and ends now. Beside `metrics` (what a
        resume reads), each nominal figure and the varied runs' pass share are user attributes
        of their own, for optuna-dashboard."""
        import optuna
        from optuna.distributions import FloatDistribution
        from optuna.trial import create_trial

        trial = create_trial(
            params={k: v for k, (v, _, _) in values.items()},
            distributions={k: FloatDistribution(lo, hi) for k, (_, lo, hi) in values.items()},
            value=loss,
            user_attrs={"generation": generation, "unit": [float(u) for u in unit],
                        "metrics": metrics, **figures(metrics)},
        )  # fmt: skip
        if started_s is not None:
            trial.datetime_start = datetime.datetime.fromtimestamp(started_s)
        with whole_write():  # a Ctrl-C now keeps this candidate and the journal's lock whole
            if not self.study.metric_names:
                with warnings.catch_warnings():  # "experimental" since Optuna 3.2, kept in 5
                    warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
                    self.study.set_metric_names([OBJECTIVE])
            self.study.add_trial(trial)
            if self._lease is not None:
                self._lease.renew()
