# SPDX-License-Identifier: Apache-2.0
"""Which drive is where, and the worst-case load that puts on each CANopen bus.

A layout is the platform config's ``drives`` section after validation
(:class:`Drives`); ``stewart.config`` builds it, ``stewart busload`` and the
drive tools read it. Frames are classic CAN, 11-bit identifiers, worst-case
bit stuffing (``classic_frame_bits``, the one formula, in stewart/canframe.py).

Per SYNC period (``sync_divider`` control ticks) each CANopen bus carries one
SYNC (no data), and per drive its setpoint RPDO and its actual-value TPDO
(plus the pressure TPDO when force feedback is on); every ``heartbeat_ms``
each drive sends one heartbeat (1 byte), and the master its own every
``drives.master_heartbeat_ms`` of the config (default
``objects.MASTER_HEARTBEAT_MS``, the firmware's SP_CO_MASTER_HEARTBEAT_MS;
0: none). SDO traffic happens only before the drives are started, EMCY
only on a fault: neither is in the cyclic budget. Standard library only.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from ..canframe import classic_frame_bits
from . import objects as ob

LEGS = 6
#: The native protocol's fixed buses (the DBC): legs 1-3 on axis_a, 4-6 on axis_b.
NATIVE_BUS = ("axis_a",) * 3 + ("axis_b",) * 3
#: Classic CAN bit rates a CANopen bus may use (CiA 301's table).
CLASSIC_BITRATES = (10_000, 20_000, 50_000, 125_000, 250_000, 500_000, 800_000, 1_000_000)
LOAD_LIMIT = 50.0
CONTROL_TICK_MS = 1.0
#: The controller's two drive buses: a config's CANopen buses, in leg order,
#: are these (sp/canopen/canopen_link.h; the analysis' axis_a and axis_b).
CONTROLLER_BUSES = ("axis_a", "axis_b")
#: The built-in CANopen layout's resolution (:func:`builtin_canopen`), m per count.
BUILTIN_POSITION_PER_COUNT = 1e-6


@dataclass(frozen=True)
class Scaling:
    """Leg length <-> the drive's position units.

    ``position = direction * round((length - length_at_zero) / position_per_count)``;
    length is joint to joint (m), as everywhere in the controller."""

    position_per_count: float    # m per count of the drive's position objects
    length_at_zero: float        # m, the leg length where the drive reads position 0
    direction: int = 1           # +1: the drive's position grows as the leg extends
    rated_force: float | None = None  # N along the leg at 1000 per mille of CiA 402's 0x60B2


@dataclass(frozen=True)
class Drive:
    leg: int                     # 1..6
    protocol: str                # "native", "cia408", "cia402"
    bus: str
    node_id: int | None = None   # 1..127 for CANopen drives
    scaling: Scaling | None = None
    control_mode: int = ob.CIA408_CONTROL_MODE_AXIS_POSITION
    force_feedforward: bool = False   # RPDO1 also maps CiA 408's vendor 0x2120 / CiA 402's 0x60B2 (8 bytes)
    on_block: str = "hold"            # the drive's state once a stop is done (ESTOP, FAULT): hold or disabled

    @property
    def is_canopen(self) -> bool:
        return self.protocol in ob.CANOPEN_PROTOCOLS


@dataclass(frozen=True)
class Drives:
    legs: tuple[Drive, ...]
    bitrates: dict = field(default_factory=dict)   # CANopen bus name -> bit/s
    sync_divider: int = 1                 # SYNC (and PDOs) every n control ticks
    heartbeat_ms: int = 20                # each drive's producer heartbeat (0x1017)
    heartbeat_timeout_ms: int = 50        # the master's consumer timeout per drive
    setpoint_timeout_ms: int = 3          # RPDO event timer: the drive's setpoint watchdog
    pressure_feedback: bool = True        # map the chamber pressures (TPDO2)
    master_heartbeat_ms: int = ob.MASTER_HEARTBEAT_MS  # the master's own heartbeat period (0 = off)
    master_node_id: int = ob.MASTER_NODE_ID            # the node id it sends that heartbeat as

    @property
    def canopen(self) -> tuple[Drive, ...]:
        return tuple(d for d in self.legs if d.is_canopen)

    def buses(self) -> list[str]:
        """The CANopen buses in use, in leg order."""
        out: list[str] = []
        for d in self.canopen:
            if d.bus not in out:
                out.append(d.bus)
        return out

    def on_bus(self, bus: str) -> tuple[Drive, ...]:
        return tuple(d for d in self.canopen if d.bus == bus)

    @property
    def sync_period_ms(self) -> float:
        return self.sync_divider * CONTROL_TICK_MS


def native_default() -> Drives:
    """Every leg on the native protocol (the default: no ``drives`` key)."""
    return Drives(tuple(Drive(i + 1, "native", NATIVE_BUS[i]) for i in range(LEGS)))


def builtin_canopen(park_lengths, protocol: str = "cia408", base: Drives | None = None) -> Drives:
    """The firmware's built-in CANopen layout, which ``sp_controller
    --canopen`` uses when the config's drives are native
    (``sp_co_master_cfg_default``, ``sp_co_link_cfg_default``): node i
    drives leg i, nodes 1-3 on axis_a and 4-6 on axis_b, 1 um per count,
    count 0 at the leg's length in the park pose (``park_lengths``, m, leg 1
    first), direction +1; CiA 408 with the pressures mapped, or every node
    ``cia402`` without them (``--cia402``). The SYNC divider is the command
    line's (``--canopen-sync-divider``), not known here: ``sync_divider``
    stays ``base``'s (the master's heartbeat keys too; default
    :func:`native_default`)."""
    if len(park_lengths) != LEGS:
        raise ValueError(f"builtin_canopen: {LEGS} park lengths expected, got {len(park_lengths)}")
    if protocol not in ob.CANOPEN_PROTOCOLS:
        raise ValueError(f"builtin_canopen: {protocol!r} is not one of {', '.join(ob.CANOPEN_PROTOCOLS)}")
    legs = tuple(Drive(i + 1, protocol, NATIVE_BUS[i], i + 1,
                       Scaling(BUILTIN_POSITION_PER_COUNT, float(park_lengths[i])))
                 for i in range(LEGS))
    return dataclasses.replace(base or native_default(), legs=legs,
                               bitrates={b: 1_000_000 for b in CONTROLLER_BUSES},
                               pressure_feedback=protocol == "cia408")


def controller_bus(drives: Drives, drive: Drive) -> str | None:
    """The controller's bus (axis_a, axis_b) a CANopen drive of the layout
    is on: the layout's CANopen buses in leg order; None beyond two."""
    order = drives.buses()
    k = order.index(drive.bus) if drive.bus in order else len(CONTROLLER_BUSES)
    return CONTROLLER_BUSES[k] if k < len(CONTROLLER_BUSES) else None


