# SPDX-License-Identifier: Apache-2.0
"""``stewart info``: where things are and what is built."""

from __future__ import annotations

import argparse

from .. import REPO_ROOT


def run(args: argparse.Namespace) -> int:
    del args
    print(f"repository: {REPO_ROOT}")
    for preset in ("host-debug", "host-release", "m4-core"):
        build = REPO_ROOT / "build" / preset
        state = "configured" if (build / "CMakeCache.txt").exists() else "not built"
        print(f"build/{preset}: {state}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="show the repository and build locations")
    p.set_defaults(func=run)
