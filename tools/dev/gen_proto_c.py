# SPDX-License-Identifier: Apache-2.0
"""Generates the firmware's protocol codec from the DBC.

    python3 tools/dev/gen_proto_c.py protocol/stewart.dbc OUTDIR

Writes OUTDIR/stewart_proto.c: the encoders and decoders of
sp/link/protocol.h (sp_proto_encode_<name>, sp_proto_decode_<name>) between
the core's message structs and cantools' raw-signal structs
(stewart_can.h, tools/dev/gen_can_c.py). What the DBC says, the code
follows: each signal's width and sign, its scale (the ratios of gen_can_c's
families: raw = value x NUM / DEN, rounded to nearest, ties away from
zero), its [min|max] (the raw range the encoder saturates to or refuses
outside, the range the decoder accepts) and each message's bus. What the
DBC cannot say is :data:`MESSAGES`: which member of the core's struct each
signal carries, and how the encoder fits a value to it (:data:`RULES`).

The decoders check the identifier, the length and the CRC (precheck), then
every signal whose [min|max] is narrower than its bits (out-of-range), and
only then write the message. The shared steps (muldiv, clamp, precheck,
finish) are hand-written in firmware/core/src/link/proto_codec.h.

To change the protocol, edit the DBC: a changed factor or range reaches the
code by itself; a new signal or message needs its row in :data:`MESSAGES`
(and its member in sp/link/protocol.h's struct). The build fails, with a
message naming the signal, when a DBC signal or message is not mapped or a
signal is mapped twice, a rule does not fit its signal (a copy of a
narrower range, a boolean wider than one bit), a family's signals differ in
range or type, or a decoded value could leave its C type. Runs with the
plain system Python, as gen_can_c.py does.
"""

from __future__ import annotations

import hashlib
import math
import re
import sys
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import gen_can_c  # beside this file in tools/dev (on the path as a script and in the tests)

OUT_NAME = "stewart_proto.c"

#: How an encoder fits a member's value to its signal:
#: copy: as it is (the signal's [min|max] must be all its bits);
#: bool: 1 for any non-zero (a one-bit signal);
#: mask: the low bits that fit (the signal's [min|max] must be all its bits);
#: enum: refused (SP_E_ARG) outside the signal's [min|max];
#: sat: scaled, then saturated to [min|max] (the call returns SP_E_RANGE);
#: clip: saturated at max without a word (counts that stop at their end);
#: check: refused (SP_E_ARG) when the value is outside the DBC's [min|max]
#: in the core's unit, else scaled (a parameter is sent as asked or not at all).
RULES = ("copy", "bool", "mask", "enum", "sat", "clip", "check")

#: The C type of the core's value of each scale family (gen_can_c.SCALES).
VALUE_TYPES = {
    "LENGTH": "sp_q24_t", "FEEDBACK_LENGTH": "sp_q24_t", "POSE": "sp_q24_t", "VELOCITY": "sp_q24_t",
    "FORCE": "sp_q8_t", "PRESSURE": "uint32_t", "WRENCH": "int32_t", "FT_WRENCH": "sp_q8_t",
    "AMPLITUDE": "sp_q24_t", "FREQUENCY": "sp_q24_t", "FADE_TIME": "uint32_t", "MASS": "sp_q16_t",
    "DAMPING": "int32_t", "STIFFNESS": "int32_t", "FRAME_POSE": "sp_q24_t", "EXCESS": "sp_q24_t",
}
TYPE_RANGES = {"sp_q24_t": (-(1 << 31), (1 << 31) - 1), "sp_q8_t": (-(1 << 31), (1 << 31) - 1),
               "sp_q16_t": (-(1 << 31), (1 << 31) - 1), "int32_t": (-(1 << 31), (1 << 31) - 1),
               "uint32_t": (0, (1 << 32) - 1)}


@dataclass(frozen=True)
class Field:
    signal: str  #: the DBC signal
    member: str  #: the member of the core's struct that it carries ("setpoint[0].length")
    rule: str = "copy"  #: one of RULES
    family: str = ""  #: the scale family (gen_can_c.SCALES) of a scaled signal


