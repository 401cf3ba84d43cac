#!/usr/bin/env bash
# Set up ArtRo Gait Studio in ./.venv with exactly the versions of requirements.lock. With --test:
# also the test tools, the cluster and gpu extras (their tests run MuJoCo Warp on its CPU
# device), Debian's Chromium (the browser tests drive it through Playwright;
# Playwright's own browser download is not used) and sigrok-cli (it decodes our VCD files).
set -euo pipefail
cd "$(dirname "$0")/.."

extras=""
[ "${1:-}" = "--test" ] && extras="[test,cluster,gpu]"

# The lock is for CPython 3.11 and newer (MuJoCo 4 has no wheel for 3.10).
python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' || {
  echo "setup: Python 3.11 or newer is needed; python3 is $(python3 --version 2>&1)" >&2; exit 2; }

[ -x .venv/bin/python ] || { echo "setup: making .venv ($(python3 --version 2>&1))"; python3 -m venv .venv; }
echo "setup: installing the locked Python packages${extras:+ with the extras $extras} (a first"\
" install downloads every wheel: minutes)"
# uv installs: it checks the lock's hashes when the lock is given as constraints (pip asks then
# for a hash of the editable checkout too, which has none). Its own version is pinned.
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r scripts/uv-requirement.txt
# The lock constrains, the package keeps its own ranges for `pip install .` (docs/DESIGN.md §13).
.venv/bin/uv pip install --quiet --python .venv/bin/python -c requirements.lock -e ".${extras}"

# Debian packages: the AVR tool chain and emulator for the firmware (always: `artro firmware`
# needs them), Chromium for the browser tests and sigrok-cli for the VCD tests (with --test).
debs=""
command -v avr-gcc >/dev/null 2>&1 || debs="$debs gcc-avr avr-libc"
[ -f /usr/include/simavr/sim_avr.h ] || debs="$debs simavr libsimavr-dev libelf-dev"
command -v cc >/dev/null 2>&1 || debs="$debs gcc"     # compiles the simavr harness
command -v make >/dev/null 2>&1 || debs="$debs make"  # the firmware Makefile
command -v avrdude >/dev/null 2>&1 || debs="$debs avrdude"  # `artro firmware flash`
if [ "${1:-}" = "--test" ]; then
  command -v chromium >/dev/null 2>&1 || debs="$debs chromium"
  command -v sigrok-cli >/dev/null 2>&1 || debs="$debs sigrok-cli"
fi
if [ -n "$debs" ]; then
  echo "setup: installing Debian packages:$debs (apt-get: minutes)"
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  # shellcheck disable=SC2086
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq $debs >/dev/null
fi
echo "ready: .venv (its commands: .venv/bin/artro, or activate it: . .venv/bin/activate)"
