# SPDX-License-Identifier: Apache-2.0
"""The CAN protocol: DBC, E2E, encoder/decoder, shared test vectors, generated docs."""

import json
from pathlib import Path

import numpy as np
import pytest

from stewart import cli, e2e
from stewart import protocol as pr
from stewart.commands import protocol_cmd

REPO_ROOT = Path(__file__).resolve().parents[2]

VECTORS = REPO_ROOT / "protocol" / "test_vectors.json"
DOC = REPO_ROOT / "docs" / "reference" / "protocol.md"

# The spec (ID, length, bus) of each message.
SPEC = {
    "SYNC": (0x010, 8, ("axis_a", "axis_b")),
    "AXIS_SETPOINTS": (0x020, 32, ("axis_a", "axis_b")),
    "AXIS_FEEDBACK_1": (0x031, 16, ("axis_a", "axis_b")),
    "AXIS_FEEDBACK_2": (0x032, 16, ("axis_a", "axis_b")),
    "AXIS_FEEDBACK_3": (0x033, 16, ("axis_a", "axis_b")),
    "OP_COMMAND": (0x040, 20, ("ops",)),
    "OP_TARGET_POSE": (0x050, 32, ("ops",)),
    "OP_HEARTBEAT": (0x060, 4, ("ops",)),
    "OP_FORCE": (0x048, 32, ("ops",)),
    "OP_FORCE_PARAMS": (0x049, 24, ("ops",)),
    "FT_SENSOR": (0x038, 20, ("axis_b",)),
    "CTRL_STATUS": (0x100, 32, ("ops",)),
    "CTRL_MONITOR": (0x101, 64, ("ops",)),
    "CTRL_WRENCH": (0x102, 24, ("ops",)),
    "CTRL_AUTH": (0x103, 16, ("ops",)),
    "CTRL_IDENTITY": (0x104, 12, ("ops",)),
    "OP_FRAME": (0x04A, 32, ("ops",)),
    "OP_REACH": (0x04B, 24, ("ops",)),
    "CTRL_REACH": (0x105, 32, ("ops",)),
    "CTRL_FRAMES": (0x106, 24, ("ops",)),
    "CTRL_REFUSAL": (0x107, 8, ("ops",)),
}
#: Messages not sent every 1 ms, and their period.
PERIOD_MS = {"CTRL_WRENCH": 2, "OP_HEARTBEAT": 20, "OP_FORCE": 10, "OP_COMMAND": 10, "CTRL_AUTH": 10,
             "OP_FORCE_PARAMS": 10, "CTRL_IDENTITY": 10, "OP_FRAME": 100, "OP_REACH": 20, "CTRL_REACH": 20,
             "CTRL_FRAMES": 100, "CTRL_REFUSAL": 10}


@pytest.fixture()
def proto():
    return pr.Protocol()


@pytest.fixture(scope="module")
def vectors():
    return json.loads(VECTORS.read_text())


# -- the DBC ----------------------------------------------------------------------

def test_dbc_loads_strict_as_can_fd(proto):
    import cantools

    db = cantools.database.load_file(str(pr.DBC_PATH), strict=True)
    assert {m.name for m in db.messages} == set(SPEC)
    assert db.dbc.attributes["BusType"].value == "CAN FD"
    assert proto.nominal_bitrate == 1_000_000 and proto.data_bitrate == 5_000_000
    for m in db.messages:
        fid, length, buses = SPEC[m.name]
        assert m.is_fd, m.name
        assert not m.is_extended_frame
        assert m.dbc.attributes["CANFD_BRS"].value == 1
        assert (m.frame_id, m.length) == (fid, length), m.name
        assert proto.infos[m.name].buses == buses
        assert m.cycle_time == PERIOD_MS.get(m.name, 1), m.name
        assert m.signals[-1].name == "Crc"
        for s in m.signals:
            assert not s.is_float, f"{m.name}.{s.name}"
            assert s.byte_order == "little_endian"
            assert s.minimum is not None and s.maximum is not None
            assert s.comment, f"{m.name}.{s.name} has no comment"


