"""Analysis of a closed-loop run: a CAN log (candump -L format) in, a per-tick
CSV, the motion segments, tracking errors, plots and a summary out.

The theory and the reasons behind every choice (tick alignment, the one-tick
delay of the tracking error, measured force from the chamber pressures) are
in docs/analysis.md. In short:

* :func:`read_log` parses the log line by line, checks every frame with
  :class:`stewart.protocol.Protocol` (CRC, alive counter per bus, length,
  ranges) and the bus the DBC allows it on, and never stops on a bad line:
  malformed lines and rejected frames are counted (``LogData.stats``).
* Rows are control ticks. CTRL_STATUS and CTRL_MONITOR carry the tick,
  AXIS_SETPOINTS the tick of its SYNC, AXIS_FEEDBACK the low 16 bits of its
  SYNC tick (``TickEcho``, unwrapped to the nearest tick seen in the log).
  In both the lockstep and the real-time mode of ``sp_controller`` the
  controller's tick equals the SYNC tick.
* :func:`find_segments` finds the RUNNING intervals and labels each with the
  operator command that started it (OP_COMMAND RUN_TRIG, MOVE_TO, STREAM).
* :func:`tracking_error` is ``estimate(t) - reference(t - d)``, d = 1 tick.

Python API (numbers are numpy arrays in SI units: m, rad, N, Pa)::

    data = read_log("run.log", buses=None, platform=cfg.load(...))
    truth = read_truth("truth.csv")          # optional
    attach_truth(data, truth)
    segs = find_segments(data)
    err = tracking_error(data, delay_ticks=1)             # (N, 6)
    m = segment_metrics(data, segs[0], delay_ticks=1)     # dict
    summary = summarize(data, segs, delay_ticks=1)        # dict (summary.json)
    write_signals_csv(data, "signals.csv")
    analyze("run.log", "out/", truth="truth.csv")         # everything
"""

from __future__ import annotations

import csv
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from . import REPO_ROOT
from . import config as cfg
from . import model
from . import protocol as pr

DEFAULT_PLATFORM = REPO_ROOT / "config" / "platform_default.json"
#: Nominal control period, s (1 tick = 1 ms).
TICK_S = 1e-3
#: Default delay of the tracking error, ticks (docs/analysis.md).
DEFAULT_DELAY_TICKS = 1
#: Fade-in/out of RUN_TRIG when OP_COMMAND.FadeTime is 0 (sp_ctrl_default_config: 2 s).
DEFAULT_FADE_S = 2.0

AXES = ("x", "y", "z", "roll", "pitch", "yaw")
#: The motion along each axis, for the labels.
MOTIONS = ("surge", "sway", "heave", "roll", "pitch", "yaw")
STATES = ("IDLE", "ENGAGING", "READY", "RUNNING", "PARKING", "FAULT", "ESTOP")
DRIVE_STATES = ("INIT", "HOLD", "ACTIVE", "FAULT")
COMMANDS = ("NONE", "ENGAGE", "RUN_TRIG", "MOVE_TO", "STREAM", "STOP", "PARK", "ESTOP", "RESET",
            "SET_FEEDFORWARD")
RUNNING = STATES.index("RUNNING")
#: Commands that start a RUNNING interval.
MOTION_COMMANDS = ("RUN_TRIG", "MOVE_TO", "STREAM")
#: Commands that end one.
STOP_COMMANDS = ("STOP", "PARK", "ESTOP")
#: Kinds of bad frames besides the protocol's rejections (pr.KINDS).
WRONG_BUS = "wrong-bus"
#: How many warning texts are kept (the counts are always complete).
MAX_WARNINGS = 50

LEGS = 6


def is_angle(axis: int) -> bool:
    return axis >= 3


def axis_unit(axis: int, scaled: bool = True) -> str:
    """'mm' / 'mrad' (scaled for errors) or 'm' / 'rad'."""
    if scaled:
        return "mrad" if is_angle(axis) else "mm"
    return "rad" if is_angle(axis) else "m"


# ---------------------------------------------------------------------------
# the log format
# ---------------------------------------------------------------------------

_LINE = re.compile(r"^\((\d+(?:\.\d*)?)\)\s+(\S+)\s+([0-9A-Fa-f]{1,8})(##|#)(\S*)$")


@dataclass
class LogFrame:
    """One frame of a candump -L line."""

    time: float        #: log timestamp, s
    iface: str         #: interface name as logged (vcan0, ...)
    frame_id: int
    data: bytes
    fd: bool
    flags: int = 0     #: CAN FD flags nibble (bit 0 BRS, bit 1 ESI)
    line_no: int = 0


