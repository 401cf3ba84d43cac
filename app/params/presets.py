"""Named parameter sets ("presets") on disk, next to read-only built-in ones (docs/DESIGN.md §6).

User presets are `<data_dir>/presets/<name>.json` documents, names of a fixed alphabet
(`NAME_RULE`), written atomically (`write_parameter_set`); see `PresetStore`. A crash's stale
temporary files are removed at start; names the API needs ("diff", "current") are reserved."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from app.assets import builtin_presets_dir
from app.params.document import ParameterSet, project_version
from app.params.formats import load_parameter_set

DATA_DIR_ENV = "ARTRO_DATA_DIR"
# a short, fixed alphabet, so a name can never leave the presets directory
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
NAME_RULE = (
    "1 to 64 characters: letters, digits, '_', '.' and '-', starting with a letter or digit, "
    "without '..' and not ending in '.'"
)
SUFFIX = ".json"
#: Names the HTTP API uses next to preset names (`GET /api/presets/diff`, "current" in a diff).
RESERVED_NAMES = frozenset({"current", "diff"})
STALE_TMP_S = 60.0  # a temporary file this old is left over from a crash mid-save
BUILTIN_DIR = builtin_presets_dir()


class PresetError(ValueError):
    """A preset name or operation was refused; the message says what is allowed."""


class PresetNotFound(KeyError):
    """No preset of that name, built in or on disk."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else "preset not found"


@dataclass(frozen=True)
class PresetInfo:
    """One entry of `PresetStore.list()`."""

    name: str
    builtin: bool
    created: str
    motion: dict[str, float]
    robot: str  # the robot it was tuned for

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class PresetProblem:
    """A file in the presets directory that `list()` skipped, and why."""

    file: str
    error: str

    def to_dict(self) -> dict[str, str]:
        return dataclasses.asdict(self)


PresetList = list[PresetInfo]  # module-level aliases: PresetStore.list shadows `list` in the class
ProblemList = list[PresetProblem]


def default_data_dir() -> Path:
    """$ARTRO_DATA_DIR if set, else $XDG_DATA_HOME/artro-gait-studio (an absolute
    $XDG_DATA_HOME, as the XDG base directories have it), else
    ~/.local/share/artro-gait-studio."""
    configured = os.environ.get(DATA_DIR_ENV, "").strip()
    if configured:
        return Path(configured).expanduser()
    xdg = os.environ.get("XDG_DATA_HOME", "").strip()
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "artro-gait-studio"


def check_name(name: object) -> str:
    """Return `name` if it is a valid preset name, else raise PresetError saying what is allowed."""
    if not isinstance(name, str):
        raise PresetError(f"a preset name must be a string of {NAME_RULE}")
    if not NAME_PATTERN.fullmatch(name) or ".." in name or name.endswith("."):
        raise PresetError(f"invalid preset name {name[:80]!r}; allowed: {NAME_RULE}")
    if name.lower() in RESERVED_NAMES:
        reserved = ", ".join(sorted(RESERVED_NAMES))
        raise PresetError(f"{name!r} is reserved ({reserved}); choose another name")
    return name


def diff(a: ParameterSet, b: ParameterSet) -> list[dict[str, Any]]:
    """Every parameter that differs: [{'field': 'motion.a_p' | 'swing.v' | ..., 'a': .., 'b': ..}].

    Motion fields come first ('motion.<x>'), then the gait in `GaitParams.flat()` order.
    Provenance (name, created, project version) is not compared.
    """
    left = {f"motion.{k}": v for k, v in dataclasses.asdict(a.motion).items()} | a.gait.flat()
    right = {f"motion.{k}": v for k, v in dataclasses.asdict(b.motion).items()} | b.gait.flat()
    return [
        {"field": name, "a": value, "b": right[name]}
        for name, value in left.items()
        if value != right[name]
    ]


def _fsync_dir(directory: Path) -> None:
    """Make a rename in `directory` durable (POSIX; a no-op where directories can't be opened)."""
    try:
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def stamped(pset: ParameterSet, name: str) -> ParameterSet:
    """`pset` named `name`, with provenance: created now (UTC), this project's version."""
    return dataclasses.replace(
        pset,
        name=name,
        created=datetime.now(UTC).isoformat(timespec="seconds"),
        project_version=project_version(),
    )


