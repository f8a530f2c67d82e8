# SPDX-License-Identifier: Apache-2.0
"""What the bus tests share: the operator tool (`stewart op`), the
controller and the plant started in order, and a listener on the ops bus
that cannot lose the frames a test counts.

Why a listener has two sockets (and large queues): the ops bus carries CTRL_STATUS,
CTRL_MONITOR (1 kHz each) and CTRL_WRENCH (500 Hz). A socket that hears
one of those and a rare frame too shares one receive queue (about 425 KB
inside user-mode Linux: net.core.rmem_max caps SO_RCVBUF); on a loaded
machine the reading thread falls behind, the queue fills and the kernel
drops whatever comes next, the rare frame as readily as a status. So the
frames a test must hear every one of (operator commands, OP_FORCE_PARAMS,
CTRL_AUTH at 100 Hz) get a socket of their own, whose queue holds seconds
of them, and the 1 kHz stream another. Both ask for a queue beyond
rmem_max (ops_socket), so that a reading thread held up for seconds loses
nothing; a test that needs one particular status (a CmdRejected lasts one
tick) should still say, when it misses it, whether statuses were lost
(Tick gaps).

python-can binds a socket before it sets the kernel's filter, so a frame
sent in that instant passes whatever the filter says: every reader here
checks the identifier of what it hears (a 64-byte CTRL_MONITOR once
reached a reader of CTRL_STATUS that way).
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import threading
import time
from typing import Iterable, Iterator
from pathlib import Path

import pytest

from stewart import closedloop as cl

REPO_ROOT = Path(__file__).resolve().parents[2]

STEWART = [sys.executable, "-m", "stewart.cli"]


def op(*args, check: int | None = None, timeout: float = 120, prefix: Iterable[str] = (),
       process: bool = True):
    """`stewart op ARGS`, printed with its exit code and time; no traceback
    allowed; `check`: the exit code it must have. As a process of its own,
    or with `process=False` the CLI's entry point (stewart.cli.main: the
    installed command's argument parsing and command code, its own bus
    socket and node) in this process: a new Python costs seconds of CPU
    inside user-mode Linux (the operator session's 35 commands took 6
    minutes as processes, 1 in process). Not for a test that keeps its own
    readers in this process: they share the interpreter with the command's
    and fall seconds behind the 1 kHz status (the auth test's listener
    lost 10 s during an in-process `op stream`). `timeout` bounds a process
    only (each command has its own)."""
    t0 = time.monotonic()
    argv = ["op", *map(str, args)]
    if process or prefix:
        r = subprocess.run([*prefix, *STEWART, *argv], capture_output=True, text=True, timeout=timeout,
                           cwd=REPO_ROOT)
    else:
        r = _in_process(argv)
    print(f"$ stewart op {' '.join(map(str, args))} -> {r.returncode} in {time.monotonic() - t0:.1f} s"
          f"{'' if process or prefix else ' (in process)'}\n{r.stdout}{r.stderr}")
    if check is not None:
        assert r.returncode == check, r.stderr
    assert "Traceback" not in r.stderr
    return r


def _in_process(argv: list[str]) -> subprocess.CompletedProcess:
    """stewart.cli.main(argv) here, its stdout and stderr captured, its
    exit code as a process's (SystemExit from argparse included; an
    exception becomes exit 1 and its traceback on stderr)."""
    import io
    import traceback

    from stewart import cli

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = cli.main(argv)
        except SystemExit as e:
            rc = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
            if not isinstance(e.code, (int, type(None))):
                print(e.code, file=sys.stderr)
        except Exception:  # noqa: BLE001 - reported as a process would: a traceback, exit 1
            traceback.print_exc()
            rc = 1
    return subprocess.CompletedProcess(argv, rc, out.getvalue(), err.getvalue())


def wait_for_line(path: Path, text: str, proc: subprocess.Popen, timeout_s: float = 30.0) -> None:
    """Waits until `proc` has written `text` to `path` (its start-up line)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if text in path.read_text():
            return
        if proc.poll() is not None:
            pytest.fail(f"{path.name}: the process ended at start-up:\n{path.read_text()}")
        time.sleep(0.05)
    pytest.fail(f"{path.name}: no '{text}' line within {timeout_s} s:\n{path.read_text()}")


