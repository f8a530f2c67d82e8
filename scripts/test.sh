#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# All tests, from a fresh machine: set-up, every build preset (host debug with
# sanitizers, host release, Cortex-M4 cross build), the benchmarks' figures,
# the C unit tests (ctest), the Python tests (pytest), the soak, the console,
# the fuzzers and the bus tests over vcan.
#
# Two lanes share the machine's two cores: the bus tests run inside
# user-mode Linux, which uses one core whatever it runs, so they start as
# soon as the host-release build and the venv are there and run beside the
# rest (the real-time simulator's tests, and the console's browser test
# against it, run just before they start). Every
# test stage runs even when one before it failed; the exit
# status is 1 if any failed. The end of the output is the bus tests' output
# and a table of each stage's wall time.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

logs=$(mktemp -d "${TMPDIR:-/tmp}/stewart-test.XXXXXX")
times=()
failed=()
bus_pid=""

run_stage() { # NAME COMMAND...: runs it, notes its time and whether it failed
  local name=$1 t0=$SECONDS rc=0
  shift
  echo "== $name"
  "$@" || rc=$?
  times+=("$(printf '%6ds  %s%s' $((SECONDS - t0)) "$name" "$([ "$rc" -ne 0 ] && echo "  (FAILED, exit $rc)")")")
  [ "$rc" -eq 0 ] || failed+=("$name")
}
finish() {
  local rc=$?
  if [ -n "$bus_pid" ] && kill -0 "$bus_pid" 2>/dev/null; then # the script stopped early: no UML left behind
    kill -TERM "$bus_pid" 2>/dev/null || true
    wait "$bus_pid" 2>/dev/null || true
  fi
  echo "== time per stage (wall seconds; $SECONDS s in all; the bus tests ran beside the stages after the build)"
  printf '%s\n' "${times[@]}"
  rm -rf "$logs"
  exit "$rc"
}
trap finish EXIT

bus_tests() {
  # 2 GiB: the identification test decodes a 30 s CAN log inside the UML (~0.4 GB);
  # 1800 s: a bound, not an estimate (a slow shared machine took 26 minutes)
  exec .venv/bin/stewart vcan --fd --mem 2G --timeout 1800 -- .venv/bin/pytest -q --durations=12 tests/bus
}

run_stage "set-up" scripts/setup.sh
[ ${#failed[@]} -eq 0 ] || exit 1
run_stage "build: host-release" scripts/build.sh host-release
[ ${#failed[@]} -eq 0 ] || exit 1

# the real-time simulator's tests first, on a quiet machine: `stewart sim`
# keeps 1 ms deadlines inside its own user-mode Linux, and beside the bus
# tests' one its relaxed watchdogs still tripped (a drive fault, CI)
run_stage "pytest: the real-time simulator (tests/python/test_sim.py), before the bus tests start" \
  .venv/bin/pytest -q tests/python/test_sim.py
run_stage "the console in headless Chromium against stewart sim, before the bus tests start" \
  env STEWART_CONSOLE_TEST_PLATFORM=sim .venv/bin/pytest -q tests/console/test_console_browser.py

bus_t0=$SECONDS
(bus_tests >"$logs/bus.txt" 2>&1) &
bus_pid=$!
echo "== bus tests over SocketCAN vcan started beside the rest (user-mode Linux where the kernel has no CAN)"

run_stage "build: the other presets" scripts/build.sh host-debug m4-core stm32g4 stm32g4-cia408
if [ ${#failed[@]} -eq 0 ]; then
  run_stage "benchmarks" scripts/bench.sh
  run_stage "ctest (host-debug, two at a time)" ctest --preset host-debug -j 2
fi
run_stage "pytest (tests/python, but test_sim.py)" .venv/bin/pytest -q tests/python --ignore=tests/python/test_sim.py
run_stage "soak: 1 h of simulated random operation, or as much as 3 minutes of wall time allow" \
  .venv/bin/stewart soak --hours 1 --max-wall 180 --seed 2026 --strict --quiet
run_stage "the console: API tests and headless Chromium (tests/console)" .venv/bin/pytest -q tests/console
run_stage "fuzz: each of the three targets 8 s" scripts/fuzz.sh 8

echo "== bus tests over SocketCAN vcan: waiting for them"
bus_rc=0
wait "$bus_pid" || bus_rc=$?
bus_pid=""
cat "$logs/bus.txt"
times+=("$(printf '%6ds  %s%s' $((SECONDS - bus_t0)) "bus tests over vcan (beside the stages above)" \
  "$([ "$bus_rc" -ne 0 ] && echo "  (FAILED, exit $bus_rc)")")")
[ "$bus_rc" -eq 0 ] || failed+=("bus tests")

if [ ${#failed[@]} -ne 0 ]; then
  echo "== FAILED: ${failed[*]}"
  exit 1
fi
echo "== all tests passed"
