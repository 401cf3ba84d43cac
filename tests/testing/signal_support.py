"""Ctrl-C as the tests that send it rely on, however the suite was launched. A background job
(`nohup bash .ci/run &`) starts with SIGINT ignored, and every process started from it inherits
that: Python then installs no KeyboardInterrupt for it, and a child ignores it as well."""

from __future__ import annotations

import contextlib
import signal
import sys
from collections.abc import Iterator, Sequence

#: run as `python -c`: set SIGINT back to its default, then become the command (same process)
_EXEC_WITH_SIGINT_DEFAULT = (
    "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
    "os.execvp(sys.argv[1], sys.argv[1:])"
)


def with_sigint_default(command: Sequence[str]) -> list[str]:
    """`command` to start as a child that takes Ctrl-C as it would from a terminal (SIGINT at
    its default: a Python child raises KeyboardInterrupt), whatever this process ignores."""
    return [sys.executable, "-c", _EXEC_WITH_SIGINT_DEFAULT, *command]


@contextlib.contextmanager
def ctrl_c_raises() -> Iterator[None]:
    """In the block, a SIGINT to this process raises KeyboardInterrupt, as it does where Python
    started with SIGINT at its default; what was there before is put back."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)
