# SPDX-License-Identifier: Apache-2.0
"""ENGAGE while the CANopen master is still configuring the drives by SDO
(issue 18): refused, then taken once every drive runs.

sp_controller and hs_sim --canopen in lockstep over vcan (inside ``stewart
vcan``): the plant's six CiA 408 nodes are slow SDO servers
(``--sdo-delay-ms``: each answer 80 ms of plant time after its request,
below the master's 100 ms SDO timeout; in lockstep both count the same
ticks), so the start-up by SDO (53 transfers per drive) lasts over 4 s of
plant time, about as long in wall time. While it runs:

* `stewart op engage` is refused: it exits 1 and says why (the drives are
  still starting), CTRL_STATUS shows CmdRejected with DrivesStarting, the
  controller stays IDLE, and the drives' SDO answers go on after the
  refusal (the configuration was still running: not a drive that never
  booted).
* Once DrivesStarting clears (every drive configured and operational),
  ENGAGE is taken (the operator node of `stewart op`, in this process:
  CTRL_STATUS leaves IDLE for ENGAGING, no CmdRejected). The test ends
  there (the move to home would take seconds of a slow lockstep); the
  controller's summary shows no fault and every node running.

Frames are recorded in threads, one socket per kind: CTRL_STATUS (every
tick) on its own, the rare ones (OP_COMMAND, the drives' SDO answers) on
sockets of their own, whose queues cannot be overrun by the status stream.
The refusal is one status (CmdRejected lasts the tick the command was
refused on): the status socket has a queue of seconds (busrig.ops_socket)
and its thread reads only the fields it keeps (no cantools decode per
frame), so it loses none and leaves the operator node, whose reader
shares this process, the time to keep up.
"""

from __future__ import annotations

import contextlib
import io
import re
import signal
import subprocess
import threading
import time

import pytest

from stewart import cli
from stewart import closedloop as cl
from stewart import protocol as pr
from stewart.operator.node import _Reader as FieldReader

import busrig

pytestmark = pytest.mark.skipif(not cl.vcan_present(), reason="needs vcan0..vcan2 (run inside stewart vcan)")

ID_COMMAND, ID_STATUS = 0x040, 0x100
SDO_TX = 0x580          # + node id: a drive's SDO answer
SDO_DELAY_MS = 80       # plant time per SDO answer (the master's SDO timeout: 100 ms)
STATES = pr.value_names("CTRL_STATUS", "State")


