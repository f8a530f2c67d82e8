# SPDX-License-Identifier: Apache-2.0
"""Through the wraps in closed loop (issue 17): the plant's SYNC tick (and
with it the 16-bit TickEcho) and the controller's own tick started 6000
ticks before 2^32 (``hs_sim --tick0``, test only), the controller in the
plant's process (``--inproc``): engage, the surge across the wrap, park.
No fault, no jump: the plant's trajectory is the same, byte for byte, as
the run started at 0, and so is every state, fault word, estimate and leg
setpoint the controller sent. The alive counters wrap every 16 frames in
every run. Needs the host-release build."""

from __future__ import annotations

import subprocess
from pathlib import Path

import cantools
import pytest

from stewart.closedloop import Binaries

REPO_ROOT = Path(__file__).resolve().parents[2]

SCENARIO = ("delay 0.2\ncmd ENGAGE\nwait ready 30\n"
            "cmd RUN_TRIG axis=x amplitude=0.09 frequency=0.5 fade=0.5\ndelay 3\n"
            "mark wrap window\ncmd PARK\nwait idle 30\nend\n")
TICK0 = 2**32 - 6000  # the SYNC tick wraps 6 s in: while the surge runs


def _built() -> bool:
    try:
        Binaries.find()
    except FileNotFoundError:
        return False
    return True


pytestmark = pytest.mark.skipif(not _built(), reason="needs build/host-release (scripts/build.sh host-release)")


def _run(tmp, tick0):
    scn = tmp / "wrap.scenario"
    scn.write_text(SCENARIO)
    log, truth = tmp / f"run{tick0}.log", tmp / f"run{tick0}.csv"
    p = subprocess.run([str(Binaries.find().plant), "--inproc", "--scenario", str(scn), "--tick0", str(tick0),
                        "--log", str(log), "--truth", str(truth)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout, log, truth


def _decoded(log, db):
    """Per CTRL_STATUS: (Tick, State, Faults, pose); per AXIS_SETPOINTS: (Tick, lengths); SYNC ticks."""
    status, setpoints, syncs = [], [], []
    for line in open(log):
        _, bus, frame = line.split()
        cid, data = frame.split("##")
        fid, payload = int(cid, 16), bytes.fromhex(data[1:])
        if fid == 0x100:
            m = db.decode_message(fid, payload, decode_choices=False)
            status.append((m["Tick"], m["State"], m["Faults"], m["X"], m["Z"], m["Yaw"]))
        elif fid == 0x020:
            m = db.decode_message(fid, payload, decode_choices=False)
            setpoints.append((m["Tick"], m["Mode"], m["Length_1"], m["Length_2"], m["Length_3"]))
        elif fid == 0x010 and bus == "vcan1":
            syncs.append(int.from_bytes(payload[:4], "little"))
    return status, setpoints, syncs


def test_closed_loop_through_the_tick_wraps(tmp_path):
    out0, log0, truth0 = _run(tmp_path, 0)
    out1, log1, truth1 = _run(tmp_path, TICK0)
    for out in (out0, out1):
        assert "hs_sim controller: last state idle, faults 0x0000" in out
        assert "lost 0, stale 0" in out and "bad-crc 0" in out and "wrong-sequence 0" in out
    # no jump: the plant moved exactly as in the run that never wrapped
    assert truth0.read_bytes() == truth1.read_bytes()
    db = cantools.database.load_file(REPO_ROOT / "protocol" / "stewart.dbc")
    s0, p0, y0 = _decoded(log0, db)
    s1, p1, y1 = _decoded(log1, db)
    assert len(s0) == len(s1) > 10000 and len(p0) == len(p1)
    # the ticks are the first run's plus TICK0 modulo 2^32, through 0xFFFFFFFF -> 0
    assert y1 == [(t + TICK0) % 2**32 for t in y0]
    assert 2**32 - 1 in y1 and 0 in y1
    assert all((b - a) % 2**32 == 1 for a, b in zip(y1, y1[1:]))  # one per cycle, no jump
    assert [(t + TICK0) % 2**32 for t, *_ in s0] == [t for t, *_ in s1]
    # everything else the controller said is the same
    assert [r[1:] for r in s0] == [r[1:] for r in s1]
    assert [r[1:] for r in p0] == [r[1:] for r in p1]
    states = [r[1] for r in s1]
    wrap_at = [t for t, *_ in s1].index(0)
    assert states[wrap_at] == 3  # RUNNING when the tick wrapped
    assert set(r[2] for r in s1) == {0}
