#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# All tests, from a fresh machine: set-up, every build preset (host debug with
# sanitizers, host release, Cortex-M4 cross build), the benchmarks' figures,
# the C unit tests (ctest) and the Python tests (pytest), the soak, the
# console, the fuzzers and the bus tests over vcan. The minutes each stage
# took are printed at the end, failed or not.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

stages=()
stage_start=$SECONDS
stage_name=""
stage() { # closes the stage under way, opens the next
  [ -n "$stage_name" ] && stages+=("$(printf '%6ds  %s' $((SECONDS - stage_start)) "$stage_name")")
  stage_name=$1
  stage_start=$SECONDS
  echo "== $1"
}
report() {
  local rc=$?
  [ -n "$stage_name" ] && stages+=("$(printf '%6ds  %s%s' $((SECONDS - stage_start)) "$stage_name" \
    "$([ "$rc" -ne 0 ] && echo ' (failed)')")")
  echo "== time per stage (wall seconds; $SECONDS s in all)"
  printf '%s\n' "${stages[@]}"
  exit "$rc"
}
trap report EXIT

stage "set-up"
scripts/setup.sh
stage "build (every preset)"
scripts/build.sh
stage "benchmarks"
scripts/bench.sh
stage "ctest (host-debug)"
ctest --preset host-debug
stage "pytest"
.venv/bin/pytest -q tests/python
stage "soak: 1 h of simulated random operation, or as much as 3 minutes of wall time allow"
.venv/bin/stewart soak --hours 1 --max-wall 180 --seed 2026 --strict --quiet
stage "the console: API tests and headless Chromium (tests/console, about a minute)"
.venv/bin/pytest -q tests/console
stage "fuzz"
scripts/fuzz.sh 8 # each of the three targets 8 s
stage "bus tests over SocketCAN vcan (user-mode Linux where the kernel has no CAN)"
# 2 GiB: the identification test decodes a 30 s CAN log inside the UML (~0.4 GB);
# 1800 s: the tests took over 600 s on a loaded 2-core machine before the frames
.venv/bin/stewart vcan --fd --mem 2G --timeout 1800 -- .venv/bin/pytest -q tests/bus
