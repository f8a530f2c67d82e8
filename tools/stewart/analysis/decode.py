# SPDX-License-Identifier: Apache-2.0
"""Decoding a CAN log into a run: one row per control tick (:class:`LogData`).

:func:`read_log` parses the log line by line (:mod:`.logfile`), checks every
frame with :class:`stewart.protocol.Protocol` (CRC, alive counter per bus,
length, ranges) and the bus the DBC allows it on, and never stops on a bad
line: malformed lines and rejected frames are counted (``LogData.stats``).

Rows are control ticks. CTRL_STATUS, CTRL_MONITOR and CTRL_WRENCH carry the tick,
AXIS_SETPOINTS the tick of its SYNC (modulo 2^32: unwrapped in log order, so a
run through the wrap after 49.7 days keeps counting), AXIS_FEEDBACK the low 16 bits of its
SYNC tick (``TickEcho``, unwrapped to the nearest tick seen in the log). In
both the lockstep and the real-time mode of ``sp_controller`` the
controller's tick equals the SYNC tick. With CANopen drives the drive
buses carry CiA 301 frames instead, which carry no tick: the drives' TPDOs
go to the tick of the CANopen SYNC they answer, placed by the tick-carrying
frames next to it in the log (:mod:`.canopen_legs`; needs the platform for
the layout).

CTRL_WRENCH comes every 2nd tick (500 Hz). Like any other value a row has
no frame for, the wrench of a tick without one is missing (NaN, blank in
signals.csv), not held: a row shows only what was sent for that tick.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from .. import model
from .. import e2e
from .. import protocol as pr
from .logfile import parse_bus_map
from .names import AXES, COMMANDS, STATES, TICK_S

#: Kinds of bad frames besides the protocol's rejections (pr.KINDS).
WRONG_BUS = "wrong-bus"
#: How many warning texts are kept (the counts are always complete).
MAX_WARNINGS = 50
#: The drive buses may carry CANopen (CiA 301) frames instead of the native
#: drive frames (``--canopen``, docs/reference/canopen.md): identifiers the DBC does
#: not define in NMT (0x000), SYNC/EMCY (0x080-0x0FF), PDOs (0x181-0x57F),
#: SDO (0x581-0x67F) and heartbeat (0x701-0x77F) are counted as CANopen
#: frames there, not as bad ones.
CANOPEN_BUSES = ("axis_a", "axis_b")


def is_canopen_id(frame_id):
    """True (elementwise for arrays) for an identifier of the CiA 301
    predefined connection set."""
    f = frame_id
    return ((f == 0x000) | ((f >= 0x080) & (f <= 0x0FF)) | ((f >= 0x181) & (f <= 0x57F))
            | ((f >= 0x581) & (f <= 0x67F)) | ((f >= 0x701) & (f <= 0x77F)))


@dataclass
class LogStats:
    """What was read and what was thrown away."""

    lines: int = 0
    frames: int = 0              #: well-formed frame lines
    accepted: int = 0            #: frames that passed every check
    malformed: int = 0           #: lines that are not frames
    unknown_interface: int = 0
    canopen: int = 0             #: CANopen frames on a drive bus (not decoded by the DBC)
    rejected: dict[str, int] = field(default_factory=dict)  #: bad frames by kind
    lost: int = 0                #: frames missing according to the alive counters
    per_message: dict[str, int] = field(default_factory=dict)
    stale_feedback: int = 0      #: feedback whose TickEcho no tick of the log matches
    setpoint_checked: int = 0    #: ticks with both CTRL_MONITOR and AXIS_SETPOINTS
    setpoint_mismatch: int = 0   #: of which the length setpoints differ by > 1 um
    #: the CANopen drives' feedback in the leg columns (.canopen_legs): the
    #: layout used, SYNCs placed and not, TPDOs used and left out by reason
    canopen_feedback: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def bad_frames(self) -> int:
        return int(sum(self.rejected.values()))

    def warn(self, text: str) -> None:
        if len(self.warnings) < MAX_WARNINGS:
            self.warnings.append(text)

    def as_dict(self) -> dict[str, Any]:
        return {"lines": self.lines, "frames": self.frames, "accepted": self.accepted,
                "malformed_lines": self.malformed, "unknown_interface": self.unknown_interface,
                "canopen": self.canopen,
                "bad_frames": self.bad_frames, "rejected": dict(sorted(self.rejected.items())),
                "lost_frames": self.lost, "per_message": dict(sorted(self.per_message.items())),
                "stale_feedback": self.stale_feedback,
                "setpoint_checked": self.setpoint_checked,
                "setpoint_mismatch": self.setpoint_mismatch,
                "canopen_feedback": dict(self.canopen_feedback),
                "warnings": list(self.warnings)}


@dataclass
class Command:
    """One OP_COMMAND as logged."""

    tick: int | None     #: controller tick that executes it (first CTRL_STATUS after it)
    time: float          #: log timestamp, s
    command: str
    axis: int
    amplitude: float     #: m or rad
    frequency: float     #: Hz
    fade_time: float     #: s
    option: int

    def as_dict(self) -> dict[str, Any]:
        return {"tick": self.tick, "time": self.time, "command": self.command,
                "axis": AXES[self.axis] if 0 <= self.axis < 6 else self.axis,
                "amplitude": self.amplitude, "frequency": self.frequency,
                "fade_time": self.fade_time, "option": self.option}


@dataclass
class LogData:
    """A decoded run, one row per tick (``ticks``, sorted, unique). Missing
    values are NaN (floats) or -1 (integers)."""

    ticks: np.ndarray            #: (N,) int64
    state: np.ndarray            #: (N,) controller state (STATES index)
    faults: np.ndarray           #: (N,) CTRL_STATUS.Faults bits
    drive_mode: np.ndarray       #: (N,) 0 HOLD, 1 ACTIVE
    feedforward: np.ndarray      #: (N,) 0 off, 1 on
    estimate_valid: np.ndarray   #: (N,)
    fk_iterations: np.ndarray    #: (N,)
    reference: np.ndarray        #: (N, 6) CTRL_MONITOR Ref*, m / rad
    estimate: np.ndarray         #: (N, 6) CTRL_STATUS pose (NaN unless EstimateValid)
    length_sp: np.ndarray        #: (N, 6) CTRL_MONITOR LengthSp_i, m
    force_ff: np.ndarray         #: (N, 6) CTRL_MONITOR ForceFf_i, N
    axis_length_sp: np.ndarray   #: (N, 6) AXIS_SETPOINTS Length_s, m
    axis_mode: np.ndarray        #: (N, 2) AXIS_SETPOINTS Mode on axis_a, axis_b
    length: np.ndarray           #: (N, 6) AXIS_FEEDBACK Length (CANopen: TPDO1's count scaled), m
    pressure_a: np.ndarray       #: (N, 6) Pa (CANopen: CiA 408 TPDO2)
    pressure_b: np.ndarray       #: (N, 6) Pa
    drive_state: np.ndarray      #: (N, 6) DRIVE_STATES index (CANopen: the status word's, .canopen_legs)
    drive_faults: np.ndarray     #: (N, 6)
    est_wrench_valid: np.ndarray  #: (N,) CTRL_WRENCH Valid (-1: no frame on this tick)
    est_wrench: np.ndarray       #: (N, 6) CTRL_WRENCH Fx..Mz, N / N m (NaN unless Valid)
    commands: list[Command]
    stats: LogStats
    platform: Any = None
    home_lengths: np.ndarray | None = None  #: (6,) IK at the config's home pose, m
    piston_area: float = math.nan           #: m^2
    annulus_area: float = math.nan          #: m^2
    truth: dict[str, np.ndarray] | None = None  #: "pose", "length", "force", "wrench": (N, 6)
    source: str = ""
    force_mode: np.ndarray = None    #: (N,) CTRL_STATUS.ForceMode (FORCE_MODES index)
    cmd_rejected: np.ndarray = None  #: (N,) CTRL_STATUS.CmdRejected
    force_target: np.ndarray = None  #: (N, 6) the commanded wrench in FORCE (0 otherwise), N / N m
    force_frames: list = field(default_factory=list)  #: OP_FORCE as (executing tick, [fx..mz])
    #: the tool's pose in the work frame (.toolpose.attach_tool): "frames", "ref", "est"[, "truth"]; None
    #: with identity frames
    tool: dict | None = None

    @classmethod
    def empty(cls, ticks: np.ndarray, commands: list[Command], stats: LogStats, source: str) -> "LogData":
        """Every column for ``ticks`` missing (NaN or -1), to be filled by a decoder."""
        n = len(ticks)

        def fl(shape):
            return np.full(shape, np.nan)

        def it(shape):
            return np.full(shape, -1, dtype=np.int64)

        return cls(
            ticks=ticks, state=it(n), faults=it(n), drive_mode=it(n), feedforward=it(n),
            estimate_valid=it(n), fk_iterations=it(n), reference=fl((n, 6)), estimate=fl((n, 6)),
            length_sp=fl((n, 6)), force_ff=fl((n, 6)), axis_length_sp=fl((n, 6)), axis_mode=it((n, 2)),
            length=fl((n, 6)), pressure_a=fl((n, 6)), pressure_b=fl((n, 6)), drive_state=it((n, 6)),
            drive_faults=it((n, 6)), est_wrench_valid=it(n), est_wrench=fl((n, 6)), commands=commands,
            stats=stats, source=source, force_mode=it(n), cmd_rejected=it(n), force_target=fl((n, 6)))

    def __len__(self) -> int:
        return int(self.ticks.shape[0])

    @property
    def time_s(self) -> np.ndarray:
        return self.ticks.astype(float) * TICK_S

    @property
    def stretch(self) -> np.ndarray:
        """Measured leg length minus the home leg length, m (NaN without a platform)."""
        if self.home_lengths is None:
            return np.full_like(self.length, np.nan)
        return self.length - self.home_lengths[None, :]

    @property
    def force(self) -> np.ndarray:
        """Measured cylinder force p_A A_piston - p_B A_annulus, N."""
        return self.pressure_a * self.piston_area - self.pressure_b * self.annulus_area

    def index_of(self, ticks) -> np.ndarray:
        """Row index of each tick, -1 where the log has no such row."""
        ticks = np.asarray(ticks, dtype=np.int64)
        if len(self) == 0:
            return np.full(ticks.shape, -1, dtype=np.int64)
        idx = np.clip(np.searchsorted(self.ticks, ticks), 0, len(self) - 1)
        return np.where(self.ticks[idx] == ticks, idx, -1)

    def state_name(self, i: int) -> str:
        s = int(self.state[i])
        return STATES[s] if 0 <= s < len(STATES) else ("" if s < 0 else str(s))


def hydraulic_areas(platform) -> tuple[float, float]:
    """(piston area, annulus area), m^2, from the config's hydraulic section."""
    hyd = getattr(platform, "hydraulic", None) or {}
    if "piston_diameter" not in hyd:
        return math.nan, math.nan
    d = float(hyd["piston_diameter"])
    r = float(hyd.get("rod_diameter", 0.0))
    return math.pi * d * d / 4.0, math.pi * (d * d - r * r) / 4.0