def parse_line(line: str, line_no: int = 0) -> LogFrame:
    """Parses one candump -L line, ``(TIME) IFACE ID#DATA`` (classic) or
    ``(TIME) IFACE ID##FDATA`` (CAN FD, F = flags nibble). Raises ValueError
    with the reason for anything else (remote frames included)."""
    m = _LINE.match(line.strip())
    if m is None:
        raise ValueError("not a candump -L frame line")
    t, iface, ident, sep, rest = m.groups()
    fd = sep == "##"
    flags = 0
    if fd:
        if not rest:
            raise ValueError("CAN FD frame without its flags nibble")
        flags = int(rest[0], 16) if rest[0] in "0123456789abcdefABCDEF" else -1
        if flags < 0:
            raise ValueError(f"bad CAN FD flags {rest[0]!r}")
        rest = rest[1:]
    if rest[:1] in ("R", "r"):
        raise ValueError("remote frame")
    if len(rest) % 2:
        raise ValueError("odd number of data digits")
    try:
        data = bytes.fromhex(rest)
    except ValueError:
        raise ValueError("data is not hexadecimal") from None
    if len(data) > (64 if fd else 8):
        raise ValueError(f"{len(data)} data bytes in a {'CAN FD' if fd else 'classic'} frame")
    frame_id = int(ident, 16)
    if len(ident) > 3:
        frame_id |= 0x80000000  # candump writes extended IDs with 8 digits
    return LogFrame(float(t), iface, frame_id, data, fd, flags, line_no)


def format_line(time_s: float, iface: str, frame_id: int, data: bytes, fd: bool = True,
                flags: int = 1) -> str:
    """One candump -L line (the inverse of :func:`parse_line`)."""
    us = int(round(time_s * 1e6))
    head = f"({us // 1_000_000:010d}.{us % 1_000_000:06d}) {iface} {frame_id:03X}"
    if fd:
        return f"{head}##{flags:X}{bytes(data).hex().upper()}"
    return f"{head}#{bytes(data).hex().upper()}"


def parse_bus_map(text: str | None) -> dict[str, str]:
    """``ops=vcan0,axis_a=vcan1,axis_b=vcan2`` -> {interface: bus}. Buses not
    given keep their default interface; a bus name is always accepted as an
    interface name too."""
    ifaces = dict(pr.BUSES)
    if text:
        for part in text.split(","):
            part = part.strip()
            if not part:
                continue
            bus, sep, iface = part.partition("=")
            bus, iface = bus.strip(), iface.strip()
            if not sep or bus not in pr.BUSES or not iface:
                raise ValueError(f"--bus: {part!r} is not BUS=IFACE with BUS one of "
                                 f"{', '.join(pr.BUSES)}")
            ifaces[bus] = iface
    if len(set(ifaces.values())) != len(ifaces):
        raise ValueError(f"--bus: two buses on one interface: "
                         f"{', '.join(f'{b}={i}' for b, i in ifaces.items())}")
    out = {iface: bus for bus, iface in ifaces.items()}
    for bus in pr.BUSES:
        out.setdefault(bus, bus)
    return out


# ---------------------------------------------------------------------------
# the decoded run
# ---------------------------------------------------------------------------

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
    commands: list[Command]
    stats: LogStats
    platform: Any = None
    home_lengths: np.ndarray | None = None  #: (6,) IK at the config's home pose, m
    piston_area: float = math.nan           #: m^2
    annulus_area: float = math.nan          #: m^2
    truth: dict[str, np.ndarray] | None = None  #: "pose" (N,6), "length" (N,6), "force" (N,6)
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
        if name in ("SYNC", "AXIS_SETPOINTS", "CTRL_STATUS", "CTRL_MONITOR"):
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
        drive_faults=it((N, 6)), commands=commands, stats=stats, source=label)
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


# ---------------------------------------------------------------------------
# truth
# ---------------------------------------------------------------------------

TRUTH_COLUMNS = (["tick"] + list(AXES) + [f"len{i}" for i in range(1, 7)]
                 + [f"force{i}" for i in range(1, 7)])


