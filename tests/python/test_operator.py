# SPDX-License-Identifier: Apache-2.0
"""The operator node's interface-agnostic layer (stewart.operator) and
`stewart op`, on python-can's `virtual` interface against a small
stand-in controller in this process: it speaks the DBC (E2E counters and
CRCs checked like the firmware's node: a new sender's first frame may be
dropped), runs the controller's state machine in outline, and answers
every 1 ms with CTRL_STATUS, every 10 ms with CTRL_AUTH, and checks the
commands' authentication codes with the test's throw-away key (conftest.py)
as the firmware does (tests/unit/link/test_node.c holds the firmware to the same
codes through sp_proto_sign). The real controller is exercised over vcan in
tests/bus/test_operator_session.py."""

from __future__ import annotations

import dataclasses
import json
import math
import struct
import threading
import time

import can
import pytest

from stewart import auth, cli, e2e
from stewart import protocol as pr
from stewart import busopts as opbus
from stewart.operator import node as opnode
from stewart.operator import sources as src

STATES = pr.value_names("CTRL_STATUS", "State")
CMDS = pr.value_names("OP_COMMAND", "Command")
KEY = auth.read_key(auth.key_file())
SESSION = 0x5EED0017


class FakeController:
    """Outline of the firmware's state machine on a virtual bus."""

    def __init__(self, channel: str, counter_ref: int | None = 9):
        self.bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
        self.proto = pr.Protocol()
        self.state = "IDLE"
        self.faults = 0
        self.drives_starting = 0    # the CANopen master still starting the drives: ENGAGE refused
        self.refusals = 0           # CTRL_STATUS Refusals: refused commands modulo 8
        self.drop_rejected = False  # leave out the status of a refusal (a receive queue that overflowed)
        self.ff = 1
        self.tick = 0
        self.timer = 0
        self.rejected = 0
        self.heartbeats = []
        self.commands = []
        self.targets = 0
        self.last_target = None
        self.force_params = []      # the OP_FORCE_PARAMS taken (signals)
        self.auth_last = 0          # the last accepted authentication counter
        self.auth_rejected = 0
        self.auth_checker = auth.Signer(self.proto.db, KEY)
        self.identity_hash = pr.dbc_hash()  # CTRL_IDENTITY ProtocolHash: this DBC's unless a test changes it
        self.identify_pending = False
        self.identities = 0         # CTRL_IDENTITY frames sent
        # the counter reference a previous operator process left behind
        if counter_ref is not None:
            self.proto.decode(0x040, self.proto.encode("OP_COMMAND", pr.command_signals("NONE"), counter_ref),
                              bus="ops")
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _authentic(self, frame_id: int, data: bytes) -> bool:
        """The firmware's check in outline: the code of the first counter
        after the last accepted one with the frame's low 16 bits."""
        c = self.auth_checker
        if not c.needs(frame_id, data) or len(data) != self.proto.message(frame_id).length:
            return True
        cbyte, tbyte, tlen = c.layout[frame_id]
        low = int.from_bytes(data[cbyte:cbyte + 2], "little")
        full = self.auth_last + ((low - self.auth_last - 1) & 0xFFFF) + 1
        if data[tbyte:tbyte + tlen] != auth.tag_bytes(KEY, frame_id, SESSION, full, data[:tbyte], tlen):
            return False
        self.auth_last = full
        return True

    def close(self):
        self._stop.set()
        self.thread.join(2)
        self.bus.shutdown()

    def _command(self, name: str, option: int) -> bool:
        s = self.state
        if name == "NONE":
            return True
        if name == "ESTOP":
            self.state, self.faults = "ESTOP", self.faults | 0x40
            return True
        if name == "ENGAGE" and s == "IDLE" and not self.drives_starting:
            self.state, self.timer = "ENGAGING", 20
            return True
        if name in ("RUN_TRIG", "STREAM") and s == "READY":
            self.state = "RUNNING"
            return True
        if name == "STOP" and s == "RUNNING":
            self.timer = 10
            return True
        if name == "PARK" and s in ("READY", "RUNNING"):
            self.state, self.timer = "PARKING", 20
            return True
        if name == "RESET" and s in ("FAULT", "ESTOP"):
            self.state, self.faults, self.timer = "ENGAGING", 0, 20
            return True
        if name == "SET_FEEDFORWARD" and s in ("IDLE", "READY"):
            self.ff = option
            return True
        return False

    def _run(self):
        nxt = time.monotonic()
        queue = []      # the firmware's node queues commands, one executed per tick
        while not self._stop.is_set():
            while True:
                msg = self.bus.recv(timeout=0)
                if msg is None:
                    break
                if not self._authentic(msg.arbitration_id, bytes(msg.data)):
                    self.auth_rejected += 1
                    continue
                r = self.proto.receive(msg.arbitration_id, bytes(msg.data), bus="ops")
                if msg.arbitration_id == 0x040 and msg.data[0] == CMDS.index("IDENTIFY") and (
                        r.ok or r.error.kind in (e2e.REPEATED, e2e.WRONG_SEQUENCE)):
                    self.identify_pending = True  # the node's own: whatever its counter, never queued
                    continue
                if not r.ok:
                    continue
                if r.name == "OP_HEARTBEAT":
                    self.heartbeats.append(time.monotonic())
                elif r.name == "OP_TARGET_POSE":
                    self.targets += 1
                    self.last_target = pr.signals_to_pose(r.signals)
                elif r.name == "OP_COMMAND":
                    queue.append(r.signals)
                elif r.name == "OP_FORCE_PARAMS":
                    self.force_params.append(r.signals)
            self.tick += 1
            rejected = 0
            if queue:
                cmd = queue.pop(0)
                name = CMDS[int(cmd["Command"])]
                self.commands.append(name)
                rejected = 0 if self._command(name, int(cmd["Option"])) else 1
                self.refusals = (self.refusals + rejected) % 8
            if self.timer > 0:
                self.timer -= 1
                if self.timer == 0:
                    self.state = {"ENGAGING": "READY", "PARKING": "IDLE", "RUNNING": "READY"}.get(
                        self.state, self.state)
            sig = {"Tick": self.tick, "State": self.state, "Faults": self.faults, "FkIterations": 1,
                   "EstimateValid": 1, "CmdRejected": rejected, "Refusals": self.refusals, "DriveMode": 1 if self.state != "IDLE" else 0,
                   "FeedForward": self.ff, "DrivesStarting": self.drives_starting, "X": 0.0, "Y": 0.0, "Z": 2.55, "Roll": 0.0, "Pitch": 0.0, "Yaw": 0.0}
            if self.tick % 10 == 0:
                a = self.proto.encode("CTRL_AUTH", {"Session": SESSION, "LastCounter": self.auth_last,
                                                    "BadTag": self.auth_rejected, "KeySet": 1}, bus="ops")
                self.bus.send(can.Message(arbitration_id=0x103, data=a, is_fd=True, is_extended_id=False))
            if self.identify_pending and self.tick % 10 != 0:
                i = self.proto.encode("CTRL_IDENTITY", {"VersionMajor": 0, "VersionMinor": 3, "VersionPatch": 0,
                                                        "Port": "STM32G474", "ProtocolHash": self.identity_hash},
                                      bus="ops")
                self.bus.send(can.Message(arbitration_id=0x104, data=i, is_fd=True, is_extended_id=False))
                self.identify_pending = False
                self.identities += 1
            data = self.proto.encode("CTRL_STATUS", sig, bus="ops")
            if not (rejected and self.drop_rejected):
                self.bus.send(can.Message(arbitration_id=0x100, data=data, is_fd=True, is_extended_id=False))
            nxt += 0.001
            time.sleep(max(0.0, nxt - time.monotonic()))