class _Scaler:
    """Raw -> physical values of the messages' signals (from the DBC)."""

    def __init__(self, proto: pr.Protocol):
        self.scale: dict[int, dict[str, tuple[float, float, bool]]] = {}
        for m in proto.db.messages:
            self.scale[m.frame_id] = {
                s.name: (float(s.scale), float(s.offset), s.scale == 1 and s.offset == 0)
                for s in m.signals}

    def __call__(self, frame_id: int, raw: Mapping[str, int]) -> dict[str, float]:
        out = {}
        for k, v in raw.items():
            sc, off, is_int = self.scale[frame_id][k]
            out[k] = int(v) if is_int else v * sc + off
        return out


class _OnDemand(dict):
    """A dict whose missing keys are computed by ``fn(key)`` (and kept)."""

    def __init__(self, fn):
        super().__init__()
        self._fn = fn

    def __missing__(self, key):
        v = self[key] = self._fn(key)
        return v


def _unwrap16(echo: int, near: int) -> int:
    """The tick with low 16 bits ``echo`` nearest to ``near``."""
    base = near - ((near - echo) & 0xFFFF)
    return base + 0x10000 if near - base > 0x8000 else base


#: Messages whose Tick signal is the tick of their row.
TICK_MESSAGES = ("SYNC", "AXIS_SETPOINTS", "CTRL_STATUS", "CTRL_MONITOR", "CTRL_WRENCH")
_BUS_ORDER = tuple(pr.BUSES)