def read_truth(path: str | Path) -> dict[str, np.ndarray]:
    """The plant's truth CSV: tick, x, y, z, roll, pitch, yaw, len1..6,
    force1..6 (SI), extra columns ignored; with or without the header line.
    Returns {"tick": (M,), "pose": (M,6), "length": (M,6), "force": (M,6)}.
    Unreadable rows are skipped (counted in "bad_rows")."""
    ticks, pose, length, force = [], [], [], []
    bad = 0
    with open(path, newline="") as f:
        reader = csv.reader(f)
        cols = None
        for n, rec in enumerate(reader):
            if not rec or not "".join(rec).strip():
                continue
            if n == 0 and not rec[0].strip().lstrip("-").isdigit():
                names = [c.strip() for c in rec]
                missing = [c for c in TRUTH_COLUMNS if c not in names]
                if missing:
                    raise ValueError(f"{path}: truth CSV lacks column(s) {', '.join(missing)}")
                cols = [names.index(c) for c in TRUTH_COLUMNS]
                continue
            idx = cols if cols is not None else list(range(len(TRUTH_COLUMNS)))
            try:
                vals = [float(rec[i]) for i in idx]
            except (ValueError, IndexError):
                bad += 1
                continue
            ticks.append(int(vals[0]))
            pose.append(vals[1:7])
            length.append(vals[7:13])
            force.append(vals[13:19])
    return {"tick": np.array(ticks, dtype=np.int64), "pose": np.array(pose).reshape(-1, 6),
            "length": np.array(length).reshape(-1, 6), "force": np.array(force).reshape(-1, 6),
            "bad_rows": np.array(bad)}


def attach_truth(data: LogData, truth: Mapping[str, np.ndarray]) -> None:
    """Puts the truth rows on the log's ticks (truth tick t = the plant state
    sampled for the feedback of SYNC t); ticks without truth stay NaN."""
    out = {k: np.full((len(data), 6), np.nan) for k in ("pose", "length", "force")}
    idx = data.index_of(truth["tick"])
    ok = idx >= 0
    for k in out:
        out[k][idx[ok]] = np.asarray(truth[k])[ok]
    data.truth = out


# ---------------------------------------------------------------------------
# errors and segments
# ---------------------------------------------------------------------------

def _wrap(e: np.ndarray) -> np.ndarray:
    """Angle differences into (-pi, pi]."""
    return (e + np.pi) % (2 * np.pi) - np.pi


def delayed(data: LogData, values: np.ndarray, delay_ticks: int) -> np.ndarray:
    """values(t - delay) on each row's tick (NaN where the log has no such tick)."""
    idx = data.index_of(data.ticks - int(delay_ticks))
    out = np.full_like(values, np.nan, dtype=float)
    ok = idx >= 0
    out[ok] = values[idx[ok]]
    return out


def tracking_error(data: LogData, delay_ticks: int = DEFAULT_DELAY_TICKS,
                   pose: np.ndarray | None = None) -> np.ndarray:
    """(N, 6) error ``pose(t) - reference(t - d)``, m / rad (angles wrapped);
    ``pose`` defaults to the controller's estimate (pass ``data.truth['pose']``
    for the true tracking error)."""
    p = data.estimate if pose is None else pose
    e = p - delayed(data, data.reference, delay_ticks)
    e[:, 3:] = _wrap(e[:, 3:])
    return e


@dataclass
class Segment:
    """One RUNNING interval (ticks ``start``..``end`` inclusive)."""

    index: int
    start: int
    end: int
    command: str | None = None     #: RUN_TRIG, MOVE_TO, STREAM or None (not in the log)
    axis: int | None = None        #: moving axis (0..5)
    amplitude: float | None = None
    frequency: float | None = None
    fade_time: float | None = None
    stop_tick: int | None = None   #: tick of the STOP/PARK/ESTOP that ended it
    feedforward: str = "?"         #: on, off, mixed, ?
    label: str = ""

    @property
    def duration_s(self) -> float:
        return (self.end - self.start + 1) * TICK_S

    def mask(self, data: LogData) -> np.ndarray:
        return (data.ticks >= self.start) & (data.ticks <= self.end)

    def steady(self) -> tuple[int, int]:
        """Ticks of the full-amplitude part of a RUN_TRIG (after the fade-in,
        before the stop); the whole segment for other motions."""
        if self.command != "RUN_TRIG":
            return self.start, self.end
        fade = self.fade_time if self.fade_time else DEFAULT_FADE_S
        a = self.start + int(round(fade / TICK_S))
        b = self.stop_tick if self.stop_tick is not None else self.end - int(round(fade / TICK_S))
        if b <= a:
            return self.start, self.end
        return a, min(b, self.end)

    def as_dict(self) -> dict[str, Any]:
        return {"index": self.index, "label": self.label, "start_tick": self.start,
                "end_tick": self.end, "duration_s": self.duration_s, "command": self.command,
                "axis": AXES[self.axis] if self.axis is not None else None,
                "amplitude": self.amplitude, "frequency": self.frequency,
                "fade_time": self.fade_time, "stop_tick": self.stop_tick,
                "feedforward": self.feedforward, "steady_ticks": list(self.steady())}