@dataclass(frozen=True)
class Message:
    dbc: str  #: the DBC message (of a slot group: the first, AXIS_FEEDBACK_1)
    name: str  #: sp_proto_encode_<name>, sp_proto_decode_<name>
    ctype: str  #: the core's struct ("": none, the message is its counter)
    fields: tuple[Field, ...]
    slots: bool = False  #: <stem>_1..<stem>_<SP_AXIS_SLOTS>, one layout, told apart by the identifier
    #: (macro, rule-"check" signal, "min" or "max"): protocol.h's limit, asserted equal to the DBC's
    limits: tuple[tuple[str, str, str], ...] = ()
    #: (macro, family): protocol.h's largest value of a family, asserted equal to the DBC's max
    largest: tuple[tuple[str, str], ...] = ()


def _pose(prefix: str, names: str, member: str) -> tuple[Field, ...]:
    six = [f"{member}pos[{k}]" for k in range(3)] + [f"{member}rpy[{k}]" for k in range(3)]
    return tuple(Field(prefix + n, m, "sat", "POSE") for n, m in zip(names.split(), six))


def _six(names: str, member: str, rule: str, family: str) -> tuple[Field, ...]:
    return tuple(Field(n, f"{member}[{k}]", rule, family) for k, n in enumerate(names.split()))


_XYZ = "X Y Z Roll Pitch Yaw"
_WRENCH = "Fx Fy Fz Mx My Mz"
_LEGS = range(1, 4)

