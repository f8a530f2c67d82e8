# SPDX-License-Identifier: Apache-2.0
"""A socketcand server on loopback for python-can's ``socketcand``
interface: the simulated buses to any python-can program on the host.

    can.Bus(interface="socketcand", host="127.0.0.1", port=29536, channel="vcan0")

What python-can's client (4.6.1) speaks, in raw mode: the server greets
``< hi >``; the client sends ``< open CHANNEL >`` and ``< rawmode >``, each
answered ``< ok >``; then the server sends every frame of the bus as
``< frame ID SECONDS.MICROS DATA >`` (DATA hexadecimal, contiguous) and the
client sends ``< send ID LENGTH B0 B1 ... >``. Also ``< echo >``. CHANNEL is
vcan0, vcan1, vcan2 or the bus's name (ops, axis_a, axis_b).

CAN FD: python-can's client marks no frame as CAN FD (no FD or bit-rate
switch flag either way), but it carries any length of data: this server
sends the buses' 64-byte frames whole, and takes frames of up to 64 bytes,
which go on the simulated buses (all three are CAN FD) as CAN FD frames
with bit-rate switch, padded to a CAN FD length. docs/guides/simulator.md
says what that means for a program.

A frame one client sends reaches the bus and every other client of that
bus, as on a real bus; a client's own frames do not come back to it. A
client that does not keep up loses frames (counted) rather than holding
the others up.

Time stamps: a frame's is when ``stewart sim`` had it from the agent (the
host's clock; the bus's own time is the user-mode Linux's, which falls
behind the host's when it is starved). A client's own frame reaches the
bus some time after it sent it (the relay into the
user-mode Linux: milliseconds, seconds on a starved machine); the frames
the bus carried before it arrived are stamped, for that client, before its
send (HOLD_BACK seconds before the server had it). So a program that
counts the answers stamped after its send (``stewart op`` does) counts
none that came before its frame was on the bus. Only frames that are
answered hold stamps back: those the DBC sends on an event (commands,
frames, reach queries). A heartbeat or a streamed target is answered by
nothing; had they held stamps back, a client that sends one every 20 ms
(the console) would see every frame two seconds old, its answers too.
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Callable

from .. import protocol as pr
from . import wire

DEFAULT_PORT = 29536
#: Frames queued for a client that does not read: beyond, frames are dropped.
CLIENT_QUEUE_BYTES = 4 << 20
#: How far before the server had a client's frame the frames that preceded
#: it on the bus are stamped for that client, s.
HOLD_BACK = 2.0
#: IDs of the frames a client may wait an answer to: the DBC's event frames.
ANSWERED_IDS = frozenset(m.frame_id for m in pr.Protocol().db.messages if m.send_type == "Event")
_CHANNELS = {**{v: i for i, v in enumerate(pr.BUSES.values())}, **{k: i for i, k in enumerate(pr.BUSES)}}


def channel_bus(name: str) -> int | None:
    """The bus index (0 ops, 1 axis_a, 2 axis_b) of a channel name, or None."""
    return _CHANNELS.get(name.strip())


def format_frame(f: wire.Frame, stamp: float | None = None) -> bytes:
    ident = f"{f.can_id:08X}" if f.extended else f"{f.can_id:03X}"
    return f"< frame {ident} {f.time if stamp is None else stamp:.6f} {f.data.hex().upper()} >".encode()


def parse_send(words: list[str], bus: int) -> wire.Frame:
    """A frame from ``< send ID LENGTH B0 B1 ... >`` (the words inside the brackets, ``send`` excluded)."""
    try:
        ident, n = words[0], int(words[1], 16)
        data = bytes(int(b, 16) for b in words[2:])
    except (IndexError, ValueError):
        raise wire.WireError("send: ID, length and bytes in hexadecimal") from None
    can_id = int(ident, 16)
    ext = len(ident) > 3 or can_id > 0x7FF
    if n != len(data) or n > 64 or can_id > 0x1FFFFFFF:
        raise wire.WireError(f"send: {n} bytes announced, {len(data)} given (at most 64)")
    return wire.Frame(bus, can_id, wire.FD | wire.BRS | (wire.EXT if ext else 0), data, time.time())


#: The server writes in blocks of python-can's read size, each ending with a
#: whole message (the last one padded with spaces before its ``>``): its
#: client then never reads half a message (which it would log as a warning).
BLOCK = 1024


def blocks(messages: list[bytes]) -> bytes:
    """``messages`` (each ``< ... >``, shorter than BLOCK) as whole blocks."""
    out: list[bytes] = []
    block: list[bytes] = []
    size = 0
    for m in messages:
        if size + len(m) > BLOCK:
            last = block[-1]
            block[-1] = last[:-1] + b" " * (BLOCK - size) + b">"
            out += block
            block, size = [], 0
        block.append(m)
        size += len(m)
    if block:
        last = block[-1]
        block[-1] = last[:-1] + b" " * (BLOCK - size) + b">"
        out += block
    return b"".join(out)


class Client:
    """One TCP connection: its bus once opened, its queue of frames out."""

    def __init__(self, sock: socket.socket, bridge: "Bridge"):
        self.sock, self.bridge = sock, bridge
        self.bus: int | None = None
        self.raw = False
        self.dropped = 0
        self._out: list[bytes] = []
        self._queued = 0
        self._cond = threading.Condition()
        self._closed = False
        #: its frames sent, in order: [time the server had it, time on the
        #: bus (None: not yet), whether it is answered (ANSWERED_IDS)]
        self.sends: list[list] = []

    def holds_back(self) -> bool:
        return any(answered for _, _, answered in self.sends)

    def stamp(self, t: float) -> float:
        """The time stamp of a frame of bus time ``t`` for this client: held
        back before its answered sends that were not on the bus yet at ``t``."""
        s = t
        for had, on_bus, answered in self.sends:
            if answered and (on_bus is None or t < on_bus):
                s = min(s, had - HOLD_BACK)
        if self.sends and self.sends[0][1] is not None and t - self.sends[0][1] > 0.5:
            self.sends = [x for x in self.sends if x[1] is None or t - x[1] <= 0.5]
        return s

    def push(self, messages: list[bytes]) -> None:
        with self._cond:
            if self._queued > CLIENT_QUEUE_BYTES:
                self.dropped += len(messages)
                return
            self._out += messages
            self._queued += sum(len(m) for m in messages)
            self._cond.notify()

    def writer(self) -> None:
        while True:
            with self._cond:
                while not self._out and not self._closed:
                    self._cond.wait(0.5)
                if self._closed:
                    return
                messages, self._out, self._queued = self._out, [], 0
            try:
                self.sock.sendall(blocks(messages))
            except OSError:
                self.close()
                return

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify()
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.bridge.forget(self)


class Bridge:
    """The server: ``send_frame(frame, client)`` is called with every frame a
    client sends (to the bus; :meth:`on_bus` is to be told when it is there); :meth:`deliver` gives it the bus's frames;
    ``subscribe(bus, on)`` is told when a bus gets its first client or
    loses its last."""

    def __init__(self, send_frame: Callable[[wire.Frame, "Client"], None], subscribe: Callable[[int, bool], None],
                 host: str = "127.0.0.1", port: int = DEFAULT_PORT):
        self.send_frame, self.subscribe = send_frame, subscribe
        self.server = socket.create_server((host, port), reuse_port=False)
        self.port = self.server.getsockname()[1]
        self.clients: list[Client] = []
        self.lock = threading.Lock()
        self.bad = 0
        self._thread = threading.Thread(target=self._accept, daemon=True)
        self._thread.start()

    def close(self) -> None:
        try:
            self.server.close()
        except OSError:
            pass
        for c in list(self.clients):
            c.close()

    def listeners(self, bus: int) -> int:
        with self.lock:
            return sum(1 for c in self.clients if c.raw and c.bus == bus)

    def deliver(self, frames: list[wire.Frame], skip: Client | None = None) -> None:
        """The bus's frames to every raw-mode client of their bus."""
        parts: dict[int, list[bytes]] = {}
        for f in frames:
            parts.setdefault(f.bus, []).append(format_frame(f))
        with self.lock:
            targets = [c for c in self.clients if c.raw and c.bus in parts and c is not skip]
            for c in targets:
                if c.holds_back():
                    c.push([format_frame(f, c.stamp(f.time)) for f in frames if f.bus == c.bus])
                else:
                    c.push(parts[c.bus])

    def on_bus(self, c: Client, t: float | None) -> None:
        """Client ``c``'s oldest frame not yet on the bus is there since ``t``
        (None: it was dropped on the way)."""
        with self.lock:
            for entry in c.sends:
                if entry[1] is None:
                    if t is None or not entry[2]:  # dropped, or no answer to tell from what came before
                        c.sends.remove(entry)
                    else:
                        entry[1] = t
                    return

    def forget(self, c: Client) -> None:
        with self.lock:
            if c not in self.clients:
                return
            self.clients.remove(c)
            last = c.raw and c.bus is not None and not any(x.raw and x.bus == c.bus for x in self.clients)
        if last:
            self.subscribe(c.bus, False)

    def _accept(self) -> None:
        while True:
            try:
                sock, _ = self.server.accept()
            except OSError:
                return
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            c = Client(sock, self)
            with self.lock:
                self.clients.append(c)
            threading.Thread(target=self._serve, args=(c,), daemon=True).start()

    def _serve(self, c: Client) -> None:
        try:
            c.sock.sendall(b"< hi >")
            buf = b""
            while True:
                chunk = c.sock.recv(65536)
                if not chunk:
                    break
                buf += chunk
                while b">" in buf:
                    msg, buf = buf.split(b">", 1)
                    start = msg.find(b"<")
                    if start >= 0:
                        self._command(c, msg[start + 1:].decode("ascii", "replace").split())
                if len(buf) > 4096:
                    buf = b""
        except OSError:
            pass
        finally:
            c.close()

    def _command(self, c: Client, words: list[str]) -> None:
        if not words:
            return
        cmd = words[0]
        if cmd == "open" and len(words) == 2 and channel_bus(words[1]) is not None:
            c.bus = channel_bus(words[1])
            c.sock.sendall(b"< ok >")
        elif cmd == "rawmode" and c.bus is not None:
            c.sock.sendall(b"< ok >")
            time.sleep(0.1)  # python-can reads the "< ok >" alone before frames may follow
            first = self.listeners(c.bus) == 0
            c.raw = True
            threading.Thread(target=c.writer, daemon=True).start()
            if first:
                self.subscribe(c.bus, True)
        elif cmd == "send" and c.bus is not None:
            try:
                f = parse_send(words[1:], c.bus)
            except wire.WireError:
                self.bad += 1  # counted, not answered: python-can's client takes any "< error" for a frame
                return
            with self.lock:
                c.sends.append([time.time(), None, f.can_id in ANSWERED_IDS])
            self.send_frame(f, c)
            self.deliver([f], skip=c)
        elif cmd == "echo":
            c.sock.sendall(b"< echo >")
        elif cmd == "open":
            names = ", ".join([*pr.BUSES.values(), *pr.BUSES])
            c.sock.sendall(f"< error unknown channel: use one of {names} >".encode())
        else:
            self.bad += 1  # not served (raw mode only); no answer, as above