def test_dbc_scales_and_ranges_as_specified(proto):
    sp = proto.message("AXIS_SETPOINTS")
    v = sp.get_signal_by_name("Velocity_2")
    assert (v.length, v.is_signed, v.scale) == (16, True, 5e-5)
    assert v.maximum == pytest.approx(1.63835, abs=1e-12)
    f = sp.get_signal_by_name("Force_3")
    assert (f.length, f.is_signed, f.scale) == (24, True, 0.02)
    assert f.maximum == pytest.approx(167772.14, abs=1e-6)
    fb = proto.message("AXIS_FEEDBACK_2")
    p = fb.get_signal_by_name("PressureA")
    assert (p.start, p.length, p.is_signed, p.scale, p.unit) == (32, 16, False, 1000, "Pa")
    assert p.maximum == pytest.approx(65.535e6)
    length = fb.get_signal_by_name("Length")
    assert (length.length, length.is_signed, length.scale) == (28, False, 1e-7)  # 0.1 um (issue 14)
    # 16 bytes: Length (0.1 um), State, PressureA/B (1 kPa), Counter, Faults, TickEcho, 2 spare bytes, CRC-16
    layout = [(s.name, s.start, s.length) for s in fb.signals]
    assert layout == [("Length", 0, 28), ("State", 28, 4), ("PressureA", 32, 16), ("PressureB", 48, 16),
                      ("Counter", 64, 4), ("Faults", 72, 8), ("TickEcho", 80, 16), ("Crc", 112, 16)]
    w = proto.message("CTRL_WRENCH")
    layout = [(s.name, s.start, s.length, s.is_signed) for s in w.signals]
    assert layout == [("Tick", 0, 32, False), ("Counter", 32, 4, False), ("Valid", 36, 1, False),
                      ("Fx", 40, 22, True), ("Fy", 62, 22, True), ("Fz", 84, 22, True),
                      ("Mx", 106, 22, True), ("My", 128, 22, True), ("Mz", 150, 22, True),
                      ("Crc", 176, 16, False)]
    for s in w.signals[3:9]:
        assert s.scale == 0.25 and s.maximum == pytest.approx(524287.75) and s.minimum == -s.maximum
        assert s.unit == ("N" if s.name[0] == "F" else "N m")
    assert {str(v) for v in fb.get_signal_by_name("State").choices.values()} == {
        "INIT", "HOLD", "ACTIVE", "FAULT"}
    cmd = proto.message("OP_COMMAND").get_signal_by_name("Command")
    assert str(cmd.choices[9]) == "SET_FEEDFORWARD" and str(cmd.choices[7]) == "ESTOP"
    st = proto.message("CTRL_STATUS").get_signal_by_name("State")
    assert str(st.choices[6]) == "ESTOP" and cmd.maximum == 14 and st.maximum == 7 and str(st.choices[7]) == "STOPPING"


def test_value_names_are_the_dbc_value_tables(tmp_path):
    assert pr.value_names("CTRL_STATUS", "State")[3] == "RUNNING"
    assert pr.value_names("OP_COMMAND", "Command")[9] == "SET_FEEDFORWARD"
    assert pr.value_names("OP_COMMAND", "Command")[10:] == ("FORCE", "GUIDE", "POSITION", "TARE", "IDENTIFY")
    assert pr.value_names("AXIS_FEEDBACK_3", "State") == ("INIT", "HOLD", "ACTIVE", "FAULT")
    assert pr.axis_names() == ("x", "y", "z", "roll", "pitch", "yaw")
    with pytest.raises(ValueError, match="SYNC.Tick has no value table"):
        pr.value_names("SYNC", "Tick")
    gap = tmp_path / "gap.dbc"
    gap.write_text(pr.DBC_PATH.read_text().replace('VAL_ 256 State 7 "STOPPING" 6 "ESTOP" 5 "FAULT"',
                                                   'VAL_ 256 State 7 "STOPPING" 6 "ESTOP"'))
    with pytest.raises(ValueError, match="numbered 0..n-1"):
        pr.value_names("CTRL_STATUS", "State", gap)


