# SPDX-License-Identifier: Apache-2.0
"""The whole-message decoder against its plain references.

* :mod:`stewart.analysis.framedecode` against cantools' ``Message.decode``
  frame by frame: the project's DBC on the frames of a real log (an excerpt
  of the demo's lockstep run, tests/python/data/demo_excerpt.log.gz: its
  first 0.25 s and 0.2 s around the first RUN_TRIG), and a DBC written here
  with big-endian, odd-sized, signed, scaled, float, 64-bit and multiplexed
  signals on random payloads. Equality is exact (same integers, same
  float64 operations).
* :func:`stewart.e2e.crc_ok_many` / :func:`stewart.e2e.check_counters`
  against :func:`stewart.e2e.crc_ok` / :class:`stewart.e2e.E2EReceiver`.
* :func:`stewart.analysis.logfile.read_frames` against ``parse_line`` per line.
* :func:`stewart.analysis.decode.read_log` against the per-frame
  tools/dev/decode_reference.py's ``read_log_reference`` (every array,
  command, count and warning) on the real excerpt, clean and corrupted.
* ``write_signals_csv`` against the csv-module writer (byte for byte), and
  ``read_truth`` (numpy) against ``read_truth_rows``.
"""

from __future__ import annotations

import gzip
import random
from pathlib import Path

import cantools
import numpy as np
import pytest

from stewart import cli
from stewart import config as cfg
from stewart import e2e
from stewart import protocol as pr
from stewart.analysis.csvout import TruthText, write_signals_csv, write_signals_csv_reference
from stewart.analysis.decode import read_log
from decode_reference import read_log_reference
from stewart.analysis.framedecode import MessageLayout
from stewart.analysis.logfile import parse_line, read_frames
from stewart.analysis.run import DEFAULT_PLATFORM
from stewart.analysis.truth import attach_truth, read_truth, read_truth_rows

DATA = Path(__file__).parent / "data"
PLATFORM = cfg.load(DEFAULT_PLATFORM)


@pytest.fixture(scope="module")
def real_lines() -> list[str]:
    with gzip.open(DATA / "demo_excerpt.log.gz", "rt") as fh:
        return fh.read().splitlines()


def assert_same_logdata(a, b):
    for name, fld in a.__dataclass_fields__.items():
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and x.shape == y.shape, name
            assert np.array_equal(x, y, equal_nan=True), name
    assert [c.as_dict() for c in a.commands] == [c.as_dict() for c in b.commands]
    assert a.stats.as_dict() == b.stats.as_dict()


# -- signals -------------------------------------------------------------------------

def test_project_dbc_matches_cantools_on_a_real_log(real_lines):
    db = cantools.database.load_file(str(pr.DBC_PATH))
    frames = read_frames(real_lines)
    seen = 0
    for m in db.messages:
        rows = np.flatnonzero((frames.frame_id == m.frame_id) & (frames.dlc == m.length))
        if len(rows) == 0:
            continue
        data = frames.data[rows, :m.length]
        lay = MessageLayout(m)
        raw = lay.raw(data)
        phys = lay.scaled(raw)
        for i in range(len(rows)):
            want_raw = m.decode(bytes(data[i]), decode_choices=False, scaling=False)
            want = m.decode(bytes(data[i]), decode_choices=False)
            for s in m.signals:
                assert raw[s.name][i] == want_raw[s.name], (m.name, s.name, i)
                assert phys[s.name][i] == want[s.name], (m.name, s.name, i)
                assert type(phys[s.name][i].item()) is type(want[s.name]), (m.name, s.name)
        seen += 1
    assert seen >= 8   # every message of the run (OP_TARGET_POSE is not in it)


