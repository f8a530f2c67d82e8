#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Bit-exactness of the portable core on a Cortex-M4: runs the golden-vector
# program (bench/m4/golden.c) built for the host and for QEMU's mps2-an386
# and compares the two outputs byte for byte (docs/explanation/m4.md).
# Usage: golden_compare.sh HOST_EXE M4_ELF QEMU OUT_DIR
set -uo pipefail
if [ $# -ne 4 ]; then
  echo "usage: $0 HOST_EXE M4_ELF QEMU OUT_DIR" >&2
  exit 2
fi
host_exe=$1 elf=$2 qemu=$3 out=$4
mkdir -p "$out"
rm -f "$out/host.txt" "$out/m4.txt"
for f in "$host_exe" "$elf"; do
  [ -f "$f" ] || { echo "FAIL: $f is missing (build the host-debug preset)"; exit 1; }
done

"$host_exe" >"$out/host.txt"
rc_host=$?
timeout -k 5 300 "$qemu" -M mps2-an386 -display none -monitor none -serial none \
  -semihosting-config enable=on,target=native -kernel "$elf" </dev/null >"$out/m4.txt"
rc_m4=$?

fail=0
if [ $rc_host -ne 0 ]; then
  echo "FAIL: host program exited with $rc_host"; fail=1
fi
if [ $rc_m4 -ne 0 ]; then
  echo "FAIL: Cortex-M4 program (QEMU) exited with $rc_m4"; fail=1
fi
for side in host m4; do
  f="$out/$side.txt"
  if ! tail -n 1 "$f" | grep -q '^fnv1a64 [0-9a-f]\{16\}$'; then
    echo "FAIL: $side output is incomplete (no final hash line)"; fail=1
  fi
  grep '^check failed' "$f" | sed "s/^/$side: /"
done
echo "host: $(wc -l <"$out/host.txt") lines, $(wc -c <"$out/host.txt") bytes; m4: $(wc -l <"$out/m4.txt") lines, $(wc -c <"$out/m4.txt") bytes"
if cmp -s "$out/host.txt" "$out/m4.txt"; then
  grep -E '^(summary|result|fnv1a64)' "$out/host.txt"
  echo "host and Cortex-M4 outputs are identical"
else
  echo "FAIL: host and Cortex-M4 outputs differ; first differences (< host, > m4):"
  cmp "$out/host.txt" "$out/m4.txt" | head -n 1
  diff "$out/host.txt" "$out/m4.txt" | head -n 20
  fail=1
fi
exit $fail