#: The core's side of each message, in sp/link/protocol.h's order. Counter,
#: Crc, AuthCounter and AuthTag are the protocol's own (e2e.h, auth.h).
MESSAGES = (
    Message("SYNC", "sync", "sp_msg_sync_t", (Field("Tick", "tick"), Field("Hold", "hold", "bool"))),
    Message("AXIS_SETPOINTS", "setpoints", "sp_msg_setpoints_t", (
        Field("Tick", "tick"), Field("Mode", "mode", "enum"),
        *(f for i in _LEGS for f in (Field(f"Length_{i}", f"setpoint[{i - 1}].length", "sat", "LENGTH"),
                                     Field(f"Velocity_{i}", f"setpoint[{i - 1}].velocity", "sat", "VELOCITY"),
                                     Field(f"Force_{i}", f"setpoint[{i - 1}].force", "sat", "FORCE"))),
        Field("FaultReset", "fault_reset", "bool"), Field("Block", "block", "bool"))),
    Message("AXIS_FEEDBACK_1", "feedback", "sp_msg_feedback_t", (
        Field("Length", "length", "sat", "FEEDBACK_LENGTH"), Field("State", "state", "enum"),
        Field("PressureA", "pressure_a", "sat", "PRESSURE"), Field("PressureB", "pressure_b", "sat", "PRESSURE"),
        Field("Faults", "faults"), Field("TickEcho", "tick_echo")), slots=True),
    Message("OP_COMMAND", "command", "sp_msg_command_t", (
        Field("Command", "command", "enum"), Field("Axis", "axis", "enum"),
        Field("Amplitude", "amplitude", "sat", "AMPLITUDE"), Field("Frequency", "frequency", "sat", "FREQUENCY"),
        Field("FadeTime", "fade_ms", "sat", "FADE_TIME"), Field("Option", "option", "enum"))),
    Message("OP_TARGET_POSE", "target", "sp_pose_t", _pose("", _XYZ, "")),
    Message("OP_HEARTBEAT", "heartbeat", "", ()),
    Message("CTRL_STATUS", "status", "sp_msg_status_t", (
        Field("Tick", "tick"), Field("State", "state", "enum"), Field("Faults", "faults"),
        Field("FkIterations", "fk_iterations", "sat"), Field("EstimateValid", "estimate_valid", "bool"),
        Field("CmdRejected", "cmd_rejected", "bool"), Field("DriveMode", "drive_mode", "bool"),
        Field("FeedForward", "feedforward", "bool"), *_pose("", _XYZ, "estimate."),
        Field("ResetRefusedLegs", "reset_refused_legs", "mask"), Field("StopReaction", "stop_reaction", "enum"),
        Field("ResetRefusedCause", "reset_refused_cause"), Field("ForceMode", "force_mode", "enum"),
        Field("Contact", "contact", "bool"), Field("DrivesStarting", "drives_starting", "bool"),
        Field("Refusals", "refusals", "mask"), Field("ForceUnmeasured", "force_unmeasured", "mask"))),
    Message("CTRL_MONITOR", "monitor", "sp_msg_monitor_t", (
        Field("Tick", "tick"), *_pose("Ref", _XYZ, "reference."),
        *(f for i in range(1, 7) for f in (Field(f"LengthSp_{i}", f"length_sp[{i - 1}]", "sat", "LENGTH"),
                                           Field(f"ForceFf_{i}", f"force_ff[{i - 1}]", "sat", "FORCE"))))),
    Message("CTRL_WRENCH", "wrench", "sp_msg_wrench_t", (
        Field("Tick", "tick"), Field("Valid", "valid", "bool"), *_six(_WRENCH, "wrench", "sat", "WRENCH")),
        largest=(("SP_PROTO_WRENCH_MAX_Q8", "WRENCH"),)),
    Message("OP_FORCE", "force", "sp_msg_force_t", (
        Field("Mask", "mask", "enum"), *_six(_WRENCH, "target", "sat", "FT_WRENCH")),
        largest=(("SP_PROTO_FT_MAX_Q8", "FT_WRENCH"),)),
    Message("OP_FORCE_PARAMS", "force_params", "sp_msg_force_params_t", (
        Field("Mask", "mask", "enum"), Field("Mode", "mode", "enum"), Field("Mass", "mass", "check", "MASS"),
        Field("Damping", "damping", "check", "DAMPING"), Field("Stiffness", "stiffness", "check", "STIFFNESS")),
        limits=(("SP_PROTO_MASS_MIN_Q16", "Mass", "min"), ("SP_PROTO_MASS_MAX_Q16", "Mass", "max"),
                ("SP_PROTO_DAMPING_MIN", "Damping", "min"), ("SP_PROTO_DAMPING_MAX", "Damping", "max"),
                ("SP_PROTO_STIFFNESS_MAX", "Stiffness", "max"))),
    Message("FT_SENSOR", "ft", "sp_msg_ft_t", (
        *_six(_WRENCH, "wrench", "sat", "FT_WRENCH"), Field("Saturated", "saturated", "bool"))),
    Message("CTRL_AUTH", "auth", "sp_msg_auth_t", (
        Field("Session", "session"), Field("LastCounter", "last_counter"), Field("BadTag", "bad_tag", "clip"),
        Field("Replayed", "replayed", "clip"), Field("KeySet", "key_set", "bool"))),
    Message("OP_FRAME", "frame", "sp_msg_frame_t", (
        Field("Op", "op", "enum"), Field("Kind", "kind", "enum"), Field("Index", "index", "mask"),
        *(Field(f.signal, f.member, "sat", "FRAME_POSE") for f in _pose("", _XYZ, "value.")))),
    Message("OP_REACH", "reach", "sp_msg_reach_t", (
        Field("Sequence", "sequence"),
        *(Field(f.signal, f.member, "sat", "FRAME_POSE") for f in _pose("", _XYZ, "pose.")))),
    Message("CTRL_REACH", "reach_answer", "sp_msg_reach_answer_t", (
        Field("Sequence", "sequence"), Field("Verdict", "verdict", "enum"), Field("Which", "which", "enum"),
        Field("Excess", "excess", "sat", "EXCESS"),
        *(Field(f"Force_{i}", f"force[{i - 1}]", "sat", "FORCE") for i in range(1, 7)))),
    Message("CTRL_FRAMES", "frames", "sp_msg_frames_t", (
        Field("ToolIndex", "tool_index", "mask"), Field("WorkIndex", "work_index", "mask"),
        Field("Identity", "identity", "bool"), Field("LastRefusal", "last_refusal", "enum"),
        Field("Checksum", "checksum"),
        *(Field(f"Refused{n}", f"refused[{k}]", "clip") for k, n in enumerate(
            ("State", "Range", "Reach", "Rate", "Force", "EmptySlot", "BadFrame", "NotFinite"))))),
    Message("CTRL_IDENTITY", "identity", "sp_msg_identity_t", (
        Field("VersionMajor", "major"), Field("VersionMinor", "minor"), Field("VersionPatch", "patch"),
        Field("Port", "port", "enum"), Field("ProtocolHash", "protocol_hash"))),
    Message("CTRL_REFUSAL", "refusal", "sp_msg_refusal_t", (
        Field("Tick", "tick"), Field("Command", "command", "enum"), Field("Reason", "reason", "enum"))),
)

