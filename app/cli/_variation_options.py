"""The worlds an `artro` command runs in: `--vary` (one variation), `--range` (the ranges a
robust bench or tune samples) and the check that a push comes before a run's end
(docs/DESIGN.md §8)."""

from __future__ import annotations

import argparse
from typing import Any

from app.worlds.sampling import VariationRanges, parse_range
from app.worlds.variations import Variation, parse_variation


def variation(text: str) -> Variation:
    """An argparse type: a variation's `key=value,...` text, not empty (leave it out for the
    nominal model)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty variation; leave it out for the nominal model")
    try:
        return parse_variation(text)
    except (ValueError, TypeError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_range_option(parser: Any, purpose: str) -> None:
    """`--range NAME=LOW:HIGH` (repeatable), read by `ranges_from`."""
    parser.add_argument(
        "--range",
        action="append",
        default=[],
        metavar="NAME=LOW:HIGH",
        help=f"narrow or widen one variation range{purpose}, e.g. friction=0.3:0.6 (repeatable)",
    )


def ranges_from(texts: list[str], duration_s: float | None = None) -> VariationRanges:
    """The `--range` options as ranges; ValueError for a field given twice (as `--vary`), or
    for pushes that may be drawn after the end of runs of `duration_s` (`check_push_time`)."""
    ranges, seen = VariationRanges(), set()
    for text in texts:
        name, low, high = parse_range(text)
        if name in seen:
            raise ValueError(f"--range {name} given twice; give each field once")
        seen.add(name)
        ranges = ranges.with_range(name, low, high)
    low, high = ranges.push_time_s
    if duration_s is not None and ranges.push_n_s[1] > 0:
        given = "" if "push_time_s" in seen else f" (its default {low:g}:{high:g})"
        check_push_time(
            high, duration_s, f"--range push_time_s reaches {high:g} s{given}", "--range"
        )
    return ranges


def check_push_time(push_time_s: float, duration_s: float, what: str, option: str) -> None:
    """ValueError if a push at `push_time_s` comes at or after the end of a run of
    `duration_s`: it would never act, and the run would be taken for one that withstood it."""
    if push_time_s >= duration_s:
        raise ValueError(
            f"{what}: a push then comes after the run's end ({duration_s:g} s) and would never "
            f"act; allowed: {option} push_time_s below {duration_s:g} s, or longer runs"
        )


def check_pushed_variation(variation: Variation, duration_s: float, runs: str) -> None:
    """`check_push_time` for `--vary`'s push in a run of `duration_s` (`runs`: what sets it)."""
    if variation.push_n_s > 0:
        check_push_time(
            variation.push_time_s,
            duration_s,
            f"--vary push_time_s={variation.push_time_s:g} in a run of {runs}",
            "--vary",
        )
