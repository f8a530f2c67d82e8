# SPDX-License-Identifier: Apache-2.0
"""``stewart faults``: the fault-injection campaign (docs/explanation/faults.md).

    stewart faults [--subset] [--fault NAME ...] [--state STATE ...] [--jobs N]
                   [--out DIR] [--build DIR] [--json FILE] [--check] [--list]

Runs every injectable fault (``stewart.faults.FAULTS``) in each state
(ENGAGING, RUNNING/trig, RUNNING/p2p, RUNNING/stream, PARKING) as a
lockstep closed loop of the firmware's controller and the simulated
hexapod in one process (``hs_sim --inproc``), the runs in parallel over the
cores, and prints one table. ``--subset``: the test command's
representative rows. ``--check``: exit 1 unless every row was detected
within its bound (tolerated faults need none) and ended at rest, inside
the strokes, with no frame unaccounted. ``--out`` keeps each run's
scenario, output and CAN log.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from .. import progress


def _run(args: argparse.Namespace) -> int:
    from .. import faults as F  # here, not at import: every command's start-up builds this parser

    if args.list:
        for f in F.FAULTS:
            bound = f"{f.bound} ticks" if f.bound is not None else "tolerated"
            print(f"{f.name:20s} {bound:10s} {f.what}: {f.inject}")
        print("states: " + ", ".join(F.STATES))
        return 0
    try:
        pairs = F.select(args.fault, args.state, args.subset)
    except (KeyError, ValueError) as e:
        print(f"stewart faults: {e}", file=sys.stderr)
        return 2
    bar = progress.Progress("stewart faults", "runs", len(pairs), quiet=args.quiet, every=0.0)
    t0 = time.monotonic()
    try:
        rows = F.campaign(pairs, jobs=args.jobs, build=args.build, workdir=args.out, log=args.out is not None,
                          done=lambda r: bar.advance(note=f"{r.fault} in {r.state}"))
    except FileNotFoundError as e:
        print(f"stewart faults: {e}", file=sys.stderr)
        return 1
    wall = time.monotonic() - t0
    print(F.table(rows))
    bad = [r for r in rows if not (r.within_bound and r.safe)]
    print(f"\n{len(rows)} runs in {wall:.1f} s ({args.jobs or 'all'} workers); "
          f"{sum(r.detected for r in rows)} detected, {len(bad)} not within bound or not safe at the end, "
          f"{sum(r.unaccounted != 0 for r in rows)} with frames unaccounted")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([{k: (str(v) if k == "log" else v) for k, v in vars(r).items()} for r in rows], fh, indent=1)
    if args.check and bad:
        for r in bad:
            print(f"stewart faults: {r.fault} in {r.state}: detected {r.detected} after {r.ticks} "
                  f"(bound {r.bound}), rest {r.rest}, strokes {r.strokes}, unaccounted {r.unaccounted} {r.error}",
                  file=sys.stderr)
        return 1
    return 0


def register(sub) -> None:
    p = sub.add_parser("faults", help="run the fault-injection campaign and print its table",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--subset", action="store_true", help="only the test command's representative rows")
    p.add_argument("--fault", action="append", metavar="NAME", help="only these faults (repeatable)")
    p.add_argument("--state", action="append", metavar="STATE", help="only these states (repeatable)")
    p.add_argument("--jobs", type=int, default=None, help="parallel runs (default: the machine's cores)")
    p.add_argument("--out", default=None, help="keep each run's files here")
    p.add_argument("--build", default=None, help="build directory (default build/host-release)")
    p.add_argument("--json", default=None, help="write the rows as JSON")
    p.add_argument("--check", action="store_true", help="exit 1 unless every row meets its bound and ends safe")
    p.add_argument("--list", action="store_true", help="list the faults and states")
    progress.add_quiet(p)
    p.set_defaults(func=_run)
