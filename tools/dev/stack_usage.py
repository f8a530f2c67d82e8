#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Worst-case stack depth of a firmware image's call chains.

Reads GCC's per-function call graphs (``-fcallgraph-info=su``: one ``.ci``
file per object, VCG text; each defined function with its static frame size
from ``-fstack-usage``) and completes them from the linked image's
disassembly (``objdump -d``):

* calls GCC emits after its call graph is built (run-time library helpers
  such as ``__aeabi_ldivmod``, ``memcpy`` for structure copies) and functions
  without a ``.ci`` entry (libgcc, newlib) are taken from the ``bl``/``blx``
  and tail-call ``b`` instructions of the image; their frames are estimated
  from their prologue (``push``, ``vpush``, ``sub sp``);
* indirect calls (``__indirect_call`` in the graph, ``blx rN`` in the code)
  must be resolved with ``--indirect CALLER=T1,T2``: the worst target counts.

Then ``depth(f) = frame(f) + max(depth(callee))``. Recursion, a dynamic
frame, or an unresolved indirect call is an error: the figure would not be a
bound. Interrupt handlers named with ``--isr`` are added on top, each with
the 32-byte exception frame the Cortex-M4 pushes (no FPU context: the
firmware is built for the soft-float ABI) plus 4 bytes of alignment.

Exit status 0, or 1 if the tick path exceeds --budget or the analysis is not
a bound; 2 for usage errors.

    stack_usage.py --ci-dir build/stm32g4 --elf sp_stm32g4.elf --root sp_g4_cycle \\
        --isr sp_g4_systick_handler --indirect sp_g4_cycle=can_send,can_receive --budget 2048
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field

EXCEPTION_FRAME = 32 + 4  # r0-r3, r12, lr, pc, xpsr; +4 if the stack is realigned to 8

_NODE = re.compile(r'^node:\s*\{\s*title:\s*"([^"]+)"\s*label:\s*"([^"]*)"')
_EDGE = re.compile(r'^edge:\s*\{\s*sourcename:\s*"([^"]+)"\s*targetname:\s*"([^"]+)"')
_SIZE = re.compile(r"\\n(\d+) bytes \(([a-z,]+)\)")


@dataclass
class Func:
    name: str
    frame: int = 0
    source: str = "?"          # "ci" (GCC's figure) or "objdump" (prologue estimate)
    kind: str = "static"       # static / dynamic / dynamic,bounded
    callees: set = field(default_factory=set)
    indirect: bool = False
    where: str = ""


def _plain(title: str) -> str:
    """GCC titles a static function "FILE:name"; the image calls it "name"."""
    return title.rsplit(":", 1)[-1]


def parse_ci(ci_dir: str) -> tuple[dict, list[str]]:
    """Functions defined in the .ci files; same-named static functions of
    different files are merged conservatively (largest frame, union of calls)."""
    funcs: dict[str, Func] = {}
    problems: list[str] = []
    files = []
    for root, _dirs, names in os.walk(ci_dir):
        files += [os.path.join(root, n) for n in names if n.endswith(".ci")]
    for path in sorted(files):
        local: dict[str, Func] = {}
        edges: list[tuple[str, str]] = []
        with open(path, encoding="utf-8", errors="replace") as fh:
            for line in fh:
                m = _NODE.match(line)
                if m:
                    title, label = _plain(m.group(1)), m.group(2)
                    s = _SIZE.search(label)
                    if s:  # a definition (declarations carry no size)
                        f = Func(title, int(s.group(1)), "ci", s.group(2), where=os.path.basename(path))
                        local[title] = f
                    continue
                m = _EDGE.match(line)
                if m:
                    edges.append((_plain(m.group(1)), _plain(m.group(2))))
        for src, dst in edges:
            if src not in local:
                continue
            if dst == "__indirect_call":
                local[src].indirect = True
            else:
                local[src].callees.add(dst)
        for name, f in local.items():
            if name in funcs:
                g = funcs[name]
                g.frame = max(g.frame, f.frame)
                g.callees |= f.callees
                g.indirect = g.indirect or f.indirect
                if f.kind != "static":
                    g.kind = f.kind
            else:
                funcs[name] = f
    if not files:
        problems.append(f"no .ci files under {ci_dir} (compile with -fcallgraph-info=su)")
    return funcs, problems


_FUNC_HDR = re.compile(r"^([0-9a-f]+) <([^>]+)>:$")
_INSN = re.compile(r"^\s*[0-9a-f]+:\s+(?:[0-9a-f]{4}\s?){1,2}\s+(\S+)\s*(.*)$")
_TARGET = re.compile(r"<([^>+]+)(\+0x[0-9a-f]+)?>")