def test_crc_is_last_bytes_and_kind_follows_length(proto):
    for name, info in proto.infos.items():
        assert info.crc_bytes == (1 if info.length <= 12 else 2), name
        crc = proto.message(name).get_signal_by_name("Crc")
        assert crc.start + crc.length == 8 * info.length


# -- E2E ------------------------------------------------------------------------

def test_crc_check_values():
    assert e2e.crc8_j1850(b"123456789") == 0x4B
    assert e2e.crc16_ccitt_false(b"123456789") == 0x29B1
    assert e2e.crc8_j1850(b"") == 0x00  # init 0xFF xor 0xFF
    assert e2e.crc16_ccitt_false(b"") == 0xFFFF


def test_crc16_equals_the_table_loop():
    """e2e's CRC-16 is the standard library's C routine: the plain byte loop
    over the same table, on random payloads of every frame length."""
    rng = np.random.default_rng(16)
    for n in list(range(0, 70)) + [rng.integers(0, 200) for _ in range(200)]:
        data = rng.integers(0, 256, int(n), dtype=np.uint8).tobytes()
        c = 0xFFFF
        for b in data:
            c = ((c << 8) & 0xFFFF) ^ e2e._T16[((c >> 8) ^ b) & 0xFF]
        assert e2e.crc16_ccitt_false(data) == c, data.hex()


def test_crc_covers_the_data_id():
    data = bytes(11) + b"\0"
    a = e2e.seal(0x031, data)
    b = e2e.seal(0x032, data)
    assert a[-1] != b[-1]
    assert a[-1] == e2e.crc8_j1850(bytes((0x31, 0x00)) + bytes(11))
    long = e2e.seal(0x101, bytes(64))
    assert int.from_bytes(long[-2:], "little") == e2e.crc16_ccitt_false(bytes((0x01, 0x01)) + bytes(62))
    assert e2e.crc_ok(0x101, long) and not e2e.crc_ok(0x100, long)


def test_counter_state_machine():
    rx = e2e.E2EReceiver()
    got = [(c.status, c.lost) for c in map(rx.check, [14, 15, 0, 2, 5, 5, 6, 11, 3, 4])]
    assert got == [("init", 0), ("ok", 0), ("ok", 0), ("lost", 1), ("lost", 2),
                   ("repeated", 0), ("ok", 0), ("wrong-sequence", 0), ("init", 0), ("ok", 0)]
    with pytest.raises(ValueError):
        rx.check(16)


# -- encode / decode --------------------------------------------------------------

def test_encode_fills_counter_and_crc(proto):
    frames = [proto.encode("SYNC", {"Tick": t, "Hold": 0}, bus="axis_a") for t in range(17)]
    counters = [proto.decode(0x010, f, bus="axis_a")[1]["Counter"] for f in frames]
    assert counters == [i % 16 for i in range(17)]  # wraps 15 -> 0, all accepted
    assert proto.accepted == 17 and sum(proto.rejections.values()) == 0
    assert all(e2e.crc_ok(0x010, f) for f in frames)


