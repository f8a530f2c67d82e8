#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the libFuzzer targets of tests/fuzz with clang (ASan + UBSan, and
# LeakSanitizer with ASan) and runs them one after the other:
#   node      the controller's receive path (firmware/core/src/link/node.c)
#   plant_bus the plant's receive path (host_sim/src/bus/bus.c)
#   scenario  the scenario parser and file reader (host_sim/src/scenario/scenario.c, scenario_inject.c)
#
#   scripts/fuzz.sh [SECONDS]        each target for SECONDS (default 20)
#   scripts/fuzz.sh --long [RUNS]    the long run: each target to RUNS inputs
#                                    (default 10^7); prints inputs, time,
#                                    exec/s, coverage and crashes per target
#                                    (--bench is the same)
#   scripts/fuzz.sh --merge          minimises the kept corpus and what the
#                                    runs found (libFuzzer -merge=1) into
#                                    tests/fuzz/corpus/TARGET
#
# The corpora start from the kept corpus in the repository
# (tests/fuzz/corpus/TARGET, read only) and seeds generated from real
# inputs (tests/fuzz/make_seeds.py: protocol/test_vectors.json's frames,
# the demo's scenarios), and grow in build/fuzz/corpus/TARGET. A crash
# stops its target, leaves the input in build/fuzz/crash-*, and the script
# fails once every target ran.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
mode=time
secs=20
runs=10000000
if [ "${1:-}" = "--bench" ] || [ "${1:-}" = "--long" ]; then
  mode=bench
  runs=${2:-$runs}
elif [ "${1:-}" = "--merge" ]; then
  mode=merge
elif [ -n "${1:-}" ]; then
  secs=$1
fi

# only the generated sources (CAN packing and codec, default platform and plant), not a whole build
cmake --preset host-debug >/dev/null
cmake --build build/host-debug --target firmware/generated/stewart_can.c firmware/generated/stewart_proto.c \
  firmware/generated/sp_platform_default.c host_sim/generated/hs_config_default.c >/dev/null
