# SPDX-License-Identifier: Apache-2.0
"""``stewart protocol``: the CAN protocol's derived files.

``stewart protocol vectors [--write]``: the shared test vectors
(``protocol/test_vectors.json``) that keep the C and Python sides
byte-compatible. Without ``--write`` the committed file is checked against the
DBC and the encoder (exit 1 when they differ).

``stewart protocol doc [--out FILE] [--check]``: the protocol documentation
(``docs/reference/protocol.md``), generated from the DBC so it is never written twice.

``stewart protocol decode ID HEX [--bus BUS]``: checks and decodes one frame.

``stewart protocol hash``: the DBC's hash, as the firmware built from it
sends it in CTRL_IDENTITY (``stewart op identify``).
"""

from __future__ import annotations

import argparse
import json
import sys
from decimal import Decimal
from pathlib import Path

from .. import resources

VECTORS_PATH = resources.source_path("protocol", "test_vectors.json")
DOC_PATH = resources.source_path("docs", "reference", "protocol.md")

#: Realistic values per message (physical units) for the "typical" vectors.
TYPICAL = {
    "SYNC": {"Tick": 123456, "Hold": 0},
    "AXIS_SETPOINTS": {
        "Tick": 123456, "Mode": "ACTIVE",
        "Length_1": 1.812345, "Velocity_1": 0.25, "Force_1": 12345.66,
        "Length_2": 1.7, "Velocity_2": -0.3, "Force_2": -2500.5,
        "Length_3": 2.05, "Velocity_3": 0.0, "Force_3": 40000.0,
    },
    "AXIS_FEEDBACK_1": {"Length": 1.812001, "PressureA": 12.5e6, "PressureB": 3.2e6,
                        "State": "ACTIVE", "Faults": 0, "TickEcho": 0xE240},
    "AXIS_FEEDBACK_2": {"Length": 1.699876, "PressureA": 8.0e6, "PressureB": 10.11e6,
                        "State": "HOLD", "Faults": 0x01, "TickEcho": 0xE240},
    "AXIS_FEEDBACK_3": {"Length": 2.05, "PressureA": 0.0, "PressureB": 40.95e6,
                        "State": "FAULT", "Faults": 0x44, "TickEcho": 0xFFFF},
    "OP_COMMAND": {"Command": "RUN_TRIG", "Axis": "X", "Amplitude": 0.09, "Frequency": 0.5,
                   "FadeTime": 2.0, "Option": 0, "AuthCounter": 0x0102, "AuthTag": 0x0A0B0C0D0E0F},
    "OP_HEARTBEAT": {},
    "OP_FORCE": {"Mask": 4, "Fx": 0.0, "Fy": -12.5, "Fz": 2000.0, "Mx": 1.03125, "My": -0.5,
                 "Mz": 0.0, "AuthCounter": 0xFFFF, "AuthTag": 0x123456789ABC},
    "OP_FORCE_PARAMS": {"Mask": 7, "Mode": "FORCE", "Mass": 35.5, "Damping": 500000.0, "Stiffness": 1000.0},
    "FT_SENSOR": {"Fx": 3.25, "Fy": -1.5, "Fz": -1987.40625, "Mx": 0.125, "My": -2.0, "Mz": 0.03125,
                  "Saturated": 0},
    "OP_TARGET_POSE": {"X": 0.05, "Y": -0.02, "Z": 0.1, "Roll": 0.01, "Pitch": -0.05,
                       "Yaw": 0.2, "AuthCounter": 0x8000, "AuthTag": 0xFEDCBA987654},
    "CTRL_STATUS": {"Tick": 99999, "State": "RUNNING", "Faults": 0, "FkIterations": 2,
                    "EstimateValid": 1, "CmdRejected": 0, "DriveMode": "ACTIVE",
                    "FeedForward": 1, "ForceMode": "FORCE", "Contact": 1, "X": 0.049998, "Y": -0.020001, "Z": 0.100002,
                    "Roll": 0.009999, "Pitch": -0.050001, "Yaw": 0.2},
    "CTRL_MONITOR": {"Tick": 99999, "RefX": 0.05, "RefY": -0.02, "RefZ": 0.1,
                     "RefRoll": 0.01, "RefPitch": -0.05, "RefYaw": 0.2,
                     **{f"LengthSp_{i}": 1.7 + 0.05 * i for i in range(1, 7)},
                     **{f"ForceFf_{i}": (-1) ** i * 1000.0 * i for i in range(1, 7)}},
    "CTRL_AUTH": {"Session": 0x5EED0017, "LastCounter": 123456, "BadTag": 3, "Replayed": 1, "KeySet": "ON"},
    "CTRL_IDENTITY": {"VersionMajor": 0, "VersionMinor": 3, "VersionPatch": 0, "Port": "STM32G474",
                      "ProtocolHash": 0x5A3C96E1},
    "CTRL_REFUSAL": {"Tick": 99997, "Command": "RUN_TRIG", "Reason": "RATE"},
    "CTRL_WRENCH": {"Tick": 99998, "Valid": 1, "Fx": 120.25, "Fy": -35.5, "Fz": -2452.75,
                    "Mx": 14.0, "My": -250.25, "Mz": 0.75},
    "OP_FRAME": {"Op": "SET", "Kind": "TOOL", "Index": 1, "X": 0.15, "Y": 0.0, "Z": 0.35,
                 "Roll": 0.0, "Pitch": 0.0, "Yaw": 0.1},
    "OP_REACH": {"Sequence": 42, "X": 0.15, "Y": -0.02, "Z": 2.5, "Roll": 0.08, "Pitch": 0.0, "Yaw": -0.08},
    "CTRL_REACH": {"Sequence": 42, "Verdict": "LEG_LONG", "Which": 3, "Excess": 0.012345,
                   **{f"Force_{i}": 4000.0 + 100.0 * i for i in range(1, 7)}},
    "CTRL_FRAMES": {"ToolIndex": 1, "WorkIndex": 0, "Identity": 0, "LastRefusal": "EMPTY_SLOT",
                    "Checksum": 0x1234ABCD, "RefusedState": 2, "RefusedRange": 6, "RefusedReach": 4,
                    "RefusedRate": 7, "RefusedForce": 8, "RefusedEmptySlot": 1, "RefusedBadFrame": 0,
                    "RefusedNotFinite": 3},
}

