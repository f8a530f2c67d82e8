# SPDX-License-Identifier: Apache-2.0
"""``stewart info``: where things are and what is built."""

from __future__ import annotations

import argparse

from .. import __version__, resources


def run(args: argparse.Namespace) -> int:
    del args
    print(f"stewart {__version__}")
    root = resources.checkout()
    print(f"repository: {root if root else 'none (an installed package)'}")
    print(f"protocol: {resources.dbc_path()}")
    print(f"core library: {resources.core_library()}")
    if root:
        for preset in ("host-debug", "host-release", "m4-core"):
            build = root / "build" / preset
            state = "configured" if (build / "CMakeCache.txt").exists() else "not built"
            print(f"build/{preset}: {state}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="show the version, the repository and where the tools find their files")
    p.set_defaults(func=run)
