#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The NUCLEO-G474RE firmware's figures (docs/reference/stm32g4.md): the image files,
# flash and RAM against their budgets (160 KiB, 32 KiB), the flash of each
# part (portable core per file, libgcc, C library, port), the worst-case
# stack of the tick path against 2.25 KiB (GCC's -fcallgraph-info=su call
# graphs completed by the disassembly; tools/dev/stack_usage.py), and
# the heap check. Builds the stm32g4 preset first (incremental).
# STM32_BUILD_DIR: use an existing build directory instead (not rebuilt).
# An argument names the preset: stm32g4 (default, the native drive
# protocol) or stm32g4-cia408 (the CANopen image, docs/reference/canopen.md).
# Exit status: 0 when every budget holds, 1 otherwise.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
preset=${1:-stm32g4}
case $preset in stm32g4 | stm32g4-cia408) ;; *) echo "stm32_report: unknown preset $preset" >&2; exit 2 ;; esac
dir=${STM32_BUILD_DIR:-build/$preset}
if [ -z "${STM32_BUILD_DIR:-}" ]; then
  if [ -f "$dir/build.ninja" ]; then
    cmake --build --preset "$preset" >/dev/null
  else
    scripts/build.sh "$preset" >/dev/null
  fi
fi
out=$dir/firmware/ports/stm32g4
elf=$out/sp_stm32g4.elf
for f in sp_stm32g4.elf sp_stm32g4.bin sp_stm32g4.hex sp_stm32g4.map; do
  [ -f "$out/$f" ] || { echo "stm32_report: $out/$f is missing (build the stm32g4 preset)" >&2; exit 1; }
done

flash_budget=163840 ram_budget=32768 stack_budget=2304
status=0
btype=$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$dir/CMakeCache.txt")
bflags=$(sed -n "s/^CMAKE_C_FLAGS_$(echo "$btype" | tr a-z A-Z):[A-Z]*=//p" "$dir/CMakeCache.txt")
proto=$(sed -n 's/^SP_DRIVE_PROTOCOL:[A-Z]*=//p' "$dir/CMakeCache.txt")
echo "== sp_stm32g4 (NUCLEO-G474RE), drive protocol ${proto:-native}: $btype ($bflags), arm-none-eabi-gcc $(arm-none-eabi-gcc -dumpfullversion)"
for f in sp_stm32g4.elf sp_stm32g4.bin sp_stm32g4.hex sp_stm32g4.map; do
  printf '  %-16s %8d bytes\n' "$f" "$(stat -c %s "$out/$f")"
done

# Section sizes (arm-none-eabi-size -A): flash = what is programmed, RAM =
# everything the linker places in SRAM1 (stack included).
read -r flash ram stack data bss noinit < <(arm-none-eabi-size -A "$elf" | awk '
  $1 == ".vectors" || $1 == ".text" || $1 ~ /^\.ARM\.ex/ { f += $2 }
  $1 == ".data" { f += $2; r += $2; d = $2 }
  $1 == ".bss" { r += $2; b = $2 }
  $1 == ".stack" { r += $2; s = $2 }
  $1 == ".noinit" { r += $2; n = $2 }
  END { print f + 0, r + 0, s + 0, d + 0, b + 0, n + 0 }')
verdict() { if [ "$1" -le "$2" ]; then echo ok; else echo OVER; status=1; fi; }
printf '  flash %6d of %6d bytes (%4.1f %%)  %s\n' "$flash" $flash_budget \
  "$(awk -v a="$flash" -v b=$flash_budget 'BEGIN { print 100 * a / b }')" "$(verdict "$flash" $flash_budget)"
printf '  RAM   %6d of %6d bytes (%4.1f %%)  %s   (stack %d, .data %d, .bss %d, .noinit %d)\n' "$ram" $ram_budget \
  "$(awk -v a="$ram" -v b=$ram_budget 'BEGIN { print 100 * a / b }')" "$(verdict "$ram" $ram_budget)" \
  "$stack" "$data" "$bss" "$noinit"
echo
awk -f bench/m4/map_sizes.awk "$out/sp_stm32g4.map" | sed 's/program, port, semihosting/port (ports\/stm32g4)        /'
echo
python3 tools/dev/stack_usage.py --ci-dir "$dir" --elf "$elf" --objdump arm-none-eabi-objdump \
  --root sp_g4_cycle --isr sp_g4_systick_handler --isr sp_g4_nmi --isr sp_g4_fdcan_drive_irq \
  --indirect "sp_g4_cycle=can_send,can_receive,watchdog_kick" --indirect "main=tick_wait" \
  --whole sp_g4_reset --stack-region sp_g4_stack_bottom,sp_g4_stack_top --budget $stack_budget || status=1
echo
heap=$(arm-none-eabi-nm "$elf" | awk '$3 ~ /^(_?malloc(_r)?|_?free(_r)?|_?calloc(_r)?|_?realloc(_r)?|_sbrk(_r)?|aligned_alloc)$/ { print $3 }')
if [ -z "$heap" ]; then echo "heap: none linked (no malloc, free, _sbrk)"; else echo "heap: LINKED: $heap"; status=1; fi
exit $status