_channels = iter(range(10_000))


@pytest.fixture()
def ctrl():
    ch = f"op-test-{next(_channels)}"
    c = FakeController(ch)
    c.channel = ch
    yield c
    c.close()


def _node(channel):
    return opnode.OperatorNode(can.Bus(interface="virtual", channel=channel), key=KEY).start()


# -- the node -----------------------------------------------------------------------

def test_command_answers_and_refusal(ctrl):
    node = _node(ctrl.channel)
    try:
        # the stand-in remembers another sender's counter: the NONE before
        # each command resynchronises it, so ENGAGE is taken
        ans = node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        assert ans.status.state == "READY"
        assert 1 <= ans.ticks <= 3          # ENGAGING on one of the first ticks after the send
        assert "ENGAGE" in ctrl.commands
        with pytest.raises(opnode.Refused, match="accepted in IDLE only; the controller was READY"):
            node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        ans = node.command("SET_FEEDFORWARD", lambda s: not s.feedforward, timeout=5, option=0)
        assert ans.ticks >= 5 and ctrl.ff == 0   # no state change: believed after the settle window
        ans = node.command("ESTOP", lambda s: s.state == "ESTOP", timeout=5, sync=False)
        assert ans.status.state == "ESTOP" and ans.status.faults == ["estop"]
        assert ans.ticks <= 3
    finally:
        node.close()