def _reglist_count(ops: str) -> int:
    m = re.search(r"\{([^}]*)\}", ops)
    if not m:
        return 0
    n = 0
    for part in m.group(1).split(","):
        part = part.strip()
        r = re.match(r"([a-z]+)(\d+)-[a-z]+(\d+)$", part)
        n += (int(r.group(3)) - int(r.group(2)) + 1) if r else 1
    return n


def parse_objdump(objdump: str, elf: str) -> dict:
    """Per function of the image: estimated frame, direct callees, indirect calls."""
    out = subprocess.run([objdump, "-d", "--no-show-raw-insn", elf], check=True, capture_output=True,
                         text=True).stdout
    funcs: dict[str, Func] = {}
    cur: Func | None = None
    for line in out.splitlines():
        m = _FUNC_HDR.match(line)
        if m:
            cur = funcs.setdefault(m.group(2), Func(m.group(2), source="objdump", where="image"))
            continue
        if cur is None:
            continue
        m = re.match(r"^\s*[0-9a-f]+:\s+(\S+)\s*(.*)$", line)
        if not m:
            continue
        op, ops = m.group(1), m.group(2)
        base = re.sub(r"(\.w|\.n)$", "", op)
        if base in ("push", "stmdb") and ("sp!" in ops or base == "push"):
            cur.frame += 4 * _reglist_count(ops)
        elif re.search(r"\[sp,\s*#-(\d+)\]!", ops):  # str/strd with pre-decrement of sp
            cur.frame += int(re.search(r"\[sp,\s*#-(\d+)\]!", ops).group(1))
        elif base == "vpush":
            regs = _reglist_count(ops)
            cur.frame += (8 if "d" in ops.split("{")[1][:2] else 4) * regs
        elif base in ("sub", "subw") and re.match(r"sp,\s*(sp,\s*)?#", ops):
            cur.frame += int(re.search(r"#(\d+)", ops).group(1))
        elif base in ("bl", "blx", "b", "b.w") or re.match(r"^b(eq|ne|cs|cc|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)?$", base):
            t = _TARGET.search(ops)
            if base == "blx" and not t:
                cur.indirect = True
            elif t and t.group(2) is None and t.group(1) != cur.name:
                cur.callees.add(t.group(1))
            elif t and base in ("bl", "blx") and t.group(1) != cur.name:
                cur.callees.add(t.group(1))
        elif base == "bx" and not ops.startswith("lr"):
            cur.indirect = True
    _add_aliases(objdump, elf, funcs)
    return funcs


def _add_aliases(objdump: str, elf: str, funcs: dict) -> None:
    """Functions folded into one body (GCC's identical-code folding at -Os)
    keep their own symbols at the same address, but the disassembly names
    only one of them: each other name becomes an alias of that body."""
    out = subprocess.run([objdump, "-t", elf], check=True, capture_output=True, text=True).stdout
    by_addr: dict[int, list[str]] = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 6 and "F" in parts[1:3] and parts[-3].startswith(".text"):
            by_addr.setdefault(int(parts[0], 16) & ~1, []).append(parts[-1])
    for names in by_addr.values():
        body = next((funcs[n] for n in names if n in funcs), None)
        if body is not None:
            for n in names:
                funcs.setdefault(n, body)


def stack_region_size(objdump: str, elf: str, spec: str) -> int:
    """Bytes between two symbols of the image (objdump -t)."""
    bottom, top = spec.split(",")
    out = subprocess.run([objdump, "-t", elf], check=True, capture_output=True, text=True).stdout
    addr = {}
    for line in out.splitlines():
        parts = line.split()
        if parts and parts[-1] in (bottom, top):
            addr[parts[-1]] = int(parts[0], 16)
    if bottom not in addr or top not in addr:
        raise SystemExit(f"stack_usage: {spec}: symbols not found in {elf}")
    return addr[top] - addr[bottom]


def merge(ci: dict, image: dict) -> dict:
    """GCC's frames where it has them; every call seen in either source."""
    funcs = dict(image)
    for name, f in ci.items():
        if name in funcs:
            g = funcs[name]
            g.frame, g.source, g.kind, g.where = f.frame, "ci", f.kind, f.where
            g.callees |= f.callees
            g.indirect = g.indirect or f.indirect
        else:
            funcs[name] = f  # not linked (garbage-collected): harmless
    return funcs