def _last_per_key(keys: np.ndarray) -> np.ndarray:
    """Indices of the last occurrence of each distinct key (keys in log
    order): the frame that wins when a tick has several."""
    if len(keys) == 0:
        return np.zeros(0, dtype=np.int64)
    rev = keys[::-1]
    _, first = np.unique(rev, return_index=True)
    return (len(keys) - 1 - first).astype(np.int64)


def _distinct(ticks: np.ndarray) -> np.ndarray:
    """``np.unique(ticks)``: marked in a table over their range when that is
    not much longer than the list (a log's ticks are about consecutive),
    which is cheaper than sorting them."""
    if len(ticks) == 0:
        return np.zeros(0, dtype=np.int64)
    lo, hi = int(ticks.min()), int(ticks.max())
    if hi - lo > 4 * len(ticks) + 4096:
        return np.unique(ticks)
    seen = np.zeros(hi - lo + 1, dtype=bool)
    seen[ticks - lo] = True
    return np.flatnonzero(seen).astype(np.int64) + lo


def _unwrap16_many(echo: np.ndarray, near: np.ndarray) -> np.ndarray:
    """:func:`_unwrap16` element-wise."""
    base = near - ((near - echo) & 0xFFFF)
    return np.where(near - base > 0x8000, base + 0x10000, base)


@dataclass
class _Accepted:
    """The accepted frames of one message on one bus."""

    name: str
    bus: str
    line_no: np.ndarray
    time: np.ndarray
    values: "_Signals"   #: physical values (cantools' conversion), by signal name


class _RawValues:
    """Raw values of one message's signals over the rows of its payload
    matrix, each taken out of the payloads when first asked for."""

    def __init__(self, layout, data: np.ndarray):
        from .framedecode import raw_values

        self._layout, self._data, self._raw_values = layout, data, raw_values
        self._done: dict[str, np.ndarray] = {}

    def __call__(self, name: str) -> np.ndarray:
        v = self._done.get(name)
        if v is None:
            v = self._done[name] = self._raw_values(self._data, self._layout.by_name[name])
        return v


class _Signals(Mapping):
    """Physical values of the accepted frames of one message on one bus, by
    signal name; ``rows``: their rows in the payload matrix (None: all).
    Each signal is decoded and scaled when first read: the analysis reads
    about half of the signals, and the rest cost nothing. A value set here
    (the unwrapped Tick) replaces the decoded one."""

    def __init__(self, layout, raw: _RawValues, rows: np.ndarray | None):
        self._layout, self._raw, self._rows = layout, raw, rows
        self._done: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        v = self._done.get(name)
        if v is None:
            r = self._raw(name)
            v = self._done[name] = self._layout.scale(name, r if self._rows is None else r[self._rows])
        return v

    def __setitem__(self, name: str, value: np.ndarray) -> None:
        self._done[name] = value

    def __iter__(self):
        return iter(self._layout.by_name)

    def __len__(self) -> int:
        return len(self._layout.by_name)


def _range_can_fail(signal, lim) -> bool:
    """Whether a raw value of the signal's bits can lie outside ``lim``."""
    if signal.is_float:
        return True
    lo, hi = ((-(1 << (signal.length - 1)), (1 << (signal.length - 1)) - 1) if signal.is_signed
              else (0, (1 << signal.length) - 1))
    return lim.lo > lo or lim.hi < hi


