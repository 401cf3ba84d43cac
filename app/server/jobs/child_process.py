"""A job that runs `artro` as a child process (the tune, the fit; docs/DESIGN.md §10): its output
read line by line on a thread of its own, the job's progress asked between lines (so a cancel is
seen), how long a child asked to stop may take, and the cores a child may use."""

from __future__ import annotations

import os
import queue
import subprocess

from app.server.jobs.registry import Progress

STOP_WAIT_S = 5.0  # a child asked to stop (SIGTERM) is killed after this long
LOG_LINES = 12  # of the child's other output, kept for the message of a failure


def child_threads() -> int:
    """A child's simulation threads: every core but one, which the live simulation keeps."""
    return max(1, (os.cpu_count() or 2) - 1)


def pump_lines(child: subprocess.Popen[str], lines: queue.Queue[str | None]) -> None:
    """The child's output, line by line, then None."""
    assert child.stdout is not None
    try:
        for line in child.stdout:
            lines.put(line)
    finally:
        lines.put(None)


def next_line(lines: queue.Queue[str | None], progress: Progress) -> str | None:
    """The next line of the child's output (None at its end); meanwhile, at least every 0.2 s,
    `progress()`, which raises JobCancelled once the job is cancelled."""
    while True:
        progress(None)
        try:
            return lines.get(timeout=0.2)
        except queue.Empty:
            continue