#: Signals of the protocol itself: the E2E counter and CRC, the authentication fields.
PROTOCOL_SIGNALS = ("Counter", "Crc", "AuthCounter", "AuthTag")


class CodecError(ValueError):
    """A DBC the mapping does not fit (the message names the signal)."""


@dataclass(frozen=True)
class Sig:
    name: str
    start: int
    length: int
    signed: bool
    factor: Fraction
    lo: int  #: the DBC's [min|max] in raw units
    hi: int

    @property
    def bits(self) -> tuple[int, int]:
        if self.signed:
            return -(1 << (self.length - 1)), (1 << (self.length - 1)) - 1
        return 0, (1 << self.length) - 1

    @property
    def ctype(self) -> str:
        width = next(w for w in (8, 16, 32, 64) if self.length <= w)
        return f"{'int' if self.signed else 'uint'}{width}_t"

    @property
    def member(self) -> str:
        return c_name(self.name)


@dataclass
class Msg:
    frame_id: int
    name: str
    length: int
    buses: list[str]
    signals: dict[str, Sig]


_BO = re.compile(r"^BO_ (\d+) (\w+)\s*:\s*(\d+)")
_SG = re.compile(r'^SG_ (\w+) : (\d+)\|(\d+)@[01]([+-]) \(([^,()]+),[^,()]+\) \[([^|\]]+)\|([^]]+)\]')
_BUS = re.compile(r'^BA_ "Bus" BO_ (\d+) "([^"]*)";')


def c_name(name: str) -> str:
    """A DBC name as cantools names it in C: CamelCase words joined by _, lower case."""
    s = re.sub(r"(?<=.)([A-Z][a-z]+)", r"_\1", name)
    s = re.sub(r"([a-z0-9])([A-Z])", r"\1_\2", s)
    return re.sub(r"_+", "_", s).lower()


def read_messages(dbc_text: str) -> dict[str, Msg]:
    """The DBC's messages with their signals' layout, scale and raw range."""
    msgs: dict[str, Msg] = {}
    by_id: dict[int, Msg] = {}
    cur = None
    for line in dbc_text.splitlines():
        line = line.strip()
        if m := _BO.match(line):
            cur = Msg(int(m.group(1)), m.group(2), int(m.group(3)), [], {})
            msgs[cur.name] = by_id[cur.frame_id] = cur
        elif (m := _SG.match(line)) and cur is not None:
            name = m.group(1)
            factor = Fraction(m.group(5).strip())
            lo = math.ceil(Fraction(m.group(6).strip()) / factor)
            hi = math.floor(Fraction(m.group(7).strip()) / factor)
            sig = Sig(name, int(m.group(2)), int(m.group(3)), m.group(4) == "-", factor, lo, hi)
            if not sig.bits[0] <= lo <= hi <= sig.bits[1]:
                raise CodecError(f"{cur.name}.{name}: [min|max] is not within its {sig.length} bits")
            cur.signals[name] = sig
        elif m := _BUS.match(line):
            by_id[int(m.group(1))].buses = m.group(2).split(",")
    return msgs


@dataclass
class Family:
    """A scale family as the generated code uses it."""
    name: str
    macro: str  #: SP_CAN_<FAMILY>_RAW_PER_<UNIT> (stewart_can.h)
    ratio: Fraction  #: raw per value LSB
    rule: str
    raw: Sig  #: the first signal: its type and range are the family's

    @property
    def vtype(self) -> str:
        return VALUE_TYPES[self.name]