def test_engage_refused_while_the_drives_start(ctrl):
    """ENGAGE while the CANopen master still starts the drives: refused
    (CmdRejected) with the reason DrivesStarting names; taken once they run."""
    ctrl.drives_starting = 1
    node = _node(ctrl.channel)
    try:
        with pytest.raises(opnode.Refused, match="still starting the drives"):
            node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        assert ctrl.state == "IDLE"
        ctrl.drives_starting = 0
        assert node.command("ENGAGE", lambda s: s.state == "READY", timeout=5).status.state == "READY"
    finally:
        node.close()


def test_engage_refusal_told_when_its_status_is_lost(ctrl):
    """The one status that says CmdRejected (it lasts a tick) lost, as a
    receive queue that overflowed on a loaded machine drops it: the node
    still reports the refusal, with its reason, from CTRL_STATUS Refusals
    (the count moved past the one before the send); taken, ENGAGE is
    answered as before."""
    ctrl.drives_starting = 1
    ctrl.drop_rejected = True
    node = _node(ctrl.channel)
    try:
        t0 = time.monotonic()
        with pytest.raises(opnode.Refused, match=r"still starting the drives.*Refusals went from 0 to 1"):
            node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        assert time.monotonic() - t0 < 2.0  # well before the timeout
        assert ctrl.state == "IDLE" and ctrl.commands[-1] == "ENGAGE"
        ctrl.drives_starting = 0
        assert node.command("ENGAGE", lambda s: s.state == "READY", timeout=5).status.state == "READY"
    finally:
        node.close()


def test_second_engage_refused_when_its_status_is_lost(ctrl):
    """A second ENGAGE in READY: its answer (READY) already holds, so only
    the refusal tells it was not taken; with the status that says
    CmdRejected lost, the count of refusals does (CI once took it for done)."""
    ctrl.drop_rejected = True
    node = _node(ctrl.channel)
    try:
        node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        for n in range(1, 10):  # the count wraps at 8: still told
            with pytest.raises(opnode.Refused, match=rf"accepted in IDLE only; the controller was READY.*"
                                                     rf"Refusals went from {(n - 1) % 8} to {n % 8}"):
                node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        assert ctrl.commands.count("ENGAGE") == 10
    finally:
        node.close()


def test_reset_answered_after_a_stale_state(ctrl):
    """The status before the send may be older than the state the command
    meets (a RESET sent while the node still showed READY, the controller
    already in ESTOP): the answer comes from what the controller did, not
    from the state before."""
    node = _node(ctrl.channel)
    try:
        node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        node.command("ESTOP", lambda s: s.state == "ESTOP", timeout=5, sync=False)
        before = node.wait_status()
        stale = dataclasses.replace(before, state="READY", faults=[])
        node.fresh_auth()
        mark = node._mark()
        sent = node.send_command("RESET")
        ans = node.wait_for("RESET", lambda s: s.state == "READY", 5, mark, stale, sent)
        assert ans.status.state == "READY" and ctrl.commands[-1] == "RESET"
    finally:
        node.close()


def test_estop_gets_through_a_stale_counter():
    # every possible counter a previous process left: ESTOP is sent twice,
    # one of the two is always taken
    for ref in range(16):
        c = FakeController(f"op-estop-{ref}", counter_ref=ref)
        node = _node(f"op-estop-{ref}")
        try:
            ans = node.command("ESTOP", lambda s: s.state == "ESTOP", timeout=5, sync=False)
            assert ans.status.state == "ESTOP", ref
        finally:
            node.close()
            c.close()