#: Counter sequences for the receiver state machine, each from a fresh receiver.
COUNTER_SEQUENCES = [
    ("wrap 15 -> 0", [13, 14, 15, 0, 1]),
    ("lost frames", [0, 2, 5, 6]),
    ("lost across the wrap", [14, 1, 2]),
    ("repeated", [4, 4, 5]),
    ("wrong sequence, resynchronise on the next frame", [0, 4, 9, 10]),
    ("counter going back", [5, 4, 5, 6]),
    ("repeat after loss", [3, 5, 5, 6]),
]


def _physical(signal, raw: int):
    if signal.scale == 1 and signal.offset == 0:
        return int(raw)
    v = Decimal(int(raw)) * Decimal(str(signal.scale)) + Decimal(str(signal.offset))
    return float(v)


def _vector(proto, name: str, case: str, raw: dict[str, int], counter: int) -> dict:
    m = proto.message(name)
    raw = dict(raw)
    raw["Counter"] = counter
    data = proto.encode_raw(name, raw)
    decoded = m.decode(data, decode_choices=False, scaling=False)
    return {
        "message": name,
        "frame_id": m.frame_id,
        "case": case,
        "counter": counter,
        "raw": {s.name: int(decoded[s.name]) for s in m.signals},
        "physical": {s.name: _physical(s, decoded[s.name]) for s in m.signals
                     if s.name not in ("Counter", "Crc")},
        "data": data.hex(),
    }


