"""The files and folders an `artro` command writes, checked before the work (`output_problem`):
argparse types that refuse, in a sentence, what cannot be written (docs/DESIGN.md §14)."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Sequence
from pathlib import Path

from app.params.presets import name_too_long, not_a_file


def output_file(text: str) -> str:
    """An argparse type: a file to write, checked before the work (`output_problem`)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty file name; give the file to write")
    if text == "-":
        raise argparse.ArgumentTypeError(
            "- is not a file name here: leave the option out for its default (standard output, "
            "where that is the default), or write ./- for a file named -"
        )
    if problem := output_problem(Path(text)):
        raise argparse.ArgumentTypeError(f"{text} {problem}")
    return text


def output_file_of(suffixes: Sequence[str], what: str) -> Callable[[str], str]:
    """An argparse type: an `output_file` whose name ends in one of `suffixes`, as what is
    written there (`what`, e.g. "a YAML description") is."""

    def parse(text: str) -> str:
        output_file(text)
        if Path(text).suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(
                f"{text}: this writes {what}; give a file ending in {' or '.join(suffixes)}"
            )
        return text

    return parse


def output_problem(path: Path, *, folder: bool = False, devices: bool = False) -> str | None:
    """Why nothing can be written at `path`, or None: the one check, before the work, of every
    option that names a file (or with `folder` a folder) to write. A name the file system
    refuses for its length; a folder where a file is meant, a file where a folder is; a device,
    pipe or socket unless `devices` (a temporary file renamed over one would replace it); a
    folder above that is a file; a read-only file (root would write over it); a place that
    cannot be looked at."""
    try:
        if problem := name_too_long(path):
            return problem
        if folder and path.exists() and not path.is_dir():
            return "is a file, not a folder"
        if not folder and path.is_dir():
            return "is a folder; give the file to write"
        if not (folder or devices) and (problem := not_a_file(path)):
            return f"{problem}; give the file to write"
        if inside_a_file(path):
            return "is inside a file, not a folder"
        if not folder and path.is_file() and _read_only(path):
            return "is a read-only file: give another file, or make it writable first"
    except OSError as exc:  # a folder above that cannot be searched
        return f"cannot be looked at ({exc.strerror or exc}); give a file in a folder of yours"
    return None


def _read_only(path: Path) -> bool:
    """Whether `path` is not to be written: no write permission for anyone, or none for this
    user (root may write anything, so the mode alone counts for it)."""
    return not (path.stat().st_mode & 0o222) or not os.access(path, os.W_OK)


def inside_a_file(path: Path) -> bool:
    """Whether a folder above `path` is a file, so nothing can be written there."""
    return any(up.exists() and not up.is_dir() for up in path.parents)


def output_folder(text: str) -> Path:
    """An argparse type: a folder to write into, checked before the work (`output_problem`)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty folder name; give the folder to write into")
    path = Path(text)
    if problem := output_problem(path, folder=True):
        raise argparse.ArgumentTypeError(f"{text} {problem}")
    return path