ODD_DBC = '''VERSION ""
NS_ :
BS_:
BU_: A B
BO_ 100 MIXED: 16 A
 SG_ LeSigned : 3|13@1- (0.5,-3) [-2050|2050] "" B
 SG_ BeUnsigned : 23|11@0+ (1,0) [0|2047] "" B
 SG_ BeSigned : 28|19@0- (0.001,0.25) [-300|300] "" B
 SG_ OneBit : 41|1@1+ (1,0) [0|1] "" B
 SG_ IntScaled : 48|7@1+ (3,-10) [-10|371] "" B
 SG_ Float32 : 64|32@1- (1,0) [-1e30|1e30] "" B
 SG_ Wide : 96|31@1- (0.25,0) [-1e9|1e9] "" B
BO_ 101 BIG64: 32 A
 SG_ Le64 : 4|64@1+ (1,0) [0|0] "" B
 SG_ Be64 : 75|64@0- (1,0) [0|0] "" B
 SG_ Double : 144|64@1- (1,0) [0|0] "" B
BO_ 102 MUXED: 8 A
 SG_ Mux M : 0|3@1+ (1,0) [0|7] "" B
 SG_ Always : 3|5@1+ (1,0) [0|31] "" B
 SG_ A0 m0 : 8|16@1- (0.01,0) [-300|300] "" B
 SG_ A1 m1 : 8|12@0+ (1,5) [0|5000] "" B
 SG_ A2 m2 : 8|24@1+ (1,0) [0|16777215] "" B
 SG_ Shared m1 : 40|8@1+ (1,0) [0|255] "" B
SIG_VALTYPE_ 100 Float32 : 1;
SIG_VALTYPE_ 101 Double : 2;
'''


def test_odd_layouts_match_cantools(tmp_path):
    path = tmp_path / "odd.dbc"
    path.write_text(ODD_DBC)
    db = cantools.database.load_file(str(path), strict=False)
    rng = np.random.default_rng(16)
    for m in db.messages:
        data = rng.integers(0, 256, size=(400, m.length), dtype=np.uint8)
        if m.name == "MIXED":   # finite floats in the float signal
            data[:, 8:12] = np.frombuffer(rng.normal(0, 1e3, 400).astype("<f4").tobytes(),
                                          dtype=np.uint8).reshape(400, 4)
        if m.name == "BIG64":
            data[:, 18:26] = np.frombuffer(rng.normal(0, 1e6, 400).astype("<f8").tobytes(),
                                           dtype=np.uint8).reshape(400, 8)
        lay = MessageLayout(m)
        raw = lay.raw(data)
        phys = lay.scaled(raw)
        present = lay.present(raw)
        bad = lay.bad_multiplexer(raw)
        checked = 0
        for i in range(len(data)):
            try:
                want_raw = m.decode(bytes(data[i]), decode_choices=False, scaling=False)
                want = m.decode(bytes(data[i]), decode_choices=False)
            except cantools.database.DecodeError:
                assert bad[i], (m.name, i)
                continue
            assert not bad[i]
            names = {s.name for s in m.signals if present[s.name][i]}
            assert names == set(want), (m.name, i)
            for s in names:
                assert raw[s][i] == want_raw[s], (m.name, s, i)
                assert phys[s][i] == want[s], (m.name, s, i)
            checked += 1
        assert checked > 100
    assert MessageLayout(db.get_message_by_name("MUXED")).multiplexed


# -- CRC and counters ---------------------------------------------------------------

def test_crc_many_matches_crc_ok(real_lines):
    rng = np.random.default_rng(7)
    for length, fid in ((8, 0x010), (12, 0x031), (24, 0x050), (32, 0x100), (64, 0x101)):
        data = rng.integers(0, 256, size=(300, length), dtype=np.uint8)
        for i in range(0, 300, 3):   # a third sealed, so both outcomes occur
            data[i] = np.frombuffer(e2e.seal(fid, bytes(data[i])), dtype=np.uint8)
        got = e2e.crc_ok_many(fid, data)
        want = np.array([e2e.crc_ok(fid, bytes(r)) for r in data])
        assert np.array_equal(got, want) and want.sum() >= 100


def test_check_counters_matches_the_receiver():
    rnd = random.Random(3)
    for case in range(200):
        seq, c = [], rnd.randrange(16)
        for _ in range(rnd.randrange(1, 60)):
            c = (c + rnd.choice([1, 1, 1, 2, 3] if case % 2 else [0, 1, 1, 2, 3, 4, 9])) % 16
            seq.append(c)
        rx = e2e.E2EReceiver()
        want = [(r.status, r.lost) for r in (rx.check(v) for v in seq)]
        codes, lost = e2e.check_counters(seq)
        assert [(e2e.STATUS_CODES[c], n) for c, n in zip(codes.tolist(), lost.tolist())] == want


# -- the log ------------------------------------------------------------------------