def _malformed(proto) -> list[dict]:
    from .. import e2e

    def typ(name: str, counter: int = 0) -> bytes:
        raw = proto.to_raw(name, TYPICAL[name], counter)
        return proto.encode_raw(name, raw)

    def with_raw(name: str, **over) -> bytes:
        m = proto.message(name)
        raw = proto.to_raw(name, TYPICAL[name], 0)
        raw.update(over)
        values = dict(raw)
        data = m.encode(values, scaling=False, padding=False, strict=False)
        return e2e.seal(m.frame_id, bytes(data))

    sync = typ("SYNC")
    fb1 = typ("AXIS_FEEDBACK_1")
    sp = typ("AXIS_SETPOINTS")
    flipped = bytearray(sp)
    flipped[9] ^= 0x10
    crc_flipped = bytearray(fb1)
    crc_flipped[-1] ^= 0x01
    cases = [
        ("unknown ID", 0x011, sync, "unknown-id"),
        ("unknown ID 0x7FF", 0x7FF, sync, "unknown-id"),
        ("SYNC one byte short", 0x010, sync[:-1], "bad-length"),
        ("SYNC as a 12-byte frame", 0x010, sync + bytes(4), "bad-length"),
        ("AXIS_SETPOINTS as a 64-byte frame", 0x020, sp + bytes(32), "bad-length"),
        ("empty AXIS_FEEDBACK_1", 0x031, b"", "bad-length"),
        ("AXIS_SETPOINTS with one payload bit flipped", 0x020, bytes(flipped), "bad-crc"),
        ("AXIS_FEEDBACK_1 with a CRC bit flipped", 0x031, bytes(crc_flipped), "bad-crc"),
        ("AXIS_FEEDBACK_1 frame on ID 0x032 (CRC valid for 0x031)", 0x032, fb1, "bad-crc"),
        ("AXIS_FEEDBACK_1 payload on ID 0x031, CRC sealed for 0x040", 0x031,
         e2e.seal(0x040, fb1), "bad-crc"),
        ("OP_COMMAND frame on ID 0x038 (same length, CRC valid for 0x040)", 0x038,
         typ("OP_COMMAND"), "bad-crc"),
        ("AXIS_SETPOINTS Mode 2", 0x020, with_raw("AXIS_SETPOINTS", Mode=2), "out-of-range"),
        ("AXIS_SETPOINTS Velocity_2 raw -32768", 0x020,
         with_raw("AXIS_SETPOINTS", Velocity_2=-32768), "out-of-range"),
        ("AXIS_SETPOINTS Force_3 raw -8388608", 0x020,
         with_raw("AXIS_SETPOINTS", Force_3=-8388608), "out-of-range"),
        ("AXIS_FEEDBACK_1 State 4", 0x031, with_raw("AXIS_FEEDBACK_1", State=4), "out-of-range"),
        ("OP_COMMAND Command 15", 0x040, with_raw("OP_COMMAND", Command=15), "out-of-range"),
        ("OP_FORCE Fz raw -524288", 0x048, with_raw("OP_FORCE", Fz=-524288), "out-of-range"),
        ("OP_FORCE as a 36-byte frame", 0x048, typ("OP_FORCE") + bytes(4), "bad-length"),
        ("FT_SENSOR Mx raw -524288", 0x038, with_raw("FT_SENSOR", Mx=-524288), "out-of-range"),
        ("CTRL_STATUS ForceMode 5", 0x100, with_raw("CTRL_STATUS", ForceMode=5), "out-of-range"),
        ("OP_COMMAND Axis 6", 0x040, with_raw("OP_COMMAND", Axis=6), "out-of-range"),
        ("CTRL_STATUS State 8", 0x100, with_raw("CTRL_STATUS", State=8), "out-of-range"),
        ("OP_TARGET_POSE Yaw raw -8388608", 0x050,
         with_raw("OP_TARGET_POSE", Yaw=-8388608), "out-of-range"),
        ("CTRL_WRENCH Mz raw -2097152", 0x102, with_raw("CTRL_WRENCH", Mz=-2097152), "out-of-range"),
        ("CTRL_WRENCH as a 32-byte frame", 0x102, typ("CTRL_WRENCH") + bytes(8), "bad-length"),
    ]
    return [{"case": c, "frame_id": fid, "data": bytes(d).hex(), "kind": k}
            for c, fid, d, k in cases]


