#!/usr/bin/env bash
# Runs the benchmarks of the host-release build and prints their figures.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
[ -d build/host-release ] || scripts/build.sh host-release >/dev/null
for b in build/host-release/bench/bench_*; do
  [ -x "$b" ] || continue
  echo "== benchmark: $(basename "$b")"
  "$b"
done
echo "== accuracy: fixed-point core vs float64 model (stewart accuracy)"
.venv/bin/stewart accuracy
