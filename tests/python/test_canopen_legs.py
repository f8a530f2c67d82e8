# SPDX-License-Identifier: Apache-2.0
"""signals.csv's leg columns from CANopen drives (stewart/analysis/canopen_legs.py):
a synthetic log, built here frame by frame, with the controller's ops
frames (CTRL_STATUS, CTRL_MONITOR: the ticks) and the drive buses' CiA 301
frames (SYNC every 3 ticks, TPDO1 status word + count, TPDO2 pressures in
kPa), in lockstep order and in real-time order.

The counts and pressures are integers the layout turns into lengths and
forces by float arithmetic only: the tolerances below (1e-9 m, 1e-6 N) are
float rounding, far below one count (1 um) or one kPa (7.9 N); a TPDO on
the wrong tick or leg is off by at least 7 counts.
"""

from __future__ import annotations

import copy
import csv
import json
from pathlib import Path

import numpy as np
import pytest

from stewart import config, model
from stewart import protocol as pr
from stewart.analysis import canopen_legs as cl
from stewart.analysis.csvout import write_signals_csv
from stewart.analysis.decode import hydraulic_areas, read_log
from decode_reference import read_log_reference
from stewart.analysis.logfile import format_line
from stewart.analysis.metrics import format_summary, summarize
from stewart.analysis.names import DRIVE_STATES
from stewart.drives import layout as lo

REPO_ROOT = Path(__file__).resolve().parents[2]

DEFAULT = json.loads((REPO_ROOT / "config" / "platform_default.json").read_text())
NATIVE = config.from_dict(DEFAULT)
AP, AR = hydraulic_areas(NATIVE)
DIVIDER = 3
TICKS = range(0, 30)
ZERO = 1.85
#: legs 1-3: CiA 408 on can_0 (the log's axis_a), nodes 11-13, leg 2 counting down;
#: legs 4-6: CiA 402 on can_1 (axis_b), nodes 21-23
NODES = {1: ("axis_a", 11), 2: ("axis_a", 12), 3: ("axis_a", 13), 4: ("axis_b", 21), 5: ("axis_b", 22),
         6: ("axis_b", 23)}
DIRECTION = {1: 1, 2: -1, 3: 1, 4: 1, 5: 1, 6: 1}
IFACE = {"ops": "vcan0", "axis_a": "vcan1", "axis_b": "vcan2"}
TOL_M = 1e-9
TOL_N = 1e-6
ACTIVE_408, FAULT_HOLD_408, OPERATION_ENABLED_402 = 0x000F, 0x0003, 0x0237


def mixed_config():
    d = copy.deepcopy(DEFAULT)
    legs = []
    for leg in range(1, 7):
        bus, node = NODES[leg]
        legs.append({"protocol": "cia408" if leg <= 3 else "cia402", "bus": "can_0" if leg <= 3 else "can_1",
                     "node_id": node, "scaling": {"position_per_count": 1e-6, "length_at_zero": ZERO,
                                                  "direction": DIRECTION[leg]}})
    d["drives"] = {"buses": {"can_0": {"bitrate": 1000000}, "can_1": {"bitrate": 1000000}},
                   "sync_divider": DIVIDER, "legs": legs}
    return config.from_dict(d)


MIXED = mixed_config()


def count(tick: int, leg: int) -> int:
    """The actual position a drive reports for the SYNC of ``tick`` (leg 3 negative)."""
    return (-5000 - 7 * tick) if leg == 3 else 200_000 + 1000 * leg + 7 * tick


def kpa(tick: int, leg: int) -> tuple[int, int]:
    return 10_000 + 10 * tick + leg, 4000 + 3 * leg


def word(tick: int, leg: int) -> int:
    if leg > 3:
        return OPERATION_ENABLED_402
    return FAULT_HOLD_408 if (tick, leg) == (12, 1) else ACTIVE_408


def _le(v: int, n: int) -> bytes:
    return (v & ((1 << (8 * n)) - 1)).to_bytes(n, "little")