def _label(seg: Segment) -> str:
    ff = f"ff={seg.feedforward}"
    if seg.axis is None:
        return f"{(seg.command or 'running').lower()} {ff}"
    ax = seg.axis
    motion = MOTIONS[ax] if MOTIONS[ax] == AXES[ax] else f"{MOTIONS[ax]} {AXES[ax]}"
    if seg.command == "RUN_TRIG":
        return (f"{motion} {seg.amplitude:.3f} {axis_unit(ax, False)} {seg.frequency:g} Hz {ff}")
    what = (seg.command or "running").lower().replace("_", "-")
    amp = f" {seg.amplitude:.3f} {axis_unit(ax, False)}" if seg.amplitude is not None else ""
    return f"{what} {motion}{amp} {ff}"


def find_segments(data: LogData) -> list[Segment]:
    """The RUNNING intervals, each labelled from the operator command that
    started it (the last RUN_TRIG/MOVE_TO/STREAM executed at or before its
    first tick and after the previous interval) and from CTRL_STATUS's
    FeedForward flag. Rows without a status do not split an interval. Without
    a command the moving axis is the one whose reference moved most."""
    known = data.state >= 0
    ticks = data.ticks[known]
    run = data.state[known] == RUNNING
    intervals: list[tuple[int, int]] = []
    start = None
    for k in range(len(ticks)):
        if run[k] and start is None:
            start = k
        elif not run[k] and start is not None:
            intervals.append((int(ticks[start]), int(ticks[k - 1])))
            start = None
    if start is not None:
        intervals.append((int(ticks[start]), int(ticks[-1])))
    segs = []
    prev_end = None
    for n, (a, b) in enumerate(intervals):
        seg = Segment(n + 1, a, b)
        cands = [c for c in data.commands if c.command in MOTION_COMMANDS and c.tick is not None
                 and c.tick <= a and (prev_end is None or c.tick > prev_end)]
        if cands:
            c = cands[-1]
            seg.command = c.command
            if c.command == "RUN_TRIG":
                seg.axis, seg.amplitude, seg.frequency = c.axis, c.amplitude, c.frequency
                seg.fade_time = c.fade_time if c.fade_time > 0 else DEFAULT_FADE_S
        stops = [c for c in data.commands if c.command in STOP_COMMANDS and c.tick is not None
                 and a <= c.tick <= b]
        if stops:
            seg.stop_tick = stops[0].tick
        m = seg.mask(data)
        ref = data.reference[m]
        if seg.axis is None and np.isfinite(ref).any():
            span = np.nanmax(ref, axis=0) - np.nanmin(ref, axis=0)
            span = np.nan_to_num(span, nan=0.0)
            if span.max() > 0:
                seg.axis = int(np.argmax(span))
                centre = ref[0, seg.axis]
                seg.amplitude = float(np.nanmax(np.abs(ref[:, seg.axis] - centre)))
        ff = data.feedforward[m]
        ff = ff[ff >= 0]
        if len(ff):
            seg.feedforward = "on" if ff.all() else ("off" if not ff.any() else "mixed")
        seg.label = _label(seg)
        segs.append(seg)
        prev_end = b
    return segs


def _stats(e: np.ndarray, scale: float) -> dict[str, float | int]:
    e = e[np.isfinite(e)]
    if len(e) == 0:
        return {"rms": None, "max": None, "mean": None, "n": 0}
    return {"rms": float(np.sqrt(np.mean(e * e)) * scale), "max": float(np.max(np.abs(e)) * scale),
            "mean": float(np.mean(e) * scale), "n": int(len(e))}


def error_metrics(err: np.ndarray, mask: np.ndarray) -> dict[str, dict]:
    """RMS, max |error| and mean per axis over the rows of ``mask`` (finite
    values only; ``n`` of them), in mm / mrad."""
    return {AXES[a]: dict(_stats(err[mask, a], 1e3), unit=axis_unit(a)) for a in range(6)}


