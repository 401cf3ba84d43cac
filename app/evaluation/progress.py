"""An evaluation's progress for a person: runs done of all, time so far and an estimate of what is
left; on a terminal one line rewritten in place (a bar), in a file or pipe a line per tenth."""

from __future__ import annotations

import time
from typing import TextIO

from app.evaluation._api import Progress

LOG_STEP = 0.1  # not a terminal: a line each time another tenth of the runs is done


class ProgressLine:
    """One line of progress on `stream`: `update(done, total, text)` rewrites it in place with
    `\\r` where the stream is a terminal, and ends it when done == total; elsewhere (a file, a
    pipe, CI's log) it writes `text` as a line when done first reaches another `step` of total
    and at the end, so a run leaves at most 1 / step + 1 lines. A `done` lower than the last one
    or a new `total` starts a new count (the next generation of a study)."""

    def __init__(self, stream: TextIO, *, step: float = LOG_STEP) -> None:
        if not 0 < step <= 1:
            raise ValueError(f"step must be in (0, 1], got {step}")
        self.stream = stream
        self.live = stream.isatty()
        self.step = step
        self._done, self._total, self._logged, self._width = 0, 0, -1, 0

    def update(self, done: int, total: int, text: str) -> None:
        """Show `text` for `done` of `total` (see the class)."""
        if done < self._done or total != self._total:
            self._logged, self._width = -1, 0
        self._done, self._total = done, total
        end = done >= total
        if self.live:
            pad = " " * max(0, self._width - len(text))  # wipe what a longer line left
            self._width = 0 if end else len(text)
            self.stream.write("\r" + text + pad + ("\n" if end else ""))
            self.stream.flush()
            return
        steps = total and int(done / total / self.step + 1e-9)  # steps reached (float-safe)
        if end or steps > self._logged:
            self._logged = steps
            self.stream.write(text + "\n")
            self.stream.flush()


def time_left_s(elapsed_s: float, done: int, total: int) -> float | None:
    """What is left of `total` at the pace of the `done` in `elapsed_s` (None before the first)."""
    return elapsed_s / done * max(total - done, 0) if done > 0 else None


def about(seconds: float | None) -> str:
    """A time left for a person: "~40 s", "~12 min", "~2 h 5 min"; "~?" before it is known."""
    if seconds is None:
        return "~?"
    if seconds < 90:
        return f"~{seconds:.0f} s"
    minutes = round(seconds / 60)
    return f"~{minutes} min" if minutes < 120 else f"~{minutes // 60} h {minutes % 60} min"


def bar(done: int, total: int, width: int = 30) -> str:
    """`[#####.....]`: done of total as a bar of `width` cells."""
    filled = int(width * done / max(total, 1))
    return f"[{'#' * filled}{'.' * (width - filled)}]"


def progress_printer(total_note: str, stream: TextIO, label: str) -> Progress:
    """Print `total_note` now; the callback shows `label: [bar] done/total runs, time so far, ~left`
    as runs end, as a `ProgressLine` on `stream`."""
    start = time.perf_counter()
    line = ProgressLine(stream)
    print(total_note, file=stream, flush=True)

    def report(done: int, total: int) -> None:
        elapsed = time.perf_counter() - start
        left = f"~{elapsed / done * (total - done):.0f} s left" if done else "~? s left"
        shown = bar(done, total) + " " if line.live else ""
        line.update(done, total, f"{label}: {shown}{done}/{total} runs, {elapsed:.0f} s, {left}")

    return report
