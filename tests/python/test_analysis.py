# SPDX-License-Identifier: Apache-2.0
"""stewart.analysis / ``stewart analyze``: a synthetic closed-loop log, built
here frame by frame with the protocol encoder, decoded back and measured.

The synthetic run: READY at home, then RUNNING segments of a sinusoid on one
axis (reference from CTRL_MONITOR), the estimate (CTRL_STATUS) equal to the
reference one tick earlier plus a known constant offset, feedback lengths the
float64 IK of the estimate, chamber pressures giving a known force, and on
even ticks a CTRL_WRENCH with a known wrench (valid while RUNNING). The DBC
quantises poses and lengths to 1 um / 1 urad, forces to 0.02 N, pressures
to 1 kPa and the wrench to 0.25 N / N m; the tolerances below are those steps.
"""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from stewart import cli
from stewart import config as cfg
from stewart import model
from stewart import protocol as pr
from stewart.analysis.csvout import signal_columns, write_signals_csv
from stewart.analysis.decode import WRONG_BUS, hydraulic_areas, read_log
from stewart.analysis.logfile import format_line, parse_bus_map, parse_line
from stewart.analysis.metrics import format_summary, jsonable, segment_metrics, summarize, tracking_error
from stewart.analysis.names import AXES, STATES
from stewart.analysis.plots import figure_window
from stewart.analysis.run import DEFAULT_PLATFORM
from stewart.analysis.segments import Segment, find_segments
from stewart.analysis.truth import TRUTH_COLUMNS, WRENCH_COLUMNS, attach_truth, read_truth

PLATFORM = cfg.load(DEFAULT_PLATFORM)
HOME = np.array(PLATFORM.home, dtype=float)
HOME_LEN = model.inverse_kinematics(PLATFORM, HOME).lengths
AP, AR = hydraulic_areas(PLATFORM)
Q_POSE = 1e-6      # m or rad per LSB of the DBC's pose signals
P_A = 10.001e6     # Pa, piston side (a multiple of the 1 kPa LSB, not of the former 10 kPa)
P_B = 4.5e6        # Pa, rod side
FORCE = P_A * AP - P_B * AR
OFFSET = np.array([0.5e-3, 0.0, -0.2e-3, 0.0, 0.0, 0.3e-3])  # estimate - delayed reference


def ref_pose(tick: int, segments) -> np.ndarray:
    """Reference: home plus A sin(2 pi f (t - start)) on the segment's axis."""
    p = HOME.copy()
    for seg in segments:
        if seg["start"] <= tick <= seg["end"]:
            t = (tick - seg["start"]) * 1e-3
            p[seg["axis"]] += seg["amp"] * math.sin(2 * math.pi * seg["freq"] * t)
    return p


def state_at(tick: int, segments) -> str:
    for seg in segments:
        if seg["start"] <= tick <= seg["end"]:
            return "RUNNING"
    return "READY"


def wrench(tick: int) -> list[float]:
    """The controller's wrench estimate sent at ``tick`` (multiples of 0.25)."""
    return [100.0 + 0.25 * (tick % 40), -20.5, -2452.75, 3.75, -0.25 * (tick % 8), 0.5]


def true_wrench(tick: int) -> list[float]:
    """The plant's wrench: the estimate plus a known error."""
    return [v + e for v, e in zip(wrench(tick), (1.5, -2.0, 30.0, 0.125, 0.0, -0.375))]


def force_ff(tick: int) -> list[float]:
    return [20000.0 + 1000.0 * j + 500.0 * math.sin(tick * 1e-2) for j in range(6)]


