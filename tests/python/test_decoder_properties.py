# SPDX-License-Identifier: Apache-2.0
"""Property tests (hypothesis) of the Python decoders on corrupted input:
the protocol's frame decoder (stewart.protocol) and the CAN log reader
(stewart.analysis.logfile.parse_line, stewart.analysis.decode.read_log).

Whatever comes in (random bytes, truncated lines, bad hex, wrong lengths,
bit flips), a decoder either returns, raises its documented exception
(ProtocolError with one of the protocol's rejection kinds, ValueError for
a log line), or, for a whole log, counts the line or frame as rejected;
never another exception. The log reader is tested through its public
functions only, so that these tests hold for any implementation of it.

The C decoders are fuzzed by libFuzzer (scripts/fuzz.sh, tests/fuzz/).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stewart import e2e
from stewart import protocol as pr
from stewart.analysis import decode
from stewart.analysis import logfile

REPO_ROOT = Path(__file__).resolve().parents[2]

SETTINGS = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
PROTO = pr.Protocol()
IDS = sorted(m.frame_id for m in PROTO.infos.values())
#: Real frames: every valid frame of the shared test vectors (CRC included).
VECTORS = [v for v in json.loads((REPO_ROOT / "protocol" / "test_vectors.json").read_text())["vectors"]]
#: The rejection kinds a decoder may give.
KINDS = set(pr.KINDS)


def vector_line(v, time_s: float = 1.0) -> str:
    """The vector's frame as a candump -L line on its message's first bus."""
    bus = PROTO.infos[v["message"]].buses[0]
    return logfile.format_line(time_s, pr.BUSES[bus], v["frame_id"], bytes.fromhex(v["data"]))


frame_ids = st.one_of(st.sampled_from(IDS), st.integers(-1, 0x800), st.integers(0, 2**32))
buses = st.one_of(st.sampled_from(["ops", "axis_a", "axis_b", "default"]), st.text(max_size=8))
vectors = st.sampled_from(VECTORS)


# -- the frame decoder -----------------------------------------------------------


@SETTINGS
@given(frames=st.lists(st.tuples(frame_ids, st.binary(max_size=72), buses), min_size=1, max_size=20))
def test_decode_random_frames_accepted_or_protocol_error(frames):
    """Random identifiers, payloads of any length and buses: decode returns a
    known message or raises ProtocolError of a known kind, counted once;
    receive never raises and says the same."""
    p, q = pr.Protocol(), pr.Protocol()
    for frame_id, data, bus in frames:
        before = (p.accepted, sum(p.rejections.values()))
        try:
            name, values = p.decode(frame_id, data, bus=bus)
        except pr.ProtocolError as err:
            assert err.kind in KINDS
            assert err.frame_id == frame_id
            assert (p.accepted, sum(p.rejections.values())) == (before[0], before[1] + 1)
            rec = q.receive(frame_id, data, bus=bus)
            assert not rec.ok and rec.error.kind == err.kind
            continue
        assert PROTO.infos[name].frame_id == frame_id and len(data) == PROTO.infos[name].length
        assert set(values) == {s.name for s in PROTO.message(name).signals}
        assert (p.accepted, sum(p.rejections.values())) == (before[0] + 1, before[1])
        rec = q.receive(frame_id, data, bus=bus)
        assert rec.ok and rec.name == name and rec.signals == values


@SETTINGS
@given(v=vectors, bit=st.integers(0, 64 * 8 - 1))
def test_decode_one_bit_flipped_is_bad_crc(v, bit):
    """A real frame with any one bit flipped is rejected as bad-crc (CRC-8
    and CRC-16 catch every single-bit error)."""
    data = bytearray.fromhex(v["data"])
    data[(bit // 8) % len(data)] ^= 1 << (bit % 8)
    with pytest.raises(pr.ProtocolError) as exc:
        pr.Protocol().decode(v["frame_id"], bytes(data))
    assert exc.value.kind == pr.BAD_CRC


@SETTINGS
@given(v=vectors, cut=st.integers(0, 64), extra=st.binary(min_size=1, max_size=8))
def test_decode_wrong_length_is_bad_length(v, cut, extra):
    """A real frame truncated or extended is rejected as bad-length."""
    data = bytes.fromhex(v["data"])
    for wrong in (data[:cut % len(data)], data + extra):
        with pytest.raises(pr.ProtocolError) as exc:
            pr.Protocol().decode(v["frame_id"], wrong)
        assert exc.value.kind == pr.BAD_LENGTH


@SETTINGS
@given(frame_id=st.sampled_from(IDS), payload=st.binary(min_size=64, max_size=64), data=st.data())
def test_decode_sealed_random_payload(frame_id, payload, data):
    """Random payloads with a correct CRC (what a sender with a bug would
    send) reach the range checks: accepted with every raw value within the
    DBC's limits and re-encoding to the same values, or out-of-range. The
    readable views of accepted status, feedback and wrench frames work."""
    info = PROTO.infos[PROTO.message(frame_id).name]
    frame = e2e.seal(frame_id, payload[:info.length])
    p = pr.Protocol()
    try:
        name, raw = p.decode(frame_id, frame, raw=True, check_counter=False)
    except pr.ProtocolError as err:
        assert err.kind == pr.OUT_OF_RANGE
        return
    for k, r in raw.items():
        assert info.limits[k].lo <= r <= info.limits[k].hi
    # unused (padding) bits are not signals: re-encoded, they are zero and the CRC differs
    again = p.encode_raw(name, raw)
    name2, raw2 = p.decode(frame_id, again, raw=True, check_counter=False)
    assert name2 == name and {k: r for k, r in raw2.items() if k != "Crc"} == {k: r for k, r in raw.items()
                                                                               if k != "Crc"}
    _, phys = p.decode(frame_id, frame, check_counter=False)
    if name == "CTRL_STATUS":
        assert pr.status_to_dict(p, phys)["tick"] == raw["Tick"]
    elif name.startswith("AXIS_FEEDBACK_"):
        assert pr.feedback_to_dict(p, phys)["tick_echo"] == raw["TickEcho"]
    elif name == "CTRL_WRENCH":
        assert len(pr.wrench_to_dict(phys)["wrench"]) == 6
    # with the counter check on, the first frame starts the sequence; the same again is repeated
    assert p.receive(frame_id, frame, bus="x").ok
    assert p.receive(frame_id, frame, bus="x").error.kind == pr.REPEATED


# -- the log reader -----------------------------------------------------------------

line_chars = st.characters(blacklist_categories=("Cs",), blacklist_characters="\n\r")


def corrupt(line: str, how: int, at: int, junk: str) -> str:
    """One corruption of a valid line: truncation, a bad hex digit, a frame
    made too long, a random character inserted, or random text."""
    head, sep, data = line.rpartition("#")
    if how == 0:
        return line[:at % (len(line) + 1)]
    if how == 1:
        i = at % max(len(data), 1)
        return head + sep + data[:i] + "g" + data[i + 1:]
    if how == 2:
        return line + "00" * 65
    if how == 3:
        i = at % (len(line) + 1)
        return line[:i] + junk[:1] + line[i:]
    return junk


@SETTINGS
@given(text=st.text(line_chars, max_size=120))
def test_parse_line_random_text(text):
    """Any text is a frame or a ValueError; a frame's payload fits its kind
    and formats back to a line that parses to the same frame."""
    try:
        f = logfile.parse_line(text)
    except ValueError:
        return
    assert len(f.data) <= (64 if f.fd else 8)
    again = logfile.parse_line(logfile.format_line(f.time, f.iface, f.frame_id & 0x7FFFFFFF, f.data, f.fd,
                                                   f.flags))
    assert (again.iface, again.data, again.fd) == (f.iface, f.data, f.fd)


@SETTINGS
@given(v=vectors, how=st.integers(0, 4), at=st.integers(0, 200), junk=st.text(line_chars, max_size=40))
def test_parse_line_corrupted(v, how, at, junk):
    """A corrupted real line parses (to a frame whose payload fits its kind)
    or raises ValueError; bad hex and an over-long payload always raise."""
    line = corrupt(vector_line(v), how, at, junk)
    if how in (1, 2):
        with pytest.raises(ValueError):
            logfile.parse_line(line)
        return
    try:
        f = logfile.parse_line(line)
    except ValueError:
        return
    assert len(f.data) <= (64 if f.fd else 8)


def check_counts(stats, n_lines: int | None) -> None:
    """Every line is counted: each non-blank one as a frame or as malformed,
    each frame as accepted, on an unknown interface, or rejected."""
    if n_lines is not None:
        assert stats.lines == n_lines
    assert stats.frames + stats.malformed <= stats.lines
    assert stats.accepted + stats.unknown_interface + stats.bad_frames == stats.frames
    assert all(k in KINDS or k == decode.WRONG_BUS for k in stats.rejected)


@SETTINGS
@given(picks=st.lists(st.tuples(vectors, st.integers(0, 5), st.integers(0, 200), st.text(line_chars, max_size=40)),
                      max_size=30))
def test_read_log_corrupted_lines_counted(picks):
    """A log of real lines, some corrupted: read_log returns, counting every
    line; lines with bad hex or too long a payload are counted as malformed."""
    lines, bad = [], 0
    for i, (v, how, at, junk) in enumerate(picks):
        line = vector_line(v, 1.0 + i * 1e-3)
        if how < 5:
            line = corrupt(line, how, at, junk)
            bad += how in (1, 2)
        lines.append(line + "\n")
    data = decode.read_log(lines)
    check_counts(data.stats, len(lines))
    assert data.stats.malformed >= bad


@settings(SETTINGS, max_examples=50)
@given(blob=st.binary(max_size=2000))
def test_read_log_random_bytes_file(tmp_path_factory, blob):
    """A file of random bytes is read (undecodable bytes replaced), every
    line counted, nothing raised. A line ends at '\n' (and, if the reader
    takes universal newlines, at '\r')."""
    path = tmp_path_factory.mktemp("log") / "random.log"
    path.write_bytes(blob)
    data = decode.read_log(path)
    check_counts(data.stats, None)
    assert blob.count(b"\n") <= data.stats.lines <= blob.count(b"\n") + blob.count(b"\r") + 1
