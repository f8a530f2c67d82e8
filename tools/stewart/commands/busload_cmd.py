# SPDX-License-Identifier: Apache-2.0
"""``stewart busload``: worst-case load of each CAN bus per millisecond, from the DBC.

Bits of one frame: stewart/canframe.py (classic CAN and CAN FD with bit-rate
switch, worst-case stuffing).

A frame whose period is ``p`` ms costs ``t / p`` us per ms; the load of a bus
is the sum over its messages (a message on several buses counts on each).

Drives on CANopen (the platform config's ``drives`` section, ``--config``):
their buses carry SYNC, PDOs and heartbeats instead of the DBC's axis
frames, classic CAN at the configured bit rate (stewart/drives/layout.py);
a CANopen bus above the limit is reported with the ways out (more buses, a
SYNC divider with the drives' interpolation, no pressure TPDO).

``--builtin cia408|cia402`` computes instead the firmware's built-in
CANopen layout, which ``sp_controller --canopen`` runs when the config has
no drives section (nodes 1-3 on axis_a, 4-6 on axis_b, classic CAN at
1 Mbit/s), with the command line's ``--sync-divider`` and
``--force-ff``: the check to make before that layout goes on a real bus.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

from .. import resources

from ..canframe import (  # noqa: F401 (re-exported: the report's formulas)
    FD_LENGTHS,
    classic_frame_bits,
    fd_frame_bits,
    fd_payload_length,
    frame_time_us,
)


@dataclass
class Row:
    bus: str
    frame_id: int
    name: str
    length: int
    is_fd: bool
    period_ms: float
    bits_nominal: int
    bits_data: int
    us_per_frame: float
    us_per_ms: float


def _bus_names(message) -> list[str]:
    dbc = getattr(message, "dbc", None)
    attr = dbc.attributes.get("Bus") if dbc is not None else None
    text = str(attr.value) if attr is not None else ""
    names = [b.strip() for b in text.split(",") if b.strip()]
    return names or ["(no bus)"]


def load_table(db, nominal: float, data: float) -> dict[str, list[Row]]:
    """Rows per bus (in DBC order of first appearance)."""
    out: dict[str, list[Row]] = {}
    for m in db.messages:
        period = float(m.cycle_time) if m.cycle_time else 1.0
        if m.is_fd:
            bn, bd = fd_frame_bits(m.length)
        else:
            bn, bd = classic_frame_bits(m.length), 0
        t = frame_time_us(m.length, m.is_fd, nominal, data)
        for bus in _bus_names(m):
            out.setdefault(bus, []).append(
                Row(bus, m.frame_id, m.name, m.length, m.is_fd, period, bn, bd, t, t / period))
    return out


def bus_load_percent(rows: list[Row]) -> float:
    """Worst-case share of each millisecond the rows occupy, in %."""
    return sum(r.us_per_ms for r in rows) / 1000.0 * 100.0


def single_bus_rows(table: dict[str, list[Row]]) -> tuple[list[Row], list[Row]]:
    """The rows of all buses as if on one bus, SYNC sent once: (everything,
    the axis buses' traffic only)."""
    everything: list[Row] = []
    drives: list[Row] = []
    seen_sync = False
    for bus, rows in table.items():
        for r in rows:
            if r.name == "SYNC":
                if seen_sync:
                    continue
                seen_sync = True
            everything.append(r)
            if bus.startswith("axis"):
                drives.append(r)
    return everything, drives


def format_report(table: dict[str, list[Row]], nominal: float, data: float,
                  limit: float) -> tuple[str, bool]:
    """Markdown-style report and whether every bus is within ``limit`` %."""
    lines = [f"Worst-case CAN load per 1 ms: nominal {nominal / 1e6:g} Mbit/s, "
             f"data {data / 1e6:g} Mbit/s (CAN FD frames with bit-rate switch), "
             f"limit {limit:g} %", ""]
    ok = True
    for bus, rows in table.items():
        lines.append(f"bus {bus}")
        lines.append("| ID | message | bytes | period ms | bits nominal | bits data "
                     "| us/frame | us per ms |")
        lines.append("|---|---|---|---|---|---|---|---|")
        for r in rows:
            lines.append(f"| 0x{r.frame_id:03X} | {r.name} | {r.length}{'' if r.is_fd else ' (classic)'} "
                         f"| {r.period_ms:g} | {r.bits_nominal} | {r.bits_data} "
                         f"| {r.us_per_frame:.1f} | {r.us_per_ms:.1f} |")
        pct = bus_load_percent(rows)
        verdict = "ok" if pct <= limit else "OVER LIMIT"
        ok = ok and pct <= limit
        lines.append(f"| | **total** | | | | | | **{sum(r.us_per_ms for r in rows):.1f} us "
                     f"= {pct:.1f} %** ({verdict}) |")
        lines.append("")
    single, drives = single_bus_rows(table)
    lines.append("Why several buses: the same traffic on a single bus would cost "
                 f"{bus_load_percent(single):.1f} % (everything, one SYNC) or "
                 f"{bus_load_percent(drives):.1f} % (one SYNC, the setpoints and the "
                 "feedback of all six drives), because every frame pays "
                 f"{fd_frame_bits(0)[0]} bits at the nominal rate.")
    return "\n".join(lines), ok


def run(args: argparse.Namespace) -> int:
    import cantools

    from ..protocol import DBC_PATH

    path = Path(args.dbc) if args.dbc else DBC_PATH
    try:
        db = cantools.database.load_file(str(path), strict=True)
    except Exception as exc:  # noqa: BLE001 - any load failure is a usage error
        print(f"stewart busload: cannot load {path}: {exc}", file=sys.stderr)
        return 2
    from .. import config
    from ..drives import layout

    try:
        platform = config.load(args.config, check_bus_load=False)
    except config.ConfigError as exc:
        print(f"stewart busload: {exc}", file=sys.stderr)
        return 2
    drives = platform.drives
    source = args.config
    if args.builtin:
        import dataclasses

        from .. import model

        park = model.inverse_kinematics(platform, platform.park).lengths
        builtin = layout.builtin_canopen([float(x) for x in park], args.builtin)
        legs = tuple(dataclasses.replace(d, force_feedforward=args.force_ff) for d in builtin.legs)
        drives = dataclasses.replace(builtin, legs=legs, sync_divider=args.sync_divider)
        source = (f"the built-in layout, {args.builtin}, sp_controller --canopen-sync-divider "
                  f"{args.sync_divider}{' --canopen-force-ff' if args.force_ff else ''}")
    elif args.sync_divider != 1 or args.force_ff:
        print("stewart busload: --sync-divider and --force-ff go with --builtin (a config layout "
              "says them in its drives section)", file=sys.stderr)
        return 2
    table = load_table(db, args.nominal, args.data)
    for bus in drives.buses():
        table.pop(bus, None)   # its drives speak CANopen: the DBC's axis frames are not there
    text, ok = format_report(table, args.nominal, args.data, args.limit)
    print(text)
    if drives.canopen:
        ctext, cok = layout.format_report(drives, args.limit)
        print()
        print(f"Drives on CANopen ({source}), limit {args.limit:g} %:")
        print(ctext)
        ok = ok and cok
    if not ok:
        print(f"stewart busload: a bus is above {args.limit:g} %", file=sys.stderr)
    return 0 if ok else 1


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("busload", help="worst-case CAN bus load per 1 ms from the DBC",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--dbc", help="DBC file (default: protocol/stewart.dbc)")
    p.add_argument("--nominal", type=float, default=1e6, help="arbitration bit rate, bit/s")
    p.add_argument("--data", type=float, default=5e6, help="CAN FD data-phase bit rate, bit/s")
    p.add_argument("--limit", type=float, default=50.0, help="highest acceptable load, %%")
    p.add_argument("--config", default=str(resources.default_platform()),
                   help="platform config: its drives section puts drives on CANopen buses")
    p.add_argument("--builtin", choices=("cia408", "cia402"),
                   help="the firmware's built-in CANopen layout (sp_controller --canopen without a drives "
                        "section) instead of the config's drives")
    p.add_argument("--sync-divider", type=int, default=1, choices=range(1, 11), metavar="N",
                   help="with --builtin: SYNC and PDOs every N ms (sp_controller --canopen-sync-divider, "
                        "default 1)")
    p.add_argument("--force-ff", action="store_true",
                   help="with --builtin: the force feed-forward in each RPDO (sp_controller --canopen-force-ff)")
    p.set_defaults(func=run)