def analyse(funcs: dict, root: str, indirect: dict) -> tuple[int, list[str], list[str]]:
    """Worst depth from root, its chain, and the problems that make it not a bound."""
    memo: dict[str, tuple[int, list[str]]] = {}
    problems: list[str] = []
    on_path: set[str] = set()

    def depth(name: str) -> tuple[int, list[str]]:
        if name in memo:
            return memo[name]
        f = funcs.get(name)
        if f is None:
            problems.append(f"{name}: called but not found in the image or the call graphs")
            return 0, [name + " (?)"]
        if name in on_path:
            problems.append(f"recursion through {name}")
            return 0, [name + " (recursion)"]
        if f.kind != "static":
            problems.append(f"{name}: {f.kind} stack frame")
        on_path.add(name)
        callees = set(f.callees)
        if f.indirect:
            if name in indirect:
                callees |= set(indirect[name])
            else:
                problems.append(f"{name}: indirect call without an --indirect resolution")
        best, chain = 0, []
        for c in sorted(callees):
            d, ch = depth(c)
            if d > best:
                best, chain = d, ch
        on_path.discard(name)
        memo[name] = (f.frame + best, [name] + chain)
        return memo[name]

    total, chain = depth(root)
    return total, chain, problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ci-dir", required=True, help="directory searched recursively for .ci files")
    ap.add_argument("--elf", required=True)
    ap.add_argument("--objdump", default="arm-none-eabi-objdump")
    ap.add_argument("--root", required=True, help="function whose call tree is the tick path")
    ap.add_argument("--isr", action="append", default=[], help="interrupt handler that can preempt (repeatable)")
    ap.add_argument("--indirect", action="append", default=[], help="CALLER=T1,T2: targets of CALLER's indirect calls")
    ap.add_argument("--whole", default=None, help="also report the worst depth from this function (e.g. the reset handler)")
    ap.add_argument("--budget", type=int, default=None, help="bytes the tick path (with interrupts) may use")
    ap.add_argument("--stack-region", default=None, metavar="BOTTOM,TOP",
                    help="symbols bounding the stack in the image: the --whole figure (with interrupts) must fit")
    ap.add_argument("--quiet", action="store_true", help="one summary line")
    a = ap.parse_args(argv)

    indirect = {}
    for spec in a.indirect:
        if "=" not in spec:
            ap.error(f"--indirect {spec!r}: expected CALLER=T1,T2")
        caller, targets = spec.split("=", 1)
        indirect[caller] = [t for t in targets.split(",") if t]

    ci, problems = parse_ci(a.ci_dir)
    funcs = merge(ci, parse_objdump(a.objdump, a.elf))
    if a.root not in funcs:
        print(f"stack_usage: {a.root} is not in {a.elf}", file=sys.stderr)
        return 2

    def frames(chain: list[str]) -> str:
        return " -> ".join(f"{n} {funcs[n].frame}" + ("*" if funcs[n].source != "ci" else "")
                           for n in chain if n in funcs)

    tick, chain, p = analyse(funcs, a.root, indirect)
    problems += p
    isr_total, isr_lines = 0, []
    for isr in a.isr:
        d, ch, p = analyse(funcs, isr, indirect)
        problems += p
        isr_total += d + EXCEPTION_FRAME
        isr_lines.append(f"  interrupt {isr}: {d} + {EXCEPTION_FRAME} exception frame ({frames(ch)})")
    with_isr = tick + isr_total

    whole_line = None
    if a.whole:
        d, ch, p = analyse(funcs, a.whole, indirect)
        problems += p
        whole_line = f"  whole program from {a.whole}: {d} bytes, {d + isr_total} with interrupts ({frames(ch)})"
        if a.stack_region:
            size = stack_region_size(a.objdump, a.elf, a.stack_region)
            whole_line += f"; stack region {size} bytes"
            if d + isr_total > size:
                problems.append(f"the whole program needs {d + isr_total} bytes, the stack region has {size}")

    ok = not problems and (a.budget is None or with_isr <= a.budget)
    budget = f" / budget {a.budget}" if a.budget is not None else ""
    summary = f"stack: tick path {tick} bytes, {with_isr} with interrupts{budget}: {'ok' if ok else 'FAIL'}"
    if a.quiet:
        print(summary)
    else:
        print(summary)
        print(f"  worst chain ({len(chain)} calls; * = frame estimated from the disassembly): {frames(chain)}")
        for line in isr_lines:
            print(line)
        if whole_line:
            print(whole_line)
        estimated = sorted({n for n in chain if n in funcs and funcs[n].source != "ci"})
        if estimated:
            print(f"  frames from the disassembly (no GCC figure): {', '.join(estimated)}")
    for prob in sorted(set(problems)):
        print(f"stack_usage: not a bound: {prob}", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
