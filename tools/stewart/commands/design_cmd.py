# SPDX-License-Identifier: Apache-2.0
"""``stewart design``: size the cylinders, valves and supply of a platform
for a duty, and see its workspace, before anything is built.

Writes OUT/report.html (self-contained) and OUT/report.json (every
figure's numbers) and prints the verdict: per requirement, pass or fail,
its margin and what limits it. With --sweep SPEC, ranks geometry
candidates by the duty's margins instead (OUT/sweep.csv), on every local
core or on the Dask cluster at --scheduler.

Exit status: 0 every requirement met, 1 some not met, 2 bad input (the
message names the key, row or file; nothing is written).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

from .. import config as cfg
from ..design import analysis, report, sweep
from ..design import duty as duty_mod
from ..design.limits import MissingKey


def _load(args) -> tuple:
    platform = cfg.load(args.config)
    duty = duty_mod.load(args.duty)
    analysis.check_config(platform)
    return platform, duty


def _report(platform, duty, out: Path) -> int:
    t0 = time.perf_counter()
    r = analysis.run(platform, duty)
    html_path, json_path = report.write(r, out)
    print(report.verdict_text(r))
    print(f"stewart design: {html_path}, {json_path} in {time.perf_counter() - t0:.1f} s")
    return 0 if all(v["pass"] for v in r["verdict"]) else 1


def write_sweep(rows: list, path: Path) -> None:
    cols = sweep.PARAMS + ["score", "failed", "lowest_hz", "push", "pull", "limit"]
    tmp = path.with_suffix(".csv.part")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    tmp.replace(path)


def _sweep(platform, duty, args, out: Path) -> int:
    cands = sweep.read_spec(args.sweep, platform)
    t0 = time.perf_counter()
    if args.scheduler:
        rows = sweep.run_dask(platform, duty, cands, args.points, args.scheduler)
    else:
        rows = sweep.run_local(platform, duty, cands, args.points, args.workers)
    dt = time.perf_counter() - t0
    ranked = sweep.rank(rows)
    out.mkdir(parents=True, exist_ok=True)
    write_sweep(ranked, out / "sweep.csv")
    where = f"Dask at {args.scheduler}" if args.scheduler else "local processes"
    print(f"stewart design: {len(rows)} candidates in {dt:.1f} s ({len(rows) / dt:.1f} per s, {where})")
    for r in ranked[:args.top]:
        geo = ", ".join(f"{k} {r[k]:.4g}" for k in sweep.PARAMS)
        print(f"  score {r['score']:+.3f}  failed {r['failed']}  {geo}  ({r['limit']})")
    print(f"stewart design: ranking -> {out / 'sweep.csv'}")
    return 0 if ranked and ranked[0]["failed"] == 0 else 1


def run(args: argparse.Namespace) -> int:
    try:
        platform, duty = _load(args)
        if args.sweep:
            return _sweep(platform, duty, args, Path(args.out))
        return _report(platform, duty, Path(args.out))
    except (cfg.ConfigError, duty_mod.DutyError, MissingKey, OSError, RuntimeError) as e:
        print(f"stewart design: {e}", file=sys.stderr)
        return 2


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("design", help="workspace, cylinder forces, hydraulics and stiffness for a duty",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("config", help="platform config JSON")
    p.add_argument("--duty", required=True, help="duty JSON (docs/guides/designing.md)")
    p.add_argument("--out", default="out/design", help="output directory (default: out/design)")
    p.add_argument("--sweep", metavar="SPEC", help="sweep JSON: geometry parameters to rank")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run the sweep on this Dask scheduler")
    p.add_argument("--workers", type=int, default=None, help="local sweep processes (default: every core)")
    p.add_argument("--points", type=int, default=2,
                   help="sweep: envelope grid points per axis for each candidate (default 2: the corners)")
    p.add_argument("--top", type=int, default=10, help="sweep: candidates to print (default 10)")
    p.set_defaults(func=run)
