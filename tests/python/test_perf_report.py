# SPDX-License-Identifier: Apache-2.0
"""docs/performance.md's generator (stewart.perf_report) on a recorded
sample of scripts/bench.sh's output, and the committed page is its output."""

from pathlib import Path

from stewart import perf_report as pr

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = Path(__file__).parent / "data" / "bench_sample.txt"
PAGE = ROOT / "docs" / "performance.md"


def test_sections_in_order_without_empty_banners():
    secs = pr.sections(SAMPLE.read_text())
    titles = [t for t, _ in secs]
    assert titles == [
        "benchmark: bench_fixed",
        "accuracy: fixed-point core vs float64 model (stewart accuracy)",
        "Cortex-M4 instruction counts, fixed point (QEMU mps2-an386, -icount shift=7,sleep=off; "
        "soft-float ABI; compiled for size (-Os))",
        "sp_stm32g4 (NUCLEO-G474RE), drive protocol native: Release (-Os -DNDEBUG), "
        "arm-none-eabi-gcc 12.2.1",
    ]
    fixed = dict(secs)["benchmark: bench_fixed"]
    assert len(fixed) == 9 and fixed[-1].startswith("sp_dot3")
    # blank lines inside a section stay, trailing ones go
    stm = secs[-1][1]
    assert "" in stm and stm[-1].startswith("heap: none linked")


def test_budgets_and_bounds_listed_per_section():
    checks = dict(pr.checks(pr.sections(SAMPLE.read_text())))
    acc = checks["accuracy: fixed-point core vs float64 model (stewart accuracy)"]
    assert [ln.split()[0] for ln in acc] == ["leg", "cylinder", "FK", "FK", "FK"]
    assert not any("stretch" in ln for ln in acc), "a line without a bound is not a check"
    m4 = next(v for k, v in checks.items() if k.startswith("Cortex-M4 instruction counts"))
    assert m4[0].endswith("OVER BUDGET in 6916 ticks") and m4[1].endswith("within budget")
    stm = next(v for k, v in checks.items() if k.startswith("sp_stm32g4"))
    assert stm == ["flash 109556 of 131072 bytes (83.6 %)  ok",
                   "RAM    13964 of  32768 bytes (42.6 %)  ok   (stack 4096, .data 0, .bss 9836, .noinit 32)",
                   "stack: tick path 1640 bytes, 1872 with interrupts / budget 2048: ok"]
    assert "benchmark: bench_fixed" not in checks


def test_page_has_every_line_verbatim_and_escaped_titles():
    text = SAMPLE.read_text()
    page = pr.render(text, "x86_64, 2 cores, 2026-12-02")
    assert page.startswith(pr.HEADER + "\n")
    assert "\nMeasured on: x86_64, 2 cores, 2026-12-02\n" in page
    assert "\n## benchmark: bench\\_fixed\n" in page
    assert "  - `flash 109556 of 131072 bytes (83.6 %)  ok`" in page
    body = page.split("\n## Budgets and bounds\n", 1)[1]
    for line in text.splitlines():
        if line and not line.startswith("== "):
            assert line.rstrip() in body.splitlines(), line
    assert page.count("```") == 2 * 4
    assert "NUCLEO-G474RE image: sizes" not in page, "the empty banner is left out"


def test_render_is_deterministic_and_recoverable():
    text = SAMPLE.read_text()
    page = pr.render(text, "m")
    assert pr.render(text, "m") == page
    again, machine = pr.recover(page)
    assert machine == "m" and pr.render(again, machine) == page


def test_main_writes_the_page(tmp_path):
    out = tmp_path / "performance.md"
    assert pr.main([str(SAMPLE), str(out), "--machine", "here"]) == 0
    assert out.read_text() == pr.render(SAMPLE.read_text(), "here")
    assert pr.main([str(tmp_path / "missing.txt"), str(out)]) == 2


def test_committed_page_is_the_generators_output():
    """docs/performance.md is not edited by hand: rendering what it holds
    gives it back byte for byte (a hand-typed figure in its list or text
    would not survive)."""
    page = PAGE.read_text()
    assert page.startswith(pr.HEADER)
    text, machine = pr.recover(page)
    assert machine and pr.render(text, machine) == page