def make_vectors(proto=None) -> dict:
    """The shared test vectors, deterministically from the DBC and the encoder."""
    from .. import e2e
    from ..protocol import Protocol

    proto = proto or Protocol()
    vectors = []
    for name, info in proto.infos.items():
        m = proto.message(name)
        sigs = [s for s in m.signals if s.name not in ("Counter", "Crc")]
        lo = {s.name: info.limits[s.name].lo for s in sigs}
        hi = {s.name: info.limits[s.name].hi for s in sigs}
        mixed = {s.name: (hi if i % 2 == 0 else lo)[s.name] for i, s in enumerate(sigs)}
        vectors.append(_vector(proto, name, "min", lo, 0))
        vectors.append(_vector(proto, name, "max", hi, 15))
        vectors.append(_vector(proto, name, "mixed", mixed, 10))
        vectors.append(_vector(proto, name, "typical", proto.to_raw(name, TYPICAL[name], 7), 7))
    sequences = []
    for title, counters in COUNTER_SEQUENCES:
        rx = e2e.E2EReceiver()
        checks = [rx.check(c) for c in counters]
        sequences.append({"case": title, "counters": counters,
                          "status": [c.status for c in checks], "lost": [c.lost for c in checks]})
    check = b"123456789"
    return {
        "about": ("Shared CAN test vectors, generated by `stewart protocol vectors --write` "
                  "from protocol/stewart.dbc. Do not edit. data: the full frame as hex, "
                  "CRC included; raw: the integer of each signal; physical: raw * scale + "
                  "offset. counter_sequences: statuses of a fresh E2E receiver fed these "
                  "counters. malformed: each frame, received first on a fresh receiver, is "
                  "rejected with this kind."),
        "crc": [
            {"algorithm": "CRC-8 SAE J1850", "input": check.hex(), "crc": e2e.crc8_j1850(check)},
            {"algorithm": "CRC-16/CCITT-FALSE", "input": check.hex(),
             "crc": e2e.crc16_ccitt_false(check)},
        ],
        "messages": {name: {"frame_id": i.frame_id, "length": i.length, "crc_bytes": i.crc_bytes,
                            "buses": list(i.buses), "cycle_ms": i.cycle_ms}
                     for name, i in proto.infos.items()},
        "vectors": vectors,
        "counter_sequences": sequences,
        "malformed": _malformed(proto),
    }


def vectors_text(vectors: dict) -> str:
    return json.dumps(vectors, indent=1) + "\n"


def run_vectors(args: argparse.Namespace) -> int:
    text = vectors_text(make_vectors())
    path = Path(args.file)
    if args.write:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        print(f"wrote {path}")
        return 0
    if not path.exists() or path.read_text() != text:
        print(f"{path} differs from the DBC and encoder: run `stewart protocol vectors --write` "
              "if the protocol change is intended", file=sys.stderr)
        return 1
    print(f"{path}: up to date")
    return 0


# -- documentation -------------------------------------------------------------

def _num(x) -> str:
    d = Decimal(str(x)).normalize()
    text = format(d, "f")
    return text


def _range(s) -> str:
    if s.minimum is None and s.maximum is None:
        return ""
    return f"{_num(s.minimum)} .. {_num(s.maximum)}"


def _bits(s) -> str:
    first, last = s.start, s.start + s.length - 1
    if s.length == 1:
        return f"{first} (byte {first // 8})"
    b0, b1 = first // 8, last // 8
    where = f"byte {b0}" if b0 == b1 else f"bytes {b0}-{b1}"
    return f"{first}-{last} ({where})"


