# SPDX-License-Identifier: Apache-2.0
"""``stewart accuracy``: the fixed-point core's largest errors against the
float64 model on random poses and motions (a benchmark: prints figures)."""

from __future__ import annotations

import argparse

from .. import config as cfg
from .. import progress, resources


def run(args: argparse.Namespace) -> int:
    from ..accuracy import measure

    try:
        platform = cfg.load(args.config)
    except cfg.ConfigError as e:
        print(f"stewart accuracy: {e}")
        return 2
    bar = progress.Progress("stewart accuracy", "random motions", args.n, quiet=args.quiet)
    rep = measure(platform, args.n, args.seed, step=bar.advance)
    print("\n".join(rep.lines()))
    return 0 if rep.ok() else 1


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("accuracy", help="errors of the fixed-point core against the float64 model")
    p.add_argument("--config", default=str(resources.default_platform()))
    p.add_argument("-n", type=int, default=10000, help="number of random poses (default 10000)")
    p.add_argument("--seed", type=int, default=1)
    progress.add_quiet(p)
    p.set_defaults(func=run)