def build_log(ticks, segments, *, ifaces=("vcan0", "vcan1", "vcan2"), ff_on=(True,),
              skip_feedback=(), tweak=None, with_truth=False):
    """Lines of a lockstep log in hs_sim's order per tick: operator commands,
    feedback and SYNC on both axis buses, setpoints, CTRL_STATUS, CTRL_MONITOR,
    CTRL_WRENCH on even ticks. Truth rows in hs_sim's column order (tick, pose,
    len, force, drive, wrench).
    ``skip_feedback``: (tick, leg) pairs left out. ``tweak(tick, lines)``
    may edit a tick's lines. Returns (lines, truth rows)."""
    p = pr.Protocol()
    bus_if = dict(zip(("ops", "axis_a", "axis_b"), ifaces))
    lines, truth = [], []
    for k, tick in enumerate(ticks):
        t = tick * 1e-3
        out = []

        def emit(bus, name, sig):
            m = p.message(name)
            out.append(format_line(t, bus_if[bus], m.frame_id, p.encode(name, sig, bus=bus)))

        for n, seg in enumerate(segments):
            if tick == seg["start"]:
                if seg.get("ff") is not None:
                    emit("ops", "OP_COMMAND", pr.command_signals("SET_FEEDFORWARD",
                                                                 option=int(seg["ff"])))
                    p_ff = seg["ff"]
                emit("ops", "OP_COMMAND", pr.command_signals(
                    "RUN_TRIG", axis=AXES[seg["axis"]], amplitude=seg["amp"],
                    frequency=seg["freq"], fade_time=0.5))
            if tick == seg.get("stop", -1):
                emit("ops", "OP_COMMAND", pr.command_signals("STOP"))
        ff = 1
        for seg in segments:
            if tick >= seg["start"] and seg.get("ff") is not None:
                ff = int(seg["ff"])
        est = ref_pose(tick, segments) + OFFSET  # a drive that follows the reference
        lengths = model.inverse_kinematics(PLATFORM, est).lengths
        for leg in range(1, 7):
            if (tick, leg) in skip_feedback:
                continue
            bus, slot = pr.LEG_BUS[leg]
            emit(bus, pr.feedback_name(slot), {
                "Length": round(lengths[leg - 1], 6), "PressureA": P_A, "PressureB": P_B,
                "State": "ACTIVE", "Faults": 0, "TickEcho": tick & 0xFFFF})
        for bus in ("axis_a", "axis_b"):
            emit(bus, "SYNC", {"Tick": tick, "Hold": 0})
        ref = ref_pose(tick, segments)
        sp_len = model.inverse_kinematics(PLATFORM, ref).lengths
        ffv = force_ff(tick) if ff else [0.0] * 6
        for b, bus in enumerate(("axis_a", "axis_b")):
            emit(bus, "AXIS_SETPOINTS", pr.setpoint_signals(
                "ACTIVE", tick, [(round(sp_len[3 * b + s], 6), 0.0, ffv[3 * b + s]) for s in range(3)]))
        status = {"Tick": tick, "State": state_at(tick, segments), "Faults": 0, "FkIterations": 2,
                  "EstimateValid": 1, "CmdRejected": 0, "DriveMode": "ACTIVE", "FeedForward": ff}
        status.update(pr.pose_to_signals([round(v, 6) for v in est]))
        emit("ops", "CTRL_STATUS", status)
        mon = {"Tick": tick}
        mon.update(pr.pose_to_signals([round(v, 6) for v in ref], prefix="Ref"))
        for i in range(6):
            mon[f"LengthSp_{i + 1}"] = round(sp_len[i], 6)
            mon[f"ForceFf_{i + 1}"] = round(ffv[i], 2)
        emit("ops", "CTRL_MONITOR", mon)
        if tick % 2 == 0:
            ws = dict(zip(pr.WRENCH_SIGNALS, wrench(tick)))
            ws.update({"Tick": tick, "Valid": int(state_at(tick, segments) == "RUNNING")})
            emit("ops", "CTRL_WRENCH", ws)
        if tweak is not None:
            tweak(tick, out)
        lines += out
        if with_truth:
            truth.append([tick] + list(est) + list(lengths) + [FORCE + j for j in range(6)] + [2] * 6
                         + true_wrench(tick))
    return lines, truth


SURGE = {"axis": 0, "amp": 0.09, "freq": 1.0, "start": 200, "end": 899, "stop": 600, "ff": True}
YAW = {"axis": 5, "amp": 0.05, "freq": 2.0, "start": 1000, "end": 1499, "ff": False}


@pytest.fixture(scope="module")
def run2():
    """Two segments (surge ff on, yaw ff off), with truth."""
    lines, truth = build_log(range(0, 1600), [SURGE, YAW], with_truth=True,
                             skip_feedback={(700, 4)})
    data = read_log(lines, platform=PLATFORM)
    tr = {"tick": np.array([r[0] for r in truth]), "pose": np.array([r[1:7] for r in truth]),
          "length": np.array([r[7:13] for r in truth]), "force": np.array([r[13:19] for r in truth]),
          "wrench": np.array([r[25:31] for r in truth])}
    attach_truth(data, tr)
    return data, lines, truth


