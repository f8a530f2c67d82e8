# SPDX-License-Identifier: Apache-2.0
"""Generates the firmware's CAN pack/unpack C code from the DBC.

    python3 tools/dev/gen_can_c.py CANTOOLS protocol/stewart.dbc OUTDIR

Runs ``cantools generate_c_source --no-floating-point-numbers``. cantools
45.1 still emits ``*_is_in_phys_range(double)`` helpers with that option;
the firmware core may not contain floating point, so this removes exactly
those functions (prototype with its comment, and definition) and then fails
if any ``double`` or ``float`` is left, rather than letting it through.

It also appends, for each message with the command authentication signals
(AuthCounter, AuthTag: docs/explanation/security.md), where they are:
SP_CAN_<MESSAGE>_AUTH_COUNTER_BYTE, _AUTH_TAG_BYTE and _AUTH_TAG_BYTES (the
code covers the payload bytes before the tag); the build fails when they are
not whole little-endian bytes, the counter is not 16 bits before the tag, or
the tag is not 4 to 8 bytes.

It then appends to the header the scale ratios of the protocol layer
(firmware/core/src/link/protocol.c) between the core's fixed-point values and the
raw signals: for each family of signals in :data:`SCALES`, raw = value x
NUM / DEN with NUM / DEN the reduced fraction (the core's LSB) / (the DBC
factor), computed exactly from the factor as written in the DBC. The build
fails with a message naming the signal when a family's signals disagree on
factor or unit, a factor is not a positive decimal number, an offset is not
zero, or NUM and DEN are too large for the core's 64-bit scaling.

Runs with the plain system Python (no cantools module): the factors are read
from the DBC's ``SG_`` lines, every one of which must parse.
"""

from __future__ import annotations

import re
import subprocess
import sys
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from fractions import Fraction
from pathlib import Path

NAME = "stewart_can"

Q24 = Fraction(1, 1 << 24)
Q8 = Fraction(1, 1 << 8)
_POSE = "X|Y|Z|Roll|Pitch|Yaw"

#: The scale families: (macro stem, the core value's unit in the macro name,
#: the core value's LSB in the DBC unit, the DBC unit(s) the signals must
#: have, the signals as (message regex, signal regex) pairs, each of which
#: must match at least one signal).
SCALES: tuple[tuple[str, str, Fraction, frozenset[str], tuple[tuple[str, str], ...]], ...] = (
    ("LENGTH", "Q24_M", Q24, frozenset({"m"}),
     (("AXIS_SETPOINTS", r"Length_\d"), ("CTRL_MONITOR", r"LengthSp_\d"))),
    ("FEEDBACK_LENGTH", "Q24_M", Q24, frozenset({"m"}), ((r"AXIS_FEEDBACK_\d", "Length"),)),
    ("POSE", "Q24_M_RAD", Q24, frozenset({"m", "rad"}),
     (("OP_TARGET_POSE", _POSE), ("CTRL_STATUS", _POSE), ("CTRL_MONITOR", f"Ref(?:{_POSE})"))),
    ("VELOCITY", "Q24_MPS", Q24, frozenset({"m/s"}), (("AXIS_SETPOINTS", r"Velocity_\d"),)),
    ("FORCE", "Q8_N", Q8, frozenset({"N"}),
     (("AXIS_SETPOINTS", r"Force_\d"), ("CTRL_MONITOR", r"ForceFf_\d"), ("CTRL_REACH", r"Force_\d"))),
    ("FRAME_POSE", "Q24_M_RAD", Q24, frozenset({"m", "rad"}), (("OP_FRAME", _POSE), ("OP_REACH", _POSE))),
    ("EXCESS", "Q24_M_RAD", Q24, frozenset({"m|rad"}), (("CTRL_REACH", "Excess"),)),
    ("PRESSURE", "PA", Fraction(1), frozenset({"Pa"}), ((r"AXIS_FEEDBACK_\d", "Pressure[AB]"),)),
    ("WRENCH", "Q8_N_NM", Q8, frozenset({"N", "N m"}), (("CTRL_WRENCH", "[FM][xyz]"),)),
    ("FT_WRENCH", "Q8_N_NM", Q8, frozenset({"N", "N m"}), (("OP_FORCE", "[FM][xyz]"), ("FT_SENSOR", "[FM][xyz]"))),
    ("AMPLITUDE", "Q24_M_RAD", Q24, frozenset({"m|rad"}), (("OP_COMMAND", "Amplitude"),)),
    ("FREQUENCY", "Q24_HZ", Q24, frozenset({"Hz"}), (("OP_COMMAND", "Frequency"),)),
    ("FADE_TIME", "MS", Fraction(1, 1000), frozenset({"s"}), (("OP_COMMAND", "FadeTime"),)),
    ("MASS", "Q16_KG", Fraction(1, 1 << 16), frozenset({"kg"}), (("OP_FORCE_PARAMS", "Mass"),)),
    ("DAMPING", "N_S_PER_M", Fraction(1), frozenset({"N s/m"}), (("OP_FORCE_PARAMS", "Damping"),)),
    ("STIFFNESS", "N_PER_M", Fraction(1), frozenset({"N/m"}), (("OP_FORCE_PARAMS", "Stiffness"),)),
)
#: The core's values are int32 and raw signals at most 32 bits; the protocol
#: layer's muldiv() needs |value x NUM| and |raw x DEN| below 2^62.
PRODUCT_LIMIT = 1 << 62
VALUE_BITS = 31


