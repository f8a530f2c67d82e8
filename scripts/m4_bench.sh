#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The portable core on a Cortex-M4 (QEMU mps2-an386; docs/explanation/m4.md): prints
# the instructions executed per IK, inverse dynamics, FK (warm start) and
# controller tick, fixed point next to the single-precision float reference
# (the ratio), against the tick budget, each compiled for size (the m4-core
# preset) and for speed (-O2); the CANopen master and its link alone
# (co_icount.c) and the whole tick with them around the controller's step
# (co_tick.c); then the flash and RAM of the core in the golden-vector
# image. Builds the m4-core preset first if needed.
# M4_BUILD_DIR overrides the build directory (default build/m4-core).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
dir=${M4_BUILD_DIR:-build/m4-core}
if [ -z "${M4_BUILD_DIR:-}" ]; then
  if [ -f "$dir/build.ninja" ]; then
    cmake --build --preset m4-core >/dev/null
  else
    scripts/build.sh m4-core >/dev/null
  fi
fi
elf=$dir/bench/m4
for f in sp_m4_icount.elf sp_m4_icount_o2.elf sp_m4_co_icount.elf sp_m4_co_tick.elf hardfp/sp_m4_icount_float.elf \
         hardfp/sp_m4_icount_float_o2.elf sp_m4_golden.elf sp_m4_golden.map; do
  [ -f "$elf/$f" ] || { echo "m4_bench: $elf/$f is missing (build the m4-core preset)" >&2; exit 1; }
done

out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
run() { # run NAME ELF: instruction counting needs -icount shift=7,sleep=off
  if ! timeout -k 5 600 qemu-system-arm -M mps2-an386 -display none -monitor none -serial none \
      -icount shift=7,sleep=off -semihosting-config enable=on,target=native \
      -kernel "$2" </dev/null >"$out/$1.txt"; then
    cat "$out/$1.txt"
    echo "m4_bench: $2 failed under QEMU" >&2
    exit 1
  fi
}
run fixed_os "$elf/sp_m4_icount.elf"
run float_os "$elf/hardfp/sp_m4_icount_float.elf"
run fixed_o2 "$elf/sp_m4_icount_o2.elf"
run float_o2 "$elf/hardfp/sp_m4_icount_float_o2.elf"

cat "$out/fixed_os.txt"
echo
cat "$out/float_os.txt"
echo
echo "== Cortex-M4: fixed point vs single-precision float (instructions per call, mean / max; QEMU -icount)"
awk '
  FNR == 1 { file++ }
  NF >= 6 && $(NF-3) ~ /^[0-9]+$/ { mean[file, $1] = $(NF-2); max[file, $1] = $NF }
  function cell(f, k) { return ((f, k) in mean) ? sprintf("%9s %9s", mean[f, k], max[f, k]) : sprintf("%19s", "-") }
  function ratio(a, b) { return ((a in mean) && (b in mean) && mean[b] > 0) ? sprintf("%6.1f", mean[a] / mean[b]) : sprintf("%6s", "-") }
  END {
    printf "%-30s | %-19s %-19s %6s | %-19s %-19s %6s\n", "", "fixed -Os*", "float -Os", "ratio", "fixed -O2", "float -O2", "ratio"
    n = split("ik:f_ik:inverse kinematics,id:f_id:inverse dynamics (after IK),sincos:f_sincos:sin + cos,fk::FK warm start,tick_running::tick in RUNNING,tick_all::tick in any state", rows, ",")
    for (i = 1; i <= n; ++i) {
      split(rows[i], r, ":")
      printf "%-30s | %s %s %s | %s %s %s\n", r[3], cell(1, r[1]), cell(2, r[2]), ratio2(1, r[1], 2, r[2]), cell(3, r[1]), cell(4, r[2]), ratio2(3, r[1], 4, r[2])
    }
  }
  function ratio2(fa, ka, fb, kb) { return (((fa, ka) in mean) && ((fb, kb) in mean) && mean[fb, kb] > 0) ? sprintf("%6.1f", mean[fa, ka] / mean[fb, kb]) : sprintf("%6s", "-") }
' "$out/fixed_os.txt" "$out/float_os.txt" "$out/fixed_o2.txt" "$out/float_o2.txt"
grep -E '^(budget|force-control budget)' "$out/fixed_os.txt" | sed 's/^/-Os* /'
grep -E '^(budget|force-control budget)' "$out/fixed_o2.txt" | sed 's/^/-O2 /'
echo "(* the m4-core preset: the core at -Os, its hot files at -O3 (SP_CORE_FAST_SOURCES in firmware/CMakeLists.txt),"
echo "   as in the STM32 image; -O2: the whole core and program at -O2)"
echo "(instructions executed, not cycles: see docs/explanation/m4.md)"
echo
# The CANopen master and its link (issue 18, docs/reference/canopen.md): what the
# CiA 408 image's tick adds to the controller's step.
run co_os "$elf/sp_m4_co_icount.elf"
cat "$out/co_os.txt"
echo
# The whole tick the CiA 408 image runs: the controller's step with the
# master and its link around it, in the scenarios above (issue 18).
run co_tick_os "$elf/sp_m4_co_tick.elf"
cat "$out/co_tick_os.txt"
echo
echo "== Cortex-M4: size of the golden-vector image (arm-none-eabi-size, bytes; the STM32 image's flash budget: 163840)"
arm-none-eabi-size "$elf/sp_m4_golden.elf"
awk -f bench/m4/map_sizes.awk "$elf/sp_m4_golden.map"
