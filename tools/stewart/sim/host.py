# SPDX-License-Identifier: Apache-2.0
"""The ``stewart sim`` process on the host: starts the agent beside the
buses (inside a user-mode Linux, or as a child where the host has vcan),
serves the buses on loopback (:mod:`stewart.sim.bridge`) and the control
socket (:mod:`stewart.sim.control`), and stops it all cleanly on SIGINT,
SIGTERM or ``stewart sim stop``."""

from __future__ import annotations

import collections
import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from .. import auth, protocol as pr, vcan
from . import bridge as br, control, wire

#: The link's console inside the UML (con3: vcan.run_uml's first extra console).
UML_TTY = "/dev/tty3"
#: A bus's relay stays on this long after its last client left, s.
LINGER = 30.0
#: Frames queued for the agent beyond this many bytes are dropped (a
#: starved agent must not block the bridge, nor a stop request behind them).
LINK_QUEUE_BYTES = 256 << 10


class LinkOut:
    """Lines to the agent, written by a thread on a non-blocking pipe:
    frames are dropped (counted) when the queue is full; control lines
    never are."""

    def __init__(self, fd: int):
        self.fd = fd
        os.set_blocking(fd, False)
        self.lines: list[bytes] = []
        self.queued = 0
        self.dropped = 0
        self.closed = False
        self.cond = threading.Condition()
        threading.Thread(target=self._loop, daemon=True).start()

    def put(self, line: str, droppable: bool = False) -> bool:
        data = line.encode()
        with self.cond:
            if self.closed or (droppable and self.queued > LINK_QUEUE_BYTES):
                self.dropped += 1
                return False
            self.lines.append(data)
            self.queued += len(data)
            self.cond.notify()
            return True

    def close(self) -> None:
        with self.cond:
            self.closed = True
            self.cond.notify()

    def _loop(self) -> None:
        import select

        pending = b""
        while True:
            with self.cond:
                while not self.lines and not pending and not self.closed:
                    self.cond.wait(0.5)
                if self.closed:
                    return
                pending += b"".join(self.lines)
                self.lines, self.queued = [], 0
            try:
                n = os.write(self.fd, pending)
                pending = pending[n:]
            except BlockingIOError:
                select.select([], [self.fd], [], 0.2)
            except OSError:
                with self.cond:
                    self.closed = True
                return


@dataclass
class Options:
    run_dir: Path
    port: int = br.DEFAULT_PORT
    backend: str = "auto"  #: auto, host or uml
    relax: int | None = None  #: supervision in ticks; None: 50 in the UML, the config's on the host
    mem: str = "1G"
    key: Path | None = None
    build: str | None = None
    operator_timeout: int | None = None
    bridge: bool = True
    ready_timeout: float = 180.0


def default_run_dir() -> Path:
    from ..uml import user_cache_dir

    return user_cache_dir() / "sim"


def run_files(run_dir: Path) -> dict[str, Path]:
    return {"control": run_dir / "control.sock", "state": run_dir / "sim.json", "canrc": run_dir / "can.ini"}


