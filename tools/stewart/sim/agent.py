# SPDX-License-Identifier: Apache-2.0
"""The agent beside the buses: runs the simulated platform
(:class:`stewart.sim.plant.Plant`) and serves ``stewart sim`` over the
link (:mod:`stewart.sim.wire`): frames both ways on the buses the host
listens to, control requests, its log.

    python -m stewart.sim.agent --tty /dev/tty3 --out DIR --key FILE [--relax TICKS]
    python -m stewart.sim.agent --fds 0,1 ...        (pipes: the host back end)

Inside user-mode Linux the link is a console (a tty in raw mode). The agent
runs at an ordinary priority, below the controller and the plant
(SCHED_FIFO where allowed): a relay that falls behind loses frames to the
host (counted), never a deadline of the 1 kHz pair. Inside the UML the
real-time tasks get at most 80 % of the CPU, so that the relay and a stop
request still run when the pair cannot keep up.
"""

from __future__ import annotations

import argparse
import os
import queue
import select
import sys
import threading
import time
from pathlib import Path

from .. import protocol as pr
from . import wire
from .plant import Plant, SimError

BUS_NAMES = tuple(pr.BUSES)  # ops, axis_a, axis_b: vcan0..vcan2
#: The host says ``K`` every second; silent this long, it is taken for gone
#: (killed outright) and the simulation stops: the UML would run on alone.
HOST_SILENCE = 60.0
#: Frames queued for the host beyond this many are dropped (counted): about
#: 2 s of the ops bus, which the console carries at up to about 2 MB/s.
QUEUE_LINES = 5000
#: After a read, the relay waits this long (s) for frames to gather: one
#: system call then takes a few milliseconds of a bus (see wire.BatchReader).
READ_PAUSE = 0.003


class Link:
    """Lines out (batched by a thread, a few ms) and in."""

    def __init__(self, fd_in: int, fd_out: int):
        self.fd_in, self.fd_out = fd_in, fd_out
        self._out: queue.SimpleQueue[str | None] = queue.SimpleQueue()
        self._writer = threading.Thread(target=self._write_loop, daemon=True)
        self._writer.start()

    def send(self, line: str, droppable: bool = False) -> bool:
        """Queues a line; a droppable one (a frame) is dropped when the
        link is that far behind. False when dropped."""
        if droppable and self._out.qsize() > QUEUE_LINES:
            return False
        self._out.put(line)
        return True

    def close(self) -> None:
        self._out.put(None)
        self._writer.join(timeout=10)

    def _write_loop(self) -> None:
        while True:
            item = self._out.get()
            batch = [item] if item is not None else []
            done = item is None
            while not done and len(batch) < 512:
                try:
                    nxt = self._out.get_nowait()
                except queue.Empty:
                    break
                if nxt is None:
                    done = True
                else:
                    batch.append(nxt)
            if batch:
                data = "".join(batch).encode("ascii", "replace")
                try:
                    while data:
                        n = os.write(self.fd_out, data)
                        data = data[n:]
                except OSError:
                    return
            if done:
                return
            time.sleep(0.002)  # a few ms of frames in one write: each costs a system call

    def lines(self):
        """The lines that come in, until the stream ends."""
        buf = b""
        while True:
            try:
                chunk = os.read(self.fd_in, 65536)
            except InterruptedError:
                continue
            except OSError:
                return
            if not chunk:
                return
            buf += chunk
            *whole, buf = buf.split(b"\n")
            for raw in whole:
                yield raw.decode("ascii", "replace").strip()
            if len(buf) > 4 * wire.MAX_LINE:
                buf = b""