def make_doc(proto=None) -> str:
    """docs/reference/protocol.md from the DBC (deterministic)."""
    from ..protocol import Protocol

    proto = proto or Protocol()
    rel = proto.dbc_path.resolve()
    try:
        rel = rel.relative_to(resources.source_path())
    except ValueError:
        pass
    out: list[str] = []
    w = out.append
    _doc_head(rel, w)
    _doc_buses(proto, w)
    _doc_nodes(proto.db, w)
    _doc_message_table(proto, w)
    for m in proto.db.messages:
        _doc_message(proto, m, w)
    _doc_e2e(w)
    _doc_bus_load(proto, w)
    return "\n".join(out).rstrip("\n") + "\n"


def _doc_head(rel: Path, w) -> None:
    """The title and where the page comes from."""
    w("# CAN protocol")
    w("")
    w(f"<!-- Generated by `stewart protocol doc` from `{rel}`; do not edit by hand. -->")
    w("")
    w(f"The single source of truth is [`{rel}`](../../{rel}); the C pack/unpack code is "
      "generated from it by cantools and the firmware's encoders and decoders (scales, ranges) by "
      "`tools/dev/gen_proto_c.py`, the Python side (`tools/stewart/protocol.py`) loads it, "
      "and this page is generated from it. Shared test vectors: "
      "[`protocol/test_vectors.json`](../../protocol/test_vectors.json).")
    w("")


def _doc_buses(proto, w) -> None:
    """The buses, their bit rates and why three CAN FD buses."""
    from ..protocol import BUSES

    w("## Buses and bit rates")
    w("")
    w(f"Three CAN FD buses, 11-bit identifiers, {proto.nominal_bitrate / 1e6:g} Mbit/s "
      f"arbitration and {proto.data_bitrate / 1e6:g} Mbit/s data phase (bit-rate switch on), "
      "a 1 ms cycle (CTRL_WRENCH: 2 ms; OP_COMMAND, OP_FORCE, CTRL_AUTH and CTRL_IDENTITY 10 ms; "
      "OP_HEARTBEAT 20 ms).")
    w("")
    w("| bus | SocketCAN interface | between |")
    w("|---|---|---|")
    between = {"ops": "operator PC (OPERATOR) and controller",
               "axis_a": "controller and the drives of legs 1..3 (slots 1..3)",
               "axis_b": "controller and the drives of legs 4..6 (slots 1..3)"}
    for bus, chan in BUSES.items():
        w(f"| `{bus}` | `{chan}` | {between.get(bus, '')} |")
    w("")
    w("Why CAN FD and why three buses: a classic CAN frame of 8 bytes takes up to 135 bits "
      "(135 us at 1 Mbit/s), so the 1 kHz traffic of six drives cannot fit one classic bus. "
      "With CAN FD the data phase runs at 5 Mbit/s, but every frame still pays about 34 bits "
      "(34 us) at the arbitration rate, so frame count matters more than payload. The "
      "STM32G474 has three FDCAN controllers: the drives are split over two axis buses "
      "(the same message IDs on both) and the operator PC gets its own bus, which keeps each "
      "bus at or under 50 % worst case per millisecond (table below).")
    w("")


def _doc_nodes(db, w) -> None:
    """The nodes and their roles."""
    w("## Nodes")
    w("")
    w("| node | role |")
    w("|---|---|")
    for node in db.nodes:
        w(f"| `{node.name}` | {node.comment or ''} |")
    w("")


def _doc_message_table(proto, w) -> None:
    """The table of all messages and the signals' conventions."""
    db = proto.db
    w("## Messages")
    w("")
    w("| ID | message | bytes | bus | period | send type | sender | receivers | CRC |")
    w("|---|---|---|---|---|---|---|---|---|")
    for m in db.messages:
        info = proto.infos[m.name]
        rx = sorted({r for s in m.signals for r in s.receivers})
        crc = "CRC-8" if info.crc_bytes == 1 else "CRC-16"
        w(f"| 0x{m.frame_id:03X} | [{m.name}](#{m.name.lower()}) | {m.length} "
          f"| {', '.join(info.buses)} | {info.cycle_ms} ms | {m.send_type or ''} "
          f"| {', '.join(m.senders)} | {', '.join(rx)} | {crc} |")
    w("")
    w("All signals are little-endian (Intel) unsigned (`u`) or two's-complement (`i`) "
      "integers; physical value = raw x scale + offset. Bits are numbered from bit 0 of "
      "byte 0. The range is the accepted physical range; a received frame with any signal "
      "outside it is rejected (signed ranges are symmetric: the most negative raw value "
      "is never valid). Bits not covered by a signal are sent as 0 and ignored.")
    w("")