def test_roundtrip_physical_values(proto):
    slots = [(1.812345, 0.25, 12345.66), (0.0, -1.63835, -167772.14), (16.777215, 1.63835, 167772.14)]
    data = proto.encode("AXIS_SETPOINTS", pr.setpoint_signals("ACTIVE", 4_000_000_000, slots), counter=3)
    assert len(data) == 32
    name, sig = proto.decode(0x020, data, bus="axis_b")
    assert name == "AXIS_SETPOINTS" and sig["Counter"] == 3 and sig["Mode"] == 1
    assert sig["Tick"] == 4_000_000_000
    for s, (length, vel, force) in enumerate(slots, start=1):
        assert sig[f"Length_{s}"] == pytest.approx(length, abs=0.5e-6)
        assert sig[f"Velocity_{s}"] == pytest.approx(vel, abs=2.5e-5)
        assert sig[f"Force_{s}"] == pytest.approx(force, abs=0.01)


def test_status_helper(proto):
    data = proto.encode("CTRL_STATUS", {
        "Tick": 42, "State": "FAULT", "Faults": 0x0041, "FkIterations": 3, "EstimateValid": 1,
        "CmdRejected": 1, "Refusals": 5, "DriveMode": "HOLD", "FeedForward": 0,
        **pr.pose_to_signals([0.1, -0.2, 0.3, 0.01, -0.02, 0.5])})
    d = pr.status_to_dict(proto, proto.decode(0x100, data)[1])
    assert d["state"] == "FAULT" and d["faults"] == ["feedback_timeout", "estop"]
    assert d["drive_mode"] == "HOLD" and d["cmd_rejected"] and d["refusals"] == 5 and not d["feedforward"]
    assert d["pose"] == pytest.approx([0.1, -0.2, 0.3, 0.01, -0.02, 0.5], abs=0.5e-6)


def test_feedback_and_command_helpers(proto):
    data = proto.encode("AXIS_FEEDBACK_2", {"Length": 1.5, "PressureA": 20.0044e6, "PressureB": 1e6,
                                           "State": "ACTIVE", "Faults": 0x82, "TickEcho": 7})
    d = pr.feedback_to_dict(proto, proto.decode(0x032, data)[1])
    assert d["state"] == "ACTIVE" and d["faults"] == ["following_error", "internal"]
    assert d["pressure_a"] == pytest.approx(20.004e6) and d["length"] == pytest.approx(1.5)  # 1 kPa steps
    data = proto.encode("CTRL_WRENCH", {"Tick": 42, "Valid": 1, "Fx": 100.25, "Fy": -0.5, "Fz": -524287.75,
                                        "Mx": 524287.75, "My": 3.0, "Mz": -12.75})
    w = pr.wrench_to_dict(proto.decode(0x102, data)[1])
    assert w == {"tick": 42, "valid": True, "wrench": [100.25, -0.5, -524287.75, 524287.75, 3.0, -12.75]}
    with pytest.raises(pr.ProtocolError, match="out-of-range"):
        proto.encode("CTRL_WRENCH", {"Fx": 524288.0})  # the Python encoder refuses, the firmware saturates
    data = proto.encode("OP_COMMAND", pr.command_signals("RUN_TRIG", "yaw", 0.1, 0.5, 2.0))
    sig = proto.decode(0x040, data)[1]
    assert (sig["Command"], sig["Axis"]) == (2, 5)
    assert sig["Amplitude"] == pytest.approx(0.1) and sig["FadeTime"] == pytest.approx(2.0)
    assert pr.LEG_BUS[5] == ("axis_b", 2) and pr.BUSES["axis_b"] == "vcan2"


def test_encode_rejects_bad_input(proto):
    with pytest.raises(pr.ProtocolError) as err:
        proto.encode("AXIS_SETPOINTS", {"Velocity_1": 1.64})
    assert err.value.kind == "out-of-range"
    with pytest.raises(pr.ProtocolError) as err:
        proto.encode("OP_COMMAND", {"Command": "LAUNCH"})
    assert err.value.kind == "out-of-range"
    with pytest.raises(pr.ProtocolError) as err:
        proto.encode("SYNC", {"Crc": 1})
    assert err.value.kind == "unknown-signal"
    with pytest.raises(pr.ProtocolError):
        proto.encode("SYNC", {"Tick": float("nan")})
    with pytest.raises(pr.ProtocolError):
        proto.encode("SYNC", {"Tick": 1}, counter=16)


