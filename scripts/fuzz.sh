#!/usr/bin/env bash
# Builds the libFuzzer target of the controller's receive path with clang
# (ASan + UBSan) and runs it for the given seconds (default 20).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
secs=${1:-20}
gen=build/host-debug/firmware/generated
[ -f "$gen/stewart_can.c" ] || scripts/build.sh host-debug >/dev/null
out=build/fuzz
mkdir -p "$out/corpus"
clang -std=c99 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -include firmware/core/sp_rules.h -Ifirmware/core/include -I"$gen" \
  tests/fuzz/fuzz_node.c firmware/core/src/*.c "$gen/stewart_can.c" "$gen/sp_platform_default.c" \
  -o "$out/fuzz_node"
echo "== fuzz: controller receive path, ${secs} s"
"$out/fuzz_node" -max_total_time="$secs" -max_len=4096 "$out/corpus" 2>&1 | grep -E "^#[0-9]+ *DONE|ERROR|SUMMARY|Done" || true
"$out/fuzz_node" -runs=0 "$out/corpus" >/dev/null 2>&1