def families(dbc_text: str, msgs: dict[str, Msg]) -> dict[str, Family]:
    ratios = {stem: (macro, r) for (stem, *_), (macro, r, _) in
              zip(gen_can_c.SCALES, gen_can_c.scale_ratios(gen_can_c.read_signals(dbc_text)))}
    out: dict[str, Family] = {}
    for msg, f in _mapped(msgs):
        if not f.family:
            continue
        sig = msg.signals[f.signal]
        where = f"{msg.name}.{f.signal}"
        if f.family not in ratios:
            raise CodecError(f"{where}: no scale family {f.family} in gen_can_c.SCALES")
        fam = out.setdefault(f.family, Family(f.family, ratios[f.family][0], ratios[f.family][1], f.rule, sig))
        if (fam.rule, fam.raw.ctype, fam.raw.lo, fam.raw.hi) != (f.rule, sig.ctype, sig.lo, sig.hi):
            raise CodecError(f"{where}: rule, type or [min|max] differ from {fam.raw.name}'s of family {f.family}")
    return out


def _mapped(msgs: dict[str, Msg]):
    for spec in MESSAGES:
        if spec.dbc not in msgs:
            raise CodecError(f"{spec.dbc}: no such message in the DBC")
        msg = msgs[spec.dbc]
        for f in spec.fields:
            if f.signal not in msg.signals:
                raise CodecError(f"{spec.dbc}.{f.signal}: no such signal in the DBC")
            yield msg, f


def check_mapping(msgs: dict[str, Msg]) -> None:
    """Every message and signal mapped once, every rule fitting its signal."""
    list(_mapped(msgs))  # every mapped message and signal is in the DBC
    covered = {m.name for spec in MESSAGES for m in (_group(msgs, spec) if spec.slots else [msgs[spec.dbc]])}
    for name in msgs:
        if name not in covered:
            raise CodecError(f"{name}: a message gen_proto_c.MESSAGES does not map")
    for spec in MESSAGES:
        msg = msgs[spec.dbc]
        names = [f.signal for f in spec.fields]
        for name in msg.signals:
            if name not in PROTOCOL_SIGNALS and names.count(name) != 1:
                raise CodecError(f"{msg.name}.{name}: mapped {names.count(name)} times in gen_proto_c.MESSAGES")
        for f in spec.fields:
            sig = msg.signals[f.signal]
            where = f"{msg.name}.{f.signal}"
            if f.rule not in RULES:
                raise CodecError(f"{where}: no rule {f.rule!r}")
            if f.rule in ("copy", "mask") and (sig.lo, sig.hi) != sig.bits:
                raise CodecError(f"{where}: [min|max] narrower than its bits: rule {f.rule} cannot keep to it")
            if f.rule == "bool" and (sig.signed or sig.length != 1):
                raise CodecError(f"{where}: rule bool needs a one-bit unsigned signal")
            if f.rule in ("enum", "clip") and (sig.signed or f.family):
                raise CodecError(f"{where}: rule {f.rule} is for unsigned unscaled signals")
            if f.rule == "check" and not f.family:
                raise CodecError(f"{where}: rule check needs a scale family")
        if spec.slots:
            for other in _group(msgs, spec):
                if (other.length, other.buses, other.signals) != (msg.length, msg.buses, msg.signals):
                    raise CodecError(f"{other.name}: its layout differs from {msg.name}'s (one codec for the slots)")
        elif spec.dbc[-2:] == "_1":
            raise CodecError(f"{spec.dbc}: a message numbered 1 needs slots=True")


def _group(msgs: dict[str, Msg], spec: Message) -> list[Msg]:
    """The messages of a slot group: <stem>_1, <stem>_2, ..."""
    return [m for n, m in msgs.items() if re.fullmatch(re.escape(spec.dbc[:-2]) + r"_\d+", n)]


def _slots(msgs: dict[str, Msg], spec: Message) -> int:
    return len(_group(msgs, spec))


# ---- C code ----------------------------------------------------------------------------------------------------

WIDTH = 120  #: the house's line length (.clang-format)