# -- the log format -----------------------------------------------------------------

def test_parse_line_fd_classic_and_malformed():
    f = parse_line("(0000000001.234000) vcan0 100##1" + "00" * 32)
    assert (f.time, f.iface, f.frame_id, f.fd, f.flags, len(f.data)) == (1.234, "vcan0", 0x100, True, 1, 32)
    f = parse_line("(1.5) can1 010#0102030405060708")
    assert (f.frame_id, f.fd, f.data) == (0x10, False, bytes(range(1, 9)))
    for bad in ("", "garbage", "(1.0) vcan0 100##", "(1.0) vcan0 100#R", "(1.0) vcan0 100#123",
                "(1.0) vcan0 100#GG", "(1.0) vcan0 100#" + "00" * 9, "vcan0 100#00"):
        with pytest.raises(ValueError):
            parse_line(bad)
    line = format_line(12.345678, "vcan2", 0x31, b"\x01\xab", fd=True)
    assert line == "(0000000012.345678) vcan2 031##101AB"
    assert parse_line(line).data == b"\x01\xab"


def test_bus_map():
    m = parse_bus_map("ops=can0,axis_a=can1,axis_b=can2")
    assert m["can0"] == "ops" and m["can2"] == "axis_b" and m["axis_a"] == "axis_a"
    assert parse_bus_map(None)["vcan1"] == "axis_a"
    with pytest.raises(ValueError):
        parse_bus_map("foo=can0")
    with pytest.raises(ValueError):
        parse_bus_map("ops")
    with pytest.raises(ValueError, match="two buses"):
        parse_bus_map("ops=vcan1")
    assert parse_bus_map("ops=vcan2,axis_b=vcan0")["vcan0"] == "axis_b"


# -- decoding -----------------------------------------------------------------------

def test_decoded_rows_match_what_was_encoded(run2):
    data, _, _ = run2
    assert len(data) == 1600 and data.ticks[0] == 0 and data.ticks[-1] == 1599
    assert data.stats.bad_frames == 0 and data.stats.malformed == 0 and data.stats.lost == 0
    assert data.stats.setpoint_checked == 1600 and data.stats.setpoint_mismatch == 0
    k = int(data.index_of([555])[0])
    ref = ref_pose(555, [SURGE, YAW])
    est = ref_pose(555, [SURGE, YAW]) + OFFSET
    np.testing.assert_allclose(data.reference[k], ref, atol=0.5 * Q_POSE + 1e-12)
    np.testing.assert_allclose(data.estimate[k], est, atol=0.5 * Q_POSE + 1e-12)
    lengths = model.inverse_kinematics(PLATFORM, est).lengths
    np.testing.assert_allclose(data.length[k], lengths, atol=0.5e-6 + 1e-12)
    np.testing.assert_allclose(data.stretch[k], lengths - HOME_LEN, atol=0.5e-6 + 1e-12)
    np.testing.assert_allclose(data.force[k], FORCE, atol=1e-6)
    np.testing.assert_allclose(data.force_ff[k], force_ff(555), atol=0.01 + 1e-9)
    assert data.state_name(k) == "RUNNING" and data.feedforward[k] == 1
    assert data.state_name(0) == "READY"
    # CTRL_WRENCH: 800 frames (even ticks), exact (multiples of 0.25), NaN on odd ticks
    assert data.stats.per_message["CTRL_WRENCH"] == 800
    k = int(data.index_of([554])[0])
    assert data.est_wrench_valid[k] == 1
    np.testing.assert_array_equal(data.est_wrench[k], wrench(554))
    np.testing.assert_allclose(data.truth["wrench"][k], true_wrench(554))
    assert data.est_wrench_valid[k + 1] == -1 and np.isnan(data.est_wrench[k + 1]).all()
    running = data.state == 3
    even = data.ticks % 2 == 0
    assert (data.est_wrench_valid[even] == running[even]).all()
    assert np.isnan(data.est_wrench[~(even & running)]).all()
    # feedback left out: that leg alone is missing at that tick
    k = int(data.index_of([700])[0])
    assert math.isnan(data.length[k, 3]) and not np.isnan(np.delete(data.length[k], 3)).any()