def segment_metrics(data: LogData, seg: Segment, delay_ticks: int = DEFAULT_DELAY_TICKS) -> dict[str, Any]:
    """Tracking error (estimate and, with truth, the true pose), estimation
    error (estimate - truth, same tick) and peak forces of one segment."""
    m = seg.mask(data)
    out: dict[str, Any] = dict(seg.as_dict())
    err = tracking_error(data, delay_ticks)
    out["error"] = error_metrics(err, m)
    out["moving_axis_error"] = out["error"][AXES[seg.axis]] if seg.axis is not None else None
    a, b = seg.steady()
    ms = (data.ticks >= a) & (data.ticks <= b)
    out["steady_error"] = error_metrics(err, ms)
    if data.truth is not None:
        et = tracking_error(data, delay_ticks, pose=data.truth["pose"])
        out["truth_error"] = error_metrics(et, m)
        out["moving_axis_truth_error"] = (out["truth_error"][AXES[seg.axis]]
                                          if seg.axis is not None else None)
        ee = data.estimate - data.truth["pose"]
        ee[:, 3:] = _wrap(ee[:, 3:])
        out["estimation_error"] = error_metrics(ee, m)
    ff = np.abs(data.force_ff[m])
    fm = np.abs(data.force[m])
    out["peak_force_ff_N"] = [float(np.nanmax(c)) if np.isfinite(c).any() else None for c in ff.T]
    out["peak_force_measured_N"] = [float(np.nanmax(c)) if np.isfinite(c).any() else None for c in fm.T]
    if data.truth is not None:
        ft = np.abs(data.truth["force"][m])
        out["peak_force_truth_N"] = [float(np.nanmax(c)) if np.isfinite(c).any() else None for c in ft.T]
    d = data.force[m] - data.force_ff[m]
    out["force_measured_minus_ff_rms_N"] = [_stats(c, 1.0)["rms"] for c in d.T]
    st = data.stretch[m]
    out["stretch_range_mm"] = [[float(np.nanmin(c) * 1e3), float(np.nanmax(c) * 1e3)]
                               if np.isfinite(c).any() else None for c in st.T]
    return out


