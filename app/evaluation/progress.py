"""An evaluation's progress for a person at a terminal: runs done of all, time so far and an
estimate of what is left, one updating line on a terminal, a line per update otherwise."""

from __future__ import annotations

import time
from typing import TextIO

from app.evaluation._api import Progress


def progress_printer(total_note: str, stream: TextIO, label: str) -> Progress:
    """Print `total_note` now; the callback prints `label: done/total runs, ...` as runs end."""
    start = time.perf_counter()
    live = stream.isatty()
    print(total_note, file=stream, flush=True)

    def report(done: int, total: int) -> None:
        elapsed = time.perf_counter() - start
        left = elapsed / done * (total - done) if done else float("nan")
        line = f"{label}: {done}/{total} runs, {elapsed:6.0f} s elapsed, ~{left:.0f} s left"
        end = "\n" if not live or done == total else ""
        print(("\r" if live else "") + line, end=end, file=stream, flush=True)

    return report