def test_signals_csv(run2, tmp_path):
    data, _, _ = run2
    path = tmp_path / "signals.csv"
    write_signals_csv(data, path)
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1600
    r = rows[555]
    assert r["tick"] == "555" and r["time_s"] == "0.555" and r["state"] == "RUNNING"
    assert r["faults"] == "0" and r["drive_mode"] == "ACTIVE" and r["feedforward"] == "1"
    assert abs(float(r["ref_x"]) - ref_pose(555, [SURGE])[0]) <= 0.5e-6 + 1e-12
    assert abs(float(r["est_yaw"]) - OFFSET[5]) <= 0.5e-6 + 1e-12
    assert abs(float(r["force1"]) - FORCE) <= 0.05
    assert r["drive_state1"] == "ACTIVE" and r["drive_faults6"] == "0"
    assert abs(float(r["truth_x"]) - (ref_pose(555, [SURGE])[0] + OFFSET[0])) < 1e-9
    assert abs(float(r["truth_force3"]) - (FORCE + 2)) < 1e-3
    # the wrench: on even ticks only (blank in between, not held), blank unless valid
    w = rows[554]
    assert w["est_wrench_valid"] == "1"
    assert [float(w[f"est_wrench_{a}"]) for a in ("fx", "fy", "fz", "mx", "my", "mz")] == wrench(554)
    assert [float(w[f"truth_wrench_{a}"]) for a in ("fx", "fy", "fz", "mx", "my", "mz")] == pytest.approx(
        true_wrench(554), abs=1e-3)
    assert r["est_wrench_valid"] == "" and r["est_wrench_fx"] == "" and r["est_wrench_mz"] == ""
    assert r["truth_wrench_fz"] != ""  # the truth has every tick
    assert rows[100]["est_wrench_valid"] == "0" and rows[100]["est_wrench_fz"] == ""  # READY
    assert rows[101]["est_wrench_valid"] == ""
    assert rows[700]["length4"] == "" and rows[700]["stretch4"] == "" and rows[700]["force4"] == ""
    assert rows[700]["length5"] != ""
    for col in signal_columns(True):
        assert col in rows[0]


# -- errors and segments ------------------------------------------------------------

def test_segments_found_and_labelled(run2):
    data, _, _ = run2
    segs = find_segments(data)
    assert [(s.start, s.end) for s in segs] == [(200, 899), (1000, 1499)]
    assert segs[0].label == "surge x 0.090 m 1 Hz ff=on"
    assert segs[1].label == "yaw 0.050 rad 2 Hz ff=off"
    assert segs[0].command == "RUN_TRIG" and segs[0].axis == 0 and segs[1].axis == 5
    assert segs[0].stop_tick == 600 and segs[1].stop_tick is None
    assert segs[0].fade_time == pytest.approx(0.5)
    # fade-in (0.5 s) longer than the run before STOP: no steady part, the whole segment
    assert segs[0].steady() == (200, 899)
    seg = Segment(1, 1000, 5000, command="RUN_TRIG", axis=0, amplitude=0.1, frequency=1.0,
                     fade_time=0.5, stop_tick=4000)
    assert seg.steady() == (1500, 4000) and figure_window(seg) == (3001, 4000)
    seg.stop_tick = None
    assert seg.steady() == (1500, 4500)


def test_tracking_error_default_delay(run2):
    data, _, _ = run2
    segs = find_segments(data)
    m = segment_metrics(data, segs[0])
    # estimate = reference of the same tick + OFFSET, quantised twice to 1 um
    tol = 2 * 0.5e-3 + 1e-9  # mm (two roundings of 0.5 um)
    for a, name in enumerate(AXES):
        assert m["error"][name]["rms"] == pytest.approx(abs(OFFSET[a]) * 1e3, abs=tol), name
        assert m["error"][name]["mean"] == pytest.approx(OFFSET[a] * 1e3, abs=tol), name
        assert m["error"][name]["max"] == pytest.approx(abs(OFFSET[a]) * 1e3, abs=tol), name
        assert m["error"][name]["n"] == 700
    assert m["moving_axis_error"]["unit"] == "mm"
    assert m["error"]["yaw"]["unit"] == "mrad"
    # truth is the unquantised estimate: one rounding of the reference
    for a, name in enumerate(AXES):
        assert m["truth_error"][name]["max"] == pytest.approx(abs(OFFSET[a]) * 1e3, abs=0.5e-3 + 1e-9)
        assert m["estimation_error"][name]["max"] <= 0.5e-3 + 1e-9
    assert max(m["peak_force_measured_N"]) == pytest.approx(FORCE, abs=1e-6)
    assert max(m["peak_force_ff_N"]) == pytest.approx(25500.0, abs=1.0)
    assert max(segment_metrics(data, segs[1])["peak_force_ff_N"]) == 0.0