# -- malformed frames are rejected and counted ------------------------------------

def _feedback(proto, counter, **kw):
    sig = {"Length": 1.7, "PressureA": 10e6, "PressureB": 5e6, "State": "ACTIVE",
           "Faults": 0, "TickEcho": counter}
    sig.update(kw)
    return proto.encode("AXIS_FEEDBACK_1", sig, counter=counter)


def _kind(proto, frame_id, data, bus="axis_a"):
    before = sum(proto.rejections.values())
    with pytest.raises(pr.ProtocolError) as err:
        proto.decode(frame_id, data, bus=bus)
    assert sum(proto.rejections.values()) == before + 1
    return err.value.kind


def test_each_malformed_kind_is_rejected_and_counted(proto):
    good = _feedback(proto, 0)
    assert _kind(proto, 0x034, good) == "unknown-id"
    assert _kind(proto, 0x031, good[:-1]) == "bad-length"
    assert _kind(proto, 0x031, good + b"\0" * 4) == "bad-length"
    flipped = bytearray(good)
    flipped[2] ^= 0x01
    assert _kind(proto, 0x031, bytes(flipped)) == "bad-crc"
    # a well-formed frame with a CRC valid for another ID (AXIS_FEEDBACK_2's frame on 0x031)
    other = proto.encode("AXIS_FEEDBACK_2", {"Length": 1.7}, counter=0)
    assert e2e.crc_ok(0x032, other)
    assert _kind(proto, 0x031, other) == "bad-crc"
    # the non-raising form agrees and counts too
    r = proto.receive(0x031, bytes(flipped), bus="axis_a")
    assert not r.ok and r.error.kind == "bad-crc"
    assert proto.rejections == {"unknown-id": 1, "bad-length": 2, "bad-crc": 3}
    assert proto.accepted == 0

    # counter: first frame accepted, then a repeat, then a jump beyond the allowed gap
    assert proto.decode(0x031, good, bus="axis_a")[1]["TickEcho"] == 0
    assert _kind(proto, 0x031, good) == "repeated"
    assert proto.receive(0x031, good, bus="axis_a").error.kind == "repeated"
    assert _kind(proto, 0x031, _feedback(proto, 4)) == "wrong-sequence"
    assert proto.rejections["repeated"] == 2 and proto.rejections["wrong-sequence"] == 1
    # after a wrong sequence the next frame resynchronises
    assert proto.receive(0x031, _feedback(proto, 9), bus="axis_a").status == "init"
    r = proto.receive(0x031, _feedback(proto, 12), bus="axis_a")
    assert r.ok and r.status == "lost" and r.lost == 2 and proto.lost_frames == 2

    # out of range: raw State 4 with a valid CRC and counter
    m = proto.message("AXIS_FEEDBACK_1")
    raw = proto.to_raw("AXIS_FEEDBACK_1", {"Length": 1.7}, 13)
    raw["State"] = 4
    bad = e2e.seal(0x031, m.encode(raw, scaling=False, strict=False))
    assert _kind(proto, 0x031, bad) == "out-of-range"
    # ... it still advanced the counter: 14 is ok
    assert proto.receive(0x031, _feedback(proto, 14), bus="axis_a").status == "ok"
    assert proto.rejections["out-of-range"] == 1
    assert proto.accepted == 4


def test_counters_are_per_bus_and_message(proto):
    a = proto.encode("SYNC", {"Tick": 1}, counter=5)
    assert proto.receive(0x010, a, bus="axis_a").status == "init"
    assert proto.receive(0x010, a, bus="axis_b").status == "init"  # other bus: own state
    fb = _feedback(proto, 5)
    assert proto.receive(0x031, fb, bus="axis_a").status == "init"  # other message
    assert proto.receive(0x010, a, bus="axis_a").error.kind == "repeated"
    assert proto.receive(0x010, proto.encode("SYNC", {}, counter=6), bus="axis_b").status == "ok"