class ScaleError(ValueError):
    """A DBC factor the generator cannot turn into an exact ratio."""


@dataclass(frozen=True)
class Signal:
    message: str
    name: str
    length: int
    factor: str
    offset: str
    unit: str


_BO = re.compile(r"^BO_ \d+ (\w+)\s*:")
_SG = re.compile(r'^SG_ (\w+) : \d+\|(\d+)@[01][+-] \(([^,()]+),([^,()]+)\) \[[^]]*\] "([^"]*)"')


def read_signals(dbc_text: str) -> list[Signal]:
    """Every signal of the DBC with its factor and offset as written."""
    out: list[Signal] = []
    message = None
    for n, line in enumerate(dbc_text.splitlines(), start=1):
        line = line.strip()
        m = _BO.match(line)
        if m:
            message = m.group(1)
            continue
        if line.startswith("SG_ "):
            m = _SG.match(line)
            if m is None or message is None:
                raise ScaleError(f"line {n}: cannot read this signal's factor: {line}")
            out.append(Signal(message, m.group(1), int(m.group(2)), m.group(3).strip(), m.group(4).strip(),
                              m.group(5)))
    return out


def _decimal(text: str, what: str) -> Fraction:
    try:
        d = Decimal(text)
    except InvalidOperation:
        raise ScaleError(f"{what} {text!r} is not a decimal number") from None
    if not d.is_finite():
        raise ScaleError(f"{what} {text!r} is not a finite number")
    return Fraction(d)


def scale_ratios(signals: list[Signal]) -> list[tuple[str, Fraction, str]]:
    """(macro stem with unit, raw per core LSB as a reduced fraction, comment)
    of each family of :data:`SCALES`; ScaleError says what is wrong."""
    out = []
    for stem, unit_name, lsb, units, patterns in SCALES:
        members = []
        for msg_re, sig_re in patterns:
            found = [s for s in signals if re.fullmatch(msg_re, s.message) and re.fullmatch(sig_re, s.name)]
            if not found:
                raise ScaleError(f"{stem}: no signal {msg_re}.{sig_re} in the DBC")
            members += found
        first = members[0]
        for s in members:
            where = f"{stem}: {s.message}.{s.name}"
            factor = _decimal(s.factor, f"{where}: factor")
            if factor <= 0:
                raise ScaleError(f"{where}: factor {s.factor} is not positive")
            if _decimal(s.offset, f"{where}: offset") != 0:
                raise ScaleError(f"{where}: offset {s.offset} is not 0 (the protocol layer scales only)")
            if factor != _decimal(first.factor, "factor"):
                raise ScaleError(f"{where}: factor {s.factor} differs from {first.message}.{first.name}'s "
                                 f"{first.factor} (one ratio per family)")
            if s.unit not in units:
                raise ScaleError(f"{where}: unit {s.unit!r}, the core's value is in {' or '.join(sorted(units))}")
        ratio = lsb / _decimal(first.factor, "factor")
        widest = max(s.length for s in members)
        if (ratio.numerator << VALUE_BITS) >= PRODUCT_LIMIT or (ratio.denominator << widest) >= PRODUCT_LIMIT:
            raise ScaleError(f"{stem}: factor {first.factor} gives raw = value x {ratio.numerator} / "
                             f"{ratio.denominator}, too large for the 64-bit scaling (value x NUM and raw x DEN "
                             f"must stay below 2^62)")
        messages = ", ".join(dict.fromkeys(s.message for s in members))
        unit = " or ".join(sorted({s.unit for s in members}))
        out.append((f"SP_CAN_{stem}_RAW_PER_{unit_name}", ratio,
                    f"1 raw = {first.factor} {unit}: {len(members)} signal(s) of {messages}"))
    return out


_SG_POS = re.compile(r"^SG_ (\w+) : (\d+)\|(\d+)@([01])([+-])")


