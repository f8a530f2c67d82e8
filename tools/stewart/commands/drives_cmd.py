# SPDX-License-Identifier: Apache-2.0
"""``stewart drives``: commission CANopen drives (CiA 408 valves and axis
controllers, CiA 402 electric drives) from the PC, over any python-can adapter.

  stewart drives scan   [-i INTERFACE -c CHANNEL -b BITRATE]
      the nodes on the bus: device type (0x1000) and identity (0x1018)
  stewart drives check  --eds FILE [--profile cia408|cia402] [--no-pressure]
      does the drive's EDS offer every object and PDO mapping the controller
      needs? Lists what is missing; exit status 1 when something is
  stewart drives config [--config FILE] [--bus NAME] [--node N] [--dry-run]
      the configuration the controller writes at start-up (PDO mapping and
      communication parameters, RPDO event timer, device mode, scaling, from
      the platform config), written by SDO and read back; --dry-run prints it
  stewart drives doc [--write]
      the object and PDO tables of docs/reference/canopen.md (--write updates the page)

What the controller needs lives in one place, stewart/drives/objects.py;
docs/reference/canopen.md has the design. Exit status: 0 ok, 1 the drive or its EDS
falls short (SDO abort, read-back differs, objects missing, no node), 2 a
usage problem (bad config, EDS unreadable, CAN adapter cannot be opened).
"""

from __future__ import annotations

import argparse
import sys

from .. import busopts, resources


def _err(msg: str) -> None:
    print(f"stewart drives: {msg}", file=sys.stderr)


def run_scan(args) -> int:
    from ..drives import session

    try:
        net = session.open_network(busopts.options(args))
    except session.DriveError as exc:
        _err(str(exc))
        return 2
    where = getattr(net.bus, "channel_info", "the bus")
    try:
        nodes = session.scan(net, args.wait)
    finally:
        session.close_network(net)
    if not nodes:
        _err(f"no node answered on {where} within {args.wait:g} s")
        return 1
    print("| node | device type | vendor-ID | product | revision | serial |")
    print("|---|---|---|---|---|---|")

    def h(v):
        return "?" if v is None else f"0x{v:08X}"

    for n in nodes:
        print(f"| {n.node_id} | {n.profile_text} | {h(n.vendor_id)} | {h(n.product_code)} | {h(n.revision)} "
              f"| {h(n.serial)} |")
    for n in nodes:
        for p in n.problems:
            print(f"node {n.node_id}: {p}")
    return 0


def run_check(args) -> int:
    from ..drives import eds

    try:
        res = eds.check_file(args.eds, args.profile, not args.no_pressure)
    except eds.EdsError as exc:
        _err(str(exc))
        return 2
    print(eds.format_result(args.eds, res))
    return 0 if res.ok else 1


def _load_config(path):
    from .. import config

    try:
        return config.load(path)
    except config.ConfigError as exc:
        _err(str(exc))
        return None


