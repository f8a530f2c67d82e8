#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Frama-C over the core: EVA (absence of runtime errors) and WP (the
fixed-point primitives' contracts in sp/math/fixed.h).

    proofs.py eva fixed|link|lu6|proto [--time-limit S] [--build DIR]
    proofs.py wp [--time-limit S]

eva: runs EVA from a harness in tests/static/eva/ and compares every alarm
with tests/static/eva_alarms.json, where each remaining alarm is justified
as a false positive: an alarm not there, or a count that differs, fails.
wp: proves the contracts (ACSL in sp/math/fixed.h) and the absence of
runtime errors (-wp-rte) of the saturating primitives with Z3 through Why3,
and fails unless every goal is proved. Both print the number of properties
and the time they took, and fail past the time limit.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
HERE = os.path.join(ROOT, "tests", "static")
# ILP32 as on the Cortex-M4 (int, long and pointers 32 bits); the core's
# standard headers listed instead of sp_rules.h, whose poisoned float would
# reject Frama-C's own builtin declarations.
CPP = ("-I{r}/firmware/core/include -I{r}/firmware/core/src -include stdint.h -include stdbool.h "
       "-include stddef.h -include limits.h -include string.h").format(r=ROOT)
BASE = ["frama-c", "-machdep", "x86_32", f"-cpp-extra-args={CPP}"]
# lu6: the portable paths of fixed_inline.h (-U__GNUC__): spi_clz32/64 as
# their shift loops and spi_sub_sat through int64, the same values as
# GCC's __builtin_clz (non-zero argument) and __builtin_sub_overflow,
# which EVA does not model (any int; an unwritten result). Only
# attributes and those three helpers depend on __GNUC__ there.
PORTABLE = "-U__GNUC__ "
# Each target: its files (a harness in tests/static/eva/ last) and the EVA
# options that keep its alarms to the false positives of eva_alarms.json in
# a few seconds (the third item: extra preprocessor options).
SPLIT = ["-eva", "-eva-split-return", "auto", "-eva-precision"]
EVA = {
    "fixed": (["firmware/core/src/math/fixed.c", "firmware/core/src/math/status.c", "tests/static/eva/fixed_main.c"],
              SPLIT + ["5"]),
    "link": (["firmware/core/src/link/e2e.c", "firmware/core/src/link/auth.c", "firmware/core/src/math/status.c",
              "tests/static/eva/link_main.c"],
             SPLIT + ["1", "-eva-slevel-function", "sp_auth_tag:200,sp_e2e_crc:200"]),
    "lu6": (["firmware/core/src/model/lu6.c", "firmware/core/src/math/fixed.c", "firmware/core/src/math/status.c",
             "tests/static/eva/lu6_main.c"], SPLIT + ["3"], PORTABLE),
    # the generated codec (gen_proto_c.py, cantools) from the build (--build)
    "proto": (["{gen}/stewart_proto.c", "{gen}/stewart_can.c", "firmware/core/src/link/protocol.c",
               "firmware/core/src/link/e2e.c", "firmware/core/src/link/auth.c", "firmware/core/src/math/fixed.c",
               "firmware/core/src/math/status.c", "tests/static/eva/proto_main.c"],
              SPLIT + ["1", "-eva-slevel-function", "sp_e2e_crc:200,sp_auth_tag:200"], "-I{gen} -I{gen}/include "),
}
WP_FUNCS = "sp_sat32,sp_add,sp_sub,sp_neg,sp_abs"
ALARM = re.compile(r"^\[eva:alarm\] (\S+?):(\d+): Warning:\s*\n\s*(.+?)\.", re.M)


def run(cmd, limit, env=None):
    t0 = time.monotonic()
    try:
        res = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=limit, env=env, check=False)
    except subprocess.TimeoutExpired:
        sys.exit(f"proofs: over the time limit of {limit} s: {' '.join(cmd[:3])} ...")
    return res, time.monotonic() - t0


