# SPDX-License-Identifier: Apache-2.0
"""The plain reference of :func:`stewart.analysis.decode.read_log`, a test
oracle (not installed): the log
line by line, each frame checked and decoded by :class:`stewart.protocol.Protocol`
(cantools' per-frame decode, the E2E receiver per frame). It was the
analysis' decoder before the whole-message one; the tests hold the whole-message decoder
to it (tests/python/test_framedecode.py). About 30x slower. The CANopen
drives' leg columns come from the one whole-log step of both
(:func:`stewart.analysis.canopen_legs.fill_legs`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from stewart import protocol as pr
from stewart.analysis.decode import (CANOPEN_BUSES, FEEDBACK_COLUMNS, STATUS_COLUMNS, WRONG_BUS, Command,
                                     LogData, LogStats, _Scaler, _unwrap16, command_from, finish_rows,
                                     is_canopen_id)
from stewart.analysis.logfile import parse_bus_map, parse_line


def read_log_reference(source: str | Path | Iterable[str], buses: str | Mapping[str, str] | None = None,
             platform=None, dbc_path: str | Path | None = None) -> LogData:
    """Reads and checks a candump -L log (a path or an iterable of lines).

    ``buses``: the ``--bus`` text or a mapping {interface: bus}; default
    vcan0 = ops, vcan1 = axis_a, vcan2 = axis_b (and the bus names
    themselves). ``platform``: a validated :class:`stewart.config.Platform`
    for the stretch and the measured force (None: those columns are NaN)."""
    ifmap = parse_bus_map(buses) if buses is None or isinstance(buses, str) else dict(buses)
    proto = pr.Protocol(dbc_path)
    stats = LogStats()
    if isinstance(source, (str, Path)):
        label = str(source)
        with open(source, "r", encoding="utf-8", errors="replace") as fh:
            accepted = _accepted_frames(fh, ifmap, proto, stats)
    else:
        label = "<lines>"
        source = list(source)   # read twice with CANopen drives (below)
        accepted = _accepted_frames(source, ifmap, proto, stats)

    known = _unwrapped_ticks(accepted)
    rows, commands, force_frames = _rows_by_tick(accepted, known, stats)
    ticks = np.array(sorted(rows), dtype=np.int64)
    d = LogData.empty(ticks, commands, stats, label)
    for k, t in enumerate(ticks):
        _fill_row(d, k, rows[int(t)])
    if stats.canopen and platform is not None:  # CANopen drives: the same step as read_log's
        from stewart.analysis.canopen_legs import TickFrames, fill_legs
        from stewart.analysis.logfile import read_frames

        at = [i for i in range(len(accepted)) if known[i] is not None]
        fill_legs(d, read_frames(source), ifmap, TickFrames(
            np.array([accepted[i][4] for i in at], dtype=np.int64), np.array([known[i] for i in at], dtype=np.int64),
            np.array([accepted[i][3] for i in at], dtype=float)), platform)
    d.force_frames = force_frames
    finish_rows(d, platform)
    return d


def _accepted_frames(lines: Iterable[str], ifmap: Mapping[str, str], proto: pr.Protocol,
                     stats: LogStats) -> list[tuple[str, str, dict[str, float], float, int]]:
    """The good frames in log order, (name, bus, signals, time, line);
    counts and warnings into ``stats``."""
    scaler = _Scaler(proto)
    accepted = []
    for line_no, line in enumerate(lines, start=1):
        stats.lines += 1
        if not line.strip():
            continue
        try:
            f = parse_line(line, line_no)
        except ValueError as exc:
            stats.malformed += 1
            stats.warn(f"line {line_no}: malformed ({exc}): {line.strip()[:80]}")
            continue
        stats.frames += 1
        bus = ifmap.get(f.iface)
        if bus is None:
            stats.unknown_interface += 1
            stats.warn(f"line {line_no}: unknown interface {f.iface!r}")
            continue
        rec = proto.receive(f.frame_id, f.data, bus=bus, raw=True)
        if (not rec.ok and rec.error.kind == pr.UNKNOWN_ID and bus in CANOPEN_BUSES
                and is_canopen_id(f.frame_id)):
            stats.canopen += 1
            continue
        if not rec.ok:
            kind = rec.error.kind
            stats.rejected[kind] = stats.rejected.get(kind, 0) + 1
            stats.warn(f"line {line_no}: {bus}: {rec.error}")
            continue
        name = rec.name
        if bus not in proto.infos[name].buses:
            stats.rejected[WRONG_BUS] = stats.rejected.get(WRONG_BUS, 0) + 1
            stats.warn(f"line {line_no}: {name} on bus {bus}, the DBC puts it on "
                       f"{', '.join(proto.infos[name].buses)}")
            continue
        stats.accepted += 1
        stats.lost += rec.lost
        stats.per_message[name] = stats.per_message.get(name, 0) + 1
        accepted.append((name, bus, scaler(f.frame_id, rec.signals), f.time, line_no))
    return accepted


def _unwrapped_ticks(accepted) -> list[int | None]:
    """The tick of each accepted frame that carries one (None for the
    others), for TickEcho unwrapping and for the command -> executing tick
    assignment. The Tick signal wraps after 2^32 ticks: unwrapped in log
    order, also in the frames' signals."""
    known: list[int | None] = [None] * len(accepted)
    for i, (name, _bus, sig, _t, _ln) in enumerate(accepted):
        if name in ("SYNC", "AXIS_SETPOINTS", "CTRL_STATUS", "CTRL_MONITOR", "CTRL_WRENCH"):
            known[i] = int(sig["Tick"])
    lap, last = 0, None
    for i in range(len(accepted)):
        if known[i] is not None:
            t = known[i] + (lap << 32)
            if last is not None and t - last < -(1 << 31):
                lap, t = lap + 1, t + (1 << 32)
            elif last is not None and t - last > (1 << 31):
                lap, t = lap - 1, t - (1 << 32)
            known[i] = last = t
            accepted[i][2]["Tick"] = t
    return known