def corrupt(lines: list[str]) -> list[str]:
    """Every kind of damage a log can have, at known places."""
    out = list(lines)
    out.insert(5, "this is not a frame")
    out.insert(9, "")
    out.insert(12, "(0000000000.000000) vcan0 100##1ZZ")            # not hex
    out[20] = out[20][:-6]                                            # truncated: bad length
    out[21] = out[21][:-2] + ("00" if not out[21].endswith("00") else "01")  # bad CRC
    out.insert(30, out[29])                                           # repeated counter
    del out[40]                                                       # a lost frame
    k = next(i for i in range(50, 200) if " vcan1 031##" in out[i])
    out[k] = out[k].replace(" vcan1 ", " vcan0 ")                     # wrong bus
    k = next(i for i in range(60, 200) if " vcan2 " in out[i] or " vcan1 " in out[i])
    out[k] = out[k].replace(" vcan2 ", " can9 ").replace(" vcan1 ", " can9 ")  # unknown iface
    out[70] = out[70].replace(") ", ")   ")                           # odd spacing, still a frame
    out[80] = "  " + out[80] + "  \r"                                 # padded, still a frame
    out.insert(90, "(0000000000.010000) vcan0 7FF##1" + "00" * 8)    # unknown ID
    out.insert(91, "(0000000000.010000) vcan0 12345678#0011")        # extended ID, classic
    out.insert(92, "(0000000000.010000) vcan0 100#R")                # remote frame
    out.insert(93, "(0000000000.010000) vcan0 100##1ABC")            # odd digits
    out.insert(94, "(0000000000.010000) vcan0 010#" + "00" * 9)      # 9 bytes classic
    out.insert(95, "(0.01) vcan0 010#0011223344556677")              # short timestamp
    out.insert(96, "(00000000000000000009.500000) vcan1 010#0011")   # long timestamp
    out.insert(97, "(0000000000.010000) vcan0 100##G" + "00" * 32)   # bad flags nibble
    out.insert(98, "(0000000000.010000) vcan0 100##1" + "00" * 65)  # 65 bytes
    out.insert(99, "(0000000000.010000)\tvcan0\t100##1" + "00" * 32)  # tabs
    out.insert(100, "(0000000000.010000) vcän0 100##1" + "00" * 32)   # non-ASCII interface
    for k in range(3000, 3040):                                        # counters jump
        if " 031##" in out[k]:
            out.pop(k)
            out.pop(k)
            out.pop(k)
            break
    return out


def test_read_frames_matches_parse_line(real_lines):
    lines = corrupt(real_lines)
    fr = read_frames(lines)
    k = 0
    bad = []
    for n, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            f = parse_line(line, n)
        except ValueError:
            bad.append(n)
            continue
        assert fr.line_no[k] == n and fr.frame_id[k] == f.frame_id and bool(fr.fd[k]) == f.fd
        assert fr.time[k] == f.time and fr.ifaces[fr.iface[k]] == f.iface
        assert bytes(fr.data[k, :fr.dlc[k]]) == f.data
        k += 1
    assert k == len(fr.line_no) and [m[0] for m in fr.malformed] == bad and len(bad) >= 7
    assert fr.lines == len(lines)


def test_read_log_matches_the_reference_on_a_real_log(real_lines, tmp_path):
    fast = read_log(real_lines, platform=PLATFORM)
    ref = read_log_reference(real_lines, platform=PLATFORM)
    assert_same_logdata(fast, ref)
    # the excerpt's gap (0.25 s to 4.55 s) breaks each message's counter
    # sequence once and leaves the first feedback after it stale
    st = fast.stats
    assert st.malformed == 0 and st.rejected == {"wrong-sequence": st.rejected["wrong-sequence"]}
    assert st.accepted == len(real_lines) - st.rejected["wrong-sequence"]
    assert len(fast.commands) == 2 and st.stale_feedback >= 1
    path = tmp_path / "run.log"
    path.write_text("\n".join(real_lines) + "\n")
    assert_same_logdata(read_log(path, platform=PLATFORM), ref)


def test_read_log_matches_the_reference_on_a_corrupted_log(real_lines, tmp_path):
    lines = corrupt(real_lines)
    fast = read_log(lines, platform=PLATFORM)
    ref = read_log_reference(lines, platform=PLATFORM)
    assert_same_logdata(fast, ref)
    st = fast.stats
    assert st.malformed >= 7 and st.unknown_interface >= 2
    for kind in ("bad-length", "bad-crc", "repeated", "wrong-bus", "unknown-id", "wrong-sequence"):
        assert st.rejected.get(kind, 0) >= 1, kind
    assert st.lost >= 1
    # the same bytes from a file, CRLF line ends and invalid UTF-8 included
    raw = ("\r\n".join(lines) + "\r\n").encode("utf-8") + b"\xff\xfe garbage\r\n"
    path = tmp_path / "bad.log"
    path.write_bytes(raw)
    f2 = read_log(path, platform=PLATFORM)
    r2 = read_log_reference(path, platform=PLATFORM)
    assert_same_logdata(f2, r2)
    assert f2.stats.malformed == st.malformed + 1