def auth_header(dbc_text: str) -> str:
    """The authentication fields' byte positions of each message that has
    them (see the module text); ScaleError says what is wrong."""
    fields: dict[str, dict[str, tuple[int, int]]] = {}
    order: list[str] = []
    message = None
    for line in dbc_text.splitlines():
        line = line.strip()
        m = _BO.match(line)
        if m:
            message = m.group(1)
            continue
        m = _SG_POS.match(line)
        if m and message is not None and m.group(1) in ("AuthCounter", "AuthTag"):
            if m.group(4) != "1" or m.group(5) != "+":
                raise ScaleError(f"{message}.{m.group(1)}: must be little-endian and unsigned")
            if message not in fields:
                fields[message] = {}
                order.append(message)
            fields[message][m.group(1)] = (int(m.group(2)), int(m.group(3)))
    lines = ["/* Command authentication fields (docs/explanation/security.md), generated by tools/dev/gen_can_c.py",
             " * from the DBC: byte offsets in the payload; the code covers the bytes before the tag. */"]
    for msg in order:
        f = fields[msg]
        if "AuthCounter" not in f or "AuthTag" not in f:
            raise ScaleError(f"{msg}: AuthCounter and AuthTag go together")
        (cs, cl), (ts, tl) = f["AuthCounter"], f["AuthTag"]
        if cs % 8 or cl != 16 or ts % 8 or tl % 8 or not 32 <= tl <= 64:
            raise ScaleError(f"{msg}: AuthCounter must be 16 whole bits, AuthTag 4 to 8 whole bytes")
        if cs + cl > ts:
            raise ScaleError(f"{msg}: AuthCounter must come before AuthTag (the code covers it)")
        lines.append(f"#define SP_CAN_{msg}_AUTH_COUNTER_BYTE {cs // 8}")
        lines.append(f"#define SP_CAN_{msg}_AUTH_TAG_BYTE {ts // 8}")
        lines.append(f"#define SP_CAN_{msg}_AUTH_TAG_BYTES {tl // 8}")
    return "\n".join(lines) + "\n\n"


def scale_header(signals: list[Signal]) -> str:
    lines = ["/* Scale ratios of the protocol layer, generated by tools/dev/gen_can_c.py from the",
             " * DBC's factors: raw = value * NUM / DEN, value = raw * DEN / NUM (reduced fractions). */"]
    for macro, ratio, comment in scale_ratios(signals):
        lines.append(f"/* {comment} */")
        lines.append(f"#define {macro}_NUM {ratio.numerator}")
        lines.append(f"#define {macro}_DEN {ratio.denominator}")
    return "\n".join(lines) + "\n\n"


def strip_phys_range(text: str) -> str:
    # definitions: "bool name_is_in_phys_range(double value)\n{ ... }\n"
    text = re.sub(r"\nbool \w+_is_in_phys_range\(double value\)\n\{\n.*?\n\}\n", "\n", text, flags=re.S)
    # prototypes with their doc comment
    text = re.sub(r"\n/\*\*(?:(?!\*/).)*?\*/\nbool \w+_is_in_phys_range\(double value\);\n", "\n", text,
                  flags=re.S)
    return text


_HEADER_END = "#ifdef __cplusplus\n}\n#endif\n\n#endif\n"


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        print("usage: gen_can_c.py CANTOOLS DBC OUTDIR", file=sys.stderr)
        return 2
    cantools, dbc, out = argv
    try:
        text = Path(dbc).read_text()
        scales = scale_header(read_signals(text)) + auth_header(text)
    except ScaleError as exc:
        print(f"error: {dbc}: {exc}", file=sys.stderr)
        return 1
    outdir = Path(out)
    outdir.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([cantools, "generate_c_source", "--no-floating-point-numbers", "--database-name", NAME,
                        "--output-directory", str(outdir), dbc], capture_output=True, text=True)
    if r.returncode != 0:
        print(r.stdout + r.stderr, file=sys.stderr)
        return 1
    for suffix in (".h", ".c"):
        p = outdir / (NAME + suffix)
        text = strip_phys_range(p.read_text())
        code = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
        bad = re.search(r"\b(double|float)\b", code)
        if bad:
            line = code[: bad.start()].count("\n") + 1
            print(f"error: {p}: floating point left in generated code near line {line}", file=sys.stderr)
            return 1
        if suffix == ".h":
            if not text.endswith(_HEADER_END):
                print(f"error: {p}: does not end as cantools' headers do; cannot add the scales", file=sys.stderr)
                return 1
            text = text[: -len(_HEADER_END)] + scales + _HEADER_END
        p.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