def eva(target, limit, build):
    files, opts, *extra = EVA[target]
    gen = os.path.join(os.path.abspath(build or os.path.join(ROOT, "build", "host-debug")), "firmware", "generated")
    if any("{gen}" in f for f in files) and not os.path.isfile(os.path.join(gen, "stewart_proto.c")):
        sys.exit(f"eva {target}: no generated codec in {gen} (build first, or pass --build)")
    files = [f.format(gen=gen) for f in files]
    extra = [e.format(gen=gen) for e in extra]
    base = [f"-cpp-extra-args={extra[0]}{CPP}" if a.startswith("-cpp-extra-args=") and extra else a for a in BASE]
    res, dt = run(base + [os.path.join(ROOT, f) for f in files] + opts, limit)
    out = res.stdout + res.stderr
    if res.returncode != 0 or "ANALYSIS SUMMARY" not in out:
        sys.exit(f"eva {target}: frama-c failed ({res.returncode}):\n{out[-3000:]}")
    found = {}
    for m in ALARM.finditer(out):
        if "postcondition" in m.group(3):
            continue  # a contract of sp/math/fixed.h: WP proves it (proofs.py wp)
        key = f"{os.path.relpath(os.path.join(ROOT, m.group(1)), ROOT)}:{m.group(2)}: {m.group(3)}"
        found[key] = found.get(key, 0) + 1
    with open(os.path.join(HERE, "eva_alarms.json"), encoding="utf-8") as f:
        record = json.load(f).get(target, {})
    bad = [f"{k}: {n} alarm(s) not justified in eva_alarms.json" for k, n in sorted(found.items())
           if record.get(k, {}).get("count") != n]
    bad += [f"{k}: justified but no longer raised" for k in sorted(record) if k not in found]
    stmts = re.search(r"(\d+) statements reached \(out of (\d+)\)", out)
    print(f"eva {target}: {sum(found.values())} alarms at {len(found)} places, "
          f"{sum(e['count'] for e in record.values())} justified as false positives; "
          f"{stmts.group(1)} of {stmts.group(2)} statements reached; {dt:.1f} s")
    for b in bad:
        print(f"eva {target}: {b}")
    return 1 if bad else 0


def wp(limit):
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, WHY3CONFIG=os.path.join(tmp, "why3.conf"))
        subprocess.run(["why3", "config", "detect"], env=env, capture_output=True, check=True)
        cmd = BASE + [os.path.join(ROOT, "firmware/core/src/math/fixed.c"), "-inline-calls", "set_flag,spi_round_away", "-wp",
                      "-wp-fct", WP_FUNCS, "-wp-rte", "-wp-prover", "z3", "-wp-timeout", "20", "-wp-par", "2",
                      "-wp-session", os.path.join(tmp, "wp")]
        res, dt = run(cmd, limit, env)
    out = res.stdout + res.stderr
    m = re.search(r"Proved goals:\s+(\d+) / (\d+)", out)
    if res.returncode != 0 or m is None:
        sys.exit(f"wp: frama-c failed ({res.returncode}):\n{out[-3000:]}")
    post = len(re.findall(r"Goal typed_\w+_ensures\w* : Valid", out))
    print(f"wp: {m.group(1)} of {m.group(2)} goals proved ({post} postconditions) for {WP_FUNCS}; {dt:.1f} s")
    if m.group(1) != m.group(2):
        print("\n".join(line for line in out.splitlines() if "Goal" in line and "Valid" not in line))
        return 1
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=["eva", "wp"])
    ap.add_argument("target", nargs="?", choices=sorted(EVA))
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument("--build", help="the build directory (eva proto: its generated codec)")
    args = ap.parse_args()
    for tool in ("frama-c", "why3", "z3"):
        if shutil.which(tool) is None:
            sys.exit(f"proofs: {tool} is not installed (scripts/setup.sh installs it)")
    if args.what == "eva":
        if args.target is None:
            ap.error("eva needs a target")
        return eva(args.target, args.time_limit, args.build)
    return wp(args.time_limit)


if __name__ == "__main__":
    sys.exit(main())