gen=build/host-debug/firmware/generated
out="$root/build/fuzz" # absolute: fuzz_scenario works in a directory of its own
mkdir -p "$out/obj"
cflags=(-std=c99 -g -O1 -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all)
# the core under its own rules (sp_rules.h), the plant and the targets without them
core=()
for src in firmware/core/src/*/*.c "$gen/stewart_can.c" "$gen/stewart_proto.c" "$gen/sp_platform_default.c"; do
  obj="$out/obj/$(basename "${src%.c}").o"
  clang "${cflags[@]}" -include firmware/core/sp_rules.h -Ifirmware/core/include -I"$gen/include" -Ifirmware/core/src -I"$gen" -c "$src" -o "$obj"
  core+=("$obj")
done
link() { # name sources...
  local name=$1
  shift
  clang "${cflags[@]}" -fsanitize=fuzzer -Ifirmware/core/include -I"$gen/include" -Ihost_sim/include -I"$gen" "$@" "${core[@]}" -lm \
    -o "$out/fuzz_$name"
}
link node tests/fuzz/fuzz_node.c
link plant_bus tests/fuzz/fuzz_plant_bus.c \
  host_sim/src/plant/{status,sensor,kin,cylinder,drive,params,plant,rig}.c host_sim/src/bus/bus.c \
  build/host-debug/host_sim/generated/hs_config_default.c
link scenario tests/fuzz/fuzz_scenario.c host_sim/src/plant/status.c host_sim/src/scenario/{scenario,scenario_inject}.c

rm -rf "$out/seeds"
python=.venv/bin/python
[ -x "$python" ] || python=python3
"$python" tests/fuzz/make_seeds.py "$out/seeds" >/dev/null

targets=(node plant_bus scenario)
declare -A what=([node]="controller receive path" [plant_bus]="plant receive path" [scenario]="scenario parser")
declare -A seeds=([node]=frames [plant_bus]=frames [scenario]=scenario)
# the benchmark's inputs are shorter (a few frames, a few dozen scenario lines) so that
# 10^7 of each take about half an hour on a shared 2-core machine; a timed run takes 4 KiB
declare -A bench_len=([node]=256 [plant_bus]=256 [scenario]=1024)
failed=0
table=()
if [ "$mode" = merge ]; then
  for t in "${targets[@]}"; do
    kept="$root/tests/fuzz/corpus/$t"
    mkdir -p "$kept" "$out/corpus/$t"
    rm -rf "$out/merge-$t"
    mkdir -p "$out/merge-$t"
    "$out/fuzz_$t" -merge=1 -max_len=4096 "$out/merge-$t" "$kept" "$out/corpus/$t" "$out/seeds/${seeds[$t]}" \
      </dev/null >"$out/merge-$t.log" 2>&1 || {
      echo "fuzz: merge of $t FAILED: $out/merge-$t.log"
      exit 1
    }
    rm -rf "$kept"
    mv "$out/merge-$t" "$kept"
    echo "fuzz: $t: kept corpus $(find "$kept" -type f | wc -l) inputs, $(du -sk "$kept" | cut -f1) KiB on disk"
  done
  exit 0
fi
for t in "${targets[@]}"; do
  mkdir -p "$out/corpus/$t" "$root/tests/fuzz/corpus/$t"
  if [ "$mode" = bench ]; then
    limit=(-runs="$runs" -max_len="${bench_len[$t]}")
    echo "== fuzz: ${what[$t]} ($t), $runs inputs of at most ${bench_len[$t]} bytes"
  else
    limit=(-max_total_time="$secs" -max_len=4096)
    echo "== fuzz: ${what[$t]} ($t), ${secs} s"
  fi
  log="$out/$t.log"
  before=$(find "$out" -maxdepth 1 -name 'crash-*' | wc -l)
  start=$(date +%s.%N)
  set +e
  "$out/fuzz_$t" "${limit[@]}" -print_final_stats=1 -artifact_prefix="$out/" \
    "$out/corpus/$t" "$root/tests/fuzz/corpus/$t" "$out/seeds/${seeds[$t]}" </dev/null >"$log" 2>&1
  rc=$?
  set -e
  end=$(date +%s.%N)
  grep -E "^#[0-9]+[[:space:]]+(INITED|DONE)|ERROR|SUMMARY|^Done" "$log" || true
  crashes=$(($(find "$out" -maxdepth 1 -name 'crash-*' | wc -l) - before))
  if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    echo "fuzz: $t FAILED (exit $rc); input and log: $out/crash-*, $log"
    failed=1
  fi
  # the figures of the DONE line (or the last status line) and the final stats
  last=$(grep -E "^#[0-9]+" "$log" | tail -1)
  inputs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
  ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
  corp=$(echo "$last" | sed -n 's/.* corp: \([0-9]*\/[0-9a-zA-Z]*\).*/\1/p')
  wall=$(echo "$start $end" | awk '{printf "%.1f", $2 - $1}')
  rate=$(echo "${inputs:-0} $wall" | awk '{printf "%.0f", ($2 > 0) ? $1 / $2 : 0}')
  table+=("$(printf '%-10s %12s %8s %9s %6s %7s %12s %8s' "$t" "${inputs:-?}" "$wall" "$rate" "${cov:-?}" "${ft:-?}" \
    "${corp:-?}" "$crashes")")
  # the corpus as it stands replays cleanly (a check that the saved inputs are sane)
  "$out/fuzz_$t" -runs=0 -max_len=4096 "$out/corpus/$t" </dev/null >/dev/null 2>&1 || {
    echo "fuzz: $t corpus replay FAILED"
    failed=1
  }
done
if [ "$mode" = bench ]; then
  echo "== fuzz benchmark: $(clang --version | head -1), ASan + UBSan, -O1, one process at a time"
  printf '%-10s %12s %8s %9s %6s %7s %12s %8s\n' target inputs wall_s exec/s cov ft corpus crashes
  printf '%s\n' "${table[@]}"
fi
exit "$failed"
