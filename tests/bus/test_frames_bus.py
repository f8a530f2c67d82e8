# SPDX-License-Identifier: Apache-2.0
"""Tool and work frames and the reach query over vcan (issue 31), against
the simulated platform in lockstep: `stewart op frame` and `stewart op
reach` (their bad inputs refused with the reason, nothing moving; the
CLI's entry point in this process, then as processes once this module's
own reader runs), then an operator node in this process for the many
queries:

- every reach query answered within 2 controller ticks on the bus (3
  statuses when it lands while a tick is under way): the order of
  OP_REACH, the controller's CTRL_STATUS (one a tick) and CTRL_REACH is
  candump's log of the bus, whatever this process's own lag (it is
  starved for seconds now and then in user-mode Linux on a loaded
  machine);
- the verdict agrees with the controller's own refusal of a MOVE_TO to the
  same pose from READY on random tool poses with a turned tool and work
  frame (the 10,000 of the issue are test_frames_ctrl's, on the same
  shared check: here what fits in about a minute);
- a frame change while moving refused (RefusedState, LastRefusal STATE), nothing moves.

Run time: about 3 minutes in user-mode Linux on a loaded 2-core machine.
"""

from __future__ import annotations

import functools
import math
import random
import time
from pathlib import Path

import pytest

from stewart import auth as au
from stewart import closedloop as cl

import busrig

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

TIP = (0.15, 0.0, 0.35, 0.05, -0.1, 0.2)
TILTED = (0.2, 0.1, 0.0, 0.0, 0.349, 0.0)
N_QUERIES = 20    # reach queries timed and checked (10,000 in test_frames_ctrl, in C)
N_MOVES = 6       # of which also sent as MOVE_TO (each moves and comes back in real time)


class BusOrder:
    """OP_REACH, CTRL_STATUS and CTRL_REACH in the order the bus carried
    them, from candump's log of vcan0: a C reader with a queue of seconds.
    A Python reader in this process is not one: starved for seconds in
    user-mode Linux, its socket dropped an answer and a query on CI (2 MB
    queue), and with a 16 MB queue it fell a minute behind."""

    def __init__(self, log: Path):
        from stewart import protocol as pr

        self.proto = pr.Protocol()
        self.ids = {self.proto.message(n).frame_id: n for n in ("OP_REACH", "CTRL_STATUS", "CTRL_REACH")}
        self.log = log
        self._dump = None
        self._out = None

    def __enter__(self) -> "BusOrder":
        import subprocess

        self._out = open(self.log, "w")
        filters = ",".join(f"{i:03X}:7FF" for i in self.ids)
        self._dump = subprocess.Popen(["candump", "-L", "-r", str(busrig.RCVBUF), f"vcan0,{filters}"],
                                      stdout=self._out, stderr=subprocess.DEVNULL)
        time.sleep(0.3)  # bound and filtering before the first query
        return self

    def __exit__(self, *exc) -> None:
        import signal

        time.sleep(0.3)
        self._dump.send_signal(signal.SIGINT)  # candump flushes its log as it ends
        self._dump.wait(timeout=10)
        self._out.close()

    def frames(self) -> list[tuple[str, bytes]]:
        out = []
        for line in self.log.read_text().splitlines():
            parts = line.split()
            if len(parts) < 3:
                continue
            ident, _, data = parts[2].partition("#")
            data = data.lstrip("#")[1:] if parts[2].count("#") == 2 else data  # CAN FD: flags digit
            name = self.ids.get(int(ident, 16))
            if name is not None:
                out.append((name, bytes.fromhex(data)))
        return out

    def ticks_to_answer(self) -> dict[int, int]:
        """Per query sequence: the controller's statuses on the bus from its
        first OP_REACH to its first CTRL_REACH, the answer's own tick counted
        (1: answered in the tick that took it; the answer precedes its tick's
        CTRL_STATUS)."""
        asked: dict[int, int] = {}
        answered: dict[int, int] = {}
        statuses = 0
        for name, data in self.frames():
            if name == "CTRL_STATUS":
                statuses += 1
                continue
            seq = int(self.proto.decode(self.proto.message(name).frame_id, data, raw=True,
                                        check_counter=False)[1]["Sequence"])
            if name == "OP_REACH":
                asked.setdefault(seq, statuses)
            elif seq in asked:
                answered.setdefault(seq, statuses - asked[seq] + 1)
        return answered


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    out = tmp_path_factory.mktemp("frames_bus")
    with busrig.controller_and_plant(out, ["--operator-timeout", "5000"]):
        time.sleep(0.3)
        yield out