class _Rejections:
    """Counts rejected frames by kind into the stats and keeps a warning,
    (line, text), for each of the first ones."""

    def __init__(self, frames, bus: np.ndarray, stats: LogStats, warnings: list[tuple[int, str]]):
        self.frames, self.bus, self.stats, self.warnings = frames, bus, stats, warnings

    def __call__(self, kind: str, idx: np.ndarray, text) -> None:
        """Frames ``idx`` (indices into the log's frames) rejected as
        ``kind``; ``text(k)``: the reason for frame ``k``."""
        if len(idx) == 0:
            return
        self.stats.rejected[kind] = self.stats.rejected.get(kind, 0) + len(idx)
        for k in idx[:MAX_WARNINGS].tolist():
            b = _BUS_ORDER[self.bus[k]]
            self.warnings.append((int(self.frames.line_no[k]), f"line {self.frames.line_no[k]}: {b}: {text(k)}"))


def _check_frames(frames, ifmap: Mapping[str, str], proto: pr.Protocol, stats: LogStats,
                  warnings: list[tuple[int, str]]) -> list[_Accepted]:
    """The checks of :meth:`stewart.protocol.Protocol.receive` and the DBC's
    bus, on whole messages: known interface, known ID, exact length, CRC,
    alive counter per bus and message, value ranges, bus. Counts into
    ``stats``; warnings as (line, text)."""
    bus = _bus_of_frames(frames, ifmap, stats, warnings)
    reject = _Rejections(frames, bus, stats, warnings)
    known_ids = {int(m.frame_id): m for m in proto.db.messages}
    on_bus = bus >= 0
    not_dbc = on_bus & ~np.isin(frames.frame_id, list(known_ids))
    drive_bus = np.isin(bus, [_BUS_ORDER.index(b) for b in CANOPEN_BUSES])
    co = not_dbc & drive_bus & is_canopen_id(frames.frame_id)
    stats.canopen += int(co.sum())
    unknown = np.flatnonzero(not_dbc & ~co)
    reject(pr.UNKNOWN_ID, unknown,
           lambda k: str(pr.ProtocolError(pr.UNKNOWN_ID, f"no message has ID 0x{frames.frame_id[k]:X}",
                                          int(frames.frame_id[k]))))
    out: list[_Accepted] = []
    for fid, m in known_ids.items():
        sel = np.flatnonzero(on_bus & (frames.frame_id == fid))
        if len(sel):
            out += _check_message(m, proto.infos[m.name], sel, frames, reject)
    return out


def _bus_of_frames(frames, ifmap: Mapping[str, str], stats: LogStats,
                   warnings: list[tuple[int, str]]) -> np.ndarray:
    """Each frame's bus (index in _BUS_ORDER), -1 for an unknown interface
    (counted and warned)."""
    bus_of_iface = np.array([_BUS_ORDER.index(ifmap[n]) if n in ifmap else -1
                             for n in frames.ifaces], dtype=np.int64)
    bus = bus_of_iface[frames.iface] if len(frames.ifaces) else np.zeros(0, np.int64)
    unknown_if = np.flatnonzero(bus < 0)
    stats.unknown_interface += len(unknown_if)
    for k in unknown_if[:MAX_WARNINGS].tolist():
        warnings.append((int(frames.line_no[k]),
                         f"line {frames.line_no[k]}: unknown interface {frames.ifaces[frames.iface[k]]!r}"))
    return bus


def _check_message(m, info, sel: np.ndarray, frames, reject: _Rejections) -> list[_Accepted]:
    """The checks of one message's frames ``sel`` (indices into the log's
    frames, on known buses): length, CRC, counters, ranges, bus. The
    accepted ones by bus."""
    from .framedecode import MessageLayout

    fid = int(m.frame_id)
    bad_len = sel[frames.dlc[sel] != m.length]
    reject(pr.BAD_LENGTH, bad_len, lambda k: str(pr.ProtocolError(
        pr.BAD_LENGTH, f"{m.name} has {m.length} bytes, got {frames.dlc[k]}", fid)))
    sel = sel[frames.dlc[sel] == m.length]
    data = frames.data[sel, :m.length]
    crc = e2e.crc_ok_many(fid, data)
    if not crc.all():
        reject(pr.BAD_CRC, sel[~crc], lambda k: str(pr.ProtocolError(pr.BAD_CRC, f"{m.name}: CRC mismatch", fid)))
        sel, data = sel[crc], data[crc]
    layout = MessageLayout(m)
    raw = _RawValues(layout, data)
    bus_sel = reject.bus[sel]
    keep, lost = _check_counters(m, sel, bus_sel, raw, reject)
    bad_rng = _check_ranges(m, info, sel, raw, keep, reject)
    keep[bad_rng] = False
    keep &= ~_wrong_bus(m, info, sel, bus_sel, keep, frames, reject)
    if not keep.any():
        return []
    stats = reject.stats
    stats.accepted += int(keep.sum())
    stats.lost += int(lost[keep].sum())
    stats.per_message[m.name] = stats.per_message.get(m.name, 0) + int(keep.sum())
    return _by_bus(m.name, layout, raw, sel, keep, frames, reject.bus)


def _check_counters(m, sel: np.ndarray, bus_sel: np.ndarray, raw: _RawValues,
                    reject: _Rejections) -> tuple[np.ndarray, np.ndarray]:
    """(kept, frames lost before each) of the alive counter check per bus:
    repeated and out-of-sequence counters are rejected."""
    keep = np.ones(len(sel), dtype=bool)
    lost = np.zeros(len(sel), dtype=np.int64)
    fid = int(m.frame_id)
    for b in range(len(_BUS_ORDER)):
        on = np.flatnonzero(bus_sel == b)
        if len(on) == 0:
            continue
        codes, lost_b = e2e.check_counters(raw("Counter")[on])
        lost[on] = lost_b
        for kind in (pr.REPEATED, pr.WRONG_SEQUENCE):
            hit = on[codes == e2e.STATUS_CODES.index(kind)]
            keep[hit] = False
            reject(kind, sel[hit], lambda k, kind=kind: str(pr.ProtocolError(
                kind, f"{m.name} on {_BUS_ORDER[reject.bus[k]]}: counter "
                f"{int(raw('Counter')[np.searchsorted(sel, k)])}", fid)))
    return keep, lost


