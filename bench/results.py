"""What every bench in bench/ writes its results with: one JSON document per run.

    args = results.parse_args(parser)          # the bench's parser, with --json PATH added
    ...                                        # measure, print the text as before
    results.write("bench_pipeline", args, figures, headline)

The document (`bench/results/<name>.json` unless `--json PATH`; `--json -` writes it to standard
output and sends the bench's text to standard error) holds:

  bench       the bench's name (its file name without .py)
  command     the command line that gives these figures (without --json)
  arguments   every option the bench ran with, defaults included
  headline    the few figures `bench/RESULTS.md` shows, name -> number (units in the names)
  figures     everything the bench measured, structured per case/kind (units in the key names)
  environment where and when: machine (platform, CPU model, logical CPUs), Python, MuJoCo and
              numpy versions, the project's version, the git commit (and whether the checkout
              had changes), the UTC time the run started and finished and its wall seconds

Floats are kept to 6 significant digits; NaN and infinities become null (JSON has neither).
`bench/results_page.py` renders `bench/RESULTS.md` from the documents in `bench/results/`.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TextIO

from app.assets import project_version

BENCH_DIR = Path(__file__).resolve().parent
RESULTS_DIR = BENCH_DIR / "results"
ROOT = BENCH_DIR.parent
SCHEMA = 1

#: what `parse_args` saw: the start of the run, and the stream the JSON goes to with --json -
_started: dict[str, Any] = {}


def default_path(name: str) -> Path:
    return RESULTS_DIR / f"{name}.json"


def add_json_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json",
        metavar="PATH",
        help="write the results there as JSON (default: bench/results/<bench>.json; "
        "'-': standard output, the text then goes to standard error)",
    )


def parse_args(
    parser: argparse.ArgumentParser, argv: list[str] | None = None
) -> argparse.Namespace:
    """The bench's options with --json added; marks the run's start. With `--json -` the
    bench's printed text goes to standard error, so standard output holds the JSON alone."""
    add_json_option(parser)
    args = parser.parse_args(argv)
    _started["utc"] = _utc_now()
    _started["monotonic"] = time.monotonic()
    _started["argv"] = list(sys.argv[1:] if argv is None else argv)
    _started["stdout"] = sys.stdout
    if args.json == "-":
        sys.stdout = sys.stderr
    return args


def _utc_now() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo where there is one, else what Python knows."""
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
    except OSError:
        text = ""
    for key in ("model name", "Model", "Hardware", "cpu model", "cpu"):
        for line in text.splitlines():
            field, _, value = line.partition(":")
            if field.strip() == key and value.strip():
                return value.strip()
    return platform.processor() or platform.machine() or "unknown"


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=20, check=False
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def _version(module: str) -> str | None:
    try:
        return str(__import__(module).__version__)
    except ImportError:
        return None


def environment() -> dict[str, Any]:
    """Where the bench runs: machine, interpreter, engine and library versions, the checkout."""
    commit = _git("rev-parse", "HEAD")
    changes = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    return {
        "machine": {
            "platform": platform.platform(),
            "cpu_model": cpu_model(),
            "logical_cpus": os.cpu_count(),
        },
        "python": platform.python_version(),
        "mujoco": _version("mujoco"),
        "numpy": _version("numpy"),
        "project_version": project_version(),
        "git_commit": commit,
        "git_changes": None if changes is None else bool(changes),
    }


def plain(value: Any) -> Any:
    """`value` as JSON can hold it: numpy scalars and arrays as Python numbers and lists, tuples
    as lists, floats to 6 significant digits, NaN and infinities as None."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        value = value.tolist()  # numpy arrays and scalars
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return float(f"{value:.6g}") if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not a result figure: {value!r}")


def command(name: str, argv: list[str]) -> str:
    """The command that repeats the run: the bench with its options, --json left out."""
    kept, skip = [], False
    for arg in argv:
        if skip:
            skip = False
        elif arg == "--json":
            skip = True
        elif not arg.startswith("--json="):
            kept.append(arg)
    return shlex.join(["python", f"bench/{name}.py", *kept])


def document(
    name: str,
    args: argparse.Namespace,
    figures: Mapping[str, Any],
    headline: Mapping[str, Any],
) -> dict[str, Any]:
    """The results document of a run (see the module's docstring)."""
    finished = _utc_now()
    started = _started.get("utc", finished)
    run_s = time.monotonic() - _started["monotonic"] if "monotonic" in _started else None
    arguments = {k: v for k, v in vars(args).items() if k != "json"}
    return {
        "schema": SCHEMA,
        "bench": name,
        "command": command(name, _started.get("argv", sys.argv[1:])),
        "arguments": plain(arguments),
        "headline": plain(dict(headline)),
        "figures": plain(dict(figures)),
        "environment": {
            **environment(),
            "started_utc": started,
            "finished_utc": finished,
            "run_s": None if run_s is None else round(run_s, 1),
        },
    }


def write(
    name: str,
    args: argparse.Namespace,
    figures: Mapping[str, Any],
    headline: Mapping[str, Any],
) -> Path | None:
    """Writes the run's document where --json says (default `bench/results/<name>.json`), and
    returns the path (None for standard output)."""
    text = (
        json.dumps(
            document(name, args, figures, headline), indent=2, allow_nan=False, ensure_ascii=False
        )
        + "\n"
    )
    where = getattr(args, "json", None)
    if where == "-":
        out: TextIO = _started.get("stdout", sys.__stdout__)
        out.write(text)
        out.flush()
        return None
    path = Path(where) if where else default_path(name)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)  # a reader never sees half a document
    print(f"results: {path}")
    return path