def test_lost_up_to_two_frames_then_wrong_sequence(proto):
    p = proto
    for start in range(16):
        p.reset_counters()
        assert p.receive(0x010, p.encode("SYNC", {}, counter=start)).status == "init"
        r = p.receive(0x010, p.encode("SYNC", {}, counter=(start + 3) % 16))
        assert r.ok and r.lost == 2
        r = p.receive(0x010, p.encode("SYNC", {}, counter=(start + 7) % 16))
        assert r.error.kind == "wrong-sequence"


def test_random_frames_never_crash_and_are_counted(proto):
    import random

    rng = random.Random(1)
    ids = [0x010, 0x020, 0x031, 0x040, 0x050, 0x100, 0x101, 0x7FF, 0x000]
    n = 3000
    accepted = 0
    for _ in range(n):
        fid = rng.choice(ids)
        data = bytes(rng.getrandbits(8) for _ in range(rng.choice([0, 1, 8, 12, 24, 32, 64])))
        if proto.receive(fid, data, bus="axis_a").ok:
            accepted += 1
    assert accepted == proto.accepted
    assert sum(proto.rejections.values()) + accepted == n
    assert accepted < 40  # random data rarely passes length + CRC-8 (+ CRC-16)


# -- shared test vectors ----------------------------------------------------------

def test_vectors_file_is_the_generated_one(vectors):
    assert vectors == json.loads(protocol_cmd.vectors_text(protocol_cmd.make_vectors()))


def test_vectors_cover_every_message_and_the_extremes(proto, vectors):
    by_msg = {}
    for v in vectors["vectors"]:
        by_msg.setdefault(v["message"], []).append(v)
    assert set(by_msg) == set(SPEC)
    for name, vs in by_msg.items():
        assert len(vs) >= 3
        info = proto.infos[name]
        for sig, lim in info.limits.items():
            if sig == "Crc":
                continue
            seen = {v["raw"][sig] for v in vs}
            assert lim.lo in seen and lim.hi in seen, f"{name}.{sig}"
        assert {v["counter"] for v in vs} >= {0, 15}
    assert {c["algorithm"]: c["crc"] for c in vectors["crc"]} == {
        "CRC-8 SAE J1850": 0x4B, "CRC-16/CCITT-FALSE": 0x29B1}


def test_vectors_roundtrip(proto, vectors):
    for v in vectors["vectors"]:
        data = bytes.fromhex(v["data"])
        name = v["message"]
        assert len(data) == SPEC[name][1]
        # encoding the physical values with the vector's counter gives the same bytes
        assert proto.encode(name, v["physical"], counter=v["counter"]) == data, (name, v["case"])
        assert proto.encode_raw(name, v["raw"]) == data
        proto.reset_counters()
        got_name, raw = proto.decode(v["frame_id"], data, raw=True)
        assert got_name == name and raw == v["raw"]
        proto.reset_counters()
        _, phys = proto.decode(v["frame_id"], data)
        for k, x in v["physical"].items():
            assert phys[k] == pytest.approx(x, rel=1e-12, abs=1e-12), (name, k)


def test_vectors_counter_sequences(vectors):
    assert len(vectors["counter_sequences"]) >= 5
    for seq in vectors["counter_sequences"]:
        rx = e2e.E2EReceiver()
        got = [rx.check(c) for c in seq["counters"]]
        assert [g.status for g in got] == seq["status"], seq["case"]
        assert [g.lost for g in got] == seq["lost"]