def test_read_log_on_empty_and_binary_input(tmp_path):
    empty = read_log([], platform=PLATFORM)
    assert len(empty) == 0 and empty.stats.frames == 0
    junk = tmp_path / "junk.log"
    junk.write_bytes(bytes(range(256)) * 50)
    d = read_log(junk, platform=PLATFORM)
    assert len(d) == 0 and d.stats.malformed >= 1
    assert_same_logdata(d, read_log_reference(junk, platform=PLATFORM))


def test_cli_analyze_corrupted_log_exits_1_without_traceback(real_lines, tmp_path, capsys):
    path = tmp_path / "bad.log"
    path.write_text("\n".join(corrupt(real_lines)) + "\n")
    rc = cli.main(["analyze", str(path), "--out", str(tmp_path / "out"), "--no-plots"])
    out = capsys.readouterr()
    assert rc == 1 and "Traceback" not in out.err
    assert "malformed lines" in out.out


# -- the outputs --------------------------------------------------------------------

def test_signals_csv_and_truth_match_their_references(real_lines, tmp_path):
    data = read_log(corrupt(real_lines), platform=PLATFORM)
    # a truth file with and without the wrench, with a header; one with a bad row
    rng = np.random.default_rng(1)
    ticks = data.ticks[::2]
    cols = ["tick", "x", "y", "z", "roll", "pitch", "yaw"] + [f"len{i}" for i in range(1, 7)] \
        + [f"force{i}" for i in range(1, 7)] + [f"wrench_{a}" for a in ("fx", "fy", "fz", "mx", "my", "mz")]
    rows = [[int(t)] + list(rng.normal(0, 1, 25)) for t in ticks]
    good = tmp_path / "truth.csv"
    good.write_text(",".join(cols) + "\n" + "\n".join(
        ",".join([str(r[0])] + [f"{v:.9f}" for v in r[1:]]) for r in rows) + "\n")
    t_fast, t_rows = read_truth(good), read_truth_rows(good)
    for k in t_rows:
        assert np.array_equal(t_fast[k], t_rows[k], equal_nan=True) and t_fast[k].dtype == t_rows[k].dtype, k
    broken = tmp_path / "broken.csv"
    text = good.read_text().splitlines()
    text[5] = "12,not,a,number"
    broken.write_text("\n".join(text) + "\n")
    tb = read_truth(broken)
    assert int(tb["bad_rows"]) == 1 and len(tb["tick"]) == len(rows) - 1
    attach_truth(data, t_fast)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    write_signals_csv(data, a)
    write_signals_csv_reference(data, b)
    assert a.read_bytes() == b.read_bytes()
    assert b.read_bytes().count(b"\r\n") == len(data) + 1
    # the truth's columns formatted before the log is decoded (stewart
    # analyze): the same text, rows without truth blank
    c = tmp_path / "c.csv"
    write_signals_csv(data, c, TruthText(t_fast))
    assert c.read_bytes() == b.read_bytes()
    # a truth with a tick twice (the last row wins) and ticks the log lacks
    dup = {k: (np.concatenate([v, v[3:4] + 1, v[:1]]) if k == "tick" else
               np.concatenate([v, v[3:4] * 2, v[:1] + 7]) if k != "bad_rows" else v)
           for k, v in t_fast.items()}
    dup["tick"][-2] = data.ticks[-1] + 100
    attach_truth(data, dup)
    write_signals_csv(data, c, TruthText(dup))
    write_signals_csv_reference(data, b)
    assert c.read_bytes() == b.read_bytes()


def test_read_frames_with_many_interfaces(real_lines):
    """More interface names in one line layout than the name look-up
    compares one by one (it sorts the rest)."""
    lines = [ln.replace(" vcan0 ", f" can{10 + k % 12} ").replace(" vcan1 ", f" can{10 + k % 12} ")
             .replace(" vcan2 ", f" can{10 + k % 12} ") for k, ln in enumerate(real_lines[:600])]
    fr = read_frames(lines)
    got = [fr.ifaces[i] for i in fr.iface]
    assert got == [parse_line(ln).iface for ln in lines] and len(set(got)) == 12