def test_heartbeat_every_20_ms(ctrl):
    node = _node(ctrl.channel)
    try:
        time.sleep(0.5)
    finally:
        node.close()
    beats = ctrl.heartbeats
    assert len(beats) >= 15                       # 25 expected in 0.5 s; the first may be dropped by E2E
    gaps = [b - a for a, b in zip(beats, beats[1:])]
    assert sorted(gaps)[len(gaps) // 2] == pytest.approx(0.020, abs=0.005)


def test_no_controller_is_no_answer():
    node = _node("op-nobody")
    try:
        with pytest.raises(opnode.NoAnswer, match="no CTRL_STATUS"):
            node.wait_status(timeout=0.2)
    finally:
        node.close()


def test_node_counts_bad_frames(ctrl):
    node = _node(ctrl.channel)
    try:
        node.wait_status(timeout=2)
        bad = bytearray(node.proto.encode("CTRL_STATUS", {"State": 0}, 3))
        bad[-1] ^= 1
        node.handle(can.Message(arbitration_id=0x100, data=bytes(bad), is_fd=True))
        node.handle(can.Message(arbitration_id=0x100, data=b"\0" * 8, is_fd=True))
        node.handle(can.Message(is_error_frame=True))
        assert node.counters.bad[pr.BAD_CRC] == 1 and node.counters.bad[pr.BAD_LENGTH] == 1
        assert node.counters.error_frames == 1
    finally:
        node.close()


def test_node_reads_the_monitor_only_when_asked(ctrl):
    """CTRL_MONITOR and CTRL_WRENCH (1.5 kHz together) are read only by a
    node that shows them (`stewart op watch`): the others leave them to the
    kernel's filter and keep up with CTRL_STATUS."""
    proto = pr.Protocol()
    frames = [(0x101, proto.encode("CTRL_MONITOR", {"Tick": 5}, 1)),
              (0x102, proto.encode("CTRL_WRENCH", {"Tick": 6, "Valid": 1, "Fx": 12.5}, 1))]
    for monitor in (False, True):
        node = opnode.OperatorNode(can.Bus(interface="virtual", channel=ctrl.channel), monitor=monitor)
        try:
            for fid, data in frames:
                node.handle(can.Message(arbitration_id=fid, data=data, is_fd=True))
            if monitor:
                assert node.monitor["tick"] == 5 and node.wrench["wrench"][0] == 12.5
            else:
                assert node.monitor is None and node.wrench is None and not node.counters.frames
        finally:
            node.close()


def test_refusal_reasons():
    st = opnode.Status(1, "READY", ["operator_silent"], 0x100, True, "ACTIVE", True, True, [0] * 6)
    assert "reset" in opnode.refusal_reason("RUN_TRIG", st, st)
    st = opnode.Status(1, "READY", [], 0, True, "ACTIVE", True, True, [0] * 6)
    assert "outside the workspace" in opnode.refusal_reason("MOVE_TO", st, st)
    assert "accepted in FAULT/ESTOP only" in opnode.refusal_reason("RESET", st, st)
    assert "measure no cylinder force" not in opnode.refusal_reason("FORCE", st, st)
    # drives without force measurement (CTRL_STATUS ForceUnmeasured): named
    # in the status line and in the reason a FORCE or GUIDE was refused
    st = opnode.Status(1, "READY", [], 0, True, "ACTIVE", True, True, [0] * 6, force_unmeasured=[2, 5])
    assert "no cylinder force from leg(s) 2,5" in st.line()
    for cmd in ("FORCE", "GUIDE"):
        assert "leg(s) 2,5 measure no cylinder force" in opnode.refusal_reason(cmd, st, st)
    assert opnode._legs(0x12) == [2, 5] and opnode._legs(0) == []


def test_node_signs_and_reports_authentication(ctrl, tmp_path, capsys, monkeypatch):
    """Commands that start motion are signed (the stand-in checks the codes:
    none rejected); without a key they are not sent (a clear error) while
    STOP, PARK and ESTOP still go; under another key the controller's
    rejection is reported with its reason from CTRL_AUTH."""
    node = _node(ctrl.channel)
    try:
        node.command("ENGAGE", lambda s: s.state == "READY", timeout=5)
        assert ctrl.auth_rejected == 0 and ctrl.auth_last > auth.COUNTER_MARGIN
    finally:
        node.close()
    bare = opnode.OperatorNode(can.Bus(interface="virtual", channel=ctrl.channel)).start()
    try:
        with pytest.raises(opnode.OpError, match="need the machine key"):
            bare.send_command("RUN_TRIG", axis="x", amplitude=0.01, frequency=0.5)
        bare.command("ESTOP", lambda s: s.state == "ESTOP", timeout=5)
    finally:
        bare.close()
    other = tmp_path / "other.key"
    auth.new_key_file(other)
    rc, out, err = _op(capsys, ctrl.channel, "--key", str(other), "reset")
    assert rc == 1 and "its authentication code did not check" in err, (out, err)
    assert ctrl.auth_rejected >= 1 and ctrl.state == "ESTOP"
    monkeypatch.delenv(auth.KEY_ENV)
    rc, out, err = _op(capsys, ctrl.channel, "reset")
    assert rc == 2 and "need the machine key (--key FILE or STEWART_KEY)" in err
    rc, out, err = _op(capsys, ctrl.channel, "--key", str(tmp_path / "missing.key"), "reset")
    assert rc == 2 and "cannot read the key file" in err


def test_force_params_are_signed(ctrl, tmp_path, capsys):
    """OP_FORCE_PARAMS is signed like OP_FORCE: the stand-in checks its code
    and takes it; without a key it is not sent; under another key it is
    rejected and `stewart op guide --mass ...` says why; a value out of
    range never reaches the bus."""
    node = _node(ctrl.channel)
    try:
        node.wait_status(timeout=2.0)
        for _ in range(2):  # a new sender's first frame may meet the E2E check
            node.send_force_params(4, "GUIDE", 40.0, 2e5, 10.0)
            node.wait_status(timeout=2.0, after=node.status.seq)
        end = time.monotonic() + 2.0
        while not ctrl.force_params and time.monotonic() < end:
            time.sleep(0.01)
    finally:
        node.close()
    assert ctrl.auth_rejected == 0 and ctrl.force_params, ctrl.auth_rejected
    p = ctrl.force_params[-1]
    assert int(p["Mask"]) == 4 and int(p["Mode"]) == 2  # GUIDE
    assert p["Mass"] == pytest.approx(40.0) and p["Damping"] == pytest.approx(2e5)
    assert p["Stiffness"] == pytest.approx(10.0)
    taken = len(ctrl.force_params)
    bare = opnode.OperatorNode(can.Bus(interface="virtual", channel=ctrl.channel)).start()
    try:
        with pytest.raises(opnode.OpError, match="OP_FORCE_PARAMS: .*need the machine key"):
            bare.send_force_params(4, "GUIDE", 40.0, 2e5, 10.0)
    finally:
        bare.close()
    other = tmp_path / "other.key"
    auth.new_key_file(other)
    rc, out, err = _op(capsys, ctrl.channel, "--key", str(other), "guide", "z",
                       "--mass", "40", "--damping", "3e5", "--stiffness", "0")
    assert rc == 1 and "admittance parameters rejected: its authentication code did not check" in err, (out, err)
    assert ctrl.auth_rejected >= 2 and len(ctrl.force_params) == taken
    rc, out, err = _op(capsys, ctrl.channel, "guide", "z", "--mass", "40", "--damping", "50", "--stiffness", "0")
    assert rc == 2 and "damping 50 N s/m is out of range" in err, (out, err)
    assert len(ctrl.force_params) == taken


# -- the command line -----------------------------------------------------------------

def _op(capsys, channel, *args):
    rc = cli.main(["op", "-i", "virtual", "-c", channel, *args])
    out = capsys.readouterr()
    assert "Traceback" not in out.err
    return rc, out.out, out.err


def test_cli_session_and_exit_codes(ctrl, capsys):
    ch = ctrl.channel
    rc, out, _ = _op(capsys, ch, "status")
    assert rc == 0 and "state IDLE" in out
    rc, out, _ = _op(capsys, ch, "engage")
    assert rc == 0 and "READY" in out
    rc, _, err = _op(capsys, ch, "engage")
    assert rc == 1 and "refused" in err
    rc, out, _ = _op(capsys, ch, "stop")
    assert rc == 0 and "nothing to stop" in out
    rc, out, _ = _op(capsys, ch, "run", "x", "0.05", "0.5", "--duration", "0.2")
    assert rc == 0 and "stopped (duration)" in out
    rc, out, _ = _op(capsys, ch, "feedforward", "off")
    assert rc == 0 and ctrl.ff == 0
    rc, out, _ = _op(capsys, ch, "status", "--json")
    assert rc == 0 and json.loads(out)["feedforward"] is False
    assert json.loads(out)["frames"] is None  # one object; this stand-in sends no CTRL_FRAMES
    rc, out, _ = _op(capsys, ch, "estop")
    assert rc == 0 and "ESTOP" in out
    rc, out, _ = _op(capsys, ch, "reset")
    assert rc == 0 and "READY" in out
    rc, out, _ = _op(capsys, ch, "park")
    assert rc == 0 and "IDLE" in out
    rc, out, _ = _op(capsys, ch, "watch", "--duration", "0.5", "--rate", "10")
    assert rc == 0 and "state IDLE" in out and "CTRL_STATUS" in out and "heartbeats" in out


def test_observers_send_no_heartbeat(ctrl, capsys):
    """`status` and `watch` only listen: a status poll or a monitoring
    screen must not keep the operator supervision satisfied for a
    commanding process that died; `watch --heartbeat` sends them."""
    ch = ctrl.channel
    n = len(ctrl.heartbeats)
    assert _op(capsys, ch, "status")[0] == 0
    assert _op(capsys, ch, "watch", "--duration", "0.3", "--rate", "10")[0] == 0
    time.sleep(0.1)
    assert len(ctrl.heartbeats) == n
    assert _op(capsys, ch, "watch", "--duration", "0.3", "--rate", "10", "--heartbeat")[0] == 0
    time.sleep(0.1)
    assert len(ctrl.heartbeats) >= n + 5      # 15 in 0.3 s at 20 ms
    n = len(ctrl.heartbeats)
    assert _op(capsys, ch, "stop")[0] == 0    # a command's process sends them
    time.sleep(0.1)
    assert len(ctrl.heartbeats) > n


def test_cli_identify(ctrl, capsys):
    """`op identify`: one request, one CTRL_IDENTITY, the controller's
    protocol hash against this DBC's (a warning when they differ); no
    command reaches the controller's queue and no heartbeat is sent."""
    ch = ctrl.channel
    n = len(ctrl.heartbeats)
    rc, out, err = _op(capsys, ch, "identify")
    assert rc == 0 and f"firmware 0.3.0 (STM32G474), protocol {pr.dbc_hash():08x}" in out
    assert f"protocol {pr.dbc_hash():08x}" in out.split(";")[1] and "warning" not in err
    rc, out, _ = _op(capsys, ch, "identify", "--json")
    got = json.loads(out)
    assert rc == 0 and got["version"] == "0.3.0" and got["port"] == "STM32G474" and got["same_protocol"] is True
    assert ctrl.identities == 2 and "IDENTIFY" not in ctrl.commands and len(ctrl.heartbeats) == n
    ctrl.identity_hash = pr.dbc_hash() ^ 0x1
    rc, out, err = _op(capsys, ch, "identify")
    assert rc == 0 and f"protocol {pr.dbc_hash() ^ 1:08x}" in out
    assert "warning: the controller speaks another protocol" in err
    rc, _, err = _op(capsys, "op-test-nobody", "identify", "--timeout", "0.3")
    assert rc == 3 and "no CTRL_IDENTITY" in err


def test_cli_stream_csv(ctrl, capsys, tmp_path):
    ch = ctrl.channel
    assert _op(capsys, ch, "engage")[0] == 0
    f = tmp_path / "p.csv"
    f.write_text("t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n0.3,0.01,0,0,0,0,0\n")
    rc, out, err = _op(capsys, ch, "stream", "--csv", str(f), "--stats", str(tmp_path / "s.json"))
    assert rc == 0, err
    stats = json.loads((tmp_path / "s.json").read_text())
    # one frame per tick of the 1 kHz grid (how many ticks a loaded machine
    # manages is the benchmark's business, bench/op_stream_bench.py)
    assert stats["frames_sent"] == stats["jitter"]["ticks"] - 1 and stats["frames_sent"] >= 10
    assert stats["frames_sent"] <= 301 and stats["send_errors"] == 0
    assert stats["events"] == ["end-of-file"]
    assert ctrl.targets >= stats["frames_sent"] - 1   # the first frame of a new sender may be dropped
    assert "settled back to home" in out


def test_cli_stream_udp_cueing(ctrl, capsys, tmp_path):
    """Telemetry through the washout filter (stewart.cueing): absolute poses
    about home; a pose datagram in cueing mode is bad; the source stopping
    ends the stream (--once) back at READY."""
    import socket

    pytest.importorskip("stewart.cueing")
    ch = ctrl.channel
    assert _op(capsys, ch, "engage")[0] == 0
    port_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    port_sock.bind(("127.0.0.1", 0))
    port = port_sock.getsockname()[1]
    port_sock.close()

    def sender():
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        time.sleep(0.3)
        for k in range(60):   # 0.6 s at 100 Hz: 1 m/s^2 forward
            tx.sendto(src.encode_datagram(k, [1.0, 0.0, 9.80665, 0.0, 0.0, 0.0], cueing=True), ("127.0.0.1", port))
            if k == 30:
                tx.sendto(src.encode_datagram(99, [0.0] * 6), ("127.0.0.1", port))   # a pose: bad
            time.sleep(0.01)
        tx.close()

    th = threading.Thread(target=sender)
    th.start()
    rc, out, err = _op(capsys, ch, "stream", "--udp", f"127.0.0.1:{port}", "--cueing", "--once",
                       "--source-timeout", "0.2", "--stats", str(tmp_path / "c.json"))
    th.join()
    assert rc == 0, err
    stats = json.loads((tmp_path / "c.json").read_text())
    assert stats["udp"]["bad"] == 1 and stats["udp"]["accepted"] >= 50
    assert "source-lost" in stats["events"] and "settled back to home" in out
    x, y, z = ctrl.last_target[:3]
    assert abs(z - 2.55) < 0.05 and abs(y) < 1e-6      # absolute, about home; a forward push moves x only
    assert 0.0 < x < 0.2


def test_cli_bad_input(capsys, tmp_path):
    rc, _, err = _op(capsys, "op-none", "stream", "--csv", str(tmp_path / "missing.csv"))
    assert rc == 2 and "cannot read" in err
    rc = cli.main(["op", "-i", "no-such-interface", "status"])
    err = capsys.readouterr().err
    assert rc == 2 and "unknown interface 'no-such-interface'" in err
    rc, _, err = _op(capsys, "op-none", "--timeout", "0.2", "status")
    assert rc == 3 and "no CTRL_STATUS" in err
    rc, _, err = _op(capsys, "op-none", "stream", "--udp", "localhost")
    assert rc == 2 and "HOST:PORT" in err
    rc, _, err = _op(capsys, "op-none", "stream", "--csv", "x.csv", "--cueing")
    assert rc == 2 and "--cueing takes UDP" in err


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf"])
def test_cli_record(ctrl, capsys, tmp_path, suffix):
    f = tmp_path / f"rec{suffix}"
    rc, out, err = _op(capsys, ctrl.channel, "record", str(f), "--duration", "0.3")
    assert rc == 0, err
    n = int(out.split()[1])
    assert n > 100                               # 1 kHz statuses for 0.3 s
    frames = list(can.LogReader(str(f)))
    assert len(frames) == n and all(m.arbitration_id in (0x100, 0x103) for m in frames)


def test_cli_record_mf4_or_a_clear_message(ctrl, capsys, tmp_path):
    rc, out, err = _op(capsys, ctrl.channel, "record", str(tmp_path / "r.mf4"), "--duration", "0.2")
    assert (rc == 0 and "frames" in out) or (rc == 2 and "not installed" in err)


# -- bus options ----------------------------------------------------------------------

def test_bus_defaults_and_python_can_config(monkeypatch, tmp_path):
    for k in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    cfg = opbus.resolve(opbus.BusOptions())
    assert cfg["interface"] == "socketcan" and cfg["channel"] == "vcan0" and cfg["fd"] is True
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "env-channel")
    cfg = opbus.resolve(opbus.BusOptions())
    assert cfg["interface"] == "virtual" and cfg["channel"] == "env-channel"
    cfg = opbus.resolve(opbus.BusOptions(channel="cli-channel", bitrate=500000, data_bitrate=2000000, fd=False))
    assert cfg["channel"] == "cli-channel" and cfg["bitrate"] == 500000 and cfg["fd"] is False
    monkeypatch.delenv("CAN_INTERFACE")
    monkeypatch.delenv("CAN_CHANNEL")
    ini = tmp_path / "can.ini"
    ini.write_text("[default]\ninterface = virtual\nchannel = from-file\n[bench]\ninterface = virtual\n"
                   "channel = bench-channel\n")
    assert opbus.resolve(opbus.BusOptions(config_file=str(ini)))["channel"] == "from-file"
    assert opbus.resolve(opbus.BusOptions(config_file=str(ini), context="bench"))["channel"] == "bench-channel"