def _wrap(head: str, items: list[str], sep: str, tail: str) -> list[str]:
    """head + items joined by sep + tail, broken after a separator where a line would pass WIDTH and
    continued under the first item, as clang-format lays out calls and conditions."""
    lines, cur, pad = [], head, " " * len(head)
    for i, item in enumerate(items):
        last = i == len(items) - 1
        piece = item + (tail if last else sep.rstrip())
        if cur not in (head, pad) and len(cur) + len(piece) > WIDTH:
            lines.append(cur.rstrip())
            cur = pad
        cur += piece if last else piece + " "
    return lines + [cur]

def _u(v: int) -> str:
    """A C literal of v."""
    return f"{v}u" if v >= 0 else f"({v})"


def family_helpers(fams: dict[str, Family]) -> list[str]:
    out = []
    for fam in fams.values():
        low = fam.name.lower()
        sig = fam.raw
        n, d = f"{fam.macro}_NUM", f"{fam.macro}_DEN"
        num, den = fam.ratio.numerator, fam.ratio.denominator
        if fam.rule == "sat":
            conv = "v" if num == den == 1 else f"muldiv(v, {n}, {d})"
            out += [f"static {sig.ctype} enc_{low}({fam.vtype} v, int *sat)", "{",
                    *_wrap(f"    return ({sig.ctype})clamp(", [conv, str(sig.lo), str(sig.hi), "sat"], ", ", ");"),
                    "}"]
        else:
            conv = "v" if num == den == 1 else f"muldiv(v, {n}, {d})"
            out += [f"static {sig.ctype} enc_{low}({fam.vtype} v)", "{", f"    return ({sig.ctype}){conv};", "}"]
        # decode: value = raw x DEN / NUM, exact when NUM is 1
        vlo, vhi = TYPE_RANGES[fam.vtype]
        exact = num == 1
        ends = [Fraction(r * den, num) for r in (sig.lo, sig.hi)]
        ends = [e if exact else _round_away(e) for e in ends]
        if not vlo <= ends[0] <= ends[1] <= vhi:
            raise CodecError(f"{fam.name}: a decoded value of {sig.name}'s [min|max] leaves {fam.vtype}")
        conv = f"raw * {d}" if exact else f"muldiv(raw, {d}, {n})"
        out += [f"static {fam.vtype} dec_{low}(int64_t raw)", "{", f"    return ({fam.vtype})({conv});", "}", ""]
    return out


def _round_away(x: Fraction) -> int:
    r = math.floor(abs(x) + Fraction(1, 2))
    return r if x >= 0 else -r


def _value_limits(fam: Family) -> tuple[int, int]:
    """A rule-check family's [min|max] in the core's unit (the values that are sent)."""
    lsb_per_raw = 1 / fam.ratio
    return math.ceil(fam.raw.lo * lsb_per_raw), math.floor(fam.raw.hi * lsb_per_raw)


def _enc_checks(spec: Message, msg: Msg, fams: dict[str, Family]) -> list[str]:
    tests = []
    for f in spec.fields:
        sig = msg.signals[f.signal]
        if f.rule == "enum":
            if sig.lo > 0:
                tests.append(f"m->{f.member} < {_u(sig.lo)}")
            tests.append(f"m->{f.member} > {_u(sig.hi)}")
        elif f.rule == "check":
            lo, hi = _value_limits(fams[f.family])
            tests += [f"m->{f.member} < {lo}", f"m->{f.member} > {hi}"]
    return tests


def _enc_value(f: Field, sig: Sig) -> str:
    v = f"m->{f.member}"
    if f.rule == "bool":
        return f"{v} ? 1u : 0u"
    if f.rule == "mask":
        return f"({sig.ctype})({v} & {_u(sig.hi)})"
    if f.rule == "clip":
        return f"({sig.ctype})({v} > {_u(sig.hi)} ? {_u(sig.hi)} : {v})"
    if f.rule == "sat":
        if f.family:
            return f"enc_{f.family.lower()}({v}, &sat)"
        return f"({sig.ctype})clamp({v}, {sig.lo}, {sig.hi}, &sat)"
    if f.rule == "check":
        return f"enc_{f.family.lower()}({v})"
    return v