def _check_ranges(m, info, sel: np.ndarray, raw: _RawValues, keep: np.ndarray,
                  reject: _Rejections) -> np.ndarray:
    """The frames (rows of ``sel``) still kept with a value out of its
    range, rejected. In the order of the signals (the first one out is
    named); a signal whose bits cannot leave its range is not read."""
    first_bad = np.full(len(sel), -1, dtype=np.int64)
    for j, s in enumerate(m.signals):
        lim = info.limits[s.name]
        if not _range_can_fail(s, lim):
            continue
        r = raw(s.name)
        out_of = (r > lim.hi) if lim.lo <= 0 and not s.is_signed else ((r < lim.lo) | (r > lim.hi))
        if out_of.any():
            first_bad = np.where((first_bad < 0) & out_of & keep, j, first_bad)
    bad_rng = np.flatnonzero(first_bad >= 0)

    def range_text(k):
        i = int(np.searchsorted(sel, k))
        s = m.signals[int(first_bad[i])]
        lim = info.limits[s.name]
        return str(pr.ProtocolError(pr.OUT_OF_RANGE, f"{m.name}.{s.name} raw {int(raw(s.name)[i])} "
                                    f"outside {lim.lo}..{lim.hi}", int(m.frame_id)))

    reject(pr.OUT_OF_RANGE, sel[bad_rng], range_text)
    return bad_rng


def _wrong_bus(m, info, sel: np.ndarray, bus_sel: np.ndarray, keep: np.ndarray, frames,
               reject: _Rejections) -> np.ndarray:
    """Which of the frames still kept are on a bus the DBC does not put the
    message on (counted, warned)."""
    allowed = np.array([_BUS_ORDER[b] in info.buses for b in range(len(_BUS_ORDER))])
    wrong = keep & ~allowed[bus_sel]
    wb = sel[wrong]
    if len(wb):
        stats = reject.stats
        stats.rejected[WRONG_BUS] = stats.rejected.get(WRONG_BUS, 0) + len(wb)
        for k in wb[:MAX_WARNINGS].tolist():
            reject.warnings.append((int(frames.line_no[k]),
                                    f"line {frames.line_no[k]}: {m.name} on bus {_BUS_ORDER[reject.bus[k]]}, "
                                    f"the DBC puts it on {', '.join(info.buses)}"))
    return wrong


def _by_bus(name: str, layout, raw: _RawValues, sel: np.ndarray, keep: np.ndarray, frames,
            bus: np.ndarray) -> list[_Accepted]:
    """The kept frames of one message, one :class:`_Accepted` per bus."""
    out = []
    rows = None if keep.all() else np.flatnonzero(keep)   # rows of the payload matrix
    kept = sel if rows is None else sel[rows]
    buses_here = bus[kept]
    for b in range(len(_BUS_ORDER)):
        on = buses_here == b
        n_on = int(on.sum())
        if n_on == len(kept):   # all on one bus: no copies
            out.append(_Accepted(name, _BUS_ORDER[b], frames.line_no[kept], frames.time[kept],
                                 _Signals(layout, raw, rows)))
        elif n_on:
            on_rows = np.flatnonzero(on) if rows is None else rows[on]
            out.append(_Accepted(name, _BUS_ORDER[b], frames.line_no[kept[on]],
                                 frames.time[kept[on]], _Signals(layout, raw, on_rows)))
    return out


#: CTRL_STATUS's signals in LogData's columns, and AXIS_FEEDBACK_i's in the
#: leg columns (both decoders write them so).
STATUS_COLUMNS = (("state", "State"), ("faults", "Faults"), ("drive_mode", "DriveMode"),
                  ("feedforward", "FeedForward"), ("estimate_valid", "EstimateValid"),
                  ("fk_iterations", "FkIterations"), ("force_mode", "ForceMode"),
                  ("cmd_rejected", "CmdRejected"))
FEEDBACK_COLUMNS = (("length", "Length"), ("pressure_a", "PressureA"), ("pressure_b", "PressureB"),
                    ("drive_state", "State"), ("drive_faults", "Faults"))


def command_from(tick: int | None, time: float, value) -> Command:
    """The :class:`Command` of one OP_COMMAND frame; ``value(name)``: the
    frame's signal ``name``."""
    c = int(value("Command"))
    return Command(tick=tick, time=float(time), command=COMMANDS[c] if 0 <= c < len(COMMANDS) else str(c),
                   axis=int(value("Axis")), amplitude=float(value("Amplitude")),
                   frequency=float(value("Frequency")), fade_time=float(value("FadeTime")),
                   option=int(value("Option")))


