#!/usr/bin/env bash
# Set up ArtRo Gait Studio in ./.venv. With --test: also the test tools and Debian's Chromium
# (the browser tests drive it through Playwright; Playwright's own browser download is not used).
set -euo pipefail
cd "$(dirname "$0")/.."

extras=""
[ "${1:-}" = "--test" ] && extras="[test]"

[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/pip install --quiet --disable-pip-version-check -e ".${extras}"

# Debian packages: the AVR tool chain and emulator for the firmware (always: `artro firmware`
# needs them), Chromium for the browser tests (with --test).
debs=""
command -v avr-gcc >/dev/null 2>&1 || debs="$debs gcc-avr avr-libc"
[ -f /usr/include/simavr/sim_avr.h ] || debs="$debs simavr libsimavr-dev libelf-dev"
command -v cc >/dev/null 2>&1 || debs="$debs gcc"     # compiles the simavr harness
command -v make >/dev/null 2>&1 || debs="$debs make"  # the firmware Makefile
if [ "${1:-}" = "--test" ]; then
  command -v chromium >/dev/null 2>&1 || debs="$debs chromium"
fi
if [ -n "$debs" ]; then
  echo "installing Debian packages:$debs"
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  # shellcheck disable=SC2086
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq $debs >/dev/null
fi
echo "ready: .venv"
