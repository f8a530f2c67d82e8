# SPDX-License-Identifier: Apache-2.0
"""The CAN protocol on the Python side: one object that loads
``protocol/stewart.dbc`` (the single source of truth) and encodes and decodes
its frames with the E2E protection of :mod:`stewart.e2e`.

>>> p = Protocol()
>>> data = p.encode("SYNC", {"Tick": 5, "Hold": 0})          # Counter and Crc filled
>>> p.decode(0x010, data, bus="axis_a")
('SYNC', {'Tick': 5, 'Hold': 0, 'Counter': 0, 'Crc': ...})

:meth:`Protocol.decode` checks, in this order: known ID (``unknown-id``), exact
length (``bad-length``), CRC over data ID and payload (``bad-crc``), alive
counter per bus and message (``repeated``, ``wrong-sequence``), then the range
of every signal (``out-of-range``). A rejected frame raises
:class:`ProtocolError` with that ``kind`` and is counted in
:attr:`Protocol.rejections`; :meth:`Protocol.receive` does the same without
raising. A frame whose CRC and counter are good but whose values are out of
range still advances the counter reference (it was sent by its sender).
"""

from __future__ import annotations

import collections
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from . import e2e, resources

DBC_PATH = resources.dbc_path()


def dbc_hash(dbc_path: str | Path | None = None) -> int:
    """The protocol's identity, as the firmware carries it in CTRL_IDENTITY
    ProtocolHash (tools/dev/gen_proto_c.py): the first 4 bytes, big-endian,
    of the SHA-256 of the DBC file's bytes."""
    import hashlib

    data = Path(dbc_path or DBC_PATH).read_bytes()
    return int.from_bytes(hashlib.sha256(data).digest()[:4], "big")


#: The three buses and the SocketCAN interface each runs on (host and vcan).
BUSES: dict[str, str] = {"ops": "vcan0", "axis_a": "vcan1", "axis_b": "vcan2"}
#: Leg (1..6) -> (axis bus, drive slot 1..3).
LEG_BUS: dict[int, tuple[str, int]] = {
    leg: ("axis_a" if leg <= 3 else "axis_b", (leg - 1) % 3 + 1) for leg in range(1, 7)
}

# Rejection kinds.
UNKNOWN_ID = "unknown-id"
BAD_LENGTH = "bad-length"
BAD_CRC = "bad-crc"
REPEATED = e2e.REPEATED
WRONG_SEQUENCE = e2e.WRONG_SEQUENCE
OUT_OF_RANGE = "out-of-range"
KINDS = (UNKNOWN_ID, BAD_LENGTH, BAD_CRC, REPEATED, WRONG_SEQUENCE, OUT_OF_RANGE)
#: Encoding only: a signal name the message does not have (or Counter/Crc).
UNKNOWN_SIGNAL = "unknown-signal"

#: Bits of CTRL_STATUS.Faults (SP_FAULT_* of firmware/core/include/sp/control/controller.h).
CONTROLLER_FAULTS = ("feedback_timeout", "drive", "fk", "divergence", "reference",
                     "compute", "estop", "leg_limit", "operator_silent", "contact_lost",
                     "excess_force", "ft_sensor")
#: Bits of AXIS_FEEDBACK_s.Faults.
DRIVE_FAULTS = ("setpoint_timeout", "following_error", "end_stop", "sensor", "valve",
                "pressure", "communication", "internal")
POSE_SIGNALS = ("X", "Y", "Z", "Roll", "Pitch", "Yaw")
#: CTRL_WRENCH's force (N) and moment (N m) signals, base frame, about o'.
WRENCH_SIGNALS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
E2E_SIGNALS = ("Counter", "Crc")
#: Feedback of drive slot s (1..3) has this ID + s.
FEEDBACK_BASE_ID = 0x030


class ProtocolError(Exception):
    """A frame that cannot be encoded or was rejected on decoding."""

    def __init__(self, kind: str, detail: str, frame_id: int | None = None):
        self.kind = kind
        self.frame_id = frame_id
        where = f" (ID 0x{frame_id:03X})" if frame_id is not None else ""
        super().__init__(f"{kind}{where}: {detail}")


@dataclass
class Received:
    """Outcome of :meth:`Protocol.receive`: ``error`` is None when accepted."""

    frame_id: int
    name: str | None = None
    signals: dict[str, Any] | None = None
    status: str | None = None  #: e2e status of an accepted frame (init/ok/lost)
    lost: int = 0
    error: ProtocolError | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


@dataclass
class _Limits:
    lo: int
    hi: int