def test_tracking_error_with_one_tick_delay_sees_the_reference_step(run2):
    data, _, _ = run2
    seg = find_segments(data)[0]
    e = tracking_error(data, delay_ticks=1)[seg.mask(data), 0]
    t = (np.arange(seg.start, seg.end + 1) - seg.start) * 1e-3
    w = 2 * math.pi * SURGE["freq"]
    expect = OFFSET[0] + SURGE["amp"] * (np.sin(w * t) - np.sin(w * (t - 1e-3)))
    expect[0] = OFFSET[0] + SURGE["amp"] * math.sin(0.0)  # the reference before the start is home
    assert np.max(np.abs(e - expect)) <= 1e-6 + 1e-12
    rms = math.sqrt(np.mean(e * e))
    assert rms > 1.05 * OFFSET[0]  # the reference step adds to the offset


def test_summary(run2):
    data, _, _ = run2
    s = summarize(data)
    assert s["final_state"] == "READY" and s["states"] == ["READY", "RUNNING", "READY", "RUNNING", "READY"]
    assert s["bad_frames"] == 0 and s["faults_seen"] == [] and s["duration_s"] == pytest.approx(1.6)
    assert len(s["segments"]) == 2 and s["segments"][1]["feedforward"] == "off"
    assert [c["command"] for c in s["commands"]] == ["SET_FEEDFORWARD", "RUN_TRIG", "STOP",
                                                    "SET_FEEDFORWARD", "RUN_TRIG"]
    assert s["commands"][1]["tick"] == 200
    text = format_summary(s)
    assert "segment 1: surge x 0.090 m 1 Hz ff=on" in text and "RMS 0.500 mm" in text
    json.dumps(jsonable(s), allow_nan=False)


# -- robustness ---------------------------------------------------------------------

def test_malformed_lines_and_bad_frames_are_counted_not_fatal():
    def tweak(tick, out):
        if tick == 20:
            out.insert(0, "this is not a frame")
            out.insert(1, "(0000000000.020000) vcan0 100##1ZZ")
            out.append("")
        if tick == 30:  # bad CRC on a feedback frame of leg 1
            i = next(i for i, s in enumerate(out) if " vcan1 031##" in s)
            out[i] = out[i][:-2] + ("00" if not out[i].endswith("00") else "01")
        if tick == 40:  # CTRL_STATUS on an axis bus (its counter is fine there: first one)
            i = next(i for i, s in enumerate(out) if " vcan0 100##" in s)
            out.append(out[i].replace(" vcan0 ", " vcan2 "))
        if tick == 50:  # an interface nobody mapped
            out.append(out[0].replace(" vcan1 ", " can7 ").replace(" vcan0 ", " can7 "))
        if tick == 60:  # truncated frame (bad length)
            i = next(i for i, s in enumerate(out) if " vcan0 101##" in s)
            out.append(out[i][:-4])
    lines, _ = build_log(range(0, 100), [], tweak=tweak)
    data = read_log(lines, platform=PLATFORM)
    st = data.stats
    assert st.malformed == 2
    assert st.rejected.get("bad-crc") == 1
    assert st.rejected.get(WRONG_BUS) == 1
    assert st.rejected.get("bad-length") == 1
    assert st.unknown_interface == 1
    assert st.bad_frames == 3
    assert len(data) == 100
    k = int(data.index_of([30])[0])
    assert math.isnan(data.length[k, 0]) and not math.isnan(data.length[k, 1])
    assert any("line" in w and "malformed" in w for w in st.warnings)