def test_every_command_takes_the_same_bus_options(monkeypatch, tmp_path):
    """op (the ops bus, FD) and drives (an axis bus, classic CAN) share one
    set of options and defaults: python-can's configuration, else SocketCAN
    on the simulated set-up's interface of the bus."""
    for k in ("CAN_INTERFACE", "CAN_CHANNEL", "CAN_BITRATE", "CAN_CONFIG"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    parser = cli.build_parser()
    plain = {"op": ["op", "status"], "scan": ["drives", "scan"], "config": ["drives", "config"]}
    defaults = {k: opbus.resolve(opbus.options(parser.parse_args(v))) for k, v in plain.items()}
    assert defaults["op"] == {"interface": "socketcan", "channel": "vcan0", "fd": True}
    assert defaults["scan"] == defaults["config"] == {"interface": "socketcan", "channel": "vcan1", "fd": False}
    given = ["-i", "virtual", "-c", "bench", "-b", "500000", "--fd", "--data-bitrate", "2000000"]
    for argv in (["op", *given, "status"], ["drives", "scan", *given], ["drives", "config", *given]):
        assert opbus.resolve(opbus.options(parser.parse_args(argv))) == {
            "interface": "virtual", "channel": "bench", "bitrate": 500000, "data_bitrate": 2000000, "fd": True}
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "env-channel")
    assert opbus.resolve(opbus.options(parser.parse_args(["drives", "scan"])))["channel"] == "env-channel"


