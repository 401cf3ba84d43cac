"""The argparse types several `artro` commands share, each refusing in a sentence that says
what is allowed (argparse exits with status 2): bounded numbers, non-empty text, an address to
listen on, a motion field's range, a Dask scheduler's address, a study's location
(docs/DESIGN.md §6, §14)."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable
from typing import Any

from gait import Motion


def number(
    low: float, high: float, *, integer: bool = False, above: bool = False, what: str = "it"
) -> Any:
    """An argparse type: a finite number from `low` (exclusive if `above`) to `high`; the error
    says what is allowed (argparse exits with status 2)."""
    kind = "a whole number " if integer else ""
    lo, hi = (f"{int(low)}", f"{int(high)}") if integer else (f"{low:g}", f"{high:g}")
    allowed = f"> {lo} and at most {hi}" if above else f"{lo} to {hi}"

    def parse(text: str) -> float | int:
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value > high or (value <= low if above else value < low):
            raise argparse.ArgumentTypeError(f"{what} must be {kind}{allowed}, got {text!r}")
        return value

    return parse


def nonempty(what: str) -> Callable[[str], str]:
    """An argparse type: any text but an empty one (which would mean the default unsaid)."""

    def parse(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"{what} is empty; leave it out for its default")
        return text

    return parse


def host_name(text: str) -> str:
    """An argparse type: an address to listen on, not empty (uvicorn would take every
    interface)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty address; 0.0.0.0 listens on every interface")
    return text


def motion_number(name: str, option: str) -> Any:
    """An argparse type: a number in the range of the motion vector's field `name`
    (`gait.Motion`), the error naming `option` and that range."""
    meta = next(f.metadata for f in dataclasses.fields(Motion) if f.name == name)
    return number(meta["min"], meta["max"], what=option)


def cluster_address(text: str) -> str:
    """An argparse type: a Dask scheduler's tcp://HOST:PORT (or HOST:PORT), as tcp://HOST:PORT."""
    from app.evaluation._dask import ClusterError, check_address

    try:
        return check_address(text)
    except ClusterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def study_location(text: str) -> str:
    """An argparse type: a study journal file or an RDB URL of a known scheme (the form only)."""
    from app.study.study_store import check_location

    try:
        return check_location(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
