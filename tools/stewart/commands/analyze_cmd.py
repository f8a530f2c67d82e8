# SPDX-License-Identifier: Apache-2.0
"""``stewart analyze LOG --out DIR``: a closed-loop run's CAN log (candump -L
format, three buses) to a per-tick CSV, segments, tracking errors, plots and
a summary (docs/reference/analysis.md).

Writes DIR/signals.csv (one row per tick, SI units), DIR/summary.json, and per
RUNNING segment DIR/segN_tracking.png (reference vs estimate on the moving
axis, tracking error) and DIR/segN_cylinders.png (stretch and force of the six
cylinders: feed-forward vs measured). With --compare LOG2 the second run goes
to DIR/run2/ and the tracking errors of matching segments are overlaid in
DIR/compareN.png.

Exit status: 0 analysed; 1 the log has bad frames or malformed lines (the
outputs are still written; controller faults are reported, not an error);
2 usage error or an unreadable input.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .. import progress, resources


def _run_label(summary, fallback: str) -> str:
    ffs = {s["feedforward"] for s in summary["segments"]}
    if len(ffs) == 1 and next(iter(ffs)) in ("on", "off"):
        return f"ff={next(iter(ffs))}"
    return fallback


class _Progress:
    """Prints each step with the time so far on stderr, from the first step
    that starts after ``quiet_s`` (a short run prints nothing; --quiet nothing)."""

    def __init__(self, quiet: bool, quiet_s: float = 1.0):
        self.t0 = time.monotonic()
        self.quiet_s = float("inf") if quiet else quiet_s

    def __call__(self, text: str) -> None:
        dt = time.monotonic() - self.t0
        if dt >= self.quiet_s:
            print(f"stewart analyze: {dt:5.1f} s: {text}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    frames = None
    if Path(args.log).is_file():
        from ..analysis.prefetch import read_frames_beside

        frames = read_frames_beside(args.log)  # while the protocol loads
    from .. import config as cfg
    from ..analysis import analyze
    from ..analysis.logfile import parse_bus_map
    from ..analysis.metrics import format_summary, format_value, segment_metrics
    from ..analysis.plots import plot_compare
    from ..analysis.segments import match_segments

    try:
        parse_bus_map(args.bus)
    except ValueError as exc:
        print(f"stewart analyze: {exc}", file=sys.stderr)
        return 2
    for path in [args.log] + ([args.truth] if args.truth else []) + ([args.compare] if args.compare else []):
        if not Path(path).is_file():
            print(f"stewart analyze: no such file: {path}", file=sys.stderr)
            return 2
    try:
        res = analyze(args.log, args.out, truth=args.truth, platform=args.platform,
                      delay_ticks=args.delay_ticks, buses=args.bus, plots=not args.no_plots,
                      progress=_Progress(args.quiet), frames=frames, tool=args.tool, work=args.work)
    except (cfg.ConfigError, ValueError, OSError) as exc:
        print(f"stewart analyze: {exc}", file=sys.stderr)
        return 2
    results = [res]
    print(format_summary(res.summary))
    if args.compare:
        try:
            res2 = analyze(args.compare, Path(args.out) / "run2", platform=args.platform,
                           delay_ticks=args.delay_ticks, buses=args.bus, plots=not args.no_plots,
                           progress=_Progress(args.quiet))
        except (cfg.ConfigError, ValueError, OSError) as exc:
            print(f"stewart analyze: {args.compare}: {exc}", file=sys.stderr)
            return 2
        results.append(res2)
        print()
        print(format_summary(res2.summary))
        n1 = _run_label(res.summary, "run 1")
        n2 = _run_label(res2.summary, "run 2")
        if n1 == n2:
            n1, n2 = f"{n1} (run 1)", f"{n2} (run 2)"
        pairs = match_segments(res.segments, res2.segments)
        print()
        for k, (s1, s2) in enumerate(pairs, start=1):
            path = Path(args.out) / f"compare{k}.png"
            if not args.no_plots:
                print(f"stewart analyze: plotting comparison {k}", file=sys.stderr, flush=True)
                plot_compare([(n1, res.data, s1), (n2, res2.data, s2)], path, args.delay_ticks)
            m1 = segment_metrics(res.data, s1, args.delay_ticks)["moving_axis_error"]
            m2 = segment_metrics(res2.data, s2, args.delay_ticks)["moving_axis_error"]
            line = f"compare {k}: {s1.label} vs {s2.label}"
            if m1 and m2:
                line += (f": RMS {format_value(m1['rms'])} vs {format_value(m2['rms'])} {m1['unit']}, "
                         f"max {format_value(m1['max'])} vs {format_value(m2['max'])} {m1['unit']}")
            if not args.no_plots:
                line += f" -> {path}"
            print(line)
    print()
    print(f"wrote {', '.join(str(f) for f in res.files)}")
    bad = any(r.summary["bad_frames"] or r.summary["malformed_lines"] for r in results)
    return 1 if bad else 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("analyze", help="CAN log of a closed-loop run -> CSV, tracking errors, plots, summary",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("log", help="CAN log in candump -L format (vcan0 ops, vcan1 axis_a, vcan2 axis_b)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--truth", help="the plant's truth CSV (tick, pose, leg lengths, forces)")
    p.add_argument("--platform", default=str(resources.default_platform()),
                   help="platform config JSON (default: config/platform_default.json)")
    p.add_argument("--delay-ticks", type=int, default=0,
                   help="tracking error = estimate(t) - reference(t - d); default d = 0 "
                   "(docs/reference/analysis.md says why)")
    p.add_argument("--bus", help="interfaces of the buses, e.g. ops=can0,axis_a=can1,axis_b=can2 "
                   "(default ops=vcan0,axis_a=vcan1,axis_b=vcan2)")
    p.add_argument("--compare", metavar="LOG2", help="a second run (e.g. feed-forward off) to overlay")
    p.add_argument("--no-plots", action="store_true", help="CSV and summary only")
    p.add_argument("--tool", type=float, nargs=6, metavar=("X", "Y", "Z", "ROLL", "PITCH", "YAW"),
                   help="the run's tool frame in o' (m, rad): signals.csv gets the tool's pose in the work frame "
                        "(tool_ref_*, tool_est_*, tool_truth_*), the summary the tracking at the tool point")
    p.add_argument("--work", type=float, nargs=6, metavar=("X", "Y", "Z", "ROLL", "PITCH", "YAW"),
                   help="the run's work frame in the base frame (m, rad; default identity)")
    progress.add_quiet(p)
    p.set_defaults(func=run)