def run_config(args) -> int:
    from ..drives import plan

    platform = _load_config(args.config)
    if platform is None:
        return 2
    drives = platform.drives
    targets = list(drives.canopen)
    if not targets:
        _err(f"{args.config}: every leg's drive is native (no CANopen drive to configure); "
             "add a drives section (config/README.md)")
        return 2
    buses = drives.buses()
    if args.bus is not None:
        if args.bus not in buses:
            _err(f"--bus {args.bus}: the config's CANopen buses are {', '.join(buses)}")
            return 2
        targets = [d for d in targets if d.bus == args.bus]
    elif len(buses) > 1 and not args.dry_run:
        _err(f"the config has CANopen drives on {', '.join(buses)}: name the adapter's bus with --bus")
        return 2
    if args.node is not None:
        targets = [d for d in targets if d.node_id == args.node]
        if not targets:
            _err(f"--node {args.node}: no CANopen drive with that node id"
                 f"{' on ' + args.bus if args.bus else ''} in {args.config}")
            return 2
    if args.dry_run:
        for d in targets:
            writes = plan.drive_writes(d, drives)
            print(f"leg {d.leg}: {d.protocol} node {d.node_id} on {d.bus}: {len(writes)} SDO writes")
            print("| # | object | value | what |")
            print("|---|---|---|---|")
            for i, w in enumerate(writes, 1):
                flags = (" (if present)" if w.optional else "") + ("" if w.final else " (step)")
                print(f"| {i} | {w.key} | {w.value_text()} | {w.purpose}{flags} |")
            print()
        return 0
    from ..drives import layout, session

    opts = busopts.options(args)
    opts.bus = layout.controller_bus(drives, targets[0]) or opts.bus
    try:
        net = session.open_network(opts)
    except session.DriveError as exc:
        _err(str(exc))
        return 2
    failed = 0
    try:
        for d in targets:
            writes = plan.drive_writes(d, drives)
            try:
                res = session.configure(net, d.node_id, writes)
            except session.DriveError as exc:
                _err(f"leg {d.leg}: {exc}")
                failed += 1
                continue
            skipped = f", skipped {len(res.skipped)} optional ({', '.join(w.key for w in res.skipped)})" \
                if res.skipped else ""
            fixed = f", {len(res.fixed)} read-only already right ({', '.join(w.key for w in res.fixed)})" \
                if res.fixed else ""
            print(f"leg {d.leg}: node {d.node_id} on {d.bus}: wrote {len(res.written)} objects, read back "
                  f"{len(res.readback)}: all equal{skipped}{fixed}")
            if d.protocol == "cia402" and d.force_feedforward and d.scaling is not None:
                try:
                    rated = session.read_rated(net, d.node_id)
                except session.DriveError as exc:
                    _err(f"leg {d.leg}: {exc}")
                    failed += 1
                    continue
                print(f"leg {d.leg}: node {d.node_id}: {session.rated_note(rated, d.scaling.rated_force)}")
    finally:
        session.close_network(net)
    return 1 if failed else 0


def run_doc(args) -> int:
    from ..drives import doc

    page = resources.source_path("docs", "reference", "canopen.md")
    if not args.write:
        print(doc.markdown(), end="")
        return 0
    try:
        page.write_text(doc.splice(page.read_text()))
    except (OSError, ValueError) as exc:
        _err(f"{page}: {exc}")
        return 2
    print(f"updated {page}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("drives", help="CANopen drives: scan a bus, check an EDS, write the configuration",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    s = p.add_subparsers(dest="drives_command", metavar="SUBCOMMAND")
    sc = s.add_parser("scan", help="the nodes on a bus, their identity and device type")
    busopts.add_arguments(sc, "axis_a", fd=False)
    sc.add_argument("--wait", type=float, default=0.5, help="seconds to wait for answers (default 0.5)")
    sc.set_defaults(func=run_scan)
    ck = s.add_parser("check", help="does an EDS offer what the controller needs?")
    ck.add_argument("--eds", required=True, help="the drive's EDS file")
    ck.add_argument("--profile", choices=("cia408", "cia402"), default="cia408",
                    help="the device profile the drive is to be used with (default cia408)")
    ck.add_argument("--no-pressure", action="store_true",
                    help="do not ask for the chamber pressures (position-only CiA 408 drive)")
    ck.set_defaults(func=run_check)
    cf = s.add_parser("config", help="write the controller's configuration to the drives and read it back")
    cf.add_argument("--config", default=str(resources.default_platform()),
                    help="platform config with a drives section")
    cf.add_argument("--bus", help="the config's bus the adapter is on (needed when there are several)")
    cf.add_argument("--node", type=int, help="only this node id")
    cf.add_argument("--dry-run", action="store_true", help="print the writes, touch no bus")
    busopts.add_arguments(cf, "axis_a", fd=False)
    cf.set_defaults(func=run_config)
    dc = s.add_parser("doc", help="the object and PDO tables of docs/reference/canopen.md")
    dc.add_argument("--write", action="store_true", help="update docs/reference/canopen.md in place")
    dc.set_defaults(func=run_doc)

    def no_sub(_args) -> int:
        p.print_help()
        return 2

    p.set_defaults(func=no_sub)