def read_log(source: str | Path | Iterable[str], buses: str | Mapping[str, str] | None = None,
             platform=None, dbc_path: str | Path | None = None, frames=None) -> LogData:
    """Reads and checks a candump -L log (a path or an iterable of lines).

    ``buses``: the ``--bus`` text or a mapping {interface: bus}; default
    vcan0 = ops, vcan1 = axis_a, vcan2 = axis_b (and the bus names
    themselves). ``platform``: a validated :class:`stewart.config.Platform`
    for the stretch and the measured force (None: those columns are NaN),
    and with CANopen drives for their layout (None: their leg columns are
    NaN).

    Whole messages at once: the log's frames are parsed column-wise
    (:func:`.logfile.read_frames`), grouped by ID, checked (CRC, counters,
    ranges, bus) and decoded with the DBC's layout by numpy
    (:mod:`.framedecode`). The same result as the per-frame
    tools/dev/decode_reference.py (tests/python/test_framedecode.py).
    ``frames``: ``read_frames(source)`` when the caller has it already."""
    from .logfile import read_frames

    ifmap = parse_bus_map(buses) if buses is None or isinstance(buses, str) else dict(buses)
    proto = pr.Protocol(dbc_path)
    stats = LogStats()
    label = str(source) if isinstance(source, (str, Path)) else "<lines>"
    if frames is None:
        frames = read_frames(source)
    groups = _accepted_groups(frames, ifmap, proto, stats)
    order = _log_order(groups)
    rows = _rows_of(groups, order, stats)
    d = LogData.empty(rows.ticks, rows.commands, stats, label)
    _fill_controller_columns(d, groups, order)
    _fill_feedback_columns(d, groups, order, rows.feedback)
    if stats.canopen and platform is not None:  # CANopen drives: their TPDOs into the leg columns
        from .canopen_legs import TickFrames, fill_legs

        line_at = np.zeros(order.n, dtype=np.int64)
        time_at = np.zeros(order.n)
        for k, g in enumerate(groups):
            line_at[order.pos_in[k]] = g.line_no
            time_at[order.pos_in[k]] = g.time
        known = order.known
        fill_legs(d, frames, ifmap, TickFrames(line_at[known], order.tick_of[known], time_at[known]), platform)
    d.force_frames = rows.force_frames
    finish_rows(d, platform)
    return d


def _accepted_groups(frames, ifmap: Mapping[str, str], proto: pr.Protocol, stats: LogStats) -> list[_Accepted]:
    """The log's accepted frames by message and bus (:func:`_check_frames`);
    counts and warnings (in line order) into ``stats``."""
    stats.lines = frames.lines
    stats.malformed = len(frames.malformed)
    stats.frames = len(frames.line_no)
    warnings: list[tuple[int, str]] = list(frames.malformed[:MAX_WARNINGS])
    groups = _check_frames(frames, ifmap, proto, stats, warnings)
    warnings.sort(key=lambda w: w[0])
    for _, text in warnings[:MAX_WARNINGS]:
        stats.warn(text)
    return groups


@dataclass
class _LogOrder:
    """All accepted frames in log order (positions 0..n-1) and the ticks
    known there."""

    n: int
    pos_in: list[np.ndarray]  #: per group: its frames' positions
    tick_of: np.ndarray       #: (n,) the frame's tick where ``known``
    known: np.ndarray         #: (n,) the frame carries its tick
    prev_i: np.ndarray        #: (n,) the last position <= i with a tick, -1 if none
    next_i: np.ndarray        #: (n,) the first position >= i with a tick, n if none
    next_s: np.ndarray        #: (n,) the first CTRL_STATUS at or after i, n if none


def _log_order(groups: list[_Accepted]) -> _LogOrder:
    """The groups' frames in log order, their Tick signals unwrapped (set
    back into the groups). A frame's position is the rank of its line among
    the accepted frames' lines (a group's frames are in log order already)."""
    lines = np.concatenate([g.line_no for g in groups]) if groups else np.zeros(0, np.int64)
    n = len(lines)
    accepted = np.zeros(int(lines.max()) + 1 if n else 1, dtype=bool)
    accepted[lines] = True
    rank = np.cumsum(accepted) - 1
    tick_of = np.zeros(n, dtype=np.int64)
    known = np.zeros(n, dtype=bool)
    status_at = np.zeros(n, dtype=bool)
    pos_in: list[np.ndarray] = []
    for g in groups:
        pos = rank[g.line_no]
        pos_in.append(pos)
        if g.name in TICK_MESSAGES:
            tick_of[pos] = g.values["Tick"]
            known[pos] = True
        if g.name == "CTRL_STATUS":
            status_at[pos] = True
    if known.any():
        _unwrap_ticks(tick_of, known)
        for k, g in enumerate(groups):
            if g.name in TICK_MESSAGES:
                g.values["Tick"] = tick_of[pos_in[k]]
    ar = np.arange(n)
    prev_i = np.maximum.accumulate(np.where(known, ar, -1)) if n else ar
    next_i = np.minimum.accumulate(np.where(known, ar, n)[::-1])[::-1] if n else ar
    next_s = np.minimum.accumulate(np.where(status_at, ar, n)[::-1])[::-1] if n else ar
    return _LogOrder(n, pos_in, tick_of, known, prev_i, next_i, next_s)


def _unwrap_ticks(tick_of: np.ndarray, known: np.ndarray) -> None:
    """The Tick signal is a cycle number modulo 2^32 (it wraps after 49.7
    days): unwrapped in log order (in place, where ``known``), a step back
    by more than half the range being a lap forward (and the other way
    round)."""
    kp = np.flatnonzero(known)
    d = np.diff(tick_of[kp])
    laps = np.concatenate(([0], np.cumsum((d < -(1 << 31)).astype(np.int64) - (d > (1 << 31)))))
    tick_of[kp] += laps << 32