@dataclass(frozen=True)
class FrameRow:
    name: str
    count: int           # frames of this kind per period
    data_bytes: int
    period_ms: float
    bits: int            # worst-case bits of one frame
    us_per_ms: float     # of all `count` frames, at the bus's bit rate


def bus_rows(drives: Drives, bus: str, n_drives: int | None = None, divider: int | None = None,
             pressure: bool | None = None) -> list[FrameRow]:
    """The cyclic frames of one CANopen bus. The optional arguments replace
    the layout's own values (to evaluate the ways out)."""
    on_bus = drives.on_bus(bus)
    n = len(on_bus) if n_drives is None else n_drives
    d = drives.sync_divider if divider is None else divider
    p = drives.pressure_feedback if pressure is None else pressure
    rate = drives.bitrates.get(bus, 1_000_000)
    period = d * CONTROL_TICK_MS
    # The PDO sizes of the profile in use (every profile's setpoint and actual
    # PDOs are 6 bytes today; take the largest on the bus to stay an upper bound).
    profiles = {dr.protocol for dr in on_bus} or {"cia408"}
    rx = max(ob.profile(x).pdo("setpoint").data_bytes for x in profiles)
    if any(dr.force_feedforward for dr in on_bus):
        rx = max(rx, ob.RPDO_SETPOINT_408_FF.data_bytes, ob.RPDO_SETPOINT_402_FF.data_bytes)
    tx = max(ob.profile(x).pdo("actual").data_bytes for x in profiles)
    with_pressure = p and "cia408" in profiles
    rows = [("SYNC", 1, 0, period), ("RPDO1 setpoint", n, rx, period), ("TPDO1 actual", n, tx, period)]
    if with_pressure:
        rows.append(("TPDO2 pressures", n, ob.TPDO_PRESSURES.data_bytes, period))
    rows.append(("heartbeat (drives)", n, 1, float(drives.heartbeat_ms)))
    if drives.master_heartbeat_ms:
        rows.append((f"heartbeat (master, node {drives.master_node_id})", 1, 1, float(drives.master_heartbeat_ms)))
    out = []
    for name, count, nbytes, per in rows:
        bits = classic_frame_bits(nbytes)
        out.append(FrameRow(name, count, nbytes, per, bits, count * bits / rate * 1e6 / per))
    return out


