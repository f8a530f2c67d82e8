#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs the benchmarks (scripts/bench.sh), keeps their output in
# out/bench/bench.txt and writes docs/performance.md from it
# (tools/stewart/perf_report.py). With an argument FILE it only turns an
# earlier bench output FILE into the page.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
if [ $# -ge 1 ]; then
  src=$1
else
  mkdir -p out/bench
  src=out/bench/bench.txt
  scripts/bench.sh | tee "$src"
fi
machine="$(uname -m), $(nproc) cores ($(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)), $(date -u +%F)"
.venv/bin/python -m stewart.perf_report "$src" docs/performance.md --machine "$machine"
echo "wrote docs/performance.md from $src"