def _doc_message(proto, m, w) -> None:
    """One message's section: its signals and their values."""
    info = proto.infos[m.name]
    w(f"### {m.name}")
    w("")
    w(f"ID 0x{m.frame_id:03X}, {m.length} bytes, CAN FD with bit-rate switch, "
      f"bus {', '.join(info.buses)}, every {info.cycle_ms} ms ({m.send_type}), "
      f"sent by {', '.join(m.senders)}.")
    w("")
    if m.comment:
        w(m.comment)
        w("")
    w("| signal | bits | length | type | scale | offset | range | unit | raw range "
      "| receivers | description |")
    w("|---|---|---|---|---|---|---|---|---|---|---|")
    for s in m.signals:
        lim = info.limits[s.name]
        w(f"| `{s.name}` | {_bits(s)} | {s.length} | {'i' if s.is_signed else 'u'}{s.length} "
          f"| {_num(s.scale)} | {_num(s.offset)} | {_range(s)} | {s.unit or ''} "
          f"| {lim.lo} .. {lim.hi} | {', '.join(s.receivers)} | {s.comment or ''} |")
    w("")
    for s in m.signals:
        if s.choices:
            vals = ", ".join(f"{k} = {v}" for k, v in sorted(s.choices.items()))
            w(f"- `{s.name}` values: {vals}")
    if any(s.choices for s in m.signals):
        w("")


def _doc_e2e(w) -> None:
    """The counter and CRC of every message and the receiver's checks."""
    from .. import e2e

    w("## E2E protection")
    w("")
    w("Every message carries an alive counter and a CRC (the pattern of the AUTOSAR E2E "
      "profiles):")
    w("")
    w("- `Counter`, 4 bits: +1 modulo 16 at each transmission of that message by its sender "
      "(per bus).")
    w(f"- `Crc` in the last byte(s): frames of up to {e2e.CRC8_MAX_LEN} bytes carry "
      "CRC-8 SAE J1850 (polynomial 0x1D, initial value 0xFF, final XOR 0xFF, not reflected; "
      "check value of \"123456789\": "
      f"0x{e2e.crc8_j1850(b'123456789'):02X}) in the last byte; longer frames carry "
      "CRC-16/CCITT-FALSE (polynomial 0x1021, initial value 0xFFFF, no final XOR, not "
      f"reflected; check value 0x{e2e.crc16_ccitt_false(b'123456789'):04X}) in the last two "
      "bytes, little-endian.")
    w("- The CRC covers the data ID, the 11-bit CAN ID as two bytes little-endian "
      "(ID & 0xFF, ID >> 8), then every payload byte before the CRC bytes. A frame received "
      "on another ID fails its CRC.")
    w("")
    w("The receiver keeps one counter reference per bus and message (each message has one "
      "sender on a bus) and checks each received frame in this order; a rejected frame is "
      "counted by kind and never reaches the application:")
    w("")
    w("1. unknown ID: `unknown-id`;")
    w("2. length different from the message's: `bad-length`;")
    w("3. CRC mismatch: `bad-crc` (the counter state is not touched);")
    w("4. counter, with delta = (counter - reference) mod 16:")
    w("")
    w("   | state / delta | status | frame | new reference |")
    w("   |---|---|---|---|")
    w("   | no reference (first frame, or after a wrong sequence) | `init` | accepted | counter |")
    w("   | 1 | `ok` | accepted | counter |")
    w(f"   | 2 .. {e2e.MAX_DELTA} | `lost` (delta - 1 frames lost, counted) | accepted | counter |")
    w("   | 0 | `repeated` | rejected | unchanged |")
    w(f"   | {e2e.MAX_DELTA + 1} .. 15 | `wrong-sequence` | rejected | none: resynchronise on "
      "the next frame |")
    w("")
    w("5. any signal outside its raw range: `out-of-range` (the counter reference has "
      "already advanced: the frame was sent by its sender).")
    w("")