def name_too_long(path: Path) -> str | None:
    """Why the file system would refuse `path` for its length, or None: a name (a part between
    slashes) over the folder's NAME_MAX bytes (255 on most), or the whole over PATH_MAX (4096).
    Looking at such a path raises OSError (File name too long), so this comes first."""
    limit = _name_max(path)
    for part in path.parts:
        size = len(os.fsencode(part))
        if size > limit:
            shown = part if len(part) <= 24 else f"{part[:12]}...{part[-8:]}"
            return f"has a name of {size} bytes ({shown}); a name is at most {limit} bytes"
    whole = len(os.fsencode(str(path)))
    limit = _pathconf("/", "PC_PATH_MAX", 4096)
    if whole >= limit:
        return f"is a path of {whole} bytes; a path is shorter than {limit} bytes"
    return None


def _name_max(path: Path) -> int:
    """The longest name the nearest folder above `path` that exists takes, in bytes."""
    for up in path.parents:
        if (found := _pathconf(up, "PC_NAME_MAX", 0)) > 0:
            return found
    return 255


def _pathconf(path: Path | str, name: str, default: int) -> int:
    try:
        return os.pathconf(path, name)
    except (OSError, ValueError):  # nothing there (yet), a name too long, no such limit
        return default


def not_a_file(path: Path) -> str | None:
    """Why `path` cannot be read or written as a file, or None (a regular file, or nothing yet):
    a name the file system refuses for its length, a folder, or a device, pipe or socket (one
    read never ends; a temporary file renamed over it would replace it)."""
    if problem := name_too_long(path):
        return problem
    if path.is_dir():
        return "is a folder"
    if path.exists() and not path.is_file():
        return "is not a regular file (a device, a pipe or a socket)"
    return None


def write_parameter_set(path: Path, pset: ParameterSet) -> None:
    """Write a parameter-set file atomically: a crash mid-write leaves the old file intact.

    The document goes to a temporary file in the same directory, is flushed and fsync'ed, renamed
    over `path` with `os.replace`, and the directory is fsync'ed: a crash at any point leaves
    either the old file or the new one, never a torn one. OSError if the folder is not writable.
    """
    if problem := not_a_file(path):  # the rename below would replace a device
        raise OSError(f"{path} {problem}")
    text = json.dumps(pset.to_dict(), indent=2, allow_nan=False) + "\n"
    fd, tmp_name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp")
    tmp = Path(tmp_name)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


def builtin_presets() -> dict[str, ParameterSet]:
    """The read-only presets shipped in models/presets/: 'paper' (the literal paper values)
    first, then the others (e.g. 'tuned')."""
    found = {p.stem: load_parameter_set(p) for p in sorted(BUILTIN_DIR.glob("*.json"))}
    paper = found.pop("paper", ParameterSet(name="paper"))
    return {"paper": paper, **found}


