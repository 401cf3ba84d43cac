#!/usr/bin/env bash
# Every test (the README's test command; .ci/run): the browser tests alone on the machine -- they
# wait on a real-time simulation and a page, and beside CPU-bound tests on a 2-core machine they
# time out -- and the rest first, on every core (pytest-xdist; tests/conftest.py keeps a module's
# tests on one worker). Arguments go to both runs, e.g. `bash scripts/test.sh -x` or a path.
# Before them the lint and the type check (pyproject.toml's [tool.ruff] and [tool.mypy]): a
# failure of either stops the run. Decision 0039.
set -uo pipefail
cd "$(dirname "$0")/.."

.venv/bin/ruff check . || exit 1
.venv/bin/mypy || exit 1

status=0
.venv/bin/pytest -m "not browser" -n auto --dist loadgroup "$@" || status=$?
[ "$status" -eq 5 ] && status=0  # nothing of the kind among the tests asked for
.venv/bin/pytest -m browser -n 0 "$@"
browser=$?
[ "$browser" -eq 5 ] && browser=0
[ "$status" -ne 0 ] && exit "$status"
exit "$browser"
