# SPDX-License-Identifier: Apache-2.0
"""Cost of ``stewart analyze``'s steps on one log: the whole-message
decoder and the numpy writers against the per-frame reference path.

    .venv/bin/python bench/bench_analyze.py LOG [TRUTH] [--repeat 3] [--reference]

Prints per step the best wall time and the CPU time of that run (on a
shared machine the CPU time is the steadier figure), and the peak memory of
the process. With --reference also the plain path (per-frame cantools
decode, csv-module writer, row-by-row truth reader), once, and checks that
both give the same LogData and the same signals.csv. docs/reference/analysis.md
quotes its figures."""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def timed(fn, repeat: int):
    best = None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        w, c = time.perf_counter() - w0, time.process_time() - c0
        if best is None or w < best[0]:
            best = (w, c)
    return out, best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log")
    ap.add_argument("truth", nargs="?")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--reference", action="store_true")
    args = ap.parse_args()

    t0w, t0c = time.perf_counter(), time.process_time()
    from stewart import config as cfg
    from stewart.analysis.csvout import write_signals_csv, write_signals_csv_reference
    from stewart.analysis.decode import read_log
    from stewart.analysis.decode_reference import read_log_reference
    from stewart.analysis.metrics import summarize
    from stewart.analysis.run import DEFAULT_PLATFORM
    from stewart.analysis.segments import find_segments
    from stewart.analysis.truth import attach_truth, read_truth, read_truth_rows
    imp = (time.perf_counter() - t0w, time.process_time() - t0c)
    plat = cfg.load(DEFAULT_PLATFORM)
    tmp = Path(tempfile.mkdtemp(prefix="bench_analyze_"))
    rows = [("imports", imp)]
    data, r = timed(lambda: read_log(args.log, platform=plat), args.repeat)
    rows.append(("read_log", r))
    if args.truth:
        truth, r = timed(lambda: read_truth(args.truth), args.repeat)
        rows.append(("read_truth", r))
        attach_truth(data, truth)
    segs, r = timed(lambda: find_segments(data), args.repeat)
    rows.append(("segments", r))
    _, r = timed(lambda: summarize(data, segs, 0), args.repeat)
    rows.append(("summary", r))
    _, r = timed(lambda: write_signals_csv(data, tmp / "fast.csv"), args.repeat)
    rows.append(("signals.csv", r))
    print(f"log {args.log}: {data.stats.frames} frames, {len(data)} ticks")
    print(f"{'step':14s} {'wall s':>8s} {'cpu s':>8s}")
    for name, (w, c) in rows:
        print(f"{name:14s} {w:8.3f} {c:8.3f}")
    tw, tc = sum(r[1][0] for r in rows), sum(r[1][1] for r in rows)
    print(f"{'total':14s} {tw:8.3f} {tc:8.3f}")
    print(f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    if args.reference:
        ref, (w1, c1) = timed(lambda: read_log_reference(args.log, platform=plat), 1)
        print(f"reference read_log {w1:8.3f} {c1:8.3f}")
        if args.truth:
            t2, (w2, c2) = timed(lambda: read_truth_rows(args.truth), 1)
            print(f"reference truth    {w2:8.3f} {c2:8.3f}")
            attach_truth(ref, t2)
        _, (w3, c3) = timed(lambda: write_signals_csv_reference(ref, tmp / "ref.csv"), 1)
        print(f"reference csv      {w3:8.3f} {c3:8.3f}")
        same = all(np.array_equal(getattr(data, k), getattr(ref, k), equal_nan=True)
                   for k in ("ticks", "reference", "estimate", "length", "pressure_a", "est_wrench"))
        same &= data.stats.as_dict() == ref.stats.as_dict()
        same &= (tmp / "fast.csv").read_bytes() == (tmp / "ref.csv").read_bytes()
        print("same result as the reference:", "yes" if same else "NO")
        if not same:
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
