# SPDX-License-Identifier: Apache-2.0
"""``stewart soak``: the randomised soak (docs/explanation/testing.md, "The soak").

    stewart soak [--hours H | --minutes M] [--seed S] [--max-wall SECONDS]
                 [--strict] [--wide] [--build DIR] [--json FILE] [--quiet]

Runs ``hs_soak`` (host_sim/app/hs_soak.c, from build/host-release): the
firmware's controller and the simulated hexapod in one process, in
lockstep, faster than real time, on random operation (motions, force
control, guiding, loads, wrenches, invalid, forged and replayed commands,
dropped and corrupted frames, injected faults, ESTOP), every invariant
checked on every tick. ``--max-wall`` stops it earlier once that much wall
time has passed (it still passes; the figures say how far it got). Prints
hs_soak's summary and the figures; exit status hs_soak's: 0 no violation,
1 a violation (its seed, tick and replay command are printed), 2 usage, 3
a defect of the generator, 5 the plant's step failed.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

_FIGURES = (
    ("simulated_s", r"hs_soak summary: seed \d+, simulated ([\d.]+) s"),
    ("wall_s", r"hs_soak summary: .*, wall ([\d.]+) s"),
    ("speedup", r"hs_soak summary: .*, ([\d.]+)x real time"),
    ("exit", r"hs_soak summary: .*, exit (-?\d+)"),
    ("checks", r"hs_soak checks: .* = (\d+) checks"),
    ("violations", r"hs_soak checks: .*, violations (\d+)"),
    ("episodes", r"hs_soak operator: episodes (\d+)"),
    ("commands", r"hs_soak operator: .*commands (\d+)"),
    ("refused", r"hs_soak operator: .*refused (\d+)"),
    ("injections", r"hs_soak operator: .*injections (\d+)"),
    ("frames", r"hs_soak frames: in (\d+)"),
    ("known", r"hs_soak known .*: (\d+) REFERENCE"),
)


def parse_summary(text: str) -> dict[str, float]:
    """The figures of hs_soak's summary lines (those it printed; the others are absent)."""
    out: dict[str, float] = {}
    for name, pattern in _FIGURES:
        m = re.search(pattern, text)
        if m:
            out[name] = float(m.group(1))
    return out


def soak_binary(build: str | None) -> Path:
    from .. import resources

    b = Path(build) if build else resources.host_build()
    p = b / "host_sim" / "hs_soak"
    if not p.exists():
        raise FileNotFoundError(f"not built: {p} (run scripts/build.sh host-release)")
    return p


def _argv(args: argparse.Namespace) -> list[str]:
    argv = [str(soak_binary(args.build)), "--seed", str(args.seed)]
    if args.minutes is not None:
        argv += ["--seconds", f"{args.minutes * 60.0:g}"]
    else:
        argv += ["--hours", f"{args.hours:g}"]
    if args.max_wall is not None:
        argv += ["--max-wall", f"{args.max_wall:g}"]
    argv += [f for f, on in (("--strict", args.strict), ("--wide", args.wide), ("--quiet", args.quiet)) if on]
    if args.break_at:
        argv += ["--break", args.break_at]
    return argv


def _run(args: argparse.Namespace) -> int:
    try:
        argv = _argv(args)
    except FileNotFoundError as e:
        print(f"stewart soak: {e}", file=sys.stderr)
        return 1
    if not args.quiet:
        print("stewart soak: " + " ".join(argv), file=sys.stderr)
    p = subprocess.run(argv, stdout=subprocess.PIPE, text=True)  # stderr (progress, a violation) passes through
    sys.stdout.write(p.stdout)
    fig = parse_summary(p.stdout)
    if "simulated_s" in fig:
        print(f"stewart soak: {fig['simulated_s'] / 3600.0:.3f} h simulated in {fig.get('wall_s', 0):.0f} s wall "
              f"({fig.get('speedup', 0):.1f}x real time), {fig.get('checks', 0):.0f} invariant checks, "
              f"{fig.get('violations', 0):.0f} violations, exit {p.returncode}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(dict(fig, argv=argv, returncode=p.returncode), fh, indent=1)
    return p.returncode


def register(sub) -> None:
    p = sub.add_parser("soak", help="run the randomised in-process soak with its invariants",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--hours", type=float, default=1.0, help="simulated hours (default 1)")
    g.add_argument("--minutes", type=float, default=None, help="simulated minutes instead")
    p.add_argument("--seed", type=int, default=1, help="the random operator's seed (default 1)")
    p.add_argument("--max-wall", type=float, default=None, metavar="SECONDS",
                   help="stop once this much wall time has passed (the run still passes)")
    p.add_argument("--strict", action="store_true",
                   help="a REFERENCE fault while RUNNING an accepted motion is a violation (the test command's)")
    p.add_argument("--wide", action="store_true", help="RUN_TRIG frequencies up to 3 Hz")
    p.add_argument("--break", dest="break_at", default=None, metavar="INVARIANT@TICK",
                   help="make that tick violate INVARIANT (the checker's own test)")
    p.add_argument("--build", default=None, help="build directory (default build/host-release)")
    p.add_argument("--json", default=None, help="write the figures as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_run)
