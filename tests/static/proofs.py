#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Frama-C over the core: EVA (absence of runtime errors) and WP (the
fixed-point primitives' contracts in sp/math/fixed.h).

    proofs.py eva fixed|link|lu6|proto [--time-limit S] [--build DIR]
    proofs.py wp [--time-limit S]
    proofs.py wp-round [--shifts used|all|K,K,...] [--time-limit S]

eva: runs EVA from a harness in tests/static/eva/ and compares every alarm
with tests/static/eva_alarms.json, where each remaining alarm is justified
as a false positive: an alarm not there, or a count that differs, fails.
wp: proves the contracts (ACSL in sp/math/fixed.h) and the absence of
runtime errors (-wp-rte) of the saturating primitives with Z3 through Why3,
and fails unless every goal is proved. Both print the number of properties
and the time they took, and fail past the time limit.
wp-round: proves the rounding contracts of spi_round_away, sp_rshift_round
and sp_mul (SP_ROUND in sp/math/fixed.h: the exact quotient rounded to
nearest, ties away from zero) with -wp-rte, one constant shift at a time:
Z3 does not prove the bit-level goals for a symbolic shift. `used` (the
default, in ctest) takes the shifts the core's sources pass as constants
(USED_SHIFTS, checked against the sources), `all` every shift 1..62 (the
long run, about 6 minutes on 2 cores). Each shift k adds two axioms that
restate what ACSL's >> and & mean on mathematical integers (x >> k is the
floor of x / 2^k; x & (2^k - 1) its remainder for x >= 0), which Qed and
Z3 do not derive for a constant k themselves.
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
#: The constant shifts the core passes to the rounding primitives
#: (spi_round_away and the calls that reach it): wp-round's default set.
#: shifts_in_sources() finds them; a test compares the two.
USED_SHIFTS = (6, 14, 16, 24, 28, 30, 32)
#: Primitives with a shift argument that round through spi_round_away or
#: sp_rshift_round, and the argument's index.
ROUNDING_CALLS = {"sp_mul": 2, "sp_rshift_round": 1, "spi_round_away": 1, "spi_round_away64": 1,
                  "spi_narrow_away": 1, "spi_mul_away": 2, "sp_narrow": 1}
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