# -- sources --------------------------------------------------------------------------

def test_datagram_formats():
    pose = [0.01, -0.02, 0.03, 0.001, -0.002, 0.5]
    for binary in (True, False):
        seq, vals = src.parse_datagram(src.encode_datagram(7, pose, binary=binary))
        assert seq == 7 and vals == pytest.approx(pose, abs=1e-9)
        seq, vals = src.parse_datagram(src.encode_datagram(8, pose, cueing=True, binary=binary), cueing=True)
        assert seq == 8
    assert src.parse_datagram(b"5, 1, 2, 3, 4, 5, 6\n") == (5, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert len(src.encode_datagram(1, pose)) == 56
    assert struct.unpack_from("<4sI", src.encode_datagram(1, pose)) == (b"SPP1", 1)
    for bad, why in [(b"1 2 3", "7"), (b"SPP1" + b"\0" * 10, "bytes"), (b"\xff\xfe", "ASCII"),
                     (b"x 1 2 3 4 5 6", "integer"), (b"1 nan 2 3 4 5 6", "finite"),
                     (src.encode_datagram(1, pose, cueing=True), "without --cueing")]:
        with pytest.raises(ValueError, match=why):
            src.parse_datagram(bad)


def test_sequence_filter_drops_and_counts():
    f = src.SequenceFilter()
    taken = [f.take(s) for s in (10, 11, 11, 9, 14, 15, 2**32 - 1)]
    assert taken == [True, True, False, False, True, True, False]
    c = f.counters
    assert (c.accepted, c.duplicate, c.late, c.lost) == (4, 1, 2, 2)
    g = src.SequenceFilter()
    assert [g.take(s) for s in (2**32 - 2, 2**32 - 1, 0, 1)] == [True] * 4   # wraps
    assert g.counters.lost == 0


def test_udp_source_end_to_end():
    import socket

    s = src.UdpSource("127.0.0.1", 0)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        addr = s.address
        for seq in (1, 2, 2, 1, 3):
            tx.sendto(src.encode_datagram(seq, [seq * 0.001] * 6, binary=seq % 2 == 0), addr)
        tx.sendto(b"garbage", addr)
        time.sleep(0.05)
        assert s.poll() == pytest.approx([0.003] * 6)
        c = s.counters
        assert (c.accepted, c.duplicate, c.late, c.bad) == (3, 1, 1, 1)
    finally:
        tx.close()
        s.close()


def test_pose_csv(tmp_path):
    f = tmp_path / "a.csv"
    f.write_text("# a comment\ntime,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n1,1,2,3,4,5,6\n")
    tr = src.read_pose_csv(f)
    assert tr.duration == 1.0
    assert tr.at(0.25) == pytest.approx([0.25, 0.5, 0.75, 1.0, 1.25, 1.5])
    assert tr.at(5) == [1, 2, 3, 4, 5, 6] and tr.at(-1) == [0] * 6
    for text, why in [("t,x,y\n", "missing z"), ("t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n0,1,1,1,1,1,1\n",
                                                     "line 3: time 0"),
                      ("t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,a\n", "line 2"), ("", "empty"),
                      ("t,x,y,z,roll,pitch,yaw\n0,0,0,0,0,0,0\n", "at least two")]:
        f.write_text(text)
        with pytest.raises(src.SourceError, match=why):
            src.read_pose_csv(f)


def test_pose_track_interpolates_like_a_plain_search(tmp_path):
    ts = [0.0, 0.1, 0.35, 0.4, 1.0]
    poses = [[math.sin(t * k) for k in range(1, 7)] for t in ts]
    tr = src.PoseTrack(ts, poses)
    for q in [x * 0.001 for x in range(0, 1001, 7)]:
        i = max(j for j in range(len(ts) - 1) if ts[j] <= q) if q < 1.0 else len(ts) - 2
        a = (q - ts[i]) / (ts[i + 1] - ts[i])
        ref = [p + a * (r - p) for p, r in zip(poses[i], poses[i + 1])]
        assert tr.at(q) == pytest.approx(ref, abs=1e-12)


def test_e2e_counter_helper_is_modulo_16():
    assert e2e.next_counter(15) == 0