def _nearby_ticks(accepted, known: list[int | None]):
    """For each accepted frame: the last tick at or before it, the first at
    or after it, and the tick of the first CTRL_STATUS at or after it."""
    n = len(accepted)
    prev_tick: list[int | None] = [None] * n
    last = None
    for i in range(n):
        if known[i] is not None:
            last = known[i]
        prev_tick[i] = last
    next_tick: list[int | None] = [None] * n
    nxt = None
    for i in range(n - 1, -1, -1):
        if known[i] is not None:
            nxt = known[i]
        next_tick[i] = nxt
    next_status: list[int | None] = [None] * n
    nxt = None
    for i in range(n - 1, -1, -1):
        if accepted[i][0] == "CTRL_STATUS":
            nxt = int(accepted[i][2]["Tick"])
        next_status[i] = nxt
    return prev_tick, next_tick, next_status


def _rows_by_tick(accepted, known: list[int | None], stats: LogStats):
    """(rows, commands, force frames): the frames of each tick, {tick: {what:
    signals}}, the last one winning; the commands and OP_FORCE frames with
    their executing tick."""
    prev_tick, next_tick, next_status = _nearby_ticks(accepted, known)
    rows: dict[int, dict[str, Any]] = {}

    def row(t: int) -> dict[str, Any]:
        r = rows.get(t)
        if r is None:
            r = rows[t] = {}
        return r

    commands: list[Command] = []
    force_frames: list = []
    for i, (name, bus, sig, t_log, line_no) in enumerate(accepted):
        if name == "CTRL_STATUS":
            row(int(sig["Tick"]))["status"] = sig
        elif name == "CTRL_MONITOR":
            row(int(sig["Tick"]))["monitor"] = sig
        elif name == "CTRL_WRENCH":
            row(int(sig["Tick"]))["wrench"] = sig
        elif name == "AXIS_SETPOINTS":
            row(int(sig["Tick"]))[("sp", bus)] = sig
        elif name == "SYNC":
            row(int(sig["Tick"]))
        elif name.startswith("AXIS_FEEDBACK_"):
            near = prev_tick[i] if prev_tick[i] is not None else next_tick[i]
            echo = int(sig["TickEcho"])
            if near is None:
                tick = echo
            else:
                tick = _unwrap16(echo, near)
                if abs(tick - near) > 1000:
                    stats.stale_feedback += 1
                    stats.warn(f"line {line_no}: {name} on {bus}: TickEcho {echo} is "
                               f"{tick - near} ticks from the log's tick {near}")
                    continue
            slot = int(name[-1])
            leg = slot + (0 if bus == "axis_a" else 3)
            row(tick)[("fb", leg)] = sig
        elif name == "OP_COMMAND":
            commands.append(command_from(next_status[i], t_log, sig.__getitem__))
        elif name == "OP_FORCE":
            force_frames.append((next_status[i], [float(sig[a]) for a in pr.WRENCH_SIGNALS]))
        # OP_TARGET_POSE: not needed for the analysis (the reference is in CTRL_MONITOR)
    return rows, commands, force_frames


def _fill_row(d: LogData, k: int, r: dict[str, Any]) -> None:
    """Row ``k`` of ``d`` from the frames of its tick."""
    s = r.get("status")
    if s is not None:
        for column, signal in STATUS_COLUMNS:
            getattr(d, column)[k] = s[signal]
        if s["EstimateValid"]:
            d.estimate[k] = [s[a] for a in pr.POSE_SIGNALS]
    mon = r.get("monitor")
    if mon is not None:
        d.reference[k] = [mon["Ref" + a] for a in pr.POSE_SIGNALS]
        d.length_sp[k] = [mon[f"LengthSp_{i}"] for i in range(1, 7)]
        d.force_ff[k] = [mon[f"ForceFf_{i}"] for i in range(1, 7)]
    w = r.get("wrench")
    if w is not None:
        d.est_wrench_valid[k] = w["Valid"]
        if w["Valid"]:
            d.est_wrench[k] = [w[s] for s in pr.WRENCH_SIGNALS]
    for b, bus in enumerate(("axis_a", "axis_b")):
        sp = r.get(("sp", bus))
        if sp is not None:
            d.axis_mode[k, b] = sp["Mode"]
            d.axis_length_sp[k, 3 * b:3 * b + 3] = [sp[f"Length_{s}"] for s in (1, 2, 3)]
    for leg in range(1, 7):
        fb = r.get(("fb", leg))
        if fb is not None:
            for column, signal in FEEDBACK_COLUMNS:
                getattr(d, column)[k, leg - 1] = fb[signal]