def op(*args) -> tuple[int, str, str]:
    """`stewart op ARGS` in this process (cli.main: no Python start-up, which
    costs seconds on a loaded machine)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli.main(["op", *map(str, args)])
    print(f"$ stewart op {' '.join(map(str, args))} -> {rc}\n{out.getvalue()}{err.getvalue()}")
    assert "Traceback" not in err.getvalue()
    return rc, out.getvalue(), err.getvalue()


class Recorder:
    """CTRL_STATUS on one socket (every tick, none lost: a queue of
    seconds), OP_COMMAND on another, the SDO answers of both drive buses
    on one each: (kernel timestamp, ...) rows."""

    def __init__(self):
        import can

        def bus(channel, can_id, mask, fd=False):
            return can.Bus(interface="socketcan", channel=channel, fd=fd,
                           can_filters=[{"can_id": can_id, "can_mask": mask, "extended": False}])

        self.proto = pr.Protocol()
        self.fields = FieldReader(self.proto, "CTRL_STATUS").fields
        self.status: list[tuple[float, int, str, int, int]] = []  # t, tick, state, CmdRejected, DrivesStarting
        self.commands: list[float] = []
        self.sdo: list[tuple[float, int]] = []                     # t, node id
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.buses = [(busrig.ops_socket([ID_STATUS]), self._on_status),
                      (bus("vcan0", ID_COMMAND, 0x7FF, fd=True), self._on_command),
                      (bus("vcan1", SDO_TX, 0x780), self._on_sdo),
                      (bus("vcan2", SDO_TX, 0x780), self._on_sdo)]
        self._threads = [threading.Thread(target=self._read, args=b, daemon=True) for b in self.buses]
        for t in self._threads:
            t.start()

    def close(self):
        self._stop.set()
        for t in self._threads:
            t.join(2)
        for b, _ in self.buses:
            b.shutdown()

    def _read(self, bus, on):
        while not self._stop.is_set():
            m = bus.recv(timeout=0.1)
            if m is not None:
                on(m)

    def _on_status(self, m):
        if m.arbitration_id != ID_STATUS:  # heard before the filter was set (busrig's doc)
            return
        w, f = int.from_bytes(m.data, "little"), self.fields
        with self._lock:
            self.status.append((m.timestamp, f["Tick"].raw(w), STATES[f["State"].raw(w)], f["CmdRejected"].raw(w),
                                f["DrivesStarting"].raw(w)))

    def _on_command(self, m):
        if m.arbitration_id != ID_COMMAND:
            return
        with self._lock:
            self.commands.append(m.timestamp)

    def _on_sdo(self, m):
        if SDO_TX < m.arbitration_id <= SDO_TX + 127:
            with self._lock:
                self.sdo.append((m.timestamp, m.arbitration_id - SDO_TX))

    def snapshot(self):
        with self._lock:
            return list(self.status), list(self.commands), list(self.sdo)

    def lost(self) -> int:
        """Statuses missing (Tick gaps): none, with the queue of seconds."""
        ticks = [s[1] for s in self.snapshot()[0]]
        return sum(b - a - 1 for a, b in zip(ticks, ticks[1:]) if b > a + 1)

    def wait(self, what: str, pred, timeout: float) -> None:
        end = time.monotonic() + timeout
        while not pred(*self.snapshot()):
            assert time.monotonic() < end, f"{what}: not within {timeout} s ({self.lost()} statuses lost)"
            time.sleep(0.01)


def test_engage_refused_while_the_drives_are_configured(tmp_path):
    import can

    from stewart import auth
    from stewart.commands import op_cmd  # noqa: F401  (imported before the start-up: the refusal comes sooner)
    from stewart.operator import node as opnode

    bins = cl.Binaries.find()
    ctl_log, plant_log = tmp_path / "controller.txt", tmp_path / "plant.txt"
    rec = Recorder()
    procs: list[subprocess.Popen] = []
    t0 = time.monotonic()
    try:
        with open(ctl_log, "w") as c_out, open(plant_log, "w") as p_out:
            procs.append(subprocess.Popen([str(bins.controller), "--lockstep", "--canopen", "--timeout-ms", "60000",
                                           "--operator-timeout", "0"], stdout=c_out, stderr=subprocess.STDOUT))
            busrig.wait_for_line(ctl_log, "mode on", procs[0])
            procs.append(subprocess.Popen([str(bins.plant), "--lockstep", "--canopen", "--ticks", "100000000",
                                           "--timeout-ms", "60000", "--sdo-delay-ms", str(SDO_DELAY_MS)],
                                          stdout=p_out, stderr=subprocess.STDOUT))
            # the configuration by SDO has begun: answers heard, the controller says its drives are starting
            rec.wait("an SDO answer and DrivesStarting", lambda st, cmd, sdo: sdo and st and st[-1][4] == 1, 30)
            print(f"[{time.monotonic() - t0:.1f} s] start-up by SDO running")

            t_op = time.monotonic()
            rc, _, err = op("engage", "--timeout", 10)
            print(f"[{time.monotonic() - t0:.1f} s] `stewart op engage` answered in {time.monotonic() - t_op:.1f} s")
            assert rc == 1 and "ENGAGE refused" in err and "still starting the drives" in err, err
            # the status of the refusal's tick (CmdRejected lasts one): the recorder, losing none, has it too
            rec.wait("OP_COMMAND, then CTRL_STATUS CmdRejected with DrivesStarting",
                     lambda st, cmd, sd: cmd and any(s[0] > cmd[0] and s[3] == 1 and s[4] == 1 for s in st), 10)
            status, commands, sdo = rec.snapshot()
            assert all(s[2] == "IDLE" for s in status if s[0] > commands[0]), {s[2] for s in status}
            # the start-up was still running: the drives answer SDO requests after the refusal's tick (its
            # status's kernel time: `stewart op` returns later, seconds later on a loaded machine)
            t_refused = next(s[0] for s in status if s[0] > commands[0] and s[3] == 1)
            rec.wait("an SDO answer after the refusal", lambda st, cmd, sd: any(t > t_refused for t, _ in sd), 10)
            print(f"[{time.monotonic() - t0:.1f} s] ENGAGE refused, {len(sdo)} SDO answers so far")

            rec.wait("DrivesStarting cleared", lambda st, cmd, sd: st and st[-1][4] == 0, 30)
            status, _, sdo = rec.snapshot()
            first = next(s for s in status if s[4] == 1)
            done = next(s for s in status if s[0] > first[0] and s[4] == 0)
            nodes = sorted({n for _, n in sdo})
            per_node = len(sdo) / max(1, len(nodes))
            print(f"[{time.monotonic() - t0:.1f} s] drives started: ticks {first[1]}..{done[1]} "
                  f"({done[1] - first[1]} ms of controller time), {len(sdo)} SDO answers from nodes {nodes}")
            assert nodes == [1, 2, 3, 4, 5, 6]
            # every answer took its SDO_DELAY_MS: the start-up lasted at least one node's transfers in a row
            assert done[1] - first[1] >= 0.9 * per_node * SDO_DELAY_MS, (done[1] - first[1], per_node)

            with opnode.OperatorNode(can.Bus(interface="socketcan", channel="vcan0", fd=True),
                                     key=auth.read_key(auth.key_file())) as node:
                ans = node.command("ENGAGE", lambda st: st.state in ("ENGAGING", "READY"), timeout=30)
            assert ans.status.state in ("ENGAGING", "READY") and not ans.status.cmd_rejected, ans.status
            assert not ans.status.drives_starting and ans.status.faults == []
            print(f"[{time.monotonic() - t0:.1f} s] ENGAGE taken: {ans.status.state}")
    finally:
        rec.close()
        for p in reversed(procs):
            p.send_signal(signal.SIGINT)
        for p in reversed(procs):
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    c_text = ctl_log.read_text()
    print(c_text[-2000:], plant_log.read_text()[-1500:])
    m = re.search(r"sp_controller canopen: ready (\d)(.*)", c_text)
    assert m and m[2].count("phase 6") == 6 and m[2].count(" none") == 6, c_text[-2000:]
    assert "faults 0x0000" in c_text, c_text[-2000:]