def _clean(obj):
    """NaN and infinities -> None, numpy scalars -> Python (for JSON)."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _max_or_none(v: list) -> float | None:
    v = [x for x in v if x is not None]
    return max(v) if v else None


def summarize(data: LogData, segments: list[Segment] | None = None,
              delay_ticks: int = DEFAULT_DELAY_TICKS) -> dict[str, Any]:
    """Everything summary.json holds."""
    if segments is None:
        segments = find_segments(data)
    faults = 0
    for f in data.faults[data.faults >= 0]:
        faults |= int(f)
    dfaults = []
    for j in range(6):
        bits = 0
        for f in data.drive_faults[:, j][data.drive_faults[:, j] >= 0]:
            bits |= int(f)
        dfaults.append(pr.fault_names(bits, pr.DRIVE_FAULTS))
    known = np.nonzero(data.state >= 0)[0]
    final = data.state_name(int(known[-1])) if len(known) else None
    visited = []
    for s in data.state[data.state >= 0]:
        name = STATES[int(s)] if 0 <= s < len(STATES) else str(int(s))
        if not visited or visited[-1] != name:
            visited.append(name)
    segs = [segment_metrics(data, s, delay_ticks) for s in segments]
    return {
        "log": data.source,
        "ticks": {"first": int(data.ticks[0]) if len(data) else None,
                  "last": int(data.ticks[-1]) if len(data) else None, "rows": len(data)},
        "duration_s": float((data.ticks[-1] - data.ticks[0] + 1) * TICK_S) if len(data) else 0.0,
        "delay_ticks": int(delay_ticks),
        "frames": data.stats.as_dict(),
        "bad_frames": data.stats.bad_frames,
        "malformed_lines": data.stats.malformed,
        "faults_seen": pr.fault_names(faults, pr.CONTROLLER_FAULTS),
        "drive_faults_seen": {f"leg{j + 1}": dfaults[j] for j in range(6) if dfaults[j]},
        "final_state": final,
        "states": visited,
        "commands": [c.as_dict() for c in data.commands],
        "truth": data.truth is not None,
        "segments": segs,
        "peak_force_ff_N": _max_or_none([_max_or_none(s["peak_force_ff_N"]) for s in segs]),
        "peak_force_measured_N": _max_or_none([_max_or_none(s["peak_force_measured_N"]) for s in segs]),
    }


def _fmt(v, spec=".3f") -> str:
    return "-" if v is None else format(v, spec)


def format_summary(summary: Mapping[str, Any]) -> str:
    """The printed human summary."""
    fr = summary["frames"]
    lines = [f"log {summary['log']}: ticks {summary['ticks']['first']}..{summary['ticks']['last']} "
             f"({summary['duration_s']:.3f} s), final state {summary['final_state']}",
             f"frames: {fr['frames']} read, {fr['accepted']} accepted, bad {summary['bad_frames']}"
             + (f" ({', '.join(f'{k} {v}' for k, v in fr['rejected'].items())})" if fr["rejected"] else "")
             + f", malformed lines {fr['malformed_lines']}, lost {fr['lost_frames']}"
             + (f", unknown interface {fr['unknown_interface']}" if fr["unknown_interface"] else "")
             + (f", stale feedback {fr['stale_feedback']}" if fr["stale_feedback"] else ""),
             f"states: {' -> '.join(summary['states']) or '-'}; controller faults seen: "
             f"{', '.join(summary['faults_seen']) or 'none'}"
             + ("; drive faults: " + ", ".join(f"{k} {'+'.join(v)}" for k, v in
                                                summary["drive_faults_seen"].items())
                if summary["drive_faults_seen"] else ""),
             f"tracking error = estimate(t) - reference(t - {summary['delay_ticks']} tick)"]
    if fr["setpoint_checked"] and fr["setpoint_mismatch"]:
        lines.append(f"WARNING: CTRL_MONITOR and AXIS_SETPOINTS length setpoints differ on "
                     f"{fr['setpoint_mismatch']} of {fr['setpoint_checked']} ticks")
    if not summary["segments"]:
        lines.append("no RUNNING segment")
    for s in summary["segments"]:
        lines.append(f"segment {s['index']}: {s['label']}, ticks {s['start_tick']}..{s['end_tick']} "
                     f"({s['duration_s']:.3f} s)")
        me = s["moving_axis_error"]
        if me is not None:
            lines.append(f"  moving axis {s['axis']}: RMS {_fmt(me['rms'])} {me['unit']}, "
                         f"max {_fmt(me['max'])} {me['unit']}")
            if s.get("moving_axis_truth_error"):
                te = s["moving_axis_truth_error"]
                lines.append(f"  against truth:  RMS {_fmt(te['rms'])} {te['unit']}, "
                             f"max {_fmt(te['max'])} {te['unit']}")
        lines.append("  all axes RMS/max: " + "; ".join(
            f"{a} {_fmt(v['rms'])}/{_fmt(v['max'])} {v['unit']}" for a, v in s["error"].items()))
        lines.append(f"  peak force: feed-forward {_fmt(_max_or_none(s['peak_force_ff_N']), '.0f')} N, "
                     f"measured {_fmt(_max_or_none(s['peak_force_measured_N']), '.0f')} N")
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# outputs
# ---------------------------------------------------------------------------

def signal_columns(truth: bool) -> list[str]:
    cols = ["tick", "time_s", "state", "faults", "fault_names", "drive_mode", "feedforward",
            "estimate_valid"]
    cols += [f"ref_{a}" for a in AXES] + [f"est_{a}" for a in AXES]
    for group in ("length_sp", "force_ff", "length", "stretch", "force", "drive_state", "drive_faults"):
        cols += [f"{group}{i}" for i in range(1, 7)]
    if truth:
        cols += [f"truth_{a}" for a in AXES]
        cols += [f"truth_length{i}" for i in range(1, 7)] + [f"truth_force{i}" for i in range(1, 7)]
    return cols


def signal_table(data: LogData) -> tuple[list[str], list[list[str]]]:
    """Header and rows (strings; blank where missing) of signals.csv."""
    cols = signal_columns(data.truth is not None)

    def f(v, spec):
        return "" if not np.isfinite(v) else format(v, spec)

    def i(v):
        return "" if v < 0 else str(int(v))

    stretch, force = data.stretch, data.force
    rows = []
    for k in range(len(data)):
        st = int(data.state[k])
        r = [str(int(data.ticks[k])), f"{data.ticks[k] * TICK_S:.3f}", data.state_name(k),
             i(data.faults[k]),
             "+".join(pr.fault_names(int(data.faults[k]), pr.CONTROLLER_FAULTS)) if st >= 0 else "",
             ("ACTIVE" if data.drive_mode[k] == 1 else "HOLD") if data.drive_mode[k] >= 0 else "",
             i(data.feedforward[k]), i(data.estimate_valid[k])]
        r += [f(v, ".6f") for v in data.reference[k]] + [f(v, ".6f") for v in data.estimate[k]]
        r += [f(v, ".6f") for v in data.length_sp[k]] + [f(v, ".2f") for v in data.force_ff[k]]
        r += [f(v, ".6f") for v in data.length[k]] + [f(v, ".6f") for v in stretch[k]]
        r += [f(v, ".1f") for v in force[k]]
        r += [DRIVE_STATES[s] if 0 <= s < 4 else i(s) for s in data.drive_state[k]]
        r += [i(v) for v in data.drive_faults[k]]
        if data.truth is not None:
            r += [f(v, ".9f") for v in data.truth["pose"][k]]
            r += [f(v, ".9f") for v in data.truth["length"][k]]
            r += [f(v, ".3f") for v in data.truth["force"][k]]
        rows.append(r)
    return cols, rows


def write_signals_csv(data: LogData, path: str | Path) -> None:
    """signals.csv: one row per tick, SI units, blank for missing values."""
    cols, rows = signal_table(data)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        w.writerows(rows)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _axis_scale(axis: int) -> tuple[float, str]:
    """Plot scale and unit of a pose axis: mm or deg."""
    return (180.0 / math.pi, "deg") if is_angle(axis) else (1e3, "mm")


def plot_tracking(data: LogData, seg: Segment, path: str | Path,
                  delay_ticks: int = DEFAULT_DELAY_TICKS) -> None:
    """(a) reference vs estimate (and truth) on the moving axis, (b) tracking
    error over time (moving axis bold, the others thin)."""
    plt = _plt()
    ax_i = seg.axis if seg.axis is not None else 0
    m = seg.mask(data)
    t = data.time_s[m] - seg.start * TICK_S
    sc, unit = _axis_scale(ax_i)
    home = data.platform.home[ax_i] if data.platform is not None else 0.0
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    a1.plot(t, (data.reference[m, ax_i] - home) * sc, lw=1.6, label="reference")
    a1.plot(t, (data.estimate[m, ax_i] - home) * sc, lw=1.0, ls="--", label="estimate (FK)")
    if data.truth is not None:
        a1.plot(t, (data.truth["pose"][m, ax_i] - home) * sc, lw=0.8, ls=":", label="truth (plant)")
    a1.set_ylabel(f"{AXES[ax_i]} - home [{unit}]")
    a1.set_title(f"segment {seg.index}: {seg.label}")
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3)
    err = tracking_error(data, delay_ticks)
    for a in range(6):
        bold = a == ax_i
        a2.plot(t, err[m, a] * 1e3, color=f"C{a}", lw=1.6 if bold else 0.6,
                alpha=1.0 if bold else 0.7, label=f"{AXES[a]} [{axis_unit(a)}]")
    if data.truth is not None:
        et = tracking_error(data, delay_ticks, pose=data.truth["pose"])
        a2.plot(t, et[m, ax_i] * 1e3, lw=0.8, ls=":", color="k", label=f"{AXES[ax_i]}, truth")
    a2.set_ylabel(f"estimate(t) - reference(t-{delay_ticks}) [mm, mrad]")
    a2.ticklabel_format(axis="y", useOffset=False)
    a2.set_xlabel("time since the segment start [s]")
    a2.legend(ncol=4, fontsize=7)
    a2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def figure_window(seg: Segment) -> tuple[int, int]:
    """Ticks plotted against the moving axis in the cylinder figure: the last
    full period of the steady part of a RUN_TRIG, else the whole segment."""
    a, b = seg.steady()
    if seg.command == "RUN_TRIG" and seg.frequency:
        period = int(round(1.0 / seg.frequency / TICK_S))
        if b - a + 1 >= period:
            return b - period + 1, b
    return a, b


def plot_cylinders(data: LogData, seg: Segment, path: str | Path) -> None:
    """(c) stretch of the six cylinders and (d) their force, feed-forward
    (controller, solid) and measured from the pressures (plant, dashed),
    against the moving axis (estimated pose) as in the paper's Figs 4/5."""
    plt = _plt()
    ax_i = seg.axis if seg.axis is not None else 0
    a, b = figure_window(seg)
    m = (data.ticks >= a) & (data.ticks <= b)
    sc, unit = _axis_scale(ax_i)
    home = data.platform.home[ax_i] if data.platform is not None else 0.0
    x = (data.estimate[m, ax_i] - home) * sc
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7.5, 8.5), sharex=True)
    stretch, force = data.stretch[m], data.force[m]
    for j in range(6):
        c = colors[j % len(colors)]
        a1.plot(x, stretch[:, j] * 1e3, color=c, lw=1.8, alpha=0.7, label=f"cyl.{j + 1}")
        a2.plot(x, data.force_ff[m, j] / 1e3, color=c, lw=1.8, alpha=0.7, label=f"cyl.{j + 1}")
        a2.plot(x, force[:, j] / 1e3, color=c, lw=0.8, ls="--")
    a2.plot([], [], color="k", lw=1.8, label="feed-forward")
    a2.plot([], [], color="k", lw=0.8, ls="--", label="measured p_A A - p_B A_r")
    a1.set_ylabel("cylinder stretch (measured) [mm]")
    a2.set_ylabel("cylinder force [kN]")
    name = MOTIONS[ax_i] if MOTIONS[ax_i] == AXES[ax_i] else f"{MOTIONS[ax_i]} {AXES[ax_i]}"
    a2.set_xlabel(f"{name} (estimate) - home [{unit}]")
    a1.set_title(f"closed loop, segment {seg.index}: {seg.label}\n"
                 f"ticks {a}..{b}")
    a1.legend(ncol=3, fontsize=8)
    a2.legend(ncol=4, fontsize=7)
    a1.grid(alpha=0.3)
    a2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_compare(runs: list[tuple[str, LogData, Segment]], path: str | Path,
                 delay_ticks: int = DEFAULT_DELAY_TICKS) -> None:
    """Tracking error of the moving axis of matching segments of several runs,
    overlaid against the time since each segment's start."""
    plt = _plt()
    fig, ax = plt.subplots(1, 1, figsize=(8, 4.5))
    for name, data, seg in runs:
        ax_i = seg.axis if seg.axis is not None else 0
        m = seg.mask(data)
        e = tracking_error(data, delay_ticks)[m, ax_i] * 1e3
        st = _stats(e, 1.0)
        ax.plot(data.time_s[m] - seg.start * TICK_S, e, lw=1.0,
                label=f"{name}: {seg.label} (RMS {_fmt(st['rms'])} {axis_unit(ax_i)})")
    ax.set_xlabel("time since the segment start [s]")
    ax.set_ylabel(f"tracking error [mm, mrad] (delay {delay_ticks} tick)")
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