def test_an_identify_and_its_answer_change_no_column(run2):
    """OP_COMMAND IDENTIFY and CTRL_IDENTITY in a log (`stewart op identify`
    during a run): decoded without a bad frame, the request listed among the
    commands, every column as without them."""
    data, _, _ = run2
    p = pr.Protocol()

    def tweak(tick, out):
        if tick == 1550:  # after the log's five commands: the next alive counter
            out.insert(0, format_line(tick * 1e-3, "vcan0", 0x040, p.encode("OP_COMMAND", pr.command_signals(
                "IDENTIFY"), 5, bus="ops")))
            out.append(format_line(tick * 1e-3, "vcan0", 0x104, p.encode("CTRL_IDENTITY", {
                "VersionMajor": 0, "VersionMinor": 3, "VersionPatch": 0, "Port": "HOST",
                "ProtocolHash": pr.dbc_hash()}, bus="ops")))
    lines, _ = build_log(range(0, 1600), [SURGE, YAW], skip_feedback={(700, 4)}, tweak=tweak)
    got = read_log(lines, platform=PLATFORM)
    assert got.stats.bad_frames == 0 and got.stats.malformed == 0
    assert np.array_equal(got.length, data.length, equal_nan=True)
    assert np.array_equal(got.est_wrench, data.est_wrench, equal_nan=True)
    assert "IDENTIFY" in [c["command"] for c in summarize(got)["commands"]]


def test_tick_echo_unwraps_across_65536_and_other_interface_names():
    lines, _ = build_log(range(65500, 65600), [], ifaces=("can0", "can1", "can2"))
    data = read_log(lines, buses="ops=can0,axis_a=can1,axis_b=can2", platform=PLATFORM)
    assert data.stats.bad_frames == 0 and data.stats.unknown_interface == 0
    assert data.ticks[0] == 65500 and data.ticks[-1] == 65599 and len(data) == 100
    assert not np.isnan(data.length).any()
    default = read_log(lines, platform=PLATFORM)
    assert default.stats.unknown_interface == len(lines)