def shift_ticks(lines: list[str], offset: int) -> list[str]:
    """The log with every Tick moved by ``offset`` modulo 2^32 (TickEcho
    modulo 2^16), CRCs resealed: the same run at another cycle number."""
    db = cantools.database.load_file(str(pr.DBC_PATH))
    out = []
    for line in lines:
        f = parse_line(line, 1)
        m = db.get_message_by_frame_id(f.frame_id)
        sig = m.decode(f.data, decode_choices=False, scaling=False)
        if "Tick" in sig:
            sig["Tick"] = (int(sig["Tick"]) + offset) % (1 << 32)
        elif "TickEcho" in sig:
            sig["TickEcho"] = (int(sig["TickEcho"]) + offset) % (1 << 16)
        else:
            out.append(line)
            continue
        data = e2e.seal(f.frame_id, m.encode(sig, scaling=False, strict=False))
        head = line.split("#")[0]
        out.append(f"{head}##{f.flags:X}{data.hex().upper()}" if f.fd else f"{head}#{data.hex().upper()}")
    return out


def test_ticks_unwrap_through_the_32_bit_wrap(real_lines):
    """Issue 17: a run whose cycle number passes 2^32 - 1 decodes as the
    same run with ticks that go on counting (fast path and reference)."""
    base = read_log(real_lines, platform=PLATFORM)
    mid = int(base.ticks[len(base.ticks) // 2])
    offset = (1 << 32) - mid                      # the wrap half-way through
    lines = shift_ticks(real_lines, offset)
    fast = read_log(lines, platform=PLATFORM)
    ref = read_log_reference(lines, platform=PLATFORM)
    assert_same_logdata(fast, ref)
    assert np.array_equal(fast.ticks, base.ticks + offset)
    assert fast.ticks[0] < (1 << 32) <= fast.ticks[-1]
    a, b = fast.stats.as_dict(), base.stats.as_dict()
    assert len(a.pop("warnings")) == len(b.pop("warnings")) and a == b  # warnings name the ticks
    for name in ("state", "estimate", "reference", "est_wrench"):
        assert np.array_equal(getattr(fast, name), getattr(base, name), equal_nan=True), name
    assert [c.tick for c in fast.commands] == [c.tick + offset for c in base.commands]


def force_targets_reference(d) -> None:
    """decode.force_targets row by row: the plain reference."""
    from stewart.analysis.decode import FORCE_MODES
    force = FORCE_MODES.index("FORCE")
    frames = sorted(((tk, w) for tk, w in d.force_frames if tk is not None), key=lambda f: f[0])
    j, last, last_tick, current, prev_mode = 0, [0.0] * 6, None, [0.0] * 6, -1
    for k in range(len(d.ticks)):
        t = int(d.ticks[k])
        while j < len(frames) and frames[j][0] <= t:
            last, last_tick = frames[j][1], frames[j][0]
            j += 1
        mode = int(d.force_mode[k])
        if mode < 0:
            continue
        if mode == force and not d.cmd_rejected[k] and (prev_mode != force or last_tick == t):
            current = list(last)
        d.force_target[k] = current if mode == force else 0.0
        prev_mode = mode


def test_force_targets_equal_the_row_by_row_reference():
    from types import SimpleNamespace

    from stewart.analysis.decode import force_targets
    rng = random.Random(15)
    for _ in range(500):
        n = rng.randrange(1, 200)
        ticks = np.arange(n) * rng.choice([1, 2]) + rng.randrange(100)
        mode = np.array([rng.choice([-1, 0, 1, 1, 1, 2, 3, 4]) for _ in range(n)])
        rejected = np.array([rng.random() < 0.1 for _ in range(n)])
        frames = [(int(rng.choice(list(ticks) + [int(ticks[-1]) + 5])) if rng.random() < 0.9 else None,
                   [rng.random()] * 6) for _ in range(rng.randrange(6))]
        a, b = (SimpleNamespace(ticks=ticks, force_mode=mode, cmd_rejected=rejected, force_frames=frames,
                                force_target=np.full((n, 6), np.nan)) for _ in range(2))
        force_targets(a)
        force_targets_reference(b)
        assert np.array_equal(a.force_target, b.force_target, equal_nan=True)