class Relay:
    """A raw socket per bus: frames from the host sent; on a subscribed
    bus every frame read goes to the host.

    Each frame from the host is acknowledged (``A BUS TIME``). On a
    subscribed bus the socket reads its own frames back when they are on
    the bus (CAN_RAW_RECV_OWN_MSGS), and the acknowledgement is queued
    there, in the bus's order among the frames relayed: the relay may run
    behind the bus (it yields to the 1 kHz pair), and an acknowledgement
    sent when the frame was written would come before frames that were on
    the bus before it. On a bus not subscribed (nothing relayed to order
    against), and for a frame the bus refused, it is queued at once; a
    frame not read back within ``CONFIRM_TIMEOUT`` s is acknowledged then
    (counted)."""

    CONFIRM_TIMEOUT = 1.0

    def __init__(self, link: Link):
        self.link = link
        self.socks = [wire.raw_socket(pr.BUSES[name]) for name in BUS_NAMES]
        for sock in self.socks:
            wire.set_receive(sock, False)
            wire.receive_own(sock)
        self.subscribed = [False] * len(self.socks)
        #: per bus, the send times of the host's frames not read back yet
        self.pending: list[list[float]] = [[] for _ in self.socks]
        self._lock = threading.Lock()
        self.sent = self.relayed = self.send_errors = self.dropped = self.unconfirmed = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def _ack(self, bus: int) -> None:
        self.link.send(f"A {bus} {time.time():.6f}\n")

    def subscribe(self, bus: int, on: bool) -> None:
        """Relays bus ``bus`` or not; an unsubscribed bus's socket takes no
        frame at all (a filter matching none): the axis buses carry about
        5,000 frames a second each, not to be read for nothing. Frames of
        the host's not read back yet are acknowledged when it goes off."""
        if 0 <= bus < len(self.socks):
            with self._lock:
                wire.set_receive(self.socks[bus], on)
                self.subscribed[bus] = on
                if not on:
                    for _ in self.pending[bus]:
                        self._ack(bus)
                    self.pending[bus].clear()

    def send(self, f: wire.Frame) -> None:
        """Puts ``f`` on its bus; its acknowledgement follows (see the class)."""
        with self._lock:
            try:
                self.socks[f.bus].send(wire.pack_raw(f))
                self.sent += 1
            except (OSError, wire.WireError):
                self.send_errors += 1
                self._ack(f.bus)
                return
            if self.subscribed[f.bus]:
                self.pending[f.bus].append(time.monotonic())
            else:
                self._ack(f.bus)

    def _confirmed(self, bus: int) -> None:
        with self._lock:
            if self.pending[bus]:
                self.pending[bus].pop(0)
                self._ack(bus)

    def _overdue(self) -> None:
        old = time.monotonic() - self.CONFIRM_TIMEOUT
        with self._lock:
            for bus, waiting in enumerate(self.pending):
                while waiting and waiting[0] < old:
                    waiting.pop(0)
                    self.unconfirmed += 1
                    self._ack(bus)

    def _loop(self) -> None:
        readers = {s: wire.BatchReader(s) for s in self.socks}
        while not self._stop.is_set():
            ready, _, _ = select.select(self.socks, [], [], 0.1)
            now = time.time()
            for s in ready:
                bus = self.socks.index(s)
                for _ in range(16):
                    try:
                        got = readers[s].read()
                    except OSError:
                        break
                    for raw, flags in got:
                        if flags & wire.MSG_CONFIRM:  # the host's own frame, now on the bus
                            self._confirmed(bus)
                        elif self.subscribed[bus]:
                            f = wire.unpack_raw(bus, raw, now)
                            if f is None:
                                continue
                            if self.link.send(wire.frame_line(f), droppable=True):
                                self.relayed += 1
                            else:
                                self.dropped += 1
                    if len(got) < readers[s].batch:
                        break
            self._overdue()
            if ready:  # let frames gather: one call then reads a few milliseconds of a bus
                self._stop.wait(READ_PAUSE)

    def figures(self) -> dict:
        """The relay's counts, for ``status`` and the final figures."""
        return {"to_host": self.relayed, "from_host": self.sent, "errors": self.send_errors,
                "dropped": self.dropped, "unconfirmed": self.unconfirmed}

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        for s in self.socks:
            s.close()


def may_use_realtime() -> bool:
    """Whether this process may use SCHED_FIFO (root inside user-mode Linux)."""
    try:
        old = os.sched_getscheduler(0), os.sched_getparam(0)
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        os.sched_setscheduler(0, old[0], old[1])
        return True
    except (OSError, AttributeError):
        return False


#: SCHED_FIFO priority of the agent's thread that reads the host's lines
#: and puts its frames on the buses (heartbeats, commands, ESTOP): above
#: the pair's (plant.PRIORITY), so that an operator's frame waits for no
#: tick. It wakes for a line and sleeps again. The relay to the host stays
#: at an ordinary priority, below the pair.
URGENT_PRIORITY = 20


