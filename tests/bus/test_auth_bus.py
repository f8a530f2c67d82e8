# SPDX-License-Identifier: Apache-2.0
"""Command authentication on the bus (docs/explanation/security.md): a third node on
the ops bus cannot engage or move the platform, while any node can stop it.

sp_controller and hs_sim in lockstep over vcan (inside ``stewart vcan``),
both with the test's throw-away machine key (conftest.py), the session drawn
by the controller (getrandom). The genuine operator is `stewart op` with the
same key. The stranger is a python-can socket on vcan0: it hears every
frame on the bus (it records the operator's), and sends

* forgeries: each authenticated command (ENGAGE, RUN_TRIG, MOVE_TO with its
  OP_TARGET_POSE, STREAM with streamed OP_TARGET_POSE, FORCE and GUIDE with
  an OP_FORCE, RESET) and OP_FORCE_PARAMS with no code, and with a code
  under another key (the right session and the next counter: only the key
  is wrong);
* replays of the genuine operator's recorded frames (its ENGAGE, its
  MOVE_TO target and command, its streamed targets, an OP_FORCE, an
  OP_FORCE_PARAMS);
* STOP, PARK and ESTOP with no code and any alive counter.

Every forged and replayed frame is rejected and counted (CTRL_AUTH's
BadTag and Replayed, the controller's bad-tag and replayed counts rise by
exactly the number sent, its LastCounter does not move, the state and the
pose do not change); the stranger's STOP and ESTOP are carried out. The
figures (tried, accepted, counted) are printed for the README.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from stewart import auth
from stewart import closedloop as cl
from stewart import protocol as pr

import busrig

REPO_ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

ID = {"OP_COMMAND": 0x040, "OP_TARGET_POSE": 0x050, "OP_FORCE": 0x048, "OP_FORCE_PARAMS": 0x049}
POSE_TOL = 0.5e-3  # m, rad: the stranger's frames leave the pose where it was


op = busrig.op


class Stranger(busrig.Listener):
    """A third node on the ops bus: hears everything, sends what it likes.
    The operator's frames it records and CTRL_AUTH come on one socket, none
    lost; CTRL_STATUS (1 kHz) on another, only its latest needed."""

    def __init__(self):
        self.proto = pr.Protocol()
        self.recorded: list[tuple[int, bytes]] = []  # the genuine operator's authenticated frames
        self.sent = 0
        self._latest: dict[int, tuple[float, bytes]] = {}
        super().__init__(every=[*ID.values(), 0x103], stream=[0x100])

    def on_frame(self, fid: int, data: bytes, timestamp: float) -> None:
        if fid in ID.values():
            self.recorded.append((fid, data))
        self._latest[fid] = (timestamp, data)  # the kernel's receive time

    def fresh(self, name: str, timeout: float = 10.0) -> dict:
        """The first CTRL_AUTH or CTRL_STATUS heard after this call, decoded."""
        fid = self.proto.message(name).frame_id
        t0 = time.time()
        end = time.monotonic() + timeout
        with self.cond:
            while fid not in self._latest or self._latest[fid][0] <= t0:
                left = end - time.monotonic()
                assert left > 0, f"no {name} on vcan0 within {timeout} s"
                self.cond.wait(left)
            data = self._latest[fid][1]
        return self.proto.decode(fid, data, bus="ops", check_counter=False)[1]

    def settle(self) -> tuple[dict, dict]:
        """CTRL_AUTH and CTRL_STATUS after everything sent so far was taken:
        two CTRL_AUTH periods later."""
        self.fresh("CTRL_AUTH")
        self.fresh("CTRL_AUTH")
        return self.fresh("CTRL_AUTH"), self.fresh("CTRL_STATUS")

    def send(self, fid: int, data: bytes) -> None:
        super().send(fid, data)
        self.sent += 1
        time.sleep(0.002)  # a frame or two per controller tick, as an operator would

    def frame(self, name: str, signals: dict, counter: int) -> bytes:
        return self.proto.encode(name, signals, counter & 0x0F)


def _pose(st: dict) -> list[float]:
    return pr.signals_to_pose(st)


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    out = tmp_path_factory.mktemp("auth")
    with busrig.controller_and_plant(out, controller=["--operator-timeout", "0"]), Stranger() as s:
        yield out, s


def test_a_third_node_cannot_engage_or_move_but_can_stop(rig):
    out, s = rig
    key = auth.read_key(auth.key_file())
    other = bytes(b ^ 0x5A for b in key)  # a stranger's guess: another key
    a0, st0 = s.settle()
    assert a0["KeySet"] == 1 and st0["State"] == pr.value_names("CTRL_STATUS", "State").index("IDLE")
    session = int(a0["Session"])
    states = pr.value_names("CTRL_STATUS", "State")
    tried: dict[str, int] = {}
    ctr = [0]

    def forge(label: str, name: str, signals: dict) -> None:
        """One frame with no code and one under another key (right session, next counter)."""
        fid = ID[name]
        plain = s.frame(name, signals, ctr[0])
        ctr[0] += 1
        s.send(fid, plain)
        a = s.fresh("CTRL_AUTH")
        wrong = auth.Signer(s.proto.db, other)
        wrong.session, wrong.counter = session, int(a["LastCounter"])
        s.send(fid, wrong.sign(fid, s.frame(name, signals, ctr[0])))
        ctr[0] += 1
        tried[label] = tried.get(label, 0) + 2

    def cmd(command: str, **kw) -> dict:
        return pr.command_signals(command, **kw)

    pose_sig = pr.pose_to_signals([0.03, -0.02, 2.6, 0.0, 0.0, 0.05])
    force_sig = pr.force_signals(4, [0, 0, -200.0, 0, 0, 0])
    params_sig = pr.force_params_signals(4, "GUIDE", 20.0, 1e4, 0.0)  # a light, fast hand guiding

    # -- IDLE: the stranger's ENGAGE and RESET are rejected; nothing moves
    forge("ENGAGE", "OP_COMMAND", cmd("ENGAGE"))
    forge("RESET", "OP_COMMAND", cmd("RESET"))
    a1, st1 = s.settle()
    assert states[int(st1["State"])] == "IDLE"
    assert a1["LastCounter"] == a0["LastCounter"]
    assert int(a1["BadTag"]) - int(a0["BadTag"]) == tried["ENGAGE"] + tried["RESET"]

    # -- the genuine operator engages (its frames recorded by the stranger)
    s.recorded.clear()
    op("engage", check=0)
    s.settle()
    engage = [(f, d) for f, d in s.recorded if f == ID["OP_COMMAND"] and d[0] == pr.value_names("OP_COMMAND", "Command").index("ENGAGE")]
    assert engage, "the operator's ENGAGE was not heard"
    # and moves (a MOVE_TO: its target and command), then back home
    s.recorded.clear()
    op("move", "0.02", "0", "0", "0", "0", "0", "--relative", check=0)
    s.settle()
    move = [(f, d) for f, d in s.recorded if f in (ID["OP_TARGET_POSE"], ID["OP_COMMAND"])]
    op("move", "0", "0", "0", "0", "0", "0", "--relative", check=0)
    # and streams a short CSV (its OP_TARGET_POSE frames recorded)
    csv = out / "sway.csv"
    csv.write_text("t,x,y,z,roll,pitch,yaw\n" + "".join(f"{k * 0.01:.2f},{0.005 * k / 50:.6f},0,0,0,0,0\n"
                                                         for k in range(51)))
    s.recorded.clear()
    op("stream", "--csv", csv, check=0)
    s.settle()
    stream = [(f, d) for f, d in s.recorded if f in (ID["OP_TARGET_POSE"], ID["OP_COMMAND"])]
    assert sum(1 for f, _ in stream if f == ID["OP_TARGET_POSE"]) >= 40
    a2, st2 = s.settle()
    assert states[int(st2["State"])] == "READY"
    home = _pose(st2)
    # a genuine OP_FORCE (a holder of the key; no FORCE command: nothing moves), recorded
    signer = auth.Signer(s.proto.db, key)
    signer.session, signer.counter = session, int(a2["LastCounter"])
    genuine_force = signer.sign(ID["OP_FORCE"], s.frame("OP_FORCE", force_sig, 0))
    s.send(ID["OP_FORCE"], genuine_force)
    # and a genuine OP_FORCE_PARAMS (taken in position control: the same
    # parameters again, nothing moves), recorded
    genuine_params = signer.sign(ID["OP_FORCE_PARAMS"],
                                 s.frame("OP_FORCE_PARAMS", pr.force_params_signals(4, "GUIDE", 20.0, 2500.0, 0.0),
                                         0))
    s.send(ID["OP_FORCE_PARAMS"], genuine_params)
    a3, _ = s.settle()
    assert a3["LastCounter"] == signer.counter  # both taken
    bad0, rep0 = int(a3["BadTag"]), int(a3["Replayed"])
    last0 = int(a3["LastCounter"])

    # -- READY: forged motion commands and targets
    forge("RUN_TRIG", "OP_COMMAND", cmd("RUN_TRIG", axis="x", amplitude=0.05, frequency=0.5))
    forge("MOVE_TO", "OP_TARGET_POSE", pose_sig)
    forge("MOVE_TO", "OP_COMMAND", cmd("MOVE_TO", frequency=0.0))
    forge("STREAM", "OP_COMMAND", cmd("STREAM"))
    for _ in range(10):
        forge("STREAM", "OP_TARGET_POSE", pose_sig)
    forge("FORCE", "OP_FORCE", force_sig)
    forge("FORCE", "OP_COMMAND", cmd("FORCE"))
    forge("FORCE_PARAMS", "OP_FORCE_PARAMS", params_sig)
    forge("GUIDE", "OP_COMMAND", cmd("GUIDE"))
    forge("SET_FEEDFORWARD", "OP_COMMAND", cmd("SET_FEEDFORWARD", option=0))
    # -- replays of the genuine operator's frames
    replayed: dict[str, int] = {}

    def replay(label, frames):
        for f, d in frames:
            s.send(f, d)
        replayed[label] = replayed.get(label, 0) + len(frames)

    needs = auth.Signer(s.proto.db, key).needs  # NONE and the stops carry no code: nothing to replay
    engage, move, stream = ([(f, d) for f, d in x if needs(f, d)] for x in (engage, move, stream))
    replay("ENGAGE", engage)
    replay("MOVE_TO", move)
    replay("STREAM", stream)
    replay("FORCE", [(ID["OP_FORCE"], genuine_force)])
    replay("FORCE_PARAMS", [(ID["OP_FORCE_PARAMS"], genuine_params)])
    a4, st4 = s.settle()
    n_forged = sum(tried.values())
    n_replayed = sum(replayed.values())
    n_forged_ready = n_forged - tried["ENGAGE"] - tried["RESET"]
    # nothing was accepted: the state, the pose and the last counter stand
    assert states[int(st4["State"])] == "READY" and int(st4["ForceMode"]) == 0
    assert max(abs(a - b) for a, b in zip(_pose(st4), home)) < POSE_TOL
    assert int(a4["LastCounter"]) == last0
    # every frame counted: the forged as bad tags, the replays as replays
    # (the code of a frame of this session up to 65,535 counters old checks
    # with its own counter: sp_auth_check calls it a replay)
    assert int(a4["BadTag"]) - bad0 == n_forged_ready
    assert int(a4["Replayed"]) - rep0 == n_replayed

    # -- any node may stop the platform: the operator runs, the stranger stops it
    run = subprocess.Popen(busrig.STEWART + ["op", "run", "x", "0.02", "0.5", "--fade", "0.3"], cwd=REPO_ROOT,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = run.stdout.readline()
    assert first.startswith("RUN_TRIG: RUNNING"), (first, run.communicate())
    s.send(ID["OP_COMMAND"], s.frame("OP_COMMAND", cmd("STOP"), 7))
    outp, err = run.communicate(timeout=60)
    print(first, outp, err)
    assert run.returncode == 0 and "the motion ended: state READY" in outp
    s.send(ID["OP_COMMAND"], s.frame("OP_COMMAND", cmd("ESTOP"), 3))
    a5, st5 = s.settle()
    assert states[int(st5["State"])] == "ESTOP"
    assert int(a5["BadTag"]) == int(a4["BadTag"]) and int(a5["Replayed"]) == int(a4["Replayed"])
    # PARK from the stranger after a genuine reset
    op("reset", check=0)
    s.send(ID["OP_COMMAND"], s.frame("OP_COMMAND", cmd("PARK"), 11))
    deadline = time.monotonic() + 60
    while states[int(s.fresh("CTRL_STATUS")["State"])] != "IDLE":
        assert time.monotonic() < deadline, "the stranger's PARK did not park"

    total_tried = n_forged + n_replayed
    print(f"auth figures: tried {total_tried} (forged {n_forged}: "
          + ", ".join(f"{k} {v}" for k, v in tried.items())
          + f"; replayed {n_replayed}: " + ", ".join(f"{k} {v}" for k, v in replayed.items())
          + f"), accepted 0, counted bad-tag {int(a4['BadTag']) - bad0 + tried['ENGAGE'] + tried['RESET']}"
          + f" replayed {int(a4['Replayed']) - rep0}; stranger's STOP, ESTOP, PARK carried out")
    (out / "figures.txt").write_text(f"tried {total_tried} forged {n_forged} replayed {n_replayed}\n")
