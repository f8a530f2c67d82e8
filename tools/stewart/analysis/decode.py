"""Decoding a CAN log into a run: one row per control tick (:class:`LogData`).

:func:`read_log` parses the log line by line (:mod:`.logfile`), checks every
frame with :class:`stewart.protocol.Protocol` (CRC, alive counter per bus,
length, ranges) and the bus the DBC allows it on, and never stops on a bad
line: malformed lines and rejected frames are counted (``LogData.stats``).

Rows are control ticks. CTRL_STATUS, CTRL_MONITOR and CTRL_WRENCH carry the tick,
AXIS_SETPOINTS the tick of its SYNC, AXIS_FEEDBACK the low 16 bits of its
SYNC tick (``TickEcho``, unwrapped to the nearest tick seen in the log). In
both the lockstep and the real-time mode of ``sp_controller`` the
controller's tick equals the SYNC tick.

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
from .. import protocol as pr
from .logfile import parse_bus_map, parse_line
from .names import AXES, COMMANDS, STATES, TICK_S

#: Kinds of bad frames besides the protocol's rejections (pr.KINDS).
WRONG_BUS = "wrong-bus"
#: How many warning texts are kept (the counts are always complete).
MAX_WARNINGS = 50


@dataclass
class LogStats:
    """What was read and what was thrown away."""

    lines: int = 0
    frames: int = 0              #: well-formed frame lines
    accepted: int = 0            #: frames that passed every check
    malformed: int = 0           #: lines that are not frames
    unknown_interface: int = 0
    rejected: dict[str, int] = field(default_factory=dict)  #: bad frames by kind
    lost: int = 0                #: frames missing according to the alive counters
    per_message: dict[str, int] = field(default_factory=dict)
    stale_feedback: int = 0      #: feedback whose TickEcho no tick of the log matches
    setpoint_checked: int = 0    #: ticks with both CTRL_MONITOR and AXIS_SETPOINTS
    setpoint_mismatch: int = 0   #: of which the length setpoints differ by > 1 um
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
                "bad_frames": self.bad_frames, "rejected": dict(sorted(self.rejected.items())),
                "lost_frames": self.lost, "per_message": dict(sorted(self.per_message.items())),
                "stale_feedback": self.stale_feedback,
                "setpoint_checked": self.setpoint_checked,
                "setpoint_mismatch": self.setpoint_mismatch,
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
    length: np.ndarray           #: (N, 6) AXIS_FEEDBACK Length, m
    pressure_a: np.ndarray       #: (N, 6) Pa
    pressure_b: np.ndarray       #: (N, 6) Pa
    drive_state: np.ndarray      #: (N, 6)
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


def _unwrap16(echo: int, near: int) -> int:
    """The tick with low 16 bits ``echo`` nearest to ``near``."""
    base = near - ((near - echo) & 0xFFFF)
    return base + 0x10000 if near - base > 0x8000 else base


def read_log(source: str | Path | Iterable[str], buses: str | Mapping[str, str] | None = None,
             platform=None, dbc_path: str | Path | None = None) -> LogData:
    """Reads and checks a candump -L log (a path or an iterable of lines).

    ``buses``: the ``--bus`` text or a mapping {interface: bus}; default
    vcan0 = ops, vcan1 = axis_a, vcan2 = axis_b (and the bus names
    themselves). ``platform``: a validated :class:`stewart.config.Platform`
    for the stretch and the measured force (None: those columns are NaN)."""
    ifmap = parse_bus_map(buses) if buses is None or isinstance(buses, str) else dict(buses)
    proto = pr.Protocol(dbc_path)
    scaler = _Scaler(proto)
    stats = LogStats()
    if isinstance(source, (str, Path)):
        label = str(source)
        fh = open(source, "r", encoding="utf-8", errors="replace")
        lines: Iterable[str] = fh
    else:
        label = "<lines>"
        fh = None
        lines = source

    # First pass: good frames in log order, (kind, bus, name, signals, time).
    accepted: list[tuple[str, str, dict[str, float], float, int]] = []
    try:
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
    finally:
        if fh is not None:
            fh.close()

    # Ticks of the tick-bearing frames, in log order, for TickEcho unwrapping
    # and for the command -> executing tick assignment.
    n = len(accepted)
    known = [None] * n
    for i, (name, _bus, sig, _t, _ln) in enumerate(accepted):
        if name in ("SYNC", "AXIS_SETPOINTS", "CTRL_STATUS", "CTRL_MONITOR", "CTRL_WRENCH"):
            known[i] = int(sig["Tick"])
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

    rows: dict[int, dict[str, Any]] = {}

    def row(t: int) -> dict[str, Any]:
        r = rows.get(t)
        if r is None:
            r = rows[t] = {}
        return r

    commands: list[Command] = []
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
            c = int(sig["Command"])
            commands.append(Command(
                tick=next_status[i], time=t_log,
                command=COMMANDS[c] if 0 <= c < len(COMMANDS) else str(c),
                axis=int(sig["Axis"]), amplitude=float(sig["Amplitude"]),
                frequency=float(sig["Frequency"]), fade_time=float(sig["FadeTime"]),
                option=int(sig["Option"])))
        # OP_TARGET_POSE: not needed for the analysis (the reference is in CTRL_MONITOR)

    ticks = np.array(sorted(rows), dtype=np.int64)
    N = len(ticks)

    def fl(shape):
        return np.full(shape, np.nan)

    def it(shape):
        return np.full(shape, -1, dtype=np.int64)

    d = LogData(
        ticks=ticks, state=it(N), faults=it(N), drive_mode=it(N), feedforward=it(N),
        estimate_valid=it(N), fk_iterations=it(N), reference=fl((N, 6)), estimate=fl((N, 6)),
        length_sp=fl((N, 6)), force_ff=fl((N, 6)), axis_length_sp=fl((N, 6)), axis_mode=it((N, 2)),
        length=fl((N, 6)), pressure_a=fl((N, 6)), pressure_b=fl((N, 6)), drive_state=it((N, 6)),
        drive_faults=it((N, 6)), est_wrench_valid=it(N), est_wrench=fl((N, 6)), commands=commands,
        stats=stats, source=label)
    for k, t in enumerate(ticks):
        r = rows[int(t)]
        s = r.get("status")
        if s is not None:
            d.state[k] = s["State"]
            d.faults[k] = s["Faults"]
            d.drive_mode[k] = s["DriveMode"]
            d.feedforward[k] = s["FeedForward"]
            d.estimate_valid[k] = s["EstimateValid"]
            d.fk_iterations[k] = s["FkIterations"]
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
                j = leg - 1
                d.length[k, j] = fb["Length"]
                d.pressure_a[k, j] = fb["PressureA"]
                d.pressure_b[k, j] = fb["PressureB"]
                d.drive_state[k, j] = fb["State"]
                d.drive_faults[k, j] = fb["Faults"]
    both = ~np.isnan(d.length_sp).any(axis=1) & ~np.isnan(d.axis_length_sp).any(axis=1)
    stats.setpoint_checked = int(both.sum())
    stats.setpoint_mismatch = int((np.abs(d.length_sp - d.axis_length_sp)[both] > 1.5e-6).any(axis=1).sum())
    if platform is not None:
        set_platform(d, platform)
    return d


def set_platform(data: LogData, platform) -> None:
    """Attaches a platform: home leg lengths (float64 model IK at ``home``) and
    the hydraulic areas, for :attr:`LogData.stretch` and :attr:`LogData.force`."""
    data.platform = platform
    data.home_lengths = np.asarray(model.inverse_kinematics(platform, platform.home).lengths, float)
    data.piston_area, data.annulus_area = hydraulic_areas(platform)