@dataclass
class MessageInfo:
    """What the tools need of one message, read from the DBC once."""

    name: str
    frame_id: int
    length: int
    buses: tuple[str, ...]
    cycle_ms: int | None
    senders: tuple[str, ...]
    crc_bytes: int
    limits: dict[str, _Limits] = field(default_factory=dict)


def _attr(obj, name: str, default=None):
    dbc = getattr(obj, "dbc", None)
    if dbc is None:
        return default
    a = dbc.attributes.get(name)
    if a is not None:
        return a.value
    d = dbc.attribute_definitions.get(name) if hasattr(dbc, "attribute_definitions") else None
    if d is not None and d.default_value is not None:
        return d.default_value
    return default


def raw_limits(signal) -> tuple[int, int]:
    """Raw integer range of a signal: its DBC minimum/maximum converted the way
    cantools' C generator does it (``*_is_in_range``), clipped to its bits."""
    if signal.is_signed:
        lo, hi = -(1 << (signal.length - 1)), (1 << (signal.length - 1)) - 1
    else:
        lo, hi = 0, (1 << signal.length) - 1
    if signal.minimum is not None:
        lo = max(lo, round(signal.scaled_to_raw(signal.minimum)))
    if signal.maximum is not None:
        hi = min(hi, round(signal.scaled_to_raw(signal.maximum)))
    return lo, hi


