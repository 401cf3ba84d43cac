#!/usr/bin/env bash
# Try the newest releases before refreshing the lock: resolve every dependency to the newest version
# its range admits, install that into a scratch environment (./.venv and requirements.lock are not
# touched), run the quick tests there and report what moved and how the tests ended.
#
#   bash scripts/check_newest.sh            # report only
#   bash scripts/check_newest.sh --adopt    # and, when the quick tests pass, take the new lock
#
# The quick tests are `pytest -m "not slow"`; the figures (`artro bench paper`, docs/DESIGN.md §13)
# are not re-measured here: after adopting, run the whole suite and the paper bench.
set -euo pipefail
cd "$(dirname "$0")/.."

scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
LOCK_OUT="$scratch/newest.lock" bash scripts/lock.sh --upgrade >/dev/null
python3 -m venv "$scratch/venv"
"$scratch/venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -r scripts/uv-requirement.txt
"$scratch/venv/bin/uv" pip install --quiet --python "$scratch/venv/bin/python" \
    -c "$scratch/newest.lock" -e ".[test,cluster]"

echo "== what the newest releases change against requirements.lock"
python3 - requirements.lock "$scratch/newest.lock" <<'PY'
import re, sys
pin = re.compile(r"^([A-Za-z0-9._-]+)==([^\s;\\]+)\s*(?:;\s*([^\\]+?))?\s*\\?$")
def pins(path):
    out = {}
    for line in open(path, encoding="utf-8"):
        if m := pin.match(line):
            out[(m[1].lower(), m[3] or "")] = m[2]
    return out
old, new = pins(sys.argv[1]), pins(sys.argv[2])
rows = [(k, old.get(k, "-"), new.get(k, "-")) for k in sorted(old.keys() | new.keys())
        if old.get(k) != new.get(k)]
for (name, marker), a, b in rows:
    print(f"  {name:24} {a:>12} -> {b:<12} {marker}")
print(f"  {len(rows)} of {len(new)} pins move" if rows else "  nothing moves: the lock is the newest")
PY

echo "== quick tests on the newest releases"
set +e
"$scratch/venv/bin/python" -m pytest -m "not slow" -q -p no:cacheprovider > "$scratch/pytest.log" 2>&1
status=$?
set -e
grep -E "^(FAILED|ERROR) " "$scratch/pytest.log" || true
tail -n 1 "$scratch/pytest.log"
if [ "$status" -ne 0 ]; then
  echo "the newest releases break the quick tests: keep requirements.lock (log above)"
  exit 1
fi
if [ "${1:-}" = "--adopt" ]; then
  cp "$scratch/newest.lock" requirements.lock
  echo "adopted: requirements.lock now holds the newest releases; run bash scripts/setup.sh --test,"
  echo "the whole suite, and artro bench paper to check the figures (docs/DESIGN.md §13)"
else
  echo "the quick tests pass on the newest releases: bash scripts/check_newest.sh --adopt takes them"
fi
