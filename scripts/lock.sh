#!/usr/bin/env bash
# The one command that writes requirements.lock: the exact version and hashes of every runtime,
# test and optional dependency of pyproject.toml, for CPython 3.11 and newer on any platform.
#
#   bash scripts/lock.sh              # add what pyproject.toml gained, keep every other pin
#   bash scripts/lock.sh --upgrade    # move every pin to the newest release the ranges admit
#   bash scripts/lock.sh --upgrade-package mujoco   # move one (uv's flags pass through)
#   LOCK_OUT=FILE bash scripts/lock.sh ...          # write FILE instead (scripts/check_newest.sh)
#
# scripts/setup.sh installs the lock as constraints; scripts/check_newest.sh tries the newest
# releases in a scratch environment before a refresh. See docs/DESIGN.md §13.
set -euo pipefail
cd "$(dirname "$0")/.."

# the resolver is pinned too (scripts/uv-requirement.txt), so the same inputs give the same lock
out="${LOCK_OUT:-requirements.lock}"
tools="$(mktemp -d)"
trap 'rm -rf "$tools"' EXIT
python3 -m venv "$tools/venv"
"$tools/venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -r scripts/uv-requirement.txt

# --universal: one file for every platform, with markers where versions differ;
# no --emit-index-url: the lock names packages and hashes, never an index or a machine path.
"$tools/venv/bin/uv" pip compile pyproject.toml \
    --all-extras --universal --python-version 3.11 --generate-hashes \
    --custom-compile-command "bash scripts/lock.sh" \
    --quiet -o "$out" "$@"
echo "wrote $out ($(grep -c '==' "$out") pins)"
