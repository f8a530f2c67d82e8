# SPDX-License-Identifier: Apache-2.0
"""The leg columns of a run with CANopen drives (CiA 408 / CiA 402,
docs/reference/canopen.md): measured length, chamber pressures (so the measured
force), drive state and faults per tick, from the drives' TPDOs.

**Layout** (node -> leg, counts -> metres): the platform config's
``drives`` section when it has CANopen drives (its CANopen buses in leg
order are the log's axis_a and axis_b, as in the firmware), else the
firmware's built-in layout (:func:`stewart.drives.layout.builtin_canopen`:
nodes 1-3 on axis_a and 4-6 on axis_b for legs 1-6, 1 um per count, count 0
at the park pose's leg length by the float64 IK of ``stewart.model``). A
node's profile is the config's, else the one its device type (0x1000) shows
in the log, else CiA 408 (as in canopen.csv).

**Ticks.** CANopen frames carry no tick. The controller's master sends
RPDO1 and the CANopen SYNC (0x080) in the step of the tick that produces
them, before that tick's ops frames (CTRL_STATUS ...); the drives sample
their position (and pressures) at SYNC and answer with TPDO1 (and TPDO2).
So, as a native AXIS_FEEDBACK with TickEcho n is the state sampled for
SYNC n and goes to row n:

- a CANopen SYNC's tick is that of the tick-carrying frame next to it in
  the log (the first logged after it, or the last before it, whichever is
  nearer in time, the first on a tie), if that is within half a tick of
  it: in lockstep every frame of tick t is stamped t ms (the plant's SYNC(t)
  before it, CTRL_STATUS(t) after it); in real time the SYNC and
  CTRL_STATUS(t) leave in one step. A SYNC with none so near is unplaced;
- a TPDO answers the last SYNC logged before it on its bus and goes to
  that SYNC's row; the first answer of a node per SYNC and kind counts, a
  second one is counted as repeated and left out.

Ticks without a SYNC (``sync_divider`` > 1) get no feedback: their leg
values stay missing (NaN), like any value a row has no frame for.

**Values.** TPDO1 (6 bytes: status word, actual position INTEGER32):
length = length_at_zero + direction x count x position_per_count; the
drive state in the native column's codes (names.DRIVE_STATES: INIT, HOLD,
ACTIVE, FAULT; the profile's own state name is in canopen.csv):

- CiA 408: ACTIVE, HOLD as themselves; DISABLED, INIT and NOT_READY as
  INIT; FAULT_REACTION, FAULT_HOLD, FAULT_DISABLED as FAULT;
- CiA 402: OPERATION_ENABLED as ACTIVE (the master holds a 402 drive by
  holding its target, which the statusword does not show), QUICK_STOP_ACTIVE
  as HOLD, FAULT_REACTION_ACTIVE and FAULT as FAULT, the others as INIT;

a status word of no state leaves the state missing. ``drive_faults`` is
:data:`FAULT_BIT` (0x80, the bit ``sp_co_link_feedback`` sets while the
master has a fault latched on the node) while the status word shows a
fault state, else 0; EMCYs and heartbeats are in canopen.csv only.
TPDO2 (4 bytes: chamber pressures A and B, kPa) only on CiA 408 nodes of a
layout with pressure feedback: the pressures in Pa, from which
:attr:`LogData.force` is p_A A_piston - p_B A_annulus as for the native
drives. CiA 402 nodes measure no force: their pressures and force stay NaN.

TPDOs of a node the layout does not have, shorter than their mapping, or
with no placed SYNC before them are left out and counted, as are the
TPDOs used (``answers``: TPDO1s, and TPDO2s of the legs that take
pressures)
(``LogStats.canopen_feedback``, with a warning for each unknown node and
the first short ones). numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..drives import layout as lo
from ..drives import objects as ob
from ..drives import traffic
from .names import DRIVE_STATES

#: A SYNC is placed on the tick of a tick-carrying frame at most this far
#: from it in time (half a control tick), s.
SYNC_TOLERANCE_S = 0.5e-3
#: ``drive_faults`` while the status word shows a fault state:
#: SP_CO_LINK_FAULT (sp/canopen/canopen_link.h), the DBC's Faults bit 7.
FAULT_BIT = 0x80
#: Device state -> the native drive state (names.DRIVE_STATES), per profile.
STATE_408 = {"ACTIVE": "ACTIVE", "HOLD": "HOLD", "DISABLED": "INIT", "INIT": "INIT", "NOT_READY": "INIT",
             "FAULT_REACTION": "FAULT", "FAULT_HOLD": "FAULT", "FAULT_DISABLED": "FAULT"}
STATE_402 = {"OPERATION_ENABLED": "ACTIVE", "QUICK_STOP_ACTIVE": "HOLD", "FAULT_REACTION_ACTIVE": "FAULT",
             "FAULT": "FAULT", "NOT_READY_TO_SWITCH_ON": "INIT", "SWITCH_ON_DISABLED": "INIT",
             "READY_TO_SWITCH_ON": "INIT", "SWITCHED_ON": "INIT"}
#: Bytes TPDO1 (status word + position) and TPDO2 (two pressures) need.
TPDO1_BYTES = ob.TPDO_ACTUAL_408.data_bytes
TPDO2_BYTES = ob.TPDO_PRESSURES.data_bytes
_BUSES = lo.CONTROLLER_BUSES


@dataclass(frozen=True)
class TickFrames:
    """The accepted frames that carry a tick, in log order."""

    line_no: np.ndarray   #: (M,) int64, ascending
    tick: np.ndarray      #: (M,) int64
    time: np.ndarray      #: (M,) float64, s


def layout_of(platform) -> tuple[lo.Drives, str]:
    """The drives' layout for the analysis and where it came from
    (``config`` or ``built-in``): the config's drives section when it has
    CANopen drives, else the firmware's built-in layout at the config's
    park pose (CiA 408; the log's device types say which nodes are 402)."""
    drives = platform.drives
    if drives.canopen:
        return drives, "config"
    from .. import model

    park = model.inverse_kinematics(platform, platform.park).lengths
    return lo.builtin_canopen([float(x) for x in park], base=drives), "built-in"


def _u16(d: np.ndarray, at: int) -> np.ndarray:
    return d[:, at].astype(np.int64) | (d[:, at + 1].astype(np.int64) << 8)


def _i32(d: np.ndarray, at: int) -> np.ndarray:
    v = _u16(d, at) | (_u16(d, at + 2) << 16)
    return np.where(v >= 1 << 31, v - (1 << 32), v)


def sync_ticks(sync_line: np.ndarray, sync_time: np.ndarray, ticks: TickFrames) -> np.ndarray:
    """The tick of each CANopen SYNC (its log line and time), -1 where no
    tick-carrying frame next to it in the log is within
    :data:`SYNC_TOLERANCE_S` (module docstring)."""
    m = len(ticks.line_no)
    out = np.full(len(sync_line), -1, dtype=np.int64)
    if m == 0 or len(sync_line) == 0:
        return out
    j = np.searchsorted(ticks.line_no, sync_line)
    after, before = np.minimum(j, m - 1), np.maximum(j - 1, 0)
    d_after = np.where(j < m, np.abs(ticks.time[after] - sync_time), np.inf)
    d_before = np.where(j > 0, np.abs(ticks.time[before] - sync_time), np.inf)
    use_after = d_after <= d_before
    near = np.where(use_after, d_after, d_before)
    tick = np.where(use_after, ticks.tick[after], ticks.tick[before])
    ok = near <= SYNC_TOLERANCE_S + 1e-9
    out[ok] = tick[ok]
    return out


def fill_legs(data, frames, ifaces: dict[str, str], ticks: TickFrames, platform) -> None:
    """Fills ``data``'s length, pressure_a/b, drive_state and drive_faults
    from the CANopen TPDOs of ``frames`` (a :class:`.logfile.LogFrames`) on
    the drive buses of ``ifaces`` ({iface: bus}), with the layout of
    ``platform`` (:func:`layout_of`); counts into
    ``data.stats.canopen_feedback``."""
    drives, source = layout_of(platform)
    counts = {"layout": source, "syncs": 0, "syncs_unplaced": 0, "answers": 0, "unplaced": 0,
              "unknown_node": 0, "short": 0, "repeated": 0}
    data.stats.canopen_feedback = counts
    if len(frames.line_no) == 0:
        return
    bus_of_iface = np.array([_BUSES.index(ifaces[n]) if ifaces.get(n) in _BUSES else -1
                             for n in frames.ifaces] + [-1], dtype=np.int64)
    bus = bus_of_iface[frames.iface]
    fid = frames.frame_id
    classic = ~frames.fd & (bus >= 0)
    si = np.flatnonzero(classic & (fid == ob.COB_SYNC))
    kind = np.where((fid > ob.COB_TPDO1) & (fid < ob.COB_TPDO1 + 0x80), 1,
                    np.where((fid > ob.COB_TPDO2) & (fid < ob.COB_TPDO2 + 0x80), 2, 0))
    ti = np.flatnonzero(classic & (kind > 0))
    s_tick = sync_ticks(frames.line_no[si], frames.time[si], ticks)
    counts["syncs"] = int((s_tick >= 0).sum())
    counts["syncs_unplaced"] = int((s_tick < 0).sum())
    if len(ti) == 0:
        return
    leg_of, by_leg = _legs_by_node(drives)
    seen = {} if source == "config" else traffic.profiles_in_log(frames, {n: b for n, b in ifaces.items()
                                                                           if b in _BUSES})
    tp = _Tpdos(ti, bus[ti], kind[ti], frames.line_no[ti], fid[ti] & 0x7F)
    tp.leg = leg_of[tp.bus, tp.node]
    ok = _usable(tp, frames, source, data.stats, counts)
    # the SYNC each answers: the last one logged before it on its bus
    sync_of = _answered_sync(tp, bus[si], frames.line_no[si])
    tick = np.where(sync_of >= 0, s_tick[np.maximum(sync_of, 0)], -1)
    unplaced = ok & (tick < 0)
    counts["unplaced"] = int(unplaced.sum())
    ok &= ~unplaced
    # the first answer per SYNC, bus, node and kind
    cand = np.flatnonzero(ok)
    key = (sync_of[cand] * len(_BUSES) + tp.bus[cand]) * 256 + tp.node[cand] * 2 + (tp.kind[cand] - 1)
    _, first = np.unique(key, return_index=True)
    keep = np.zeros(len(ti), dtype=bool)
    keep[cand[first]] = True
    counts["repeated"] = int(len(cand) - len(first))
    row = data.index_of(tick)
    keep &= row >= 0
    data_bytes = frames.data[ti, :8]
    for lg, dr in sorted(by_leg.items()):
        # the profile: the config's, else the log's device type, else CiA 408
        prof = seen.get((lo.controller_bus(drives, dr), dr.node_id), dr.protocol)
        on_leg = keep & (tp.leg == lg)
        counts["answers"] += _fill_tpdo1(data, dr, prof, row, data_bytes, np.flatnonzero(on_leg & (tp.kind == 1)))
        if prof == "cia408" and drives.pressure_feedback:
            counts["answers"] += _fill_tpdo2(data, dr, row, data_bytes, np.flatnonzero(on_leg & (tp.kind == 2)))


@dataclass
class _Tpdos:
    """The TPDO frames on the drive buses: their indices into the log's
    frames and, per frame, bus, kind (1, 2), line, node and leg (0: a node
    the layout does not have)."""

    index: np.ndarray
    bus: np.ndarray
    kind: np.ndarray
    line: np.ndarray
    node: np.ndarray
    leg: np.ndarray | None = None


def _legs_by_node(drives: lo.Drives) -> tuple[np.ndarray, dict[int, lo.Drive]]:
    """(leg of each node per controller bus, 0 for none; the CANopen drives by leg)."""
    leg_of = np.zeros((len(_BUSES), 128), dtype=np.int64)
    by_leg: dict[int, lo.Drive] = {}
    for dr in drives.canopen:
        b = lo.controller_bus(drives, dr)
        if b is not None:
            leg_of[_BUSES.index(b), dr.node_id] = dr.leg
            by_leg[dr.leg] = dr
    return leg_of, by_leg


def _usable(tp: _Tpdos, frames, source: str, stats, counts: dict) -> np.ndarray:
    """The TPDOs of a node of the layout with their mapping's bytes; the
    others are counted and warned about."""
    unknown = tp.leg == 0
    counts["unknown_node"] = int(unknown.sum())
    for b, n in sorted({(int(b), int(n)) for b, n in zip(tp.bus[unknown], tp.node[unknown])}):
        first = int(tp.line[unknown & (tp.bus == b) & (tp.node == n)][0])
        stats.warn(f"line {first}: {_BUSES[b]}: TPDOs of node {n}, which the {source} CANopen layout does "
                   f"not have: left out")
    need = np.where(tp.kind == 1, TPDO1_BYTES, TPDO2_BYTES)
    short = ~unknown & (frames.dlc[tp.index] < need)
    counts["short"] = int(short.sum())
    for r in np.flatnonzero(short)[:5].tolist():
        stats.warn(f"line {tp.line[r]}: {_BUSES[tp.bus[r]]}: TPDO{tp.kind[r]} of node {tp.node[r]} has "
                   f"{frames.dlc[tp.index[r]]} bytes, its mapping {need[r]}: left out")
    return ~unknown & ~short


def _answered_sync(tp: _Tpdos, sync_bus: np.ndarray, sync_line: np.ndarray) -> np.ndarray:
    """For each TPDO the SYNC (index among the SYNCs) logged last before it
    on its bus, -1 for none."""
    sync_of = np.full(len(tp.index), -1, dtype=np.int64)
    for b in range(len(_BUSES)):
        on_s = np.flatnonzero(sync_bus == b)
        on_t = np.flatnonzero(tp.bus == b)
        if len(on_s) == 0:   # no SYNC on this bus: nothing answered
            continue
        k = np.searchsorted(sync_line[on_s], tp.line[on_t]) - 1
        sync_of[on_t] = np.where(k >= 0, on_s[np.maximum(k, 0)], -1)
    return sync_of


def _fill_tpdo1(data, dr: lo.Drive, prof: str, row: np.ndarray, data_bytes: np.ndarray, t1: np.ndarray) -> int:
    """The length and the drive state of leg ``dr`` from its TPDO1s ``t1``
    (the status word and the position count); how many."""
    if len(t1) == 0:
        return 0
    j, s, k = dr.leg - 1, dr.scaling, row[t1]
    count = _i32(data_bytes[t1], 2)
    data.length[k, j] = s.length_at_zero + s.direction * count * s.position_per_count
    word = _u16(data_bytes[t1], 0)
    table, name_of = (STATE_402, traffic.state_402) if prof == "cia402" else (STATE_408, traffic.state_408)
    uniq, inv = np.unique(word, return_inverse=True)
    names = [table.get(name_of(int(w))) for w in uniq.tolist()]
    code = {name: DRIVE_STATES.index(name) for name in DRIVE_STATES}
    state = np.array([code[n] if n is not None else -1 for n in names], dtype=np.int64)[inv]
    data.drive_state[k, j] = state
    data.drive_faults[k, j] = np.where(state == code["FAULT"], FAULT_BIT, 0)
    return len(t1)


def _fill_tpdo2(data, dr: lo.Drive, row: np.ndarray, data_bytes: np.ndarray, t2: np.ndarray) -> int:
    """The chamber pressures of leg ``dr`` from its CiA 408 TPDO2s ``t2``; how many."""
    if len(t2) == 0:
        return 0
    k = row[t2]
    data.pressure_a[k, dr.leg - 1] = _u16(data_bytes[t2], 0) * 1000.0
    data.pressure_b[k, dr.leg - 1] = _u16(data_bytes[t2], 2) * 1000.0
    return len(t2)
