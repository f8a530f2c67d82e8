# SPDX-License-Identifier: Apache-2.0
"""Faults over vcan (issue 17, docs/explanation/faults.md): a drive's latched fault
cleared by the controller's RESET over CAN (the setpoints' FaultReset
edge), a reset refused while the cause stays (reported in CTRL_STATUS with
the drive's fault bits), and one row of the fault campaign run over vcan
giving the same CAN log, byte for byte, as the campaign's in-memory bus
(``hs_sim --inproc``), and the closed loop through the SYNC tick's wrap.

Run inside ``stewart vcan`` (scripts/test.sh does).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import cantools
import pytest

from stewart import closedloop as cl
from stewart import faults as F

REPO_ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

RESET = ("delay 0.2\n"
         "cmd ENGAGE\n"
         "wait ready 30\n"
         "delay 0.1\n"
         "inject drive 3 fault 0x10\n"      # a one-shot valve fault: no cause left
         "wait fault 1\n"
         "delay 0.1\n"
         "mark reset 1\n"
         "cmd RESET\n"
         "wait ready 30\n"
         "mark ready again\n"
         "inject drive 5 fault 0x10 hold\n"  # the cause stays
         "wait fault 1\n"
         "delay 0.1\n"
         "mark reset 2\n"
         "cmd RESET\n"
         "delay 0.2\n"
         "mark cause gone\n"
         "inject drive 5 ok\n"
         "cmd RESET\n"
         "wait ready 30\n"
         "cmd PARK\n"
         "wait idle 30\n"
         "end\n")

ROW = ("drive-freeze", "RUNNING/p2p")
WRAP = ("delay 0.2\ncmd ENGAGE\nwait ready 30\n"
        "cmd RUN_TRIG axis=x amplitude=0.09 frequency=0.5 fade=0.5\ndelay 3\ncmd PARK\nwait idle 30\nend\n")
TICK0 = 2**32 - 6000  # the SYNC tick wraps while the surge runs


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("faults_bus")
    fault = {f.name: f for f in F.FAULTS}[ROW[0]]
    specs = [cl.RunSpec("reset", RESET), cl.RunSpec("row", F.scenario(fault, ROW[1]), seed=1),
             cl.RunSpec("wrap", WRAP, plant_args=("--tick0", str(TICK0)))]
    return {r.spec.name: r for r in cl.run(specs, out, progress=False, timeout=600)}, out


def _status(log_path, db):
    """(time s, State, Faults, ResetRefusedLegs, ResetRefusedCause) of each CTRL_STATUS; FaultReset edges."""
    rows, edges = [], []
    for line in open(log_path):
        ts, bus, frame = line.split()
        cid, data = frame.split("##")
        fid = int(cid, 16)
        t = float(ts.strip("()"))
        if bus == "vcan0" and fid == 0x100:
            m = db.decode_message(fid, bytes.fromhex(data[1:]), decode_choices=False)
            rows.append((t, m["State"], m["Faults"], m["ResetRefusedLegs"], m["ResetRefusedCause"]))
        elif bus == "vcan1" and fid == 0x20:
            m = db.decode_message(fid, bytes.fromhex(data[1:]), decode_choices=False)
            if m["FaultReset"]:
                edges.append(t)
    return rows, edges


def test_reset_clears_drive_faults_over_can(runs):
    r = runs[0]["reset"]
    assert r.plant_rc == 0, r.plant_out[-2000:]
    marks = cl.marks(r.plant_out)
    db = cantools.database.load_file(REPO_ROOT / "protocol" / "stewart.dbc")
    status, edges = _status(r.log, db)
    t1, t2, t3 = marks["reset 1"] / 1000, marks["reset 2"] / 1000, marks["cause gone"] / 1000
    # each RESET sends one FaultReset edge (one setpoints frame per axis bus)
    assert [round(e, 3) for e in edges] == [round(t1, 3), round(t2, 3), round(t3, 3)]
    # 1: cleared; the controller re-engages within the drive reset wait (20 ticks)
    after1 = [s for s in status if t1 <= s[0] <= t1 + 0.020]
    assert any(s[1] in (1, 2) and s[2] == 0 for s in after1), after1[-3:]
    # 2: refused after 20 ticks, leg 5 and its valve bit reported, still FAULT
    refused = [s for s in status if t2 < s[0] < t3 and s[3] != 0]
    assert refused and refused[0][0] - t2 == pytest.approx(0.020, abs=0.0015)
    assert all(s[1] == 5 and s[3] == 1 << 4 and s[4] == 0x10 for s in refused)
    # 3: the cause gone, the next RESET re-engages; the run ends parked
    assert "ready again" in marks and r.plant_out.count("hs_sim controller: last state idle") == 1


def assert_same_log(vcan_bytes: bytes, mem_bytes: bytes) -> None:
    """The two logs byte for byte; a difference is reported by its first
    line (pytest's own diff of two 10 MB byte strings takes hours)."""
    if vcan_bytes != mem_bytes:
        a, b = vcan_bytes.split(b"\n"), mem_bytes.split(b"\n")
        k = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
        pytest.fail(f"the logs differ from line {k + 1}: over vcan {a[k:k + 1]!r}, in memory {b[k:k + 1]!r} "
                    f"({len(vcan_bytes)} and {len(mem_bytes)} bytes)")


def test_campaign_row_same_log_over_vcan_and_in_memory(runs):
    res, out = runs
    r = res["row"]
    assert r.plant_rc == 0, r.plant_out[-2000:]
    mem = out / "row.inproc.log"
    p = subprocess.run([str(cl.Binaries.find().plant), "--inproc", "--scenario", str(out / "row.scenario"),
                        "--seed", "1", "--log", str(mem)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    vcan_bytes = r.log.read_bytes()
    mem_bytes = mem.read_bytes()
    print(f"{ROW[0]} in {ROW[1]}: vcan log {len(vcan_bytes)} B, in-memory log {len(mem_bytes)} B, "
          f"vcan {r.figures.get('speed', 0):.2f}x real time")
    assert len(vcan_bytes) > 1_000_000
    assert_same_log(vcan_bytes, mem_bytes)
    # and the report over vcan says the same as in memory: detected, held
    assert "detected yes" in r.plant_out and "detected yes" in p.stdout


def test_through_the_tick_wrap_over_vcan(runs):
    """sp_controller over vcan through the SYNC tick's 2^32 (and TickEcho's
    2^16) wrap: no fault, parked, and the same log as in memory."""
    res, out = runs
    r = res["wrap"]
    assert r.plant_rc == 0, r.plant_out[-2000:]
    assert "hs_sim controller: last state idle, faults 0x0000" in r.plant_out
    assert "lost 0, stale 0" in r.plant_out and "wrong-sequence 0" in r.plant_out
    assert "state idle, faults 0x0000" in r.controller_out
    mem = out / "wrap.inproc.log"
    p = subprocess.run([str(cl.Binaries.find().plant), "--inproc", "--scenario", str(out / "wrap.scenario"),
                        "--tick0", str(TICK0), "--log", str(mem)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert_same_log(r.log.read_bytes(), mem.read_bytes())
    assert "vcan1 010##1FFFFFFFF" in mem.read_text()