class Protocol:
    """Encoder/decoder of the protocol with E2E state and rejection counters."""

    def __init__(self, dbc_path: str | Path | None = None):
        self.dbc_path = Path(dbc_path) if dbc_path else DBC_PATH
        # Parsed once per process (the parse is most of a Protocol's set-up);
        # the database is only read, never changed.
        self.db = _database(str(self.dbc_path.resolve()))
        self.nominal_bitrate = int(_attr(self.db, "Baudrate", 1_000_000))
        self.data_bitrate = int(_attr(self.db, "BaudrateCANFD", 5_000_000))
        self.infos: dict[str, MessageInfo] = {}
        self._by_id: dict[int, Any] = {}
        for m in self.db.messages:
            if m.is_extended_frame:
                raise ValueError(f"{m.name}: the protocol uses 11-bit IDs only")
            names = [s.name for s in m.signals]
            for needed in E2E_SIGNALS:
                if needed not in names:
                    raise ValueError(f"{m.name}: no {needed} signal")
            n = e2e.crc_length(m.length)
            crc = m.get_signal_by_name("Crc")
            if crc.start != 8 * (m.length - n) or crc.length != 8 * n:
                raise ValueError(f"{m.name}: Crc must be the last {n} byte(s)")
            bus_text = str(_attr(m, "Bus", "") or "")
            info = MessageInfo(
                name=m.name, frame_id=m.frame_id, length=m.length,
                buses=tuple(b.strip() for b in bus_text.split(",") if b.strip()),
                cycle_ms=m.cycle_time, senders=tuple(m.senders), crc_bytes=n,
                limits={s.name: _Limits(*raw_limits(s)) for s in m.signals})
            for b in info.buses:
                if b not in BUSES:
                    raise ValueError(f"{m.name}: unknown bus {b!r}")
            self.infos[m.name] = info
            self._by_id[m.frame_id] = m
        self.rejections: collections.Counter[str] = collections.Counter()
        self.lost_frames = 0
        self.accepted = 0
        self._rx: dict[tuple[str, int], e2e.E2EReceiver] = {}
        self._tx: dict[tuple[str, str], int] = {}

    # -- look-up -----------------------------------------------------------
    def message(self, name_or_id: str | int):
        if isinstance(name_or_id, int):
            return self._by_id[name_or_id]
        return self.db.get_message_by_name(name_or_id)

    def messages_on(self, bus: str) -> list[MessageInfo]:
        return [i for i in self.infos.values() if bus in i.buses]

    @staticmethod
    def channel(bus: str) -> str:
        return BUSES[bus]

    # -- encoding ----------------------------------------------------------
    def to_raw(self, name: str, signals: Mapping[str, Any], counter: int) -> dict[str, int]:
        """Physical values (or choice names) to raw integers, range-checked.
        Signals not given are 0 (raw)."""
        m = self.message(name)
        info = self.infos[name]
        raw: dict[str, int] = {}
        for key in signals:
            if key in E2E_SIGNALS:
                raise ProtocolError(UNKNOWN_SIGNAL, f"{key} is filled by the encoder", m.frame_id)
            if key not in info.limits:
                raise ProtocolError(UNKNOWN_SIGNAL, f"{name} has no signal {key}", m.frame_id)
        for s in m.signals:
            if s.name == "Crc":
                raw[s.name] = 0
                continue
            if s.name == "Counter":
                v: Any = counter
            else:
                v = signals.get(s.name, None)
            if v is None:
                r = 0
            elif isinstance(v, str):
                try:
                    r = int(s.conversion.choice_to_number(v))
                except (KeyError, AttributeError) as exc:
                    raise ProtocolError(OUT_OF_RANGE, f"{name}.{s.name}: no choice {v!r}",
                                        m.frame_id) from exc
            else:
                try:
                    r = int(s.scaled_to_raw(v))
                except (ValueError, OverflowError, TypeError) as exc:
                    raise ProtocolError(OUT_OF_RANGE, f"{name}.{s.name} = {v!r}",
                                        m.frame_id) from exc
            lim = info.limits[s.name]
            if not lim.lo <= r <= lim.hi:
                raise ProtocolError(OUT_OF_RANGE, f"{name}.{s.name} = {v!r} (raw {r}) outside "
                                    f"raw {lim.lo}..{lim.hi}", m.frame_id)
            raw[s.name] = r
        return raw

    def encode_raw(self, name: str, raw: Mapping[str, int]) -> bytes:
        """Frame from raw integers (Counter included, Crc ignored), CRC sealed."""
        m = self.message(name)
        info = self.infos[name]
        values = {s.name: int(raw.get(s.name, 0)) for s in m.signals}
        values["Crc"] = 0
        for k, r in values.items():
            lim = info.limits[k]
            if not lim.lo <= r <= lim.hi:
                raise ProtocolError(OUT_OF_RANGE, f"{name}.{k} raw {r} outside {lim.lo}..{lim.hi}",
                                    m.frame_id)
        data = m.encode(values, scaling=False, padding=False, strict=False)
        return e2e.seal(m.frame_id, bytes(data))

    def encode(self, name: str, signals: Mapping[str, Any], counter: int | None = None,
               *, bus: str = "default") -> bytes:
        """Frame of message ``name`` with the given physical signal values.

        ``counter`` None takes the next value of this encoder's own counter for
        (bus, message), starting at 0; an explicit counter sets it."""
        key = (bus, name)
        if counter is None:
            counter = self._tx.get(key, 0)
        if not 0 <= counter < e2e.COUNTER_MODULO:
            raise ProtocolError(OUT_OF_RANGE, f"counter {counter} is not 4 bits")
        data = self.encode_raw(name, self.to_raw(name, signals, counter))
        self._tx[key] = e2e.next_counter(counter)
        return data

    # -- decoding ----------------------------------------------------------
    def _reject(self, kind: str, detail: str, frame_id: int):
        self.rejections[kind] += 1
        raise ProtocolError(kind, detail, frame_id)

    def decode(self, frame_id: int, data: bytes, *, bus: str = "default",
               raw: bool = False, check_counter: bool = True) -> tuple[str, dict[str, Any]]:
        """Checks and decodes one received frame; see the module text.

        Returns (message name, signals): physical values (int for unscaled
        signals, float otherwise; enums as numbers), or raw integers."""
        return self._decode(frame_id, data, bus, raw, check_counter)[:2]

    def _decode(self, frame_id, data, bus, raw, check_counter):
        data = bytes(data)
        m = self._by_id.get(frame_id)
        if m is None:
            self._reject(UNKNOWN_ID, f"no message has ID 0x{frame_id:X}", frame_id)
        if len(data) != m.length:
            self._reject(BAD_LENGTH, f"{m.name} has {m.length} bytes, got {len(data)}", frame_id)
        if not e2e.crc_ok(frame_id, data):
            self._reject(BAD_CRC, f"{m.name}: CRC mismatch", frame_id)
        values = m.decode(data, decode_choices=False, scaling=False)
        check = None
        if check_counter:
            rx = self._rx.setdefault((bus, frame_id), e2e.E2EReceiver())
            check = rx.check(int(values["Counter"]))
            if not check.accepted:
                self._reject(check.status, f"{m.name} on {bus}: counter {values['Counter']}",
                             frame_id)
        info = self.infos[m.name]
        for k, r in values.items():
            lim = info.limits[k]
            if not lim.lo <= r <= lim.hi:
                self._reject(OUT_OF_RANGE, f"{m.name}.{k} raw {r} outside {lim.lo}..{lim.hi}",
                             frame_id)
        self.accepted += 1
        if check is not None:
            self.lost_frames += check.lost
        if not raw:
            values = {s.name: s.conversion.raw_to_scaled(values[s.name], decode_choices=False)
                      for s in m.signals}
        return m.name, values, check

    def receive(self, frame_id: int, data: bytes, *, bus: str = "default",
                raw: bool = False) -> Received:
        """Like :meth:`decode` but never raises for a bad frame."""
        try:
            name, values, check = self._decode(frame_id, data, bus, raw, True)
        except ProtocolError as err:
            return Received(frame_id, error=err)
        return Received(frame_id, name, values, check.status if check else None,
                        check.lost if check else 0)

    def reset_counters(self) -> None:
        """Forget every counter reference (receivers) and transmit counter."""
        self._rx.clear()
        self._tx.clear()