class Host:
    def __init__(self, opts: Options):
        self.o = opts
        self.files = run_files(opts.run_dir)
        self.replies: dict[int, dict] = {}
        self.cond = threading.Condition()
        self.ready: dict | None = None
        self.bye: dict | None = None
        self.ended = False
        self.n = 0
        self.pgid: int | None = None
        self.child: subprocess.Popen | None = None
        self.created: list[str] = []
        self.backend = ""
        self.bridge: br.Bridge | None = None
        self.server: control.Server | None = None
        self.stop_asked = threading.Event()
        self.out: LinkOut | None = None
        self.sub_gen: dict[int, int] = {}
        self.sent_order: collections.deque = collections.deque()  # (bus, client) of each frame sent
        self.exit_status: int | None = None
        self.link_closed = False

    # -------------------------------------------------------------- start

    def start(self) -> None:
        o = self.o
        o.run_dir.mkdir(parents=True, exist_ok=True)
        self.server = control.Server(self.files["control"], self.handle)  # first: one simulation a run dir
        key = o.key or auth.run_key(o.run_dir)
        self.key = Path(key).resolve()
        choice = vcan.choose(3, o.backend)
        self.backend = choice.backend
        relax = o.relax if o.relax is not None else (50 if self.backend == "uml" else None)
        agent = [sys.executable, "-m", "stewart.sim.agent", "--out", str(o.run_dir.resolve()),
                 "--key", str(self.key)]
        if relax:
            agent += ["--relax", str(relax)]
        if o.build:
            agent += ["--build", str(Path(o.build).resolve())]
        if o.operator_timeout is not None:
            agent += ["--operator-timeout", str(o.operator_timeout)]
        to_agent_r, to_agent_w = os.pipe()
        from_agent_r, from_agent_w = os.pipe()
        self.out, self.link_r = LinkOut(to_agent_w), from_agent_r
        if self.backend == "uml":
            agent += ["--tty", UML_TTY]
            threading.Thread(target=self._run_uml, args=(agent, (to_agent_r, from_agent_w)), daemon=True).start()
        else:
            self._host_buses()
            agent += ["--fds", f"{to_agent_r},{from_agent_w}"]
            self.child = subprocess.Popen(agent, stdin=subprocess.DEVNULL, pass_fds=(to_agent_r, from_agent_w),
                                          start_new_session=True)
            self.pgid = self.child.pid
            os.close(to_agent_r)
            os.close(from_agent_w)
            threading.Thread(target=self._wait_child, daemon=True).start()
        threading.Thread(target=self._read_link, daemon=True).start()
        threading.Thread(target=self._keepalive, daemon=True).start()
        if o.bridge:
            self.bridge = br.Bridge(self._to_bus, self._subscribe, port=o.port)
        self._wait_ready()
        self._write_state(relax)

    def _run_uml(self, agent: list[str], console: tuple[int, int]) -> None:
        open_fds = list(console)

        def started(pgid: int) -> None:
            self.pgid = pgid
            while open_fds:  # linux.uml has its own copies now: its end closes the link
                os.close(open_fds.pop())

        try:
            rc = vcan.run_uml(agent, consoles=[console], on_start=started, timeout=10 * 365 * 86400.0,
                              mem=self.o.mem)
        except (vcan.VcanError, OSError) as e:
            print(f"stewart sim: {e}", file=sys.stderr)
            rc = vcan.EXIT_SETUP
        while open_fds:
            os.close(open_fds.pop())
        self._ended(rc)

    def _wait_child(self) -> None:
        assert self.child is not None
        self._ended(self.child.wait())

    def _ended(self, rc: int) -> None:
        with self.cond:
            self.ended = True
            self.exit_status = rc
            self.cond.notify_all()

    def _host_buses(self) -> None:
        """vcan0..vcan2 on the host: made (CAN FD, MTU 72) where missing."""
        for name in vcan.interface_names(3):
            if vcan._host_link_mtu(name) is None:
                for step in (("link", "add", "dev", name, "type", "vcan"),
                             ("link", "set", "dev", name, "mtu", str(vcan.MTU_FD)),
                             ("link", "set", "dev", name, "up")):
                    r = vcan._ip(*step)
                    if r.returncode != 0:
                        raise vcan.VcanError(f"ip {' '.join(step)}: {r.stderr.strip()}")
                self.created.append(name)

    def _wait_ready(self) -> None:
        end = time.monotonic() + self.o.ready_timeout
        with self.cond:
            while self.ready is None:
                if self.bye is not None or self.ended:
                    why = (self.bye or {}).get("error") or f"the agent ended (status {self.exit_status})"
                    raise vcan.VcanError(f"the simulation did not start: {why}")
                left = end - time.monotonic()
                if left <= 0:
                    raise vcan.VcanError(f"the simulation did not start within {self.o.ready_timeout:g} s")
                self.cond.wait(min(left, 0.2))

    def _write_state(self, relax: int | None) -> None:
        st = {"pid": os.getpid(), "pgid": self.pgid, "backend": self.backend, "key": str(self.key), "relax": relax,
              "control": str(self.files["control"]), "started": time.time(),
              "buses": dict(pr.BUSES), "attach": self.attach()}
        self.files["state"].write_text(json.dumps(st, indent=1) + "\n")
        if self.bridge is not None:
            lines = [f"# python-can configuration of the running stewart sim ({self.files['state']})"]
            for section, channel in [("default", "vcan0"), *((b, c) for b, c in pr.BUSES.items())]:
                lines += [f"[{section}]", "interface = socketcand", "host = 127.0.0.1",
                          f"port = {self.bridge.port}", f"channel = {channel}", "fd = True", ""]
            self.files["canrc"].write_text("\n".join(lines))

    def attach(self) -> dict:
        a: dict = {}
        if self.backend == "host":
            a["socketcan"] = {"interface": "socketcan", "channels": dict(pr.BUSES)}
        if self.bridge is not None:
            a["socketcand"] = {"interface": "socketcand", "host": "127.0.0.1", "port": self.bridge.port,
                               "channels": dict(pr.BUSES), "config": str(self.files["canrc"])}
        return a

    # --------------------------------------------------------------- link

    def _send(self, line: str) -> None:
        if self.out is not None:
            self.out.put(line)

    def _keepalive(self) -> None:
        """``K`` every second: the agent stops the simulation when the host
        is gone (killed outright), rather than leave the UML running."""
        while not self.ended and (self.out is None or not self.out.closed):
            self._send("K\n")
            time.sleep(1.0)

    def _to_bus(self, f: wire.Frame, client) -> None:
        assert self.out is not None and self.bridge is not None
        with self.cond:  # the agent acknowledges the frames in the order they are queued
            if self.out.put(wire.frame_line(f, with_time=False), droppable=True):
                self.sent_order.append((f.bus, client))
                return
        self.bridge.on_bus(client, None)

    def _subscribe(self, bus: int, on: bool) -> None:
        """The relay of a bus on with its first client; off LINGER s after
        its last left (one-shot programs in a row find it warm)."""
        with self.cond:
            self.sub_gen[bus] = self.sub_gen.get(bus, 0) + 1
            gen = self.sub_gen[bus]
        if on:
            self._send(f"SUB {bus} 1\n")
            return

        def later() -> None:
            time.sleep(LINGER)
            with self.cond:
                if self.sub_gen.get(bus) != gen:
                    return
            self._send(f"SUB {bus} 0\n")

        threading.Thread(target=later, daemon=True).start()

    def _read_link(self) -> None:
        buf = b""
        while True:
            try:
                chunk = os.read(self.link_r, 1 << 16)
            except OSError:
                chunk = b""
            if not chunk:
                break
            buf += chunk
            *lines, buf = buf.split(b"\n")
            frames = []
            now = time.time()
            for raw in lines:
                self._line(raw.decode("ascii", "replace").strip(), frames, now)
            if frames and self.bridge is not None:
                self.bridge.deliver(frames)
        with self.cond:
            self.link_closed = True
            self.cond.notify_all()

    def _line(self, line: str, frames: list, now: float) -> None:
        """One line from the agent. Frames are stamped with the host's clock
        when read (the user-mode Linux's clock may fall behind the host's
        when it is starved), and so are the acknowledgements."""
        kind, _, rest = line.partition(" ")
        if kind == "F":
            try:
                f = wire.parse_frame(rest.split())
            except wire.WireError:
                return
            f.time = now
            frames.append(f)
            return
        if kind == "A":
            bus = rest.split()[0] if rest else ""
            self._acknowledged(int(bus) if bus.lstrip("-").isdigit() else -1, now, frames)
            return
        with self.cond:
            if kind == "R":
                n, _, text = rest.partition(" ")
                self.replies[int(n)] = _json(text)
            elif kind == "READY":
                self.ready = _json(rest)
            elif kind == "BYE":
                self.bye = _json(rest)
            elif kind == "L":
                print(f"stewart sim: {_json(rest).get('text', rest)}", file=sys.stderr)
            self.cond.notify_all()

    def _acknowledged(self, bus: int, t: float, frames: list) -> None:
        """The oldest frame sent to bus ``bus`` (-1: whichever is oldest) is
        on it: what came before it goes out first (stamped for its client as
        before its send)."""
        client = None
        with self.cond:
            for i, (b, c) in enumerate(self.sent_order):
                if bus in (b, -1):
                    client = c
                    del self.sent_order[i]
                    break
        if client is None or self.bridge is None:
            return
        if frames:
            self.bridge.deliver(frames)
            frames.clear()
        self.bridge.on_bus(client, t)

    def request(self, req: dict, timeout: float = 30.0) -> dict:
        with self.cond:
            self.n += 1
            n = self.n
        self._send(wire.json_line("C", req, n))
        end = time.monotonic() + timeout
        with self.cond:
            while n not in self.replies:
                left = end - time.monotonic()
                if left <= 0 or self.ended or self.bye is not None:
                    return {"ok": False, "answer": "the simulation did not answer"}
                self.cond.wait(min(left, 0.2))
            return self.replies.pop(n)

    # ------------------------------------------------------------ control

    def handle(self, req: dict) -> dict:
        op = req.get("op")
        if self.ready is None:
            return {"ok": False, "answer": "the simulation is starting"}
        if op == "stop":
            self.stop_asked.set()
            return {"ok": True, "answer": "stopping"}
        if op == "inject":
            line = req.get("line")
            if not isinstance(line, str):
                return {"ok": False, "answer": "inject needs a line (a string)"}
            return self.request({"op": "inject", "line": line})
        if op == "status":
            st = self.request({"op": "status"})
            st.update(backend=self.backend, attach=self.attach(), key=str(self.key), pgid=self.pgid,
                      host_load=[round(x, 2) for x in os.getloadavg()], host_cores=os.cpu_count(),
                      link_dropped=self.out.dropped if self.out is not None else 0)
            if self.bridge is not None:
                st["bridge"] = {"clients": len(self.bridge.clients), "bad": self.bridge.bad,
                                "dropped": sum(c.dropped for c in self.bridge.clients)}
            return st
        return {"ok": False, "answer": f"unknown op {op!r} (status, inject, stop)"}

    # --------------------------------------------------------------- stop

    def wait(self) -> None:
        """Until SIGINT, SIGTERM, a stop request or the simulation's end."""
        def on_signal(signum, frame):
            self.stop_asked.set()

        old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
        try:
            while not self.stop_asked.is_set():
                with self.cond:
                    if self.ended or self.bye is not None:
                        return
                self.stop_asked.wait(0.5)
        finally:
            for s, h in old.items():
                signal.signal(s, h)

    def stop(self, timeout: float = 30.0) -> dict:
        """Asks the agent to stop (the pair's summaries), waits for the UML
        to halt; kills what is left after ``timeout``. The final figures."""
        end = time.monotonic() + timeout
        if self.bye is None and not self.ended:
            self.request({"op": "stop"}, timeout=timeout * 0.7)
        with self.cond:
            while not self.ended and time.monotonic() < end:
                self.cond.wait(0.2)
        if not self.ended and self.pgid is not None:
            print("stewart sim: the simulation did not end in time: killed", file=sys.stderr)
            try:
                os.killpg(self.pgid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            with self.cond:
                while not self.ended and time.monotonic() < end + 10:
                    self.cond.wait(0.2)
        self.close()
        return self.bye or {"ok": False, "error": "no final figures (the agent ended without them)"}

    def abort(self) -> None:
        """After a failed start: whatever runs is stopped."""
        if self.ready is not None or (self.pgid is not None and not self.ended):
            self.stop(timeout=20)
        else:
            self.close()

    def close(self) -> None:
        if self.out is not None:
            self.out.close()
        if self.bridge is not None:
            self.bridge.close()
        if self.server is not None:  # the run directory is ours: its files go
            self.server.close()
            for p in (self.files["state"], self.files["canrc"]):
                try:
                    p.unlink()
                except OSError:
                    pass
        for name in self.created:
            vcan._ip("link", "del", "dev", name)


def _json(text: str) -> dict:
    try:
        v = json.loads(text)
        return v if isinstance(v, dict) else {"value": v}
    except ValueError:
        return {"text": text}