def _bus(msg: Msg) -> str:
    return "bus" if len(msg.buses) > 1 else f"SP_BUS_{msg.buses[0].upper()}"


def encoder(spec: Message, msg: Msg, fams: dict[str, Family]) -> list[str]:
    stem = f"stewart_can_{c_name(msg.name)}"
    params = ([f"const {spec.ctype} *m"] if spec.ctype else []) + (["uint8_t slot"] if spec.slots else []) + \
        ["uint8_t counter"] + (["uint8_t bus"] if _bus(msg) == "bus" else []) + ["sp_can_frame_t *f"]
    tests = (["m == NULL"] if spec.ctype else []) + ["f == NULL"] + \
        (["slot < 1u", "slot > SP_AXIS_SLOTS"] if spec.slots else []) + _enc_checks(spec, msg, fams)
    sat = any(f.rule == "sat" for f in spec.fields)
    out = [*_wrap(f"sp_status_t sp_proto_encode_{spec.name}(", params, ", ", ")"), "{",
           *_wrap("    if (", tests, " || ", ") {"), "        return SP_E_ARG;", "    }"]
    if sat:
        out.append("    int sat = 0;")
    out += [f"    struct {stem}_t s;", f"    (void){stem}_init(&s);"]
    fields = {f.signal: f for f in spec.fields}
    for sig in msg.signals.values():
        if sig.name == "Counter":
            out.append(f"    s.counter = ({sig.ctype})(counter & {_u(sig.hi)});")
        elif sig.name in fields:
            out.append(f"    s.{sig.member} = {_enc_value(fields[sig.name], sig)};")
    frame_id = f"SP_ID_{msg.name} + slot - 1u" if spec.slots else f"SP_ID_{msg.name}"
    out += ["    clear(f);",
            *_wrap("    return finish(", ["f", frame_id, _bus(msg), f"{stem}_pack(f->data, &s, SP_CAN_MAX_DATA)",
                                          f"{stem.upper()}_LENGTH", "sat" if sat else "0"], ", ", ");"),
            "}", ""]
    return out


def _dec_checks(spec: Message, msg: Msg) -> list[str]:
    tests = []
    for f in spec.fields:
        sig = msg.signals[f.signal]
        if sig.lo > sig.bits[0]:
            tests.append(f"s.{sig.member} < {_u(sig.lo) if sig.lo >= 0 else sig.lo}")
        if sig.hi < sig.bits[1]:
            tests.append(f"s.{sig.member} > {_u(sig.hi)}")
    return tests


def decoder(spec: Message, msg: Msg) -> list[str]:
    stem = f"stewart_can_{c_name(msg.name)}"
    params = ["const sp_can_frame_t *f"] + ([f"{spec.ctype} *m"] if spec.ctype else []) + \
        (["uint8_t *slot"] if spec.slots else []) + ["uint8_t *counter", "sp_proto_error_t *error"]
    nulls = (["m == NULL"] if spec.ctype else []) + (["slot == NULL"] if spec.slots else []) + ["counter == NULL"]
    out = [*_wrap(f"sp_status_t sp_proto_decode_{spec.name}(", params, ", ", ")"), "{",
           *_wrap("    if (", nulls, " || ", ") {"), "        return SP_E_ARG;", "    }"]
    frame_id = f"SP_ID_{msg.name}"
    if spec.slots:
        out += [f"    if (f == NULL || f->id < {frame_id} || f->id >= {frame_id} + SP_AXIS_SLOTS) {{",
                "        return reject(error, SP_PROTO_UNKNOWN_ID);", "    }"]
        frame_id = "f->id"
    out += [f"    if (precheck(f, {frame_id}, {stem.upper()}_LENGTH, error) != SP_OK) {{",
            "        return SP_E_FRAME;", "    }",
            f"    struct {stem}_t s;",
            f"    (void){stem}_unpack(&s, f->data, f->len); /* cannot fail: precheck checked the length */"]
    tests = _dec_checks(spec, msg)
    if tests:
        out += [*_wrap("    if (", tests, " || ", ") {"), "        return reject(error, SP_PROTO_OUT_OF_RANGE);",
                "    }"]
    for f in spec.fields:
        sig = msg.signals[f.signal]
        value = f"dec_{f.family.lower()}(s.{sig.member})" if f.family else f"s.{sig.member}"
        out.append(f"    m->{f.member} = {value};")
    if spec.slots:
        out.append(f"    *slot = (uint8_t)(f->id - SP_ID_{msg.name} + 1u);")
    out += ["    *counter = s.counter;", "    return SP_OK;", "}", ""]
    return out


