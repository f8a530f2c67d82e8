#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Prints the benchmark figures: the host-release benchmarks (fixed-point
# primitives, kinematics and the controller tick, the plant), accuracy of the
# core against the float64 model, instruction counts of the core on a
# Cortex-M4 (QEMU) next to the float reference, and the NUCLEO-G474RE images'
# (native and CiA 408) sizes and worst-case stack against their budgets (a
# budget overrun fails).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
[ -d build/host-release ] || scripts/build.sh host-release >/dev/null
for b in build/host-release/bench/bench_* build/host-release/bench/*/bench_*; do
  [ -x "$b" ] && [ -f "$b" ] || continue
  echo "== benchmark: $(basename "$b")"
  "$b"
done
echo "== accuracy: fixed-point core vs float64 model (stewart accuracy)"
.venv/bin/stewart accuracy
echo "== Cortex-M4 (QEMU mps2-an386): instructions per call (scripts/m4_bench.sh)"
scripts/m4_bench.sh
echo "== NUCLEO-G474RE image: sizes, stack, heap (scripts/stm32_report.sh)"
scripts/stm32_report.sh
echo "== NUCLEO-G474RE CANopen image (CiA 408 drives): sizes, stack, heap"
scripts/stm32_report.sh stm32g4-cia408