@dataclass
class _Rows:
    """What the groups give the rows: the ticks, the feedback frames and
    the operator's frames."""

    ticks: np.ndarray
    #: per AXIS_FEEDBACK group kept: (leg, ticks, group index, rows of the group)
    feedback: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]
    commands: list[Command]
    force_frames: list[tuple[int | None, list[float]]]


def _rows_of(groups: list[_Accepted], order: _LogOrder, stats: LogStats) -> _Rows:
    """The rows' ticks (every tick a frame is placed on), the feedback to
    place, the commands and the OP_FORCE frames with their executing tick."""
    row_ticks: list[np.ndarray] = []
    feedback = []
    commands: list[Command] = []
    stale_warn: list[tuple[int, str]] = []
    for k, g in enumerate(groups):
        if g.name in TICK_MESSAGES:
            row_ticks.append(np.asarray(g.values["Tick"], dtype=np.int64))
        elif g.name.startswith("AXIS_FEEDBACK_"):
            tick, ok = _feedback_ticks(g, order.pos_in[k], order, stats, stale_warn)
            leg = int(g.name[-1]) + (0 if g.bus == "axis_a" else 3)
            row_ticks.append(tick[ok])
            feedback.append((leg, tick[ok], np.full(int(ok.sum()), k), np.flatnonzero(ok)))
        elif g.name == "OP_COMMAND":
            for r, p_ in enumerate(order.pos_in[k].tolist()):
                commands.append(command_from(_executing_tick(order, p_), g.time[r],
                                             lambda s, g=g, r=r: g.values[s][r]))
    cmd_lines = [g.line_no for g in groups if g.name == "OP_COMMAND"]
    if len(cmd_lines) > 1:  # accepted on more than one bus: back to log order
        commands = [commands[i] for i in np.argsort(np.concatenate(cmd_lines), kind="stable")]
    stale_warn.sort(key=lambda w: w[0])
    for _, text in stale_warn:
        stats.warn(text)
    ticks = _distinct(np.concatenate(row_ticks)) if row_ticks else np.zeros(0, np.int64)
    return _Rows(ticks, feedback, commands, _force_frames(groups, order))


def _executing_tick(order: _LogOrder, pos: int) -> int | None:
    """The tick of the first CTRL_STATUS at or after log position ``pos``:
    the tick that executes an operator's frame there."""
    ns = int(order.next_s[pos])
    return int(order.tick_of[ns]) if ns < order.n else None


def _feedback_ticks(g: _Accepted, pos: np.ndarray, order: _LogOrder, stats: LogStats,
                    stale_warn: list[tuple[int, str]]) -> tuple[np.ndarray, np.ndarray]:
    """(tick, not stale) of an AXIS_FEEDBACK group's frames: TickEcho
    unwrapped to the nearest tick in the log; more than 1000 ticks from it
    is stale (counted, warned)."""
    n = order.n
    echo = np.asarray(g.values["TickEcho"], dtype=np.int64)
    pi, ni = order.prev_i[pos], order.next_i[pos]
    has = (pi >= 0) | (ni < n)
    near_i = np.where(pi >= 0, pi, np.minimum(ni, max(n - 1, 0)))
    near = order.tick_of[near_i] if n else near_i
    tick = np.where(has, _unwrap16_many(echo, near), echo)
    stale = has & (np.abs(tick - near) > 1000)
    stats.stale_feedback += int(stale.sum())
    for r in np.flatnonzero(stale)[:MAX_WARNINGS].tolist():
        stale_warn.append((int(g.line_no[r]),
                           f"line {g.line_no[r]}: {g.name} on {g.bus}: TickEcho {echo[r]} is "
                           f"{tick[r] - near[r]} ticks from the log's tick {near[r]}"))
    return tick, ~stale


def _force_frames(groups: list[_Accepted], order: _LogOrder) -> list[tuple[int | None, list[float]]]:
    """The OP_FORCE frames in log order: (executing tick, [fx..mz])."""
    force_frames: list[tuple[int | None, list[float], int]] = []
    for k, g in enumerate(groups):
        if g.name == "OP_FORCE":
            for r, p_ in enumerate(order.pos_in[k].tolist()):
                force_frames.append((_executing_tick(order, p_),
                                     [float(g.values[a][r]) for a in pr.WRENCH_SIGNALS], int(g.line_no[r])))
    force_frames.sort(key=lambda f: f[2])
    return [(tk, w) for tk, w, _ in force_frames]


def _merged(groups: list[_Accepted], order: _LogOrder, ticks: np.ndarray, name: str, bus: str | None = None):
    """(row index, values) of the last frame per tick of a message (all
    buses unless ``bus``), in log order; None without such frames."""
    parts = [k for k, g in enumerate(groups) if g.name == name and (bus is None or g.bus == bus)]
    if not parts:
        return None
    posv = np.concatenate([order.pos_in[k] for k in parts])
    o = np.argsort(posv, kind="stable")
    t = np.asarray(np.concatenate([groups[k].values["Tick"] for k in parts])[o], dtype=np.int64)
    last = _last_per_key(t)
    rows = o[last]   # of the parts' frames one after the other
    return np.searchsorted(ticks, t[last]), _OnDemand(
        lambda s: np.concatenate([groups[k].values[s] for k in parts])[rows])


