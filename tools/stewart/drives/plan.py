# SPDX-License-Identifier: Apache-2.0
"""The SDO writes that configure one CANopen drive, from the platform config.

What the controller's master writes at start-up (in NMT pre-operational),
in order, and what it then reads back: the producer heartbeat, the device
or operating mode, the scaling units, the communication cycle period, and
each PDO's mapping and communication parameters (COB-ID, transmission type
and the RPDO event timer that is the drive's own setpoint watchdog). Every
number comes from :mod:`.objects` and the config's ``drives`` section.
Standard library only (the firmware generator is to read it too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import objects as ob
from .layout import Drive, Drives


@dataclass(frozen=True)
class Write:
    index: int
    subindex: int
    datatype: int
    value: int
    purpose: str
    final: bool = True       # read back after the sequence (False: a step of a PDO re-mapping)
    optional: bool = False   # skipped when the drive has no such object (SDO abort "does not exist")

    @property
    def key(self) -> str:
        return f"0x{self.index:04X}.{self.subindex}"

    def value_text(self) -> str:
        if self.datatype in ob.SIGNED_TYPES:
            return str(self.value)
        if self.datatype == ob.UNSIGNED32:
            return f"0x{self.value:08X}"
        return str(self.value)


def unit_prefix(position_per_count: float) -> int | None:
    """The decimal prefix of a power-of-ten resolution (1e-6 m -> -6), else None."""
    k = round(math.log10(position_per_count))
    return k if math.isclose(10.0 ** k, position_per_count, rel_tol=1e-9) else None


def pdo_writes(pdo: ob.Pdo, node_id: int, drives: Drives) -> list[Write]:
    """Disable the PDO, rewrite its mapping, set its communication parameters,
    enable it (CiA 301's order: a mapping may change only while the PDO is invalid)."""
    cob = pdo.cob_id(node_id)
    what = f"{'R' if pdo.direction == 'rx' else 'T'}PDO{pdo.number} {pdo.name}"
    out = [Write(pdo.comm_index, ob.PDO_COMM_COB_ID, ob.UNSIGNED32, ob.PDO_COB_INVALID | cob,
                 f"{what}: disable while re-mapping", final=False),
           Write(pdo.map_index, 0, ob.UNSIGNED8, 0, f"{what}: clear the mapping", final=False)]
    for i, e in enumerate(pdo.entries, 1):
        out.append(Write(pdo.map_index, i, ob.UNSIGNED32, e.mapping_value(), f"{what}: map {e.key} {e.name}"))
    out.append(Write(pdo.map_index, 0, ob.UNSIGNED8, len(pdo.entries), f"{what}: {len(pdo.entries)} entries"))
    out.append(Write(pdo.comm_index, ob.PDO_COMM_TRANSMISSION_TYPE, ob.UNSIGNED8, ob.TRANSMISSION_SYNC_EVERY,
                     f"{what}: synchronous, every SYNC"))
    if pdo.direction == "rx":
        out.append(Write(pdo.comm_index, ob.PDO_COMM_EVENT_TIMER, ob.UNSIGNED16, drives.setpoint_timeout_ms,
                         f"{what}: event timer {drives.setpoint_timeout_ms} ms = the drive's setpoint watchdog"))
    out.append(Write(pdo.comm_index, ob.PDO_COMM_COB_ID, ob.UNSIGNED32, cob, f"{what}: enable on COB-ID 0x{cob:03X}"))
    return out


def drive_writes(drive: Drive, drives: Drives) -> list[Write]:
    """The whole configuration of one CANopen drive, in the order it is written."""
    if not drive.is_canopen or drive.node_id is None or drive.scaling is None:
        raise ValueError(f"leg {drive.leg}: not a configured CANopen drive")
    prof = ob.profile(drive.protocol)
    out = [Write(ob.PRODUCER_HEARTBEAT.index, 0, ob.UNSIGNED16, drives.heartbeat_ms,
                 f"heartbeat every {drives.heartbeat_ms} ms (the master's timeout: "
                 f"{drives.heartbeat_timeout_ms} ms)")]
    if drives.master_heartbeat_ms:  # the drive watches the master: three of its periods (0x1016.1)
        t = min(3 * drives.master_heartbeat_ms, 0xFFFF)
        out.append(Write(ob.CONSUMER_HEARTBEAT.index, ob.CONSUMER_HEARTBEAT.subindex, ob.UNSIGNED32,
                         (drives.master_node_id << 16) | t,
                         f"watch the master's heartbeat (node {drives.master_node_id}, {t} ms)", optional=True))
    for index, sub, value in prof.mode_writes:
        entry = next(e for e in prof.entries if e.index == index and e.subindex == sub)
        if index == ob.CONTROL_MODE.index and drive.protocol == "cia408":
            value = drive.control_mode
        out.append(Write(index, sub, entry.datatype, value, f"{entry.name} = {value}"))
    if drive.protocol == "cia408":
        prefix = unit_prefix(drive.scaling.position_per_count)
        if prefix is not None:
            out.append(Write(0x6600, 2, ob.UNSIGNED8, ob.UNIT_METRE, "setpoint unit: metre", optional=True))
            out.append(Write(0x6600, 3, ob.INTEGER8, prefix,
                             f"setpoint prefix: 1e{prefix} m per count (config scaling)", optional=True))
    else:
        out.append(Write(0x60C2, 1, ob.UNSIGNED8, drives.sync_divider,
                         f"interpolation period {drives.sync_divider}", optional=True))
        out.append(Write(0x60C2, 2, ob.INTEGER8, -3, "interpolation period unit: ms", optional=True))
    out.append(Write(ob.CYCLE_PERIOD.index, 0, ob.UNSIGNED32, int(drives.sync_period_ms * 1000),
                     f"SYNC period {drives.sync_period_ms:g} ms (the drive may watch it)", optional=True))
    for pdo in ob.pdos_used(prof, drives.pressure_feedback and drive.protocol == "cia408",
                            drive.force_feedforward):
        out.extend(pdo_writes(pdo, drive.node_id, drives))
    return out


def length_to_position(drive: Drive, length_m: float) -> int:
    """The drive's position count of a leg length (m), rounded to nearest."""
    s = drive.scaling
    return s.direction * int(round((length_m - s.length_at_zero) / s.position_per_count))


def position_to_length(drive: Drive, position: int) -> float:
    s = drive.scaling
    return s.length_at_zero + s.direction * position * s.position_per_count