def load_percent(rows: list[FrameRow]) -> float:
    return sum(r.us_per_ms for r in rows) / 1000.0 * 100.0


def bus_load(drives: Drives, bus: str, **kw) -> float:
    return load_percent(bus_rows(drives, bus, **kw))


def ways_out(drives: Drives, bus: str, limit: float = LOAD_LIMIT) -> list[str]:
    """What would bring an overloaded bus within ``limit`` %, each with its load."""
    n = len(drives.on_bus(bus))
    out = []
    for d in range(drives.sync_divider + 1, 11):
        pct = bus_load(drives, bus, divider=d)
        if pct <= limit:
            out.append(f"a SYNC divider: drives.sync_divider = {d} (SYNC and PDOs every {d} ms, "
                       f"the drives interpolate between setpoints): {pct:.1f} %")
            break
    fit = 0
    for k in range(1, n + 1):
        if bus_load(drives, bus, n_drives=k) <= limit:
            fit = k
    if fit:
        buses = math.ceil(len(drives.canopen) / fit)
        out.append(f"more buses: at most {fit} drive{'s' if fit > 1 else ''} per bus at this SYNC "
                   f"period ({bus_load(drives, bus, n_drives=fit):.1f} %), {buses} CANopen buses for "
                   f"{len(drives.canopen)} drives")
    else:
        out.append("more buses cannot do it alone: one drive alone is over the limit at this SYNC period")
    if drives.pressure_feedback and any(d.protocol == "cia408" for d in drives.on_bus(bus)):
        pct = bus_load(drives, bus, pressure=False)
        out.append(f"no pressure TPDO: drives.pressure_feedback = false (position only, no measured "
                   f"force): {pct:.1f} %{'' if pct <= limit else ' (still over)'}")
    return out


def format_report(drives: Drives, limit: float = LOAD_LIMIT) -> tuple[str, bool]:
    """The CANopen buses' load table and whether every bus is within ``limit``."""
    lines = []
    ok = True
    for bus in drives.buses():
        rows = bus_rows(drives, bus)
        pct = load_percent(rows)
        rate = drives.bitrates.get(bus, 1_000_000)
        nodes = ", ".join(f"leg {d.leg} = node {d.node_id} ({d.protocol})" for d in drives.on_bus(bus))
        lines.append(f"CANopen bus {bus}: classic CAN {rate / 1e6:g} Mbit/s, SYNC every "
                     f"{drives.sync_period_ms:g} ms; {nodes}")
        lines.append("| frame | count | bytes | period ms | bits | us per ms |")
        lines.append("|---|---|---|---|---|---|")
        for r in rows:
            lines.append(f"| {r.name} | {r.count} | {r.data_bytes} | {r.period_ms:g} | {r.bits} "
                         f"| {r.us_per_ms:.1f} |")
        verdict = "ok" if pct <= limit else "OVER LIMIT"
        lines.append(f"| **total** | | | | | **{sum(r.us_per_ms for r in rows):.1f} us = {pct:.1f} %** "
                     f"({verdict}) |")
        if pct > limit:
            ok = False
            lines.append(f"Ways out for {bus}:")
            lines.extend(f"- {w}" for w in ways_out(drives, bus, limit))
        lines.append("")
    return "\n".join(lines), ok


def overloaded(drives: Drives, limit: float = LOAD_LIMIT) -> list[tuple[str, float]]:
    """The CANopen buses above ``limit`` %, with their load."""
    return [(b, bus_load(drives, b)) for b in drives.buses() if bus_load(drives, b) > limit]
