# SPDX-License-Identifier: Apache-2.0
"""CANopen traffic of a CAN log decoded into signals (``stewart analyze``).

The drive buses of a run with CiA 408 drives carry CiA 301 frames instead
of the DBC's drive frames. Each one is decoded by the predefined connection
set and the master's PDO layout (``objects.py``; the layout the controller
writes at start-up):

- NMT (0x000): the command and its node (0 = all);
- SYNC (0x080, no data);
- EMCY (0x081-0x0FF): error code, its CiA 301 class, error register;
- RPDO1 (0x201-0x27F): control word and position setpoint (counts), and the
  force feed-forward (daN) when it is 8 bytes (vendor object 0x2120);
- TPDO1 (0x181-0x1FF): status word, the device state, actual position;
  the state by the node's profile: CiA 402's statusword table for a node
  the config says is ``cia402`` (or whose 0x1000 the log shows read as
  402), else CiA 408's device states;
- TPDO2 (0x281-0x2FF): chamber pressures A and B (kPa);
- SDO (0x581-0x5FF answers, 0x601-0x67F requests): command, object, value
  or abort code;
- heartbeat (0x701-0x77F): the NMT state (0 = boot-up).

One row per frame in ``canopen.csv``; :func:`summary` counts them per bus
and node and lists the EMCYs, SDO aborts and NMT states seen. The leg
columns of signals.csv (lengths, pressures, drive states per tick) come
from the same TPDOs by the same profile rule (:func:`profiles_in_log`
finds the device types; stewart/analysis/canopen_legs.py). numpy only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import objects as ob
from .layout import controller_bus

#: kinds of frame, in the CSV's ``kind`` column
KINDS = ("nmt", "sync", "emcy", "tpdo1", "rpdo1", "tpdo2", "sdo_answer", "sdo_request", "heartbeat")
NMT_STATES = {0x00: "boot-up", 0x04: "stopped", 0x05: "operational", 0x7F: "pre-operational"}
NMT_COMMANDS = {ob.NMT_START: "start", ob.NMT_STOP: "stop", ob.NMT_PRE_OPERATIONAL: "pre-operational",
                ob.NMT_RESET_NODE: "reset node", ob.NMT_RESET_COMMUNICATION: "reset communication"}
STATES_408 = {v: k for k, v in ob.SW408.items()}


def state_408(word: int) -> str:
    """CiA 408 device state of a status word (bits 0..3), ``unknown`` for none."""
    return STATES_408.get(word & ob.SW408_MASK, "unknown")


def state_402(word: int) -> str:
    """CiA 402 state of a statusword (its (mask, value) table), ``unknown`` for none."""
    for name, (mask, value) in ob.SW402.items():
        if word & mask == value:
            return name
    return "unknown"


def profiles_from_drives(drives) -> dict[tuple[str, int], str]:
    """{(bus, node): protocol} of a config's CANopen drives, with the
    config's CANopen buses in order as the controller's axis_a and axis_b
    (sp/canopen/canopen_link.h) and as themselves."""
    out: dict[tuple[str, int], str] = {}
    for d in drives.canopen:
        out[(d.bus, d.node_id)] = d.protocol
        bus = controller_bus(drives, d)
        if bus is not None:
            out[(bus, d.node_id)] = d.protocol
    return out


def profile_of_device_type(value: int) -> str:
    """The profile a device type (0x1000) names in its bits 0..15:
    ``cia402`` for 402, else ``cia408``."""
    return "cia402" if value & 0xFFFF == 402 else "cia408"


def profiles_in_log(frames, ifaces: dict[str, str]) -> dict[tuple[str, int], str]:
    """{(bus, node): profile} of the nodes whose device type (0x1000) an
    SDO upload answer in the log shows (the last answer of each node), on
    the interfaces named in ``ifaces`` ({iface: bus})."""
    if len(frames.line_no) == 0:
        return {}
    bus_of = np.array([ifaces.get(n, "") for n in frames.ifaces] + [""], dtype=object)
    d = frames.data
    sel = np.flatnonzero(~frames.fd & (bus_of[frames.iface] != "") & (frames.frame_id >= 0x581)
                         & (frames.frame_id <= 0x5FF) & (frames.dlc == 8) & (d[:, 0] != 0x80)
                         & (d[:, 0] != 0x60) & (d[:, 1] == 0x00) & (d[:, 2] == 0x10) & (d[:, 3] == 0))
    out: dict[tuple[str, int], str] = {}
    for i in sel.tolist():
        value = int(d[i, 4]) | (int(d[i, 5]) << 8)
        out[(bus_of[frames.iface[i]], int(frames.frame_id[i]) & 0x7F)] = profile_of_device_type(value)
    return out


EMCY_CLASSES = {0x0: "error reset", 0x1: "generic", 0x2: "current", 0x3: "voltage", 0x4: "temperature",
                0x5: "device hardware", 0x6: "device software", 0x7: "additional modules", 0x8: "monitoring",
                0x9: "external", 0xF: "device specific"}
COLUMNS = ("time_s", "bus", "node", "kind", "word", "state", "position", "force_daN", "pressure_a_kPa",
           "pressure_b_kPa", "code", "detail")


def _kind(fid: np.ndarray) -> np.ndarray:
    """Index into KINDS per identifier, -1 for none of them."""
    k = np.full(len(fid), -1, dtype=np.int64)
    ranges = ((0x000, 0x000, 0), (0x080, 0x080, 1), (0x081, 0x0FF, 2), (0x181, 0x1FF, 3), (0x201, 0x27F, 4),
              (0x281, 0x2FF, 5), (0x581, 0x5FF, 6), (0x601, 0x67F, 7), (0x701, 0x77F, 8))
    for lo, hi, idx in ranges:
        k[(fid >= lo) & (fid <= hi)] = idx
    return k


def _u16(d: np.ndarray, at: int) -> np.ndarray:
    return d[:, at].astype(np.int64) | (d[:, at + 1].astype(np.int64) << 8)


def _i32(d: np.ndarray, at: int) -> np.ndarray:
    v = _u16(d, at) | (_u16(d, at + 2) << 16)
    return np.where(v >= 1 << 31, v - (1 << 32), v)


def _emcy_class(code: int) -> str:
    if code == 0:
        return "error reset"
    if code >> 8 == 0x81:
        return "communication"
    if code >> 8 == 0x82:
        return "protocol"
    return EMCY_CLASSES.get(code >> 12, "additional functions")


def decode(frames, ifaces: dict[str, str], profiles: dict[tuple[str, int], str] | None = None) -> list[tuple]:
    """Rows (COLUMNS) of every classic CANopen frame on the interfaces named
    in ``ifaces`` ({iface: bus}), in log order. ``frames``: a
    :class:`stewart.analysis.logfile.LogFrames`. ``profiles``:
    {(bus, node): "cia408" or "cia402"} (:func:`profiles_from_drives`);
    a node not in it takes the profile its 0x1000 answer in the log shows
    (from then on), else CiA 408."""
    rows: list[tuple] = []
    if len(frames.line_no) == 0:
        return rows
    bus_of = np.array([ifaces.get(n, "") for n in frames.ifaces] + [""], dtype=object)
    sel = np.flatnonzero(~frames.fd & (bus_of[frames.iface] != ""))
    kind = _kind(frames.frame_id[sel])
    sel, kind = sel[kind >= 0], kind[kind >= 0]
    fid, dlc, data, t = frames.frame_id[sel], frames.dlc[sel], frames.data[sel], frames.time[sel]
    bus = bus_of[frames.iface[sel]]
    word, pos = _u16(data, 0), _i32(data, 2)
    force = _u16(data, 6)
    force = np.where(force >= 1 << 15, force - (1 << 16), force)
    given = dict(profiles or {})
    seen: dict[tuple[str, int], str] = {}  # from the 0x1000 answers in the log
    for i in range(len(sel)):
        k, f, n = int(kind[i]), int(fid[i]), int(dlc[i])
        node = f & 0x7F
        r = [f"{t[i]:.6f}", bus[i], node, KINDS[k], "", "", "", "", "", "", "", ""]
        d = data[i]
        if k == 0 and n >= 2:        # NMT
            r[2] = int(d[1])
            r[10] = int(d[0])
            r[11] = NMT_COMMANDS.get(int(d[0]), "unknown command")
        elif k == 2 and n >= 3:      # EMCY
            code = int(word[i])
            r[10] = f"0x{code:04X}"
            r[11] = f"{_emcy_class(code)}; error register 0x{int(d[2]):02X}"
        elif k in (3, 4) and n >= 6:  # TPDO1 / RPDO1
            r[4] = f"0x{int(word[i]):04X}"
            if k == 3:
                prof = given.get((bus[i], node)) or seen.get((bus[i], node), "cia408")
                r[5] = state_402(int(word[i])) if prof == "cia402" else state_408(int(word[i]))
            r[6] = int(pos[i])
            if k == 4 and n == 8:
                r[7] = int(force[i])
        elif k == 5 and n >= 4:      # TPDO2
            r[8], r[9] = int(word[i]), int(_u16(data[i:i + 1], 2)[0])
        elif k in (6, 7) and n == 8:  # SDO
            cmd = int(d[0])
            index, sub = int(d[1]) | (int(d[2]) << 8), int(d[3])
            value = int(d[4]) | (int(d[5]) << 8) | (int(d[6]) << 16) | (int(d[7]) << 24)
            r[10] = f"0x{index:04X}.{sub}"
            if cmd == 0x80:
                r[11] = f"abort 0x{value:08X}"
            elif k == 7:
                r[11] = "read" if cmd >> 5 == 2 else f"write 0x{value:X}"
            else:
                r[11] = "written" if cmd == 0x60 else f"value 0x{value:X}"
                if k == 6 and cmd != 0x80 and cmd != 0x60 and (index, sub) == (0x1000, 0):
                    seen[(bus[i], node)] = profile_of_device_type(value)
        elif k == 8 and n >= 1:      # heartbeat
            r[10] = int(d[0]) & 0x7F
            r[11] = NMT_STATES.get(int(d[0]) & 0x7F, "unknown state")
        rows.append(tuple(r))
    return rows


def write_csv(rows: list[tuple], path: str | Path) -> None:
    lines = [",".join(COLUMNS)] + [",".join(str(x) for x in r) for r in rows]
    Path(path).write_text("\n".join(lines) + "\n")


def summary(rows: list[tuple]) -> dict:
    """Frames per bus, node and kind; EMCYs, SDO aborts and the NMT states
    the heartbeats showed, per node."""
    counts: dict[str, dict[str, int]] = {}
    emcy, aborts, states = [], [], {}
    for r in rows:
        bus, node, kind = r[1], r[2], r[3]
        key = f"{bus} node {node}" if kind not in ("nmt", "sync") else f"{bus}"
        c = counts.setdefault(key, {})
        c[kind] = c.get(kind, 0) + 1
        if kind == "emcy":
            emcy.append({"time_s": float(r[0]), "bus": bus, "node": node, "code": r[10], "detail": r[11]})
        elif kind == "sdo_answer" and str(r[11]).startswith("abort"):
            aborts.append({"time_s": float(r[0]), "bus": bus, "node": node, "object": r[10], "detail": r[11]})
        elif kind == "heartbeat":
            seen = states.setdefault(f"{bus} node {node}", [])
            if not seen or seen[-1] != r[11]:
                seen.append(r[11])
    return {"frames": counts, "emcy": emcy[:50], "sdo_aborts": aborts[:50], "nmt_states": states}