@pytest.fixture(scope="module")
def node(rig):
    import can

    from stewart.operator.node import OperatorNode

    bus = can.Bus(interface="socketcan", channel="vcan0", fd=True)
    n = OperatorNode(bus, key=au.read_key(au.key_file(None)), monitor=False).start()
    yield n
    n.close()
    bus.shutdown()


def test_cli_bad_inputs_refused(rig):
    # the CLI in this process (busrig.op process=False): no reader of this module's runs yet
    op = functools.partial(busrig.op, process=False)
    op("engage", check=0)
    r = op("frame", "tool", "set", "3", "3", "3", "0", "0", "0", "--slot", "2")
    assert r.returncode != 0 and "BadFrame" in r.stderr
    r = op("frame", "work", "select", "3")
    assert r.returncode != 0 and "EmptySlot" in r.stderr
    r = op("reach", "0", "0", "nan", "0", "0", "0")
    assert r.returncode == 2 and "not a finite number" in r.stdout
    r = op("frame", "tool", "set", "0", "0", "inf", "0", "0", "0")
    assert r.returncode != 0 and "NotFinite" in r.stderr
    r = op("frame", "tool", "select", "1", check=0)  # the config's "tip"
    assert "tool 1" in r.stdout
    r = op("reach", "0.15", "0", "2.6", "0", "0", "0")
    assert "reach:" in r.stdout
    r = op("status", check=0)
    assert "frames: tool 1, work 0" in r.stdout
    for needle in ("BadFrame 1", "EmptySlot 1", "NotFinite 2"):
        assert needle in r.stdout, needle  # each refusal counted once
    r = op("move", "0.15", "0", "5", "0", "0", "0", "--frame", "1:0")  # beyond the workspace
    assert r.returncode != 0
    op("frame", "tool", "select", "0", check=0)


def _tool_home(node) -> list[float]:
    """The tool pose of home with TIP and TILTED (the float64 reference)."""
    from stewart import config as cf
    from stewart import resources
    from stewart.frames import Frames

    home = cf.load(resources.default_platform()).home
    return list(Frames(TIP, TILTED).from_platform(home))


def _move_to(node, pose) -> bool:
    """MOVE_TO pose from READY: True once RUNNING, False once CTRL_FRAMES'
    RefusedReach rose (a one-tick CmdRejected may be missed by a
    reader that lags in user-mode Linux)."""
    before = node.wait_frames(timeout=10.0)["refused"]["Reach"]
    node.send_command("NONE")  # the alive-counter check may drop a new sender's first OP_COMMAND
    node.send_target(pose)
    node.wait_status(timeout=5.0)
    node.send_target(pose)
    node.fresh_auth()
    node.send_command("MOVE_TO")
    end = time.monotonic() + 30.0
    while time.monotonic() < end:
        st = node.wait_status(timeout=5.0, after=node.status.seq)
        if st.state == "RUNNING":
            return True
        if node.frames["refused"]["Reach"] > before:
            return False
    raise AssertionError("MOVE_TO: neither RUNNING nor refused within 30 s")


