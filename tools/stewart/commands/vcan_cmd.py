# SPDX-License-Identifier: Apache-2.0
"""``stewart vcan``: run a command with virtual CAN buses up.

    stewart vcan [--fd] [--count N] [--timeout S] [--mem 512M] [--host|--uml] -- COMMAND...

On the host when its kernel has vcan, else inside a user-mode Linux (see
:mod:`stewart.vcan`). Exits with COMMAND's status; 124 on the time limit,
125 when the buses cannot be set up.
"""

from __future__ import annotations

import argparse
import sys


def run(args: argparse.Namespace) -> int:
    from .. import vcan  # kept local: one broken module must not break the CLI

    command = list(args.command)
    if command and command[0] == "--":
        command = command[1:]
    if not command:
        print("stewart vcan: no command given (stewart vcan [options] -- COMMAND...)",
              file=sys.stderr)
        return 2
    try:
        return vcan.run(command, count=args.count, fd=args.fd, timeout=args.timeout,
                        backend=args.backend, mem=args.mem, verbose=args.verbose)
    except vcan.VcanError as e:
        print(f"stewart vcan: {e}", file=sys.stderr)
        return vcan.EXIT_SETUP


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "vcan", help="run a command with virtual CAN buses vcan0.. up (host or user-mode Linux)",
        description="Run COMMAND with vcan0..vcan<N-1> up: on the host when its kernel can, "
                    "else inside a user-mode Linux (Debian package user-mode-linux). The "
                    "working directory and environment are kept; stdin is /dev/null. Exit "
                    "status: COMMAND's; 124 when the time limit is reached; 125 when the "
                    "buses cannot be set up.")
    p.add_argument("--fd", action="store_true", help="CAN FD buses (MTU 72); default classic (16)")
    p.add_argument("--count", type=int, default=3, metavar="N",
                   help="number of buses vcan0..vcan<N-1> (default 3)")
    p.add_argument("--timeout", type=float, default=600.0, metavar="SECONDS",
                   help="time limit for everything, boot included (default 600)")
    p.add_argument("--mem", default="512M", help="memory of the user-mode Linux (default 512M)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--host", dest="backend", action="store_const", const="host",
                   help="use the host kernel's vcan (fail if it cannot)")
    g.add_argument("--uml", dest="backend", action="store_const", const="uml",
                   help="always use a user-mode Linux")
    p.set_defaults(backend="auto")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="report the back end, boot time and UML log on stderr")
    p.add_argument("command", nargs=argparse.REMAINDER, metavar="-- COMMAND...",
                   help="the command and its arguments")
    p.set_defaults(func=run)