def build(realtime: bool = False, extra=None, nodes=NODES, skip_sync=()):
    """Log lines of ticks 0..29. Lockstep (hs_sim's order, every frame of
    tick t stamped t ms): the plant's SYNC(t) on both axis buses, then on
    SYNC ticks the master's CANopen SYNC on each bus and the drives' answers,
    then CTRL_STATUS(t) and CTRL_MONITOR(t). Real time (``realtime``): no
    plant SYNC; the master's SYNC before CTRL_STATUS(t) on even SYNC ticks,
    logged 0.4 ms after it on odd ones (as from a slower drive bus), and the
    drives' answers 0.3 to 0.6 ms after the SYNC, after the ops frames.
    ``extra(tick, out)`` may add lines; ``skip_sync``: (tick, bus) whose
    CANopen SYNC is left out."""
    p = pr.Protocol()
    lines = []
    for tick in TICKS:
        t = tick * 1e-3
        out, late = [], []

        def emit(bus, name, sig, at=t, to=out):
            m = p.message(name)
            to.append(format_line(at, IFACE[bus], m.frame_id, p.encode(name, sig, bus=bus)))

        def classic(bus, fid, data, at=t, to=out):
            to.append(format_line(at, IFACE[bus], fid, data, fd=False))

        if not realtime:
            for bus in ("axis_a", "axis_b"):
                emit(bus, "SYNC", {"Tick": tick, "Hold": 0})
        sync_tick = tick % DIVIDER == 0
        if sync_tick:
            reordered = realtime and (tick // DIVIDER) % 2 == 1
            for bus in ("axis_a", "axis_b"):
                ts = t + (0.4e-3 if reordered else 0.0)
                answers = late if realtime else out
                if (tick, bus) not in skip_sync:
                    classic(bus, 0x080, b"", ts, late if reordered else out)
                for leg in range(1, 7):
                    b, node = nodes[leg]
                    if b != bus:
                        continue
                    ta = ts + (0.3e-3 if realtime else 0.0)
                    classic(bus, 0x180 + node, _le(word(tick, leg), 2) + _le(count(tick, leg), 4), ta, answers)
                    pa, pb = kpa(tick, leg)   # on the 402 nodes a TPDO2 too (not pressures there)
                    classic(bus, 0x280 + node, _le(pa, 2) + _le(pb, 2), ta, answers)
        status = {"Tick": tick, "State": "RUNNING", "Faults": 0, "FkIterations": 2, "EstimateValid": 1,
                  "CmdRejected": 0, "DriveMode": "ACTIVE", "FeedForward": 1}
        status.update(pr.pose_to_signals(NATIVE.home))
        emit("ops", "CTRL_STATUS", status)
        mon = {"Tick": tick}
        mon.update(pr.pose_to_signals(NATIVE.home, prefix="Ref"))
        for i in range(6):
            mon[f"LengthSp_{i + 1}"] = 2.0
            mon[f"ForceFf_{i + 1}"] = 5000.0 + 100 * i
        emit("ops", "CTRL_MONITOR", mon)
        out += late
        if extra is not None:
            extra(tick, out)
        lines += out
    return lines


def expected_length(tick: int, leg: int) -> float:
    return ZERO + DIRECTION[leg] * count(tick, leg) * 1e-6


def expected_force(tick: int, leg: int) -> float:
    pa, pb = kpa(tick, leg)
    return pa * 1e3 * AP - pb * 1e3 * AR


def check_values(d, legs=range(1, 7), skip=()):
    """Every SYNC tick's lengths (and forces on the CiA 408 legs) on its own
    row and leg; every other row blank."""
    assert list(d.ticks) == list(TICKS)
    for k, tick in enumerate(d.ticks.tolist()):
        for leg in legs:
            j = leg - 1
            if tick % DIVIDER or (tick, leg) in skip:
                assert np.isnan(d.length[k, j]) and np.isnan(d.force[k, j]), (tick, leg)
                assert d.drive_state[k, j] == -1 and d.drive_faults[k, j] == -1, (tick, leg)
                continue
            assert abs(d.length[k, j] - expected_length(tick, leg)) < TOL_M, (tick, leg)
            if leg <= 3:
                assert abs(d.force[k, j] - expected_force(tick, leg)) < TOL_N, (tick, leg)
            else:
                assert np.isnan(d.force[k, j]) and np.isnan(d.pressure_a[k, j]), (tick, leg)


@pytest.mark.parametrize("realtime", [False, True])
def test_answers_land_on_their_sync_tick_and_leg(realtime):
    d = read_log(build(realtime=realtime), platform=MIXED)
    check_values(d)
    fb = d.stats.canopen_feedback
    syncs = len(TICKS) // DIVIDER
    # TPDO1 of every node, TPDO2 of the CiA 408 ones (a CiA 402 drive's TPDO2 holds no pressures)
    assert fb == {"layout": "config", "syncs": 2 * syncs, "syncs_unplaced": 0, "answers": 9 * syncs,
                  "unplaced": 0, "unknown_node": 0, "short": 0, "repeated": 0}
    # the state by each node's profile; the 408 fault state is FAULT with the link's fault bit
    st = DRIVE_STATES
    k = list(d.ticks).index(12)
    assert [st[s] for s in d.drive_state[k]] == ["FAULT"] + ["ACTIVE"] * 5
    assert d.drive_faults[k].tolist() == [cl.FAULT_BIT, 0, 0, 0, 0, 0]
    k = list(d.ticks).index(15)
    assert [st[s] for s in d.drive_state[k]] == ["ACTIVE"] * 6 and d.drive_faults[k].tolist() == [0] * 6


def test_without_a_tick_nearby_a_sync_is_not_placed():
    """A SYNC more than half a tick from every tick-carrying frame next to
    it is unplaced, and so are its answers; a SYNC missing from the log
    leaves its tick's row blank (its drives' answers go to no other tick)."""
    def far(tick, out):
        if tick == 6:  # SYNC and answers of tick 6 on axis_b stamped 0.7 ms late (between the ticks' frames)
            for i, line in enumerate(out):
                if " vcan2 " in line and "##" not in line:
                    out[i] = format_line(6.7e-3, "vcan2", int(line.split()[2].split("#")[0], 16),
                                         bytes.fromhex(line.split("#")[1]), fd=False)
    d = read_log(build(realtime=True, extra=far, skip_sync={(9, "axis_a")}), platform=MIXED)
    fb = d.stats.canopen_feedback
    assert fb["syncs_unplaced"] == 1 and fb["syncs"] == 2 * 10 - 2
    # tick 9's axis_a answers follow tick 6's SYNC on axis_a: a second answer to it, left out
    assert fb["unplaced"] == 6 and fb["repeated"] == 6
    check_values(d, skip={(6, 4), (6, 5), (6, 6), (9, 1), (9, 2), (9, 3)})


def test_a_bus_without_any_sync():
    """axis_b's SYNCs all missing from the log: its answers are unplaced
    (counted), axis_a's used."""
    d = read_log(build(skip_sync={(t, "axis_b") for t in TICKS}), platform=MIXED)
    fb = d.stats.canopen_feedback
    assert fb["unplaced"] == 6 * len(TICKS) // DIVIDER and fb["syncs"] == len(TICKS) // DIVIDER
    assert np.isnan(d.length[:, 3:]).all()
    check_values(d, legs=(1, 2, 3))


def test_unknown_node_short_tpdo_and_answer_before_any_sync():
    def noise(tick, out):
        if tick == 0:  # before any SYNC of axis_b: nothing to answer
            out.insert(0, format_line(0.0, "vcan2", 0x180 + 21, bytes(6), fd=False))
        if tick == 3:  # a node of no leg
            out.append(format_line(3e-3, "vcan1", 0x180 + 30, _le(ACTIVE_408, 2) + _le(1, 4), fd=False))
            out.append(format_line(3e-3, "vcan1", 0x280 + 30, _le(1, 2) + _le(1, 2), fd=False))
    # tick 9: leg 1's TPDO1 cut to 4 bytes, leg 2's TPDO2 to 3 bytes
    cut = {"(0000000000.009000) vcan1 18B": 8, "(0000000000.009000) vcan1 28C": 6}
    lines = []
    for ln in build(extra=noise):
        head, _, data = ln.partition("#")
        lines.append(f"{head}#{data[:cut[head]]}" if head in cut else ln)
    d = read_log(lines, platform=MIXED)
    fb = d.stats.canopen_feedback
    assert fb["unknown_node"] == 2 and fb["short"] == 2 and fb["unplaced"] == 1, fb
    assert any("TPDOs of node 30" in w for w in d.stats.warnings)
    assert sum("bytes, its mapping" in w for w in d.stats.warnings) == 2
    k = list(d.ticks).index(9)
    assert np.isnan(d.length[k, 0]) and abs(d.force[k, 0] - expected_force(9, 1)) < TOL_N  # TPDO2 still used
    assert np.isnan(d.force[k, 1]) and abs(d.length[k, 1] - expected_length(9, 2)) < TOL_M
    check_values(d, legs=range(3, 7))


def test_builtin_layout_and_402_by_device_type():
    """A native config: the firmware's built-in layout (nodes 1-6, 1 um,
    count 0 at the park pose); node 4's 0x1000 answer says CiA 402, so its
    leg measures no force."""
    park = model.inverse_kinematics(NATIVE, NATIVE.park).lengths
    nodes = {leg: ("axis_a" if leg <= 3 else "axis_b", leg) for leg in range(1, 7)}

    def sdo(tick, out):
        if tick == 0:
            out.insert(0, format_line(0.0, "vcan2", 0x584, bytes([0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00]),
                                      fd=False))
    d = read_log(build(nodes=nodes, extra=sdo), platform=NATIVE)
    assert d.stats.canopen_feedback["layout"] == "built-in"
    for k, tick in enumerate(d.ticks.tolist()):
        if tick % DIVIDER:
            assert np.isnan(d.length[k]).all()
            continue
        for leg in range(1, 7):
            assert abs(d.length[k, leg - 1] - (park[leg - 1] + count(tick, leg) * 1e-6)) < TOL_M
            if leg == 4:
                assert np.isnan(d.force[k, 3])
            else:
                assert abs(d.force[k, leg - 1] - expected_force(tick, leg)) < TOL_N
    drives = lo.builtin_canopen(park)
    assert [(lo.controller_bus(drives, x), x.node_id, x.leg) for x in drives.canopen] == \
        [("axis_a", 1, 1), ("axis_a", 2, 2), ("axis_a", 3, 3), ("axis_b", 4, 4), ("axis_b", 5, 5), ("axis_b", 6, 6)]


def test_signals_csv_summary_and_reference(tmp_path):
    lines = build()
    d = read_log(lines, platform=MIXED)
    ref = read_log_reference(lines, platform=MIXED)
    for name in ("length", "pressure_a", "pressure_b", "drive_state", "drive_faults"):
        np.testing.assert_array_equal(getattr(d, name), getattr(ref, name))
    assert d.stats.as_dict() == ref.stats.as_dict()
    write_signals_csv(d, tmp_path / "signals.csv")
    rows = {int(r["tick"]): r for r in csv.DictReader(open(tmp_path / "signals.csv", newline=""))}
    assert rows[4]["length1"] == rows[4]["force1"] == rows[4]["drive_state1"] == rows[4]["drive_faults1"] == ""
    assert abs(float(rows[3]["length2"]) - expected_length(3, 2)) < 1e-7
    assert abs(float(rows[3]["force3"]) - expected_force(3, 3)) <= 0.05
    assert rows[3]["force4"] == "" and rows[3]["drive_state4"] == "ACTIVE"
    assert rows[12]["drive_state1"] == "FAULT" and rows[12]["drive_faults1"] == str(cl.FAULT_BIT)
    s = summarize(d)
    seg = s["segments"][0]
    assert seg["peak_force_measured_N"][3:] == [None] * 3
    assert abs(seg["peak_force_measured_N"][2] - max(expected_force(t, 3) for t in TICKS if t % DIVIDER == 0)) < TOL_N
    assert s["drive_faults_seen"] == {"leg1": ["internal"]}
    text = format_summary(s)
    assert "CANopen feedback (config layout): 90 TPDOs into the leg columns, 20 SYNCs placed on ticks" in text
    assert "measured - N" not in text