@contextlib.contextmanager
def controller_and_plant(out: Path, controller: Iterable[str] = (), plant: Iterable[str] = (),
                         lockstep: bool = True, prefix: Iterable[str] = ()) -> Iterator[None]:
    """sp_controller, then hs_sim (host-release build), their output in
    ``out``/controller.txt and plant.txt. The plant starts only once the
    controller says its sockets are open ("mode on"): in lockstep the
    plant's cycle 0 is sent once, and a controller that binds after it would
    wait for it forever. In lockstep both get a 60 s stall timeout and the
    plant runs until stopped. On leaving: SIGINT to both (killed after
    10 s), the tails of their output printed."""
    bins = cl.Binaries.find()
    ctl_cmd = [*prefix, str(bins.controller), *controller]
    plant_cmd = [*prefix, str(bins.plant), *plant]
    if lockstep:
        ctl_cmd += ["--lockstep", "--timeout-ms", "60000"]
        plant_cmd += ["--lockstep", "--ticks", "100000000", "--timeout-ms", "60000"]
    with open(out / "controller.txt", "w") as ctl_out, open(out / "plant.txt", "w") as plant_out:
        procs = []
        try:
            procs.append(subprocess.Popen(ctl_cmd, stdout=ctl_out, stderr=subprocess.STDOUT, text=True))
            wait_for_line(out / "controller.txt", "mode on", procs[0])
            procs.insert(0, subprocess.Popen(plant_cmd, stdout=plant_out, stderr=subprocess.STDOUT, text=True))
            wait_for_line(out / "plant.txt", "mode on", procs[0])
            yield
        finally:
            for p in procs:
                p.send_signal(signal.SIGINT)
            for p in procs:
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
            for name in ("controller.txt", "plant.txt"):
                print((out / name).read_text()[-1500:])


#: The receive queue asked for (bytes): seconds of the 1 kHz status.
RCVBUF = 16 << 20


def ops_socket(ids: Iterable[int], rcvbuf: int | None = RCVBUF):
    """A python-can CAN FD socket on vcan0 hearing only these identifiers,
    its receive queue rcvbuf: SO_RCVBUFFORCE where allowed (root, as inside
    user-mode Linux: beyond net.core.rmem_max), else SO_RCVBUF (capped);
    None: the system's default queue."""
    import can

    bus = can.Bus(interface="socketcan", channel="vcan0", fd=True,
                  can_filters=[{"can_id": i, "can_mask": 0x7FF, "extended": False} for i in ids])
    if rcvbuf is not None:
        force_rcvbuf(bus, rcvbuf)
    return bus


def force_rcvbuf(bus, rcvbuf: int = RCVBUF) -> None:
    """A python-can SocketCAN bus's receive queue set to rcvbuf bytes:
    SO_RCVBUFFORCE where allowed, else SO_RCVBUF (capped by rmem_max)."""
    import socket

    try:
        bus.socket.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_RCVBUFFORCE", 33), rcvbuf)
    except OSError:
        bus.socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)


class Listener:
    """Hears the ops bus on two sockets, a thread each (see the module's
    doc): `every` the identifiers of which no frame may be lost, `stream`
    those of the 1 kHz stream. Each frame goes to on_frame(id, data, kernel
    receive time) with self.cond held (notified after); send() uses the
    `every` socket, so that the listener does not hear its own frames (the
    `stream` socket's filter must not pass them either). A context manager:
    closed on leaving."""

    def __init__(self, every: Iterable[int], stream: Iterable[int], stream_rcvbuf: int | None = RCVBUF):
        self._ids = {"every": set(every), "stream": set(stream)}
        self.every = ops_socket(self._ids["every"])
        self.stream = ops_socket(self._ids["stream"], stream_rcvbuf)
        self.cond = threading.Condition()
        self._stream_stamp = 0.0  # the kernel receive time of the newest stream frame handled
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._read, args=(b,), daemon=True)
                         for b in (self.every, self.stream)]
        for t in self._threads:
            t.start()

    def on_frame(self, fid: int, data: bytes, timestamp: float) -> None:
        raise NotImplementedError

    def send(self, fid: int, data: bytes) -> None:
        import can

        self.every.send(can.Message(arbitration_id=fid, data=data, is_extended_id=False, is_fd=True,
                                    bitrate_switch=True))

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(2)
        for b in (self.every, self.stream):
            b.shutdown()

    def _read(self, bus) -> None:
        ids = self._ids["stream" if bus is self.stream else "every"]
        while not self._stop.is_set():
            m = bus.recv(timeout=0.1)
            if m is None or m.arbitration_id not in ids:  # not ours: heard before the filter was set
                continue
            with self.cond:
                self.on_frame(m.arbitration_id, bytes(m.data), m.timestamp)
                if bus is self.stream:
                    self._stream_stamp = m.timestamp
                self.cond.notify_all()

    def sync(self, timeout: float = 60.0) -> None:
        """Returns once the stream's thread has handled every frame the bus
        carried before this call: with a queue of seconds the thread may be
        that far behind on a loaded machine (nothing lost, but late)."""
        now, end = time.time(), time.monotonic() + timeout
        with self.cond:
            while self._stream_stamp < now:
                left = end - time.monotonic()
                assert left > 0, f"the listener did not catch up with the bus within {timeout} s"
                self.cond.wait(left)