# -- the DBC's value tables ----------------------------------------------------

@functools.lru_cache(maxsize=None)
def _database(dbc_path: str):
    import cantools

    return cantools.database.load_file(dbc_path, strict=True)


@functools.lru_cache(maxsize=None)
def value_names(message: str, signal: str, dbc_path: str | Path | None = None) -> tuple[str, ...]:
    """The value table (``VAL_``) of a signal in the DBC as its names indexed
    by raw value: ``value_names("CTRL_STATUS", "State")[3] == "RUNNING"``.
    The table must cover 0..n-1 without gaps (ValueError otherwise)."""
    path = str(Path(dbc_path or DBC_PATH).resolve())
    s = _database(path).get_message_by_name(message).get_signal_by_name(signal)
    table = {int(k): str(v) for k, v in (s.choices or {}).items()}
    if not table or sorted(table) != list(range(len(table))):
        raise ValueError(f"{path}: {message}.{signal} has no value table numbered 0..n-1")
    return tuple(table[i] for i in range(len(table)))


def axis_names() -> tuple[str, ...]:
    """The tools' pose axis names, x y z roll pitch yaw: OP_COMMAND.Axis's
    value table in lower case."""
    return tuple(a.lower() for a in value_names("OP_COMMAND", "Axis"))


# -- helpers between physical values and the messages -------------------------

def fault_names(bits: int, table: tuple[str, ...]) -> list[str]:
    """Names of the set bits; unnamed bits as ``bitN``."""
    out = []
    for i in range(max(len(table), int(bits).bit_length())):
        if int(bits) >> i & 1:
            out.append(table[i] if i < len(table) else f"bit{i}")
    return out


def _choice(proto: Protocol, message: str, signal: str, value: int) -> str:
    s = proto.message(message).get_signal_by_name(signal)
    if s.choices and int(value) in s.choices:
        return str(s.choices[int(value)])
    return str(int(value))


def pose_to_signals(pose, prefix: str = "") -> dict[str, float]:
    """[x, y, z, roll, pitch, yaw] (m, rad) -> {X: .., ..., Yaw: ..}."""
    if len(pose) != 6:
        raise ValueError("a pose has 6 values")
    return {prefix + n: float(v) for n, v in zip(POSE_SIGNALS, pose)}


def signals_to_pose(signals: Mapping[str, Any], prefix: str = "") -> list[float]:
    return [float(signals[prefix + n]) for n in POSE_SIGNALS]


def status_to_dict(proto: Protocol, signals: Mapping[str, Any]) -> dict[str, Any]:
    """Decoded CTRL_STATUS (physical) -> a readable dict."""
    return {
        "tick": int(signals["Tick"]),
        "state": _choice(proto, "CTRL_STATUS", "State", signals["State"]),
        "faults": fault_names(int(signals["Faults"]), CONTROLLER_FAULTS),
        "fk_iterations": int(signals["FkIterations"]),
        "estimate_valid": bool(signals["EstimateValid"]),
        "cmd_rejected": bool(signals["CmdRejected"]),
        "refusals": int(signals["Refusals"]),
        "stop_reaction": _choice(proto, "CTRL_STATUS", "StopReaction", signals["StopReaction"]),
        "drive_mode": _choice(proto, "CTRL_STATUS", "DriveMode", signals["DriveMode"]),
        "feedforward": bool(signals["FeedForward"]),
        "pose": signals_to_pose(signals),
    }


def wrench_to_dict(signals: Mapping[str, Any]) -> dict[str, Any]:
    """Decoded CTRL_WRENCH (physical) -> a readable dict: tick, valid, and the
    wrench [fx, fy, fz, mx, my, mz] (N, N m; 0.25 steps, saturated at
    +-524287.75 by the sender)."""
    return {"tick": int(signals["Tick"]), "valid": bool(signals["Valid"]),
            "wrench": [float(signals[n]) for n in WRENCH_SIGNALS]}