@dataclass
class Analysis:
    data: LogData
    segments: list[Segment]
    summary: dict[str, Any]
    files: list[Path]


def analyze(log: str | Path, out: str | Path, truth: str | Path | None = None,
            platform: str | Path | None = None, delay_ticks: int = DEFAULT_DELAY_TICKS,
            buses: str | None = None, plots: bool = True) -> Analysis:
    """Reads ``log`` (and ``truth``), writes signals.csv, summary.json and the
    plots into ``out``; returns the data, segments, summary and files."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plat = cfg.load(platform or DEFAULT_PLATFORM)
    data = read_log(log, buses=buses, platform=plat)
    if truth is not None:
        t = read_truth(truth)
        attach_truth(data, t)
    segs = find_segments(data)
    summary = summarize(data, segs, delay_ticks)
    if truth is not None:
        summary["truth_file"] = str(truth)
        summary["truth_bad_rows"] = int(t["bad_rows"])
    files = [out / "signals.csv", out / "summary.json"]
    write_signals_csv(data, files[0])
    if plots:
        for s in segs:
            p1 = out / f"seg{s.index}_tracking.png"
            p2 = out / f"seg{s.index}_cylinders.png"
            plot_tracking(data, s, p1, delay_ticks)
            plot_cylinders(data, s, p2)
            files += [p1, p2]
    summary["files"] = [str(f) for f in files]
    files[1].write_text(json.dumps(_clean(summary), indent=1, allow_nan=False) + "\n")
    return Analysis(data, segs, summary, files)


def match_segments(a: list[Segment], b: list[Segment]) -> list[tuple[Segment, Segment]]:
    """Pairs segments of two runs with the same motion (command, axis,
    amplitude, frequency), in order; falls back to pairing by position."""
    pairs = []
    used: set[int] = set()

    def key(s):
        return (s.command, s.axis, None if s.amplitude is None else round(s.amplitude, 5),
                None if s.frequency is None else round(s.frequency, 3))

    for s in a:
        for k, t in enumerate(b):
            if k not in used and key(t) == key(s):
                pairs.append((s, t))
                used.add(k)
                break
    if not pairs:
        pairs = list(zip(a, b))
    return pairs