def _doc_bus_load(proto, w) -> None:
    """The worst-case bus load table of ``stewart busload``."""
    from .busload_cmd import format_report, load_table

    w("## Bus load")
    w("")
    w("Computed by `stewart busload` from the DBC: worst-case bit stuffing, every message "
      "budgeted at its period (OP_COMMAND, event-driven, as if sent every millisecond). "
      "A CAN FD frame with bit-rate switch and n data bytes takes 34 bits at the nominal rate "
      "(17 arbitration bits + 4 stuff bits + CRC delimiter, ACK, EOF and intermission) and "
      "5 + 8n + floor((5 + 8n) / 4) + 4 + CRC + fixed stuff bits at the data rate (CRC 17 "
      "bits and 6 fixed stuff bits up to 16 bytes, 21 and 7 above).")
    w("")
    table = load_table(proto.db, proto.nominal_bitrate, proto.data_bitrate)
    text, _ = format_report(table, proto.nominal_bitrate, proto.data_bitrate, 50.0)
    for line in text.splitlines()[2:]:
        if line.startswith("bus "):
            w(f"Bus `{line[4:]}`:")
            w("")
        else:
            w(line)
    w("")


def run_doc(args: argparse.Namespace) -> int:
    text = make_doc()
    path = Path(args.out)
    if args.check:
        if not path.exists() or path.read_text() != text:
            print(f"{path} is not the documentation generated from the DBC: run "
                  "`stewart protocol doc`", file=sys.stderr)
            return 1
        print(f"{path}: up to date")
        return 0
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    print(f"wrote {path}")
    return 0


def run_decode(args: argparse.Namespace) -> int:
    from ..protocol import Protocol, ProtocolError

    proto = Protocol()
    try:
        frame_id = int(args.id, 0)
        data = bytes.fromhex(args.hex)
    except ValueError as exc:
        print(f"stewart protocol decode: {exc}", file=sys.stderr)
        return 2
    try:
        name, signals = proto.decode(frame_id, data, bus=args.bus, check_counter=False)
    except ProtocolError as err:
        print(f"rejected: {err}")
        return 1
    print(name)
    for k, v in signals.items():
        print(f"  {k} = {v}")
    return 0


def run_hash(args: argparse.Namespace) -> int:
    del args
    from .. import protocol as pr

    print(f"{pr.dbc_hash():08x}  {pr.DBC_PATH}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("protocol", help="CAN protocol: test vectors, documentation, decoding",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ps = p.add_subparsers(dest="protocol_command", metavar="ACTION")
    v = ps.add_parser("vectors", help="check (or --write) protocol/test_vectors.json")
    v.add_argument("--write", action="store_true", help="write the file instead of checking it")
    v.add_argument("--file", default=str(VECTORS_PATH), help="vectors file")
    v.set_defaults(func=run_vectors)
    d = ps.add_parser("doc", help="generate docs/reference/protocol.md from the DBC")
    d.add_argument("--out", default=str(DOC_PATH), help="output file")
    d.add_argument("--check", action="store_true", help="only check that --out is up to date")
    d.set_defaults(func=run_doc)
    c = ps.add_parser("decode", help="check and decode one frame (counter not checked)")
    c.add_argument("id", help="CAN ID, e.g. 0x31")
    c.add_argument("hex", help="frame data as hex")
    c.add_argument("--bus", default="default")
    c.set_defaults(func=run_decode)
    h = ps.add_parser("hash", help="the DBC's hash (CTRL_IDENTITY ProtocolHash)")
    h.set_defaults(func=run_hash)

    def no_action(args: argparse.Namespace) -> int:
        del args
        p.print_help()
        return 2

    p.set_defaults(func=no_action)