def raise_priority() -> None:
    """The calling thread at SCHED_FIFO URGENT_PRIORITY (Linux: 0 is the
    calling thread); left as it is where not allowed."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(URGENT_PRIORITY))
    except (OSError, AttributeError):
        pass


def leave_time_to_others() -> None:
    """Inside the UML (its own kernel, never the host's): real-time tasks
    get at most 80 % of each second, so that the relay and a stop request
    still run when the pair cannot keep up (the kernel's default: 95 %)."""
    if os.environ.get("STEWART_VCAN") != "uml":
        return
    try:
        with open("/proc/sys/kernel/sched_rt_runtime_us", "w") as f:
            f.write("800000\n")
    except OSError:
        pass


def serve(link: Link, plant: Plant, relay: Relay) -> dict:
    """Handles the host's lines until a stop request or the end of the
    link or of the simulation; returns the final figures."""
    stopping = threading.Event()

    def watch() -> None:  # the simulation ending by itself ends the agent
        while not stopping.is_set() and plant.alive():
            time.sleep(0.2)
        if not stopping.is_set():
            link.send(wire.json_line("L", {"text": "the simulation ended by itself"}))
            figures = final(plant, relay)
            link.send(wire.json_line("BYE", dict(figures, ok=False, error="the simulation ended by itself")))
            link.close()
            os._exit(1)

    threading.Thread(target=watch, daemon=True).start()
    heard = [time.monotonic()]

    def host_alive() -> None:  # a host killed outright (SIGKILL) leaves no one to stop the UML but us
        while not stopping.is_set():
            time.sleep(1.0)
            if time.monotonic() - heard[0] > HOST_SILENCE and not stopping.is_set():
                stopping.set()
                figures = final(plant, relay)
                link.send(wire.json_line("BYE", dict(figures, ok=False, error="the host went silent")))
                link.close()
                os._exit(1)

    threading.Thread(target=host_alive, daemon=True).start()
    for line in link.lines():
        heard[0] = time.monotonic()
        words = line.split(" ", 2)
        kind = words[0]
        if kind == "F":
            try:
                f = wire.parse_frame(line.split()[1:])
            except wire.WireError:  # the host sends only frames it parsed: the line was damaged
                relay.send_errors += 1
                link.send(f"A -1 {time.time():.6f}\n")
                continue
            relay.send(f)
        elif kind == "SUB" and len(words) == 3:
            relay.subscribe(int(words[1]) if words[1].isdigit() else -1, words[2] == "1")
        elif kind == "C" and len(words) == 3:
            reply, stop = request(plant, relay, words[2])
            link.send(wire.json_line("R", reply, int(words[1]) if words[1].isdigit() else 0))
            if stop:
                break
    stopping.set()
    return final(plant, relay)


def request(plant: Plant, relay: Relay, text: str) -> tuple[dict, bool]:
    import json

    try:
        req = json.loads(text)
        op = req["op"]
    except (ValueError, KeyError, TypeError):
        return {"ok": False, "answer": "a request is JSON with an op"}, False
    if op == "inject":
        return plant.inject(str(req.get("line", ""))), False
    if op == "status":
        st = plant.status()
        st["relay"] = dict(relay.figures(), subscribed=[BUS_NAMES[i] for i, on in enumerate(relay.subscribed) if on])
        return dict(st, ok=True), False
    if op == "stop":
        return {"ok": True, "answer": "stopping"}, True
    return {"ok": False, "answer": f"unknown op {op!r}"}, False


def final(plant: Plant, relay: Relay) -> dict:
    st = plant.stop()
    st["relay"] = relay.figures()
    st["tails"] = {k: list(v)[-12:] for k, v in plant.tails.items()}
    return st


def _open_link(args) -> Link:
    if args.tty:
        import tty

        fd = os.open(args.tty, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(fd)
        return Link(fd, fd)
    r, w = (int(x) for x in args.fds.split(","))
    return Link(r, w)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m stewart.sim.agent")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--tty", help="the link's console (raw mode)")
    g.add_argument("--fds", help="the link's file descriptors IN,OUT")
    ap.add_argument("--out", required=True, help="directory for the processes' output")
    ap.add_argument("--key", required=True, help="the machine key file")
    ap.add_argument("--build", help="the host build (default: build/host-release)")
    ap.add_argument("--relax", type=int, help="feedback and setpoint supervision, ticks")
    ap.add_argument("--operator-timeout", type=int)
    args = ap.parse_args(argv)
    link = _open_link(args)
    try:
        relay = Relay(link)
    except OSError as e:
        link.send(wire.json_line("BYE", {"ok": False, "error": f"cannot open the buses: {e}"}))
        link.close()
        return 1
    realtime = may_use_realtime()
    if realtime:
        leave_time_to_others()
    try:
        plant = Plant(Path(args.out), Path(args.key), args.build, args.relax, realtime, args.operator_timeout)
        plant.start()
    except (SimError, FileNotFoundError) as e:
        link.send(wire.json_line("BYE", {"ok": False, "error": str(e)}))
        link.close()
        return 1
    if realtime:  # after the pair's start: the processes it started do not inherit it
        raise_priority()
    link.send(wire.json_line("READY", {"controller": plant.commands()[0], "plant": plant.commands()[1],
                                       "realtime": realtime, "pid": os.getpid()}))
    figures = serve(link, plant, relay)
    relay.close()
    link.send(wire.json_line("BYE", dict(figures, ok=True)))
    link.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