def feedback_to_dict(proto: Protocol, signals: Mapping[str, Any]) -> dict[str, Any]:
    """Decoded AXIS_FEEDBACK_s (physical) -> a readable dict (SI units)."""
    return {
        "length": float(signals["Length"]),
        "pressure_a": float(signals["PressureA"]),
        "pressure_b": float(signals["PressureB"]),
        "state": _choice(proto, "AXIS_FEEDBACK_1", "State", signals["State"]),
        "faults": fault_names(int(signals["Faults"]), DRIVE_FAULTS),
        "tick_echo": int(signals["TickEcho"]),
    }


def command_signals(command: str, axis: str | int = 0, amplitude: float = 0.0,
                    frequency: float = 0.0, fade_time: float = 0.0,
                    option: int = 0) -> dict[str, Any]:
    """Signals of an OP_COMMAND (command and axis by name or number)."""
    return {"Command": command, "Axis": axis.upper() if isinstance(axis, str) else axis,
            "Amplitude": amplitude, "Frequency": frequency, "FadeTime": fade_time,
            "Option": option}


#: OP_FORCE's Mask bits, in order (bit k: axis k of the base frame).
FORCE_AXES = ("x", "y", "z", "roll", "pitch", "yaw")


def force_mask(axes: str | int) -> int:
    """OP_FORCE's Mask from axis names joined by commas ("z", "x,y") or a
    number 0..63; ValueError for anything else."""
    if isinstance(axes, int):
        mask = axes
    elif axes.strip().isdigit():
        mask = int(axes)
    else:
        mask = 0
        for name in axes.split(","):
            name = name.strip().lower()
            if name not in FORCE_AXES:
                raise ValueError(f"unknown axis {name!r} (x, y, z, roll, pitch, yaw, joined by commas)")
            mask |= 1 << FORCE_AXES.index(name)
    if not 0 <= mask <= 63:
        raise ValueError(f"mask {mask} is out of range (0..63)")
    return mask


def force_signals(mask: int, target) -> dict[str, Any]:
    """OP_FORCE signals: the mask and the target wrench [fx, fy, fz, mx, my,
    mz] (N, N m, base frame, about o'; what the platform is to exert)."""
    return {"Mask": int(mask), **{n: float(v) for n, v in zip(WRENCH_SIGNALS, target)}}


#: OP_FORCE_PARAMS' ranges (the DBC's; the controller's node rejects others
#: as out-of-range): mass kg (kg m^2), damping N s/m (N m s/rad), stiffness N/m (N m/rad).
FORCE_PARAM_RANGES = {"mass": (1.0, 5000.0), "damping": (100.0, 1e8), "stiffness": (0.0, 1e7)}


def force_params_check(mass: float, damping: float, stiffness: float) -> str | None:
    """None when the admittance parameters are within OP_FORCE_PARAMS'
    ranges, else the reason, naming the parameter and its range."""
    for name, v in (("mass", mass), ("damping", damping), ("stiffness", stiffness)):
        lo, hi = FORCE_PARAM_RANGES[name]
        if not (math.isfinite(v) and lo <= v <= hi):
            unit = {"mass": "kg", "damping": "N s/m", "stiffness": "N/m"}[name]
            return f"{name} {v:g} {unit} is out of range ({lo:g} .. {hi:g})"
    return None


def force_params_signals(mask: int, mode: str, mass: float, damping: float, stiffness: float) -> dict[str, Any]:
    """OP_FORCE_PARAMS signals: the axes, whose free damping (mode "FORCE":
    the approach, "GUIDE": hand guiding), mass, damping, stiffness.
    ValueError (the reason) for a value out of range."""
    why = force_params_check(mass, damping, stiffness)
    if why is not None:
        raise ValueError(why)
    if not 1 <= int(mask) <= 63:
        raise ValueError(f"mask {mask} is out of range (1..63)")
    return {"Mask": int(mask), "Mode": mode, "Mass": round(float(mass), 1),
            "Damping": 10.0 * round(float(damping) / 10.0), "Stiffness": round(float(stiffness))}


def setpoint_signals(mode: str | int, tick: int, slots) -> dict[str, Any]:
    """AXIS_SETPOINTS signals; ``slots`` is 3 tuples (length m, velocity m/s, force N)."""
    out: dict[str, Any] = {"Tick": tick, "Mode": mode}
    for s, (length, velocity, force) in enumerate(slots, start=1):
        out[f"Length_{s}"] = length
        out[f"Velocity_{s}"] = velocity
        out[f"Force_{s}"] = force
    return out


def feedback_name(slot: int) -> str:
    if not 1 <= slot <= 3:
        raise ValueError("drive slots are 1..3")
    return f"AXIS_FEEDBACK_{slot}"
