#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# All tests, from a fresh machine: set-up, every build preset (host debug with
# sanitizers, host release, Cortex-M4 cross build), the benchmarks' figures,
# the C unit tests (ctest) and the Python tests (pytest).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
scripts/setup.sh
scripts/build.sh
scripts/bench.sh
echo "== ctest (host-debug)"
ctest --preset host-debug
echo "== pytest"
.venv/bin/pytest -q tests/python
echo "== soak: 1 h of simulated random operation, or as much as 3 minutes of wall time allow"
.venv/bin/stewart soak --hours 1 --max-wall 180 --seed 2026 --strict --quiet
echo "== the console: API tests and headless Chromium (tests/console, about a minute)"
.venv/bin/pytest -q tests/console
scripts/fuzz.sh 8 # each of the three targets 8 s
echo "== bus tests over SocketCAN vcan (user-mode Linux where the kernel has no CAN)"
# 2 GiB: the identification test decodes a 30 s CAN log inside the UML (~0.4 GB);
# 1800 s: the tests took over 600 s on a loaded 2-core machine before the frames
.venv/bin/stewart vcan --fd --mem 2G --timeout 1800 -- .venv/bin/pytest -q tests/bus
