#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Instruction profile of the controller tick on the Cortex-M4 (QEMU): runs
# sp_m4_profile.elf (profile.c: 300 RUNNING ticks of the golden scenario) with
# QEMU's translation-block trace and prints the instructions executed per
# function, most first. Usage: bench/m4/profile.sh [M4 build dir] [top N] [stream]
# (stream: the STREAM scenario's first 2000 RUNNING ticks, all four of its
# target poses, sp_m4_profile_stream.elf;
# yaw: the yaw scenario's, sp_m4_profile_yaw.elf;
# force: the force scenario's FORCE command and the 2000 ticks after it;
# engage: the surge's ENGAGE tick alone, sp_m4_profile_engage.elf;
# trig: the surge's RUN_TRIG tick alone, sp_m4_profile_trig.elf;
# stream_all: the STREAM scenario's whole RUNNING phase (5658 ticks, the
# settling tail after PARK included), sp_m4_profile_stream_all.elf;
# twin: the force scenario's position-control twin, every tick from ENGAGE
# (13866 ticks), sp_m4_profile_twin.elf;
# stream_start: the STREAM command's tick alone;
# slide: the force scenario's 50 mm slide in FORCE, the MOVE_TO tick and
# the 843 after it;
# tip: the surge with a tool tip (0.15, 0, 0.35) m (tip_yaw, tip_stream,
# tip_force: the yaw, the stream and the force run with it); frames, frames_stream,
# frames_force: the surge, the stream and the force run with turned tool
# and work frames, issue 31)
# PROFILE_TICKS=n divides by n ticks for an ELF built with -DPROFILE_TICKS=n.
# PROFILE_ABOVE=n keeps only the ticks whose controller step (between
# profile.c's tick markers) executed more than n instructions, and divides
# by their number: what the highest ticks spend their instructions in;
# PROFILE_LIST=1 with it also lists each kept tick (its index from the
# first counted tick, 1 first, and its instructions) on stderr;
# PROFILE_TICK=i with it keeps tick i alone (PROFILE_ABOVE=1
# PROFILE_TICK=i: what that one tick spends its instructions in).
# PROFILE_FUNC=name (with PROFILE_ABOVE, 1 for every tick) lists that
# function's translation blocks by start address instead (objdump -d).
set -euo pipefail
dir=${1:-build/m4-core}
top=${2:-25}
elf=$dir/bench/m4/sp_m4_profile${3:+_$3}.elf
[ "${3:-}" = force ] && : "${PROFILE_TICKS:=2001}"
[ "${3:-}" = stream ] && : "${PROFILE_TICKS:=2000}"
[ "${3:-}" = stream_all ] && : "${PROFILE_TICKS:=5658}"
[ "${3:-}" = twin ] && : "${PROFILE_TICKS:=13866}"
[ "${3:-}" = engage ] && : "${PROFILE_TICKS:=1}"
[ "${3:-}" = trig ] && : "${PROFILE_TICKS:=1}"
[ "${3:-}" = stream_start ] && : "${PROFILE_TICKS:=1}"
[ "${3:-}" = slide ] && : "${PROFILE_TICKS:=844}"
[ "${3:-}" = frames_stream ] && : "${PROFILE_TICKS:=2000}"
[ "${3:-}" = tip_stream ] && : "${PROFILE_TICKS:=2000}"
[ "${3:-}" = tip_force ] && : "${PROFILE_TICKS:=2001}"
[ "${3:-}" = frames_force ] && : "${PROFILE_TICKS:=2001}"
[ -f "$elf" ] || { echo "profile: $elf is missing (build the m4-core preset)" >&2; exit 1; }
log=$(mktemp -d)
trap 'rm -rf "$log"' EXIT
mkfifo "$log/fifo"
awk -v above="${PROFILE_ABOVE:-0}" -v pick="${PROFILE_TICK:-}" -v only="${PROFILE_FUNC:-}" -v list="${PROFILE_LIST:-0}" '
  /^IN:/ { intb = 1; start = ""; n = 0; fn = $2; next }
  /^Trace/ && !on { split($0, f, "/"); if (func["0x" f[2]] == "profile_begin") on = 1; else next }
  intb && /^0x[0-9a-f]+:/ { if (start == "") start = substr($1, 1, length($1) - 1); n++; next }
  intb && /^$/ { if (start != "") { size[start] = n; func[start] = fn }; intb = 0; next }
  /^Trace/ && above > 0 {
    split($0, f, "/"); a = "0x" f[2]; k = (a in func) ? func[a] : "?"
    if (k == "profile_tick") { intick = 1; split("", tc); tt = 0; next }
    if (k == "profile_tick_end") {
      intick = 0
      ticks++
      if (tt > above && (pick == "" || ticks == pick)) {
        for (j in tc) per[j] += tc[j]
        tot += tt; kept++
        if (list) printf "tick %d: %d\n", ticks, tt > "/dev/stderr"
      }
      next
    }
    if (intick) { tt += size[a]; if (only == "" || k == only) tc[only == "" ? k : a] += size[a] }
    next
  }
  /^Trace/ { split($0, f, "/"); a = "0x" f[2]; cnt[a]++; next }
  END {
    for (a in cnt) { k = (a in func) ? func[a] : "?"; per[k] += cnt[a] * size[a]; tot += cnt[a] * size[a] }
    if (above > 0 && kept == 0) { print "profile: no tick above " above " instructions"; exit }
    printf "%-28s %12s %6s\n", "function", "instructions", "%"
    for (k in per) printf "%-28s %12d %6.1f\n", k, per[k], 100 * per[k] / tot | "sort -k2 -nr | head -'"$top"'"
    close("sort -k2 -nr | head -'"$top"'")
    printf "%-28s %12d\n", "total", tot
    if (above > 0) printf "%-28s %12d (%d ticks above %d)\n", "per tick", tot / kept, kept, above
    else printf "%-28s %12d\n", "per tick", tot / '"${PROFILE_TICKS:-300}"'
  }' "$log/fifo" &
qemu-system-arm -M mps2-an386 -display none -monitor none -serial none \
  -semihosting-config enable=on,target=native -kernel "$elf" \
  -d in_asm,exec,nochain -D "$log/fifo" </dev/null >/dev/null
wait
