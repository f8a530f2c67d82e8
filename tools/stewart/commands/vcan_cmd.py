# SPDX-License-Identifier: Apache-2.0
"""``stewart vcan``: run a command with virtual CAN buses up.

    stewart vcan [--fd] [--count N] [--timeout S] [--mem 512M] [--host|--uml]
                 [--uml-kernel auto|system|cache] -- COMMAND...
    stewart vcan --check        the back end in use, its kernel, where from, why
    stewart vcan --setup        make one work here (fetch a newer UML if needed)
    stewart vcan --install-uml  fetch Debian's newer UML into the cache

On the host when its kernel has vcan, else inside a user-mode Linux (see
:mod:`stewart.vcan` and :mod:`stewart.uml`). Exits with COMMAND's status;
124 on the time limit, 125 when the buses cannot be set up.
"""

from __future__ import annotations

import argparse
import sys


def _action(args: argparse.Namespace) -> int:
    from .. import uml, vcan

    if args.install_uml:
        k = uml.install_cache()
        print(f"stewart vcan: installed {k.origin}")
        return 0
    if args.setup:
        print(f"vcan: {vcan.ensure(args.count, args.uml_kernel)}")
        return 0
    c = vcan.choose(args.count, args.backend, args.uml_kernel, refresh=args.refresh)
    for line in c.describe():
        print(line)
    return 0


def run(args: argparse.Namespace) -> int:
    from .. import uml, vcan  # kept local: one broken module must not break the CLI

    command = list(args.command)
    if command and command[0] == "--":
        command = command[1:]
    try:
        if args.check or args.setup or args.install_uml:
            if command:
                print("stewart vcan: --check, --setup and --install-uml take no command",
                      file=sys.stderr)
                return 2
            return _action(args)
        if not command:
            print("stewart vcan: no command given (stewart vcan [options] -- COMMAND...)",
                  file=sys.stderr)
            return 2
        return vcan.run(command, count=args.count, fd=args.fd, timeout=args.timeout,
                        backend=args.backend, mem=args.mem, verbose=args.verbose,
                        uml_kernel=args.uml_kernel)
    except (vcan.VcanError, uml.UmlError) as e:
        print(f"stewart vcan: {e}", file=sys.stderr)
        return vcan.EXIT_SETUP


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "vcan", help="run a command with virtual CAN buses vcan0.. up (host or user-mode Linux)",
        description="Run COMMAND with vcan0..vcan<N-1> up: on the host when its kernel can, "
                    "else inside a user-mode Linux (UML). The working directory and "
                    "environment are kept; stdin is /dev/null. Exit status: COMMAND's; 124 "
                    "when the time limit is reached; 125 when the buses cannot be set up. "
                    "Which UML kernel boots here is probed once per host and cached "
                    "(~/.cache/stewart/uml-probe.json).")
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
    p.add_argument("--uml-kernel", choices=("auto", "system", "cache"), default=None,
                   help="which UML kernel: the installed one (system), the newer one fetched "
                        "into .cache/uml (cache), or the first that boots (auto, default; "
                        "also set by $STEWART_UML)")
    a = p.add_mutually_exclusive_group()
    a.add_argument("--check", action="store_true",
                   help="print the back end in use, its kernel version, where it comes from "
                        "and why; exit 125 when none works")
    a.add_argument("--setup", action="store_true",
                   help="make a back end work here: fetch a newer UML kernel into the cache "
                        "when the installed one does not boot (scripts/setup.sh runs this)")
    a.add_argument("--install-uml", action="store_true",
                   help="fetch Debian's newer user-mode-linux (and the glibc it needs) into "
                        "the cache, whatever the probe says")
    p.add_argument("--refresh", action="store_true",
                   help="with --check: probe again instead of using the cached verdict")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="report the back end, boot time and UML log on stderr")
    p.add_argument("command", nargs=argparse.REMAINDER, metavar="-- COMMAND...",
                   help="the command and its arguments")
    p.set_defaults(func=run)