def _caught_up(node, timeout: float = 10.0) -> None:
    """Waits (up to `timeout`) until the node's reader holds a status that
    reached its socket less than 0.25 s ago: while `stewart op` processes
    start inside user-mode Linux, this process's reader of the 1 kHz
    status falls seconds behind, and what it reads then is old. A reader
    that does not catch up is printed, not failed: what follows waits for
    what it needs."""
    end = time.monotonic() + timeout
    first = lag = None
    while time.monotonic() < end:
        st = node.wait_status(timeout=5.0, after=node.status.seq if node.status else 0)
        lag = time.time() - st.stamp
        first = lag if first is None else first
        if lag < 0.25:
            break
        time.sleep(0.02)
    print(f"the node's reader was {first:.2f} s behind the bus, then {lag:.2f} s")


def test_reach_timing_and_agreement(rig, node):
    busrig.op("frame", "tool", "set", *map(str, TIP), "--slot", "2", check=0)
    r = busrig.op("frame", "work", "set", *map(str, TILTED), "--slot", "2", check=0)
    assert "tool 2, work 2" in r.stdout
    _caught_up(node)
    fr = node.wait_frames(timeout=10.0)
    assert fr["tool"] == 2 and fr["work"] == 2 and not fr["identity"]
    home = _tool_home(node)
    node.reach(home, timeout=5.0)  # this sender's first OP_REACH (the alive-counter check may drop it)
    on_bus = BusOrder(rig / "reach.log")
    with on_bus:
        agree, reachable = _queries(node, home)
    ticks = sorted(on_bus.ticks_to_answer().values())
    print(f"reach: {N_QUERIES} queries, {reachable} reachable; {agree} MOVE_TO agreed; controller ticks on the "
          f"bus from a query to its answer: {ticks}")
    assert 0 < reachable < N_QUERIES
    assert len(ticks) == N_QUERIES
    # answered by the tick that takes the query, or by the next when that one sends CTRL_AUTH (test_node
    # asserts it frame by frame in C); the tick that takes it is the next to start: one more status on
    # the bus when the query lands while a tick is under way (after its receive, before its status)
    assert ticks[-1] <= 3, ticks


def _queries(node, home) -> tuple[int, int]:
    """N_QUERIES reach queries around home, the first N_MOVES also sent as
    MOVE_TO (and back home when it moved): (agreements, reachable)."""
    rng = random.Random(31)
    agree, reachable = 0, 0
    for q in range(N_QUERIES):
        # the MOVE_TOs move the tool point only (a turn between two reachable
        # tool poses can leave the workspace on the way: CHANGELOG, known issue)
        turn = 0.0 if q < N_MOVES else 0.6
        pose = [h + rng.uniform(-0.5, 0.5) * (0.8 if k < 3 else turn) for k, h in enumerate(home)]
        a = node.reach(pose, timeout=10.0)
        reachable += a["verdict"] == "REACHABLE"
        if q < N_MOVES:
            moved = _move_to(node, pose)
            assert moved == (a["verdict"] == "REACHABLE"), (pose, a)
            agree += 1
            if moved:
                st = node.wait_status(timeout=5.0)
                end = time.monotonic() + 60
                while st.state == "RUNNING" and time.monotonic() < end:
                    st = node.wait_status(timeout=5.0, after=st.seq)
                assert st.state == "READY", st.line()
                assert _move_to(node, home)
                st = node.wait_status(timeout=5.0)
                while st.state == "RUNNING" and time.monotonic() < end + 60:
                    st = node.wait_status(timeout=5.0, after=st.seq)
    return agree, reachable


def test_frame_change_while_moving_refused(node):
    _caught_up(node)
    node.command("RUN_TRIG", lambda s: s.state == "RUNNING", timeout=10.0, axis="Z", amplitude=0.01,
                 frequency=0.5, fade_time=0.5)
    before = node.wait_status()
    r = busrig.op("frame", "tool", "select", "0")
    assert r.returncode != 0 and "State" in r.stderr
    r = busrig.op("status", check=0)
    assert "frames: tool 2, work 2" in r.stdout and "last: STATE" in r.stdout
    node.command("STOP", lambda s: s.state == "READY", timeout=60.0)
    assert math.isfinite(before.pose[2])
    busrig.op("frame", "tool", "select", "0", check=0)
    r = busrig.op("frame", "work", "select", "0", check=0)
    assert "identity" in r.stdout