class PresetStore:
    """Built-in presets (read-only) plus user presets in `<data_dir>/presets/`.

    Each user preset is one `ParameterSet.to_dict()` JSON document, `<name>.json`. `builtins`
    maps name -> set in display order (e.g. `builtin_presets()`); PresetError for a bad name.
    """

    diff = staticmethod(diff)

    def __init__(self, data_dir: Path, builtins: Mapping[str, ParameterSet]) -> None:
        self.data_dir = Path(data_dir)
        self.directory = self.data_dir / "presets"
        self._builtins = {check_name(name): pset for name, pset in builtins.items()}
        self.problems: ProblemList = []  # from the latest list()
        self.removed_tmp = self.clear_stale_tmp()

    def clear_stale_tmp(self, older_than_s: float = STALE_TMP_S) -> list[str]:
        """Remove temporary files of saves that a crash (SIGKILL, power loss) interrupted;
        recent ones may belong to a save running now in another process."""
        if not self.directory.is_dir():
            return []
        removed = []
        now = time.time()
        for path in self.directory.glob(".*.tmp"):
            try:
                if now - path.stat().st_mtime >= older_than_s:
                    path.unlink()
                    removed.append(path.name)
            except OSError:
                continue  # gone already, or not ours to remove: list() never shows it anyway
        return removed

    def is_builtin(self, name: str) -> bool:
        """True for a built-in (read-only) preset name."""
        return name in self._builtins

    def _path(self, name: str) -> Path:
        path = self.directory / f"{check_name(name)}{SUFFIX}"
        if path.parent != self.directory:  # unreachable with NAME_PATTERN; defence in depth
            raise PresetError(f"invalid preset name {name!r}; allowed: {NAME_RULE}")
        return path

    def _refuse_builtin(self, name: str) -> None:
        if name in self._builtins:
            raise PresetError(f"{name!r} is built in and read-only; save under another name")

    @staticmethod
    def _read(path: Path) -> ParameterSet:
        """Parse one preset file; ValueError/OSError say what is wrong with it."""
        text = path.read_text(encoding="utf-8")
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"not valid JSON (line {exc.lineno}, column {exc.colno})") from exc
        return ParameterSet.from_dict(data)

    def get(self, name: str) -> ParameterSet:
        """The built-in or saved preset `name`.

        Raises:
            PresetError: invalid name, or the file exists but is not a valid parameter set.
            PresetNotFound: no such preset.
        """
        check_name(name)
        if name in self._builtins:
            return self._builtins[name]
        path = self._path(name)
        try:
            return self._read(path)
        except FileNotFoundError:
            raise PresetNotFound(f"no preset named {name!r}") from None
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise PresetError(f"preset {name!r} cannot be read: {exc}") from exc

    def save(self, name: str, pset: ParameterSet) -> ParameterSet:
        """Store `pset` as `name` (replacing a saved one atomically); returns what was stored.

        The stored document gets provenance: name = `name`, created = now (UTC), this project's
        version. Built-in names are refused.

        Raises:
            PresetError: invalid or built-in name. OSError: the file cannot be written.
        """
        path = self._path(name)
        self._refuse_builtin(name)
        stored = stamped(pset, name)
        self.directory.mkdir(parents=True, exist_ok=True)
        write_parameter_set(path, stored)
        return stored

    def delete(self, name: str) -> None:
        """Remove the saved preset `name`; built-ins are refused, a missing one is not found.

        Raises:
            PresetError: invalid or built-in name. PresetNotFound: no such saved preset.
        """
        path = self._path(name)
        self._refuse_builtin(name)
        try:
            path.unlink()
        except FileNotFoundError:
            raise PresetNotFound(f"no preset named {name!r}") from None
        _fsync_dir(self.directory)

    def start_for(self, robot: str, default: str) -> ParameterSet:
        """The set a robot starts in: its `default` preset (built in), unless that was tuned for
        another robot and a preset saved here was tuned for this one (by `artro tune` or the
        page's "Tune for this robot"): then the newest such. A robot of your own thus walks its
        own tune, not ArtRo's `robust`, once it has one."""
        chosen = self._builtins.get(default, self._builtins.get("paper"))
        if chosen is None or chosen.robot == robot:
            return chosen or ParameterSet()
        own = [info for info in self.list() if not info.builtin and info.robot == robot]
        if not own:
            return chosen
        newest = max(own, key=lambda info: info.created)
        try:
            return self.get(newest.name)
        except (PresetNotFound, PresetError):  # removed or broken since the listing
            return chosen

    def list(self) -> PresetList:
        """Built-ins (in the given order), then saved presets sorted by name.

        Files that are not valid presets are skipped and recorded in `self.problems`, so one bad
        file never hides the others.
        """
        infos = [
            PresetInfo(name, True, pset.created, dataclasses.asdict(pset.motion), pset.robot)
            for name, pset in self._builtins.items()
        ]
        problems: ProblemList = []
        paths = sorted(self.directory.glob(f"*{SUFFIX}")) if self.directory.is_dir() else []
        for path in paths:
            name = path.name[: -len(SUFFIX)]
            try:
                check_name(name)
            except PresetError:
                problems.append(PresetProblem(path.name, f"not a valid preset name ({NAME_RULE})"))
                continue
            if name in self._builtins:
                problems.append(PresetProblem(path.name, "shadowed by the built-in preset"))
                continue
            try:
                pset = self._read(path)
            except (OSError, UnicodeDecodeError, ValueError) as exc:
                problems.append(PresetProblem(path.name, str(exc)))
                continue
            motion = dataclasses.asdict(pset.motion)
            infos.append(PresetInfo(name, False, pset.created, motion, pset.robot))
        self.problems = problems
        return infos