def _asserts(msgs: dict[str, Msg], fams: dict[str, Family]) -> list[str]:
    """protocol.h's identifiers and limits against the DBC: the build fails where they differ."""
    out = []
    for spec in MESSAGES:
        msg = msgs[spec.dbc]
        out.append(f"SP_PROTO_ASSERT(SP_ID_{msg.name} == {msg.frame_id}u, id_{spec.name});")
        if spec.slots:
            out.append(f"SP_PROTO_ASSERT(SP_AXIS_SLOTS == {_slots(msgs, spec)}u, slots_{spec.name});")
        for macro, signal, end in spec.limits:
            field = next(f for f in spec.fields if f.signal == signal)
            lo, hi = _value_limits(fams[field.family])
            out.append(f"SP_PROTO_ASSERT({macro} == {lo if end == 'min' else hi}, {macro.lower()});")
        for macro, family in spec.largest:
            fam = fams[family]
            top = Fraction(fam.raw.hi) / fam.ratio
            if top.denominator != 1:
                raise CodecError(f"{family}: the largest raw value is no whole value of the core")
            out.append(f"SP_PROTO_ASSERT({macro} == {top.numerator}, {macro.lower()});")
    return out


def dbc_hash(dbc_text: str) -> int:
    """The protocol's identity (CTRL_IDENTITY ProtocolHash): the first 4 bytes, big-endian, of the
    SHA-256 of the DBC's bytes (UTF-8), as tools/stewart/protocol.py computes it."""
    return int.from_bytes(hashlib.sha256(dbc_text.encode("utf-8")).digest()[:4], "big")


def generate(dbc_text: str, dbc_name: str) -> str:
    msgs = read_messages(dbc_text)
    check_mapping(msgs)
    fams = families(dbc_text, msgs)
    lines = ["/* SPDX-License-Identifier: Apache-2.0 */",
             f"/* Generated by tools/dev/gen_proto_c.py from {dbc_name}: do not edit. The protocol codec of",
             " * sp/link/protocol.h; the shared steps are link/proto_codec.h's. */",
             '#include "link/proto_codec.h"', "",
             "#define SP_PROTO_ASSERT(cond, name) typedef char sp_proto_check_##name[(cond) ? 1 : -1]",
             *_asserts(msgs, fams), "",
             f"/* the DBC's identity (CTRL_IDENTITY ProtocolHash): SHA-256 of {dbc_name}, first 4 bytes */",
             f"const uint32_t sp_proto_dbc_hash = 0x{dbc_hash(dbc_text):08X}u;", "",
             "/* value <-> raw of each scale family: raw = value x NUM / DEN (stewart_can.h) */",
             *family_helpers(fams)]
    for spec in MESSAGES:
        lines.append(f"/* ---- {spec.dbc[:-2] + '_1..' + str(_slots(msgs, spec)) if spec.slots else spec.dbc} ---- */")
        lines += encoder(spec, msgs[spec.dbc], fams)
        lines += decoder(spec, msgs[spec.dbc])
    return "\n".join(lines).rstrip("\n") + "\n"


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: gen_proto_c.py DBC OUTDIR", file=sys.stderr)
        return 2
    dbc, out = argv
    try:
        text = generate(Path(dbc).read_bytes().decode("utf-8"), Path(dbc).name)
    except (CodecError, gen_can_c.ScaleError) as exc:
        print(f"error: {dbc}: {exc}", file=sys.stderr)
        return 1
    outdir = Path(out)
    outdir.mkdir(parents=True, exist_ok=True)
    (outdir / OUT_NAME).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