def test_truth_csv_with_and_without_header(tmp_path, run2):
    _, _, truth = run2
    cols = TRUTH_COLUMNS + [f"drive{i}" for i in range(1, 7)] + WRENCH_COLUMNS
    with_header = tmp_path / "t1.csv"
    with open(with_header, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        w.writerows(truth[:50])
        w.writerow(["oops"])
    no_header = tmp_path / "t2.csv"
    with open(no_header, "w", newline="") as f:
        csv.writer(f).writerows(truth[:50])
    for path in (with_header, no_header):
        t = read_truth(path)
        assert t["tick"].shape == (50,) and t["pose"].shape == (50, 6)
        np.testing.assert_allclose(t["force"][7], [FORCE + j for j in range(6)])
        np.testing.assert_allclose(t["wrench"][7], true_wrench(7))
    assert int(read_truth(with_header)["bad_rows"]) == 1
    # an older truth file without the wrench: the wrench is NaN, the rest is read
    old = tmp_path / "t4.csv"
    with open(old, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRUTH_COLUMNS)
        w.writerows(r[:19] for r in truth[:10])
    t = read_truth(old)
    assert t["wrench"].shape == (10, 6) and np.isnan(t["wrench"]).all()
    np.testing.assert_allclose(t["force"][3], [FORCE + j for j in range(6)])
    bad = tmp_path / "t3.csv"
    bad.write_text("tick,x,y\n1,2,3\n")
    with pytest.raises(ValueError, match="len1"):
        read_truth(bad)


# -- the command line ---------------------------------------------------------------

SHORT = {"axis": 0, "amp": 0.09, "freq": 4.0, "start": 50, "end": 449, "stop": 250}


def _write(path, lines):
    path.write_text("\n".join(lines) + "\n")


def test_cli_analyze_with_truth_and_compare(tmp_path, capsys):
    on = dict(SHORT, ff=True)
    off = dict(SHORT, ff=False)
    lines1, truth = build_log(range(0, 500), [on], with_truth=True)
    lines2, _ = build_log(range(0, 500), [off])
    log1, log2, tpath = tmp_path / "on.log", tmp_path / "off.log", tmp_path / "truth.csv"
    _write(log1, lines1)
    _write(log2, lines2 + ["broken line"])
    with open(tpath, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRUTH_COLUMNS + [f"drive{i}" for i in range(1, 7)] + WRENCH_COLUMNS)
        w.writerows(truth)
    out = tmp_path / "out"
    rc = cli.main(["analyze", str(log1), "--out", str(out), "--truth", str(tpath),
                   "--compare", str(log2)])
    text = capsys.readouterr().out
    assert rc == 1  # the second log has a malformed line
    for name in ("signals.csv", "summary.json", "seg1_tracking.png", "seg1_cylinders.png",
                 "compare1.png", "run2/signals.csv", "run2/seg1_tracking.png"):
        assert (out / name).stat().st_size > 1000 or name.endswith(".json"), name
    s = json.loads((out / "summary.json").read_text())
    assert s["segments"][0]["label"] == "surge x 0.090 m 4 Hz ff=on"
    assert s["segments"][0]["moving_axis_error"]["rms"] == pytest.approx(0.5, abs=1e-3)
    assert s["segments"][0]["moving_axis_truth_error"]["rms"] == pytest.approx(0.5, abs=1e-3)
    assert s["truth"] is True and s["bad_frames"] == 0
    with open(out / "signals.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for a in ("fx", "fy", "fz", "mx", "my", "mz"):
        assert f"est_wrench_{a}" in rows[0] and f"truth_wrench_{a}" in rows[0]
    assert float(rows[100]["est_wrench_fz"]) == -2452.75 and rows[101]["est_wrench_fz"] == ""
    assert float(rows[101]["truth_wrench_fz"]) == pytest.approx(-2452.75 + 30.0, abs=1e-3)
    s2 = json.loads((out / "run2" / "summary.json").read_text())
    assert s2["malformed_lines"] == 1 and s2["segments"][0]["feedforward"] == "off"
    assert "segment 1: surge x 0.090 m 4 Hz ff=on" in text
    assert "segment 1: surge x 0.090 m 4 Hz ff=off" in text
    assert "compare 1: surge x 0.090 m 4 Hz ff=on vs surge x 0.090 m 4 Hz ff=off" in text


def test_cli_analyze_usage_errors(tmp_path, capsys):
    assert cli.main(["analyze", str(tmp_path / "nope.log"), "--out", str(tmp_path)]) == 2
    log = tmp_path / "x.log"
    _write(log, build_log(range(0, 5), [])[0])
    assert cli.main(["analyze", str(log), "--out", str(tmp_path / "o"), "--bus", "bogus"]) == 2
    assert cli.main(["analyze", str(log), "--out", str(tmp_path / "o"), "--no-plots"]) == 0
    assert "no RUNNING segment" in capsys.readouterr().out


def test_wrench_metrics_against_a_known_error():
    """wrench_metrics judges the estimate only 20 ticks after each change of
    the true wrench, and relates the loaded error to 2 % + 100 N / 50 N m."""
    from types import SimpleNamespace

    from stewart.analysis.metrics import wrench_metrics

    n = 200
    ticks = np.arange(n)
    truth = np.zeros((n, 6))
    truth[100:, :] = [1000.0, 0, 0, 0, 0, 500.0]          # a step at tick 100
    est = truth.copy()
    est[:, 0] += 30.0                                       # 30 N off everywhere
    est[100:119, 0] += 5000.0                               # the transient, inside the 20 ticks
    est[150, 5] += 40.0                                     # 40 N m once, loaded: bound 50 + 10
    est[1::2] = np.nan                                      # a frame every second tick
    data = SimpleNamespace(truth={"wrench": truth}, est_wrench=est, ticks=ticks,
                           state=np.full(n, STATES.index("RUNNING")))
    w = wrench_metrics(data)
    assert w["unloaded"]["force_N"] == pytest.approx(30.0)
    assert w["unloaded_running"]["moment_Nm"] == pytest.approx(0.0)
    assert w["loaded"]["force_N"] == pytest.approx(30.0)
    assert w["loaded"]["moment_Nm"] == pytest.approx(40.0)
    assert w["loaded"]["worst_share_of_bound"] == pytest.approx(40.0 / 60.0)
    assert w["loaded"]["within"]
    assert w["loaded"]["n"] == 40  # ticks 120..198, even ones
    est[170, 1] += 101.0
    assert not wrench_metrics(data)["loaded"]["within"]


def test_wrench_metrics_never_valid():
    """An estimate never valid (drives without force measurement: CTRL_WRENCH
    Valid 0, its columns NaN) is said so, not taken for a missing truth."""
    from types import SimpleNamespace

    from stewart.analysis.metrics import format_wrench, wrench_metrics

    n = 50
    data = SimpleNamespace(truth={"wrench": np.zeros((n, 6))}, est_wrench=np.full((n, 6), np.nan),
                           ticks=np.arange(n), state=np.full(n, STATES.index("RUNNING")))
    w = wrench_metrics(data)
    assert w["valid_ticks"] == 0
    assert format_wrench(w) == ["wrench estimate: never valid (CTRL_WRENCH Valid 0 on every tick: "
                                "the drives measure no cylinder force)"]
    data.est_wrench[10] = 0.0
    assert wrench_metrics(data)["valid_ticks"] == 1