def _fill_controller_columns(d: LogData, groups: list[_Accepted], order: _LogOrder) -> None:
    """The columns of CTRL_STATUS, CTRL_MONITOR, CTRL_WRENCH and
    AXIS_SETPOINTS: the last frame of each tick."""
    got = _merged(groups, order, d.ticks, "CTRL_STATUS")
    if got is not None:
        k, s = got
        for column, signal in STATUS_COLUMNS:
            getattr(d, column)[k] = s[signal]
        v = np.asarray(s["EstimateValid"]) != 0
        d.estimate[k[v]] = np.stack([s[a] for a in pr.POSE_SIGNALS], axis=1)[v]
    got = _merged(groups, order, d.ticks, "CTRL_MONITOR")
    if got is not None:
        k, s = got
        d.reference[k] = np.stack([s["Ref" + a] for a in pr.POSE_SIGNALS], axis=1)
        d.length_sp[k] = np.stack([s[f"LengthSp_{i}"] for i in range(1, 7)], axis=1)
        d.force_ff[k] = np.stack([s[f"ForceFf_{i}"] for i in range(1, 7)], axis=1)
    got = _merged(groups, order, d.ticks, "CTRL_WRENCH")
    if got is not None:
        k, s = got
        d.est_wrench_valid[k] = s["Valid"]
        v = np.asarray(s["Valid"]) != 0
        d.est_wrench[k[v]] = np.stack([s[a] for a in pr.WRENCH_SIGNALS], axis=1)[v]
    for b, bus in enumerate(("axis_a", "axis_b")):
        got = _merged(groups, order, d.ticks, "AXIS_SETPOINTS", bus)
        if got is not None:
            k, s = got
            d.axis_mode[k, b] = s["Mode"]
            d.axis_length_sp[k, 3 * b:3 * b + 3] = np.stack([s[f"Length_{j}"] for j in (1, 2, 3)], axis=1)


def _fill_feedback_columns(d: LogData, groups: list[_Accepted], order: _LogOrder,
                           feedback: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]) -> None:
    """The leg columns of AXIS_FEEDBACK_i: the last frame of each tick and leg."""
    for leg in range(1, 7):
        parts = [p for p in feedback if p[0] == leg]
        if not parts:
            continue
        t = np.concatenate([p[1] for p in parts])
        posv = np.concatenate([order.pos_in[p[2][0]][p[3]] if len(p[2]) else np.zeros(0, np.int64)
                               for p in parts])
        o = np.argsort(posv, kind="stable")
        t = t[o]
        last = _last_per_key(t)
        rows = o[last]   # of the parts' frames one after the other
        k = np.searchsorted(d.ticks, t[last])
        for column, signal in FEEDBACK_COLUMNS:
            getattr(d, column)[k, leg - 1] = np.concatenate([groups[p[2][0]].values[signal][p[3]] if len(p[2])
                                                             else np.zeros(0) for p in parts])[rows]


def finish_rows(d: LogData, platform) -> None:
    """What both decoders do last: the force targets, the check of
    CTRL_MONITOR's length setpoints against AXIS_SETPOINTS', the platform."""
    force_targets(d)
    both = ~np.isnan(d.length_sp).any(axis=1) & ~np.isnan(d.axis_length_sp).any(axis=1)
    d.stats.setpoint_checked = int(both.sum())
    d.stats.setpoint_mismatch = int((np.abs(d.length_sp - d.axis_length_sp)[both] > 1.5e-6).any(axis=1).sum())
    if platform is not None:
        set_platform(d, platform)


def set_platform(data: LogData, platform) -> None:
    """Attaches a platform: home leg lengths (float64 model IK at ``home``) and
    the hydraulic areas, for :attr:`LogData.stretch` and :attr:`LogData.force`."""
    data.platform = platform
    data.home_lengths = np.asarray(model.inverse_kinematics(platform, platform.home).lengths, float)
    data.piston_area, data.annulus_area = hydraulic_areas(platform)


FORCE_MODES = pr.value_names("CTRL_STATUS", "ForceMode")
#: signals.csv's control_mode of each ForceMode: RELEASE and HOLD follow
#: (or brake onto) the position reference.
CONTROL_MODES = {"OFF": "position", "FORCE": "force", "GUIDE": "guide", "RELEASE": "position", "HOLD": "position"}


def force_targets(d: LogData) -> None:
    """d.force_target from the OP_FORCE frames (d.force_frames) and
    CTRL_STATUS: the controller takes the last OP_FORCE with an accepted
    FORCE (entering FORCE, or a target update on the tick the frame is
    executed); a refused one (CmdRejected on that tick) leaves the target
    as it was. 0 outside FORCE (as sp_ctrl_output_t.force_target), NaN
    where no status was logged."""
    force = FORCE_MODES.index("FORCE")
    frames = sorted(((tk, w) for tk, w in d.force_frames if tk is not None), key=lambda f: f[0])
    mode = np.asarray(d.force_mode)
    valid = np.flatnonzero(mode >= 0)
    d.force_target[valid] = 0.0                 # outside FORCE; FORCE rows below
    prev = np.full(len(mode), -1, dtype=np.int64)  # the mode of the row logged before
    prev[valid[1:]] = mode[valid[:-1]]
    j = 0
    last = [0.0] * 6
    last_tick = None
    current = [0.0] * 6
    for k in np.flatnonzero(mode == force).tolist():  # in tick order, as the controller takes them
        t = int(d.ticks[k])
        while j < len(frames) and frames[j][0] <= t:
            last, last_tick = frames[j][1], frames[j][0]
            j += 1
        if not d.cmd_rejected[k] and (prev[k] != force or last_tick == t):
            current = list(last)
        d.force_target[k] = current