def test_vectors_malformed_frames(vectors):
    kinds = set()
    for case in vectors["malformed"]:
        p = pr.Protocol()
        r = p.receive(case["frame_id"], bytes.fromhex(case["data"]), bus="axis_a")
        assert not r.ok and r.error.kind == case["kind"], case["case"]
        assert p.rejections == {case["kind"]: 1}
        kinds.add(case["kind"])
    assert kinds == {"unknown-id", "bad-length", "bad-crc", "out-of-range"}


def test_vectors_cli_check(capsys):
    assert cli.main(["protocol", "vectors"]) == 0
    assert "up to date" in capsys.readouterr().out


def test_vectors_cli_detects_a_stale_file(tmp_path):
    f = tmp_path / "v.json"
    f.write_text(VECTORS.read_text().replace('"counter": 7', '"counter": 8', 1))
    assert cli.main(["protocol", "vectors", "--file", str(f)]) == 1
    assert cli.main(["protocol", "vectors", "--write", "--file", str(f)]) == 0
    assert cli.main(["protocol", "vectors", "--file", str(f)]) == 0


# -- generated documentation --------------------------------------------------------

def test_committed_doc_is_the_generated_one():
    assert DOC.read_text() == protocol_cmd.make_doc(), (
        "docs/reference/protocol.md differs from the DBC: run `stewart protocol doc`")


def test_doc_lists_every_message_and_signal(proto):
    text = protocol_cmd.make_doc(proto)
    for name in SPEC:
        assert f"### {name}" in text
        for s in proto.message(name).signals:
            assert f"| `{s.name}` |" in text
    assert "0x29B1" in text and "0x4B" in text
    assert "38.0 %" in text and "46.2 %" in text and "48.7 %" in text


def test_doc_cli_check(tmp_path):
    out = tmp_path / "p.md"
    assert cli.main(["protocol", "doc", "--out", str(out), "--check"]) == 1
    assert cli.main(["protocol", "doc", "--out", str(out)]) == 0
    assert cli.main(["protocol", "doc", "--out", str(out), "--check"]) == 0


def test_decode_cli(capsys, vectors):
    v = next(x for x in vectors["vectors"] if x["message"] == "OP_COMMAND" and x["case"] == "typical")
    assert cli.main(["protocol", "decode", hex(v["frame_id"]), v["data"]]) == 0
    assert "Command = 2" in capsys.readouterr().out
    bad = v["data"][:-2] + ("00" if v["data"][-2:] != "00" else "01")
    assert cli.main(["protocol", "decode", hex(v["frame_id"]), bad]) == 1
    assert "bad-crc" in capsys.readouterr().out


def test_force_params_ranges_are_refused_by_name(proto):
    """OP_FORCE_PARAMS: the tool refuses a parameter outside the DBC's range
    naming it; within range it encodes to the C encoder's bytes
    (tests/unit/link/test_node.c sends the same)."""
    assert pr.force_params_check(40.0, 5e5, 0.0) is None
    assert pr.force_params_check(0.5, 5e5, 0.0) == "mass 0.5 kg is out of range (1 .. 5000)"
    assert pr.force_params_check(40.0, 50.0, 0.0).startswith("damping 50 N s/m is out of range")
    assert pr.force_params_check(40.0, 5e5, 2e7).startswith("stiffness 2e+07 N/m is out of range")
    assert pr.force_params_check(float("nan"), 5e5, 0.0).startswith("mass nan")
    with pytest.raises(ValueError, match="mask 0"):
        pr.force_params_signals(0, "FORCE", 40.0, 5e5, 0.0)
    msg = proto.message("OP_FORCE_PARAMS")
    for s in msg.signals[3:6]:
        lo, hi = pr.FORCE_PARAM_RANGES[s.name.lower()]
        assert (s.minimum, s.maximum) == (lo, hi), s.name
    data = proto.encode("OP_FORCE_PARAMS", pr.force_params_signals(4, "FORCE", 40.0, 5e5, 0.0), 0)
    assert data.hex() == "0410900150c300000000000000000000000000000000ac27"  # auth fields 0 until signed