def run_wp(label, files, inline, funcs, what, limit):
    """Frama-C WP with Z3 over files (-wp-rte, functions funcs, inline the
    calls named): prints the goals proved and fails unless all are."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, WHY3CONFIG=os.path.join(tmp, "why3.conf"))
        subprocess.run(["why3", "config", "detect"], env=env, capture_output=True, check=True)
        cmd = BASE + files(tmp) + ["-inline-calls", inline, "-wp", "-wp-fct", funcs, "-wp-rte", "-wp-prover", "z3",
                                   "-wp-timeout", "20", "-wp-par", "2", "-wp-session", os.path.join(tmp, "wp")]
        res, dt = run(cmd, limit, env)
    out = res.stdout + res.stderr
    m = re.search(r"Proved goals:\s+(\d+) / (\d+)", out)
    if res.returncode != 0 or m is None:
        sys.exit(f"{label}: frama-c failed ({res.returncode}):\n{out[-3000:]}")
    post = len(re.findall(r"Goal typed_\w+_ensures\w* : Valid", out))
    print(f"{label}: {m.group(1)} of {m.group(2)} goals proved ({post} postconditions) for {what}; {dt:.1f} s")
    if m.group(1) != m.group(2):
        print("\n".join(line for line in out.splitlines() if "Goal" in line and "Valid" not in line))
        return 1
    return 0


def wp(limit):
    return run_wp("wp", lambda tmp: [os.path.join(ROOT, "firmware/core/src/math/fixed.c")],
                  "set_flag,spi_round_away", WP_FUNCS, WP_FUNCS, limit)


def shifts_in_sources():
    """The constant shift arguments of ROUNDING_CALLS in firmware/core (the
    forwarding of a parameter inside the primitives themselves aside)."""
    found = set()
    call = re.compile(r"\b(" + "|".join(ROUNDING_CALLS) + r")\s*\(")
    for d, _, files in os.walk(os.path.join(ROOT, "firmware", "core")):
        for f in files:
            if not f.endswith((".c", ".h")):
                continue
            with open(os.path.join(d, f), encoding="utf-8") as fh:
                text = re.sub(r"/\*.*?\*/", "", fh.read(), flags=re.S)
            for m in call.finditer(text):
                args, depth, cur, i = [], 1, "", m.end()
                while depth and i < len(text):
                    ch = text[i]
                    depth += (ch == "(") - (ch == ")")
                    if depth == 1 and ch == ",":
                        args.append(cur)
                        cur = ""
                    elif depth:
                        cur += ch
                    i += 1
                args.append(cur)
                idx = ROUNDING_CALLS[m.group(1)]
                lit = re.fullmatch(r"\s*(\d+)u?\s*", args[idx]) if len(args) > idx else None
                if lit:
                    found.add(int(lit.group(1)))
    return sorted(found)


def round_harness(shifts):
    """A C file: per shift k, the rounding contracts of fixed.h for that k
    (spi_round_away only for 1 <= k <= 62; k = 63 checks that
    sp_rshift_round and sp_mul take a shift above 62 as 62), and two
    axioms per divisor 2^min(k, 62)."""
    out = ['#include "sp/math/fixed.h"', '#include "math/fixed_inline.h"', ""]
    for e in sorted({min(k, 62) for k in shifts if k > 0}):
        p = 1 << e
        out += [f"/*@ axiomatic Shift{e} {{",
                f"  @ axiom shr_{e}: \\forall integer x; (x >> {e}) * {p} <= x < (x >> {e}) * {p} + {p};",
                f"  @ axiom mask_{e}: \\forall integer x; 0 <= x ==> (x & {p - 1}) == x - (x >> {e}) * {p};",
                "  @ } */"]
    for k in shifts:
        p = 1 << min(k, 62)
        if 1 <= k <= 62:
            out += [f"/*@ requires v <= {(1 << 63) - 1 - (p >> 1)};",
                    "  @ assigns \\nothing;",
                    f"  @ ensures \\result == SP_ROUND(v, {p});",
                    "  @*/",
                    f"int64_t wp_round_away_{k}(int64_t v) {{ return spi_round_away(v, {k}u); }}"]
        out += ["/*@ assigns \\nothing;",
                f"  @ ensures \\result == SP_ROUND(v, {p});",
                "  @*/",
                f"int64_t wp_rshift_round_{k}(int64_t v) {{ return sp_rshift_round(v, {k}u); }}",
                "/*@ requires flags == \\null || \\valid(flags);",
                "  @ assigns *flags;",
                f"  @ ensures \\result == SP_SAT32(SP_ROUND(a * b, {p}));",
                "  @*/",
                f"int32_t wp_mul_{k}(int32_t a, int32_t b, sp_flags_t *flags) {{ return sp_mul(a, b, {k}u, flags); }}",
                ""]
    return "\n".join(out)


def wp_round(which, limit):
    if which == "used":
        shifts = list(USED_SHIFTS)
        src = shifts_in_sources()
        if src != shifts:
            sys.exit(f"wp-round: the core passes the shifts {src}, USED_SHIFTS says {shifts}: update USED_SHIFTS")
    elif which == "all":
        shifts = list(range(0, 64))
    else:
        shifts = sorted({int(k) for k in which.split(",")})
        if not all(0 <= k <= 63 for k in shifts):
            sys.exit("wp-round: shifts are 0..63 (63: any shift above 62)")

    def files(tmp):
        harness = os.path.join(tmp, "round_main.c")
        with open(harness, "w", encoding="utf-8") as f:
            f.write(round_harness(shifts))
        return [os.path.join(ROOT, "firmware/core/src/math/fixed.c"), harness]

    funcs = ",".join(f"wp_{n}_{k}" for k in shifts for n in ("round_away", "rshift_round", "mul")
                     if n != "round_away" or 1 <= k <= 62)
    return run_wp("wp-round", files, "set_flag,spi_round_away,sp_rshift_round,sp_mul", funcs,
                  f"spi_round_away, sp_rshift_round and sp_mul at the shifts {','.join(map(str, shifts))}", limit)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", choices=["eva", "wp", "wp-round"])
    ap.add_argument("target", nargs="?", choices=sorted(EVA))
    ap.add_argument("--time-limit", type=float, default=300.0)
    ap.add_argument("--shifts", default="used", help="wp-round: used, all or a list K,K,...")
    ap.add_argument("--build", help="the build directory (eva proto: its generated codec)")
    args = ap.parse_args()
    for tool in ("frama-c", "why3", "z3"):
        if shutil.which(tool) is None:
            sys.exit(f"proofs: {tool} is not installed (scripts/setup.sh installs it)")
    if args.what == "eva":
        if args.target is None:
            ap.error("eva needs a target")
        return eva(args.target, args.time_limit, args.build)
    if args.what == "wp-round":
        return wp_round(args.shifts, args.time_limit)
    return wp(args.time_limit)


if __name__ == "__main__":
    sys.exit(main())
