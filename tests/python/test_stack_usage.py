# SPDX-License-Identifier: Apache-2.0
"""tools/dev/stack_usage.py on small Cortex-M4 programs whose worst-case
stack is known: GCC's frames summed along the deepest chain, libgcc calls
GCC's call graph does not show, and the cases that are not a bound
(recursion, unresolved indirect call) failing. Needs arm-none-eabi-gcc."""
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "tools" / "dev" / "stack_usage.py"
GCC = shutil.which("arm-none-eabi-gcc")
pytestmark = pytest.mark.skipif(GCC is None, reason="arm-none-eabi-gcc not installed")

SOURCE = r"""
typedef int (*fn_t)(int);
__attribute__((noinline)) int leaf(int x) { volatile char b[100]; b[0] = (char)x; return b[0]; }
__attribute__((noinline)) int mid(int x) { volatile char b[40]; b[0] = (char)leaf(x); return b[0]; }
__attribute__((noinline)) int shallow(int x) { volatile char b[8]; b[0] = (char)x; return b[0]; }
__attribute__((noinline)) long long divide(long long a, long long b) { return a / b; }
__attribute__((noinline)) int top(int x) { return mid(x) + shallow(x) + (int)divide(x, 3); }
__attribute__((noinline)) int rec(int x) { return x > 0 ? rec(x - 1) + 1 : 0; }
__attribute__((noinline)) int via(fn_t f, int x) { return f(x); }
int isr(void);
int isr(void) { return 0; }
void start(void);
void start(void) { volatile int r = top(1) + rec(3) + via(shallow, 2); (void)r; for (;;) {} }
"""


def build(tmp_path: Path) -> Path:
    src = tmp_path / "prog.c"
    src.write_text(SOURCE)
    elf = tmp_path / "prog.elf"
    subprocess.run([GCC, "-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=soft", "-O1", "-fstack-usage",
                    "-fcallgraph-info=su", "-nostartfiles", "-Wl,-estart", "-Wl,--gc-sections",
                    "-Wl,-Ttext=0x8000000", "-o", str(elf), str(src), "-lgcc"],
                   check=True, cwd=tmp_path)
    return elf


def su_frames(tmp_path: Path) -> dict:
    frames = {}
    for su in tmp_path.glob("*.su"):
        for line in su.read_text().splitlines():
            parts = line.split("\t")
            frames[parts[0].rsplit(":", 1)[-1]] = int(parts[1])
    return frames


def run(tmp_path: Path, elf: Path, *args: str):
    return subprocess.run([sys.executable, str(SCRIPT), "--ci-dir", str(tmp_path), "--elf", str(elf), *args],
                          capture_output=True, text=True)


def test_sum_along_the_deepest_chain_with_libgcc(tmp_path):
    elf = build(tmp_path)
    f = su_frames(tmp_path)
    r = run(tmp_path, elf, "--root", "top")
    assert r.returncode == 0, r.stderr
    tick = int(re.search(r"tick path (\d+) bytes", r.stdout).group(1))
    via_call = f["top"] + f["mid"] + f["leaf"]
    assert tick == via_call, r.stdout  # leaf's 100-byte buffer is the deepest path
    assert "top" in r.stdout and "leaf" in r.stdout
    # divide() calls __aeabi_ldivmod, which GCC's call graph does not show: found in the disassembly
    r = run(tmp_path, elf, "--root", "divide")
    assert r.returncode == 0, r.stderr
    assert "__aeabi_ldivmod" in r.stdout and "__udivmoddi4" in r.stdout


def test_interrupts_added_and_budget(tmp_path):
    elf = build(tmp_path)
    f = su_frames(tmp_path)
    r = run(tmp_path, elf, "--root", "top", "--isr", "isr", "--budget", "10000")
    assert r.returncode == 0
    expect = f["top"] + f["mid"] + f["leaf"] + f["isr"] + 36
    assert f"{expect} with interrupts" in r.stdout
    r = run(tmp_path, elf, "--root", "top", "--budget", "16")
    assert r.returncode == 1 and "FAIL" in r.stdout


def test_not_a_bound_fails(tmp_path):
    elf = build(tmp_path)
    r = run(tmp_path, elf, "--root", "rec")
    assert r.returncode == 1 and "recursion" in r.stderr
    r = run(tmp_path, elf, "--root", "via")
    assert r.returncode == 1 and "indirect" in r.stderr
    r = run(tmp_path, elf, "--root", "via", "--indirect", "via=shallow")
    assert r.returncode == 0, r.stderr
