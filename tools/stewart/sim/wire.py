# SPDX-License-Identifier: Apache-2.0
"""The link between ``stewart sim`` on the host and its agent beside the
buses: ASCII lines over a byte stream (a UML console channel, or pipes).

One message a line, the first word its kind:

``F BUS ID FLAGS DATA [TIME]``
    a CAN frame: BUS 0..2 (ops, axis_a, axis_b), ID hexadecimal (3 digits:
    standard, 8: extended), FLAGS a number (1 CAN FD, 2 bit-rate switch,
    4 extended), DATA hexadecimal (0..64 bytes; ``-`` for none), TIME the
    agent's receive time (s since the epoch; only from the agent).
``SUB BUS 0|1``
    (host to agent) relay that bus's frames to the host, or stop.
``K``
    (host to agent) every second: the host is there (the agent stops the
    simulation after a minute without a line from the host).
``C N JSON`` / ``R N JSON``
    a control request (``{"op": "inject", "line": ...}``, ``{"op":
    "status"}``, ``{"op": "stop"}``) and its reply, matched by N.
``A BUS TIME``
    (agent to host) the host's oldest frame for bus BUS not acknowledged yet
    is on that bus since TIME, or was refused (one for each ``F`` line the
    agent got, in order per bus). On a bus the host listens to, the ``A``
    comes in the bus's order among its ``F`` lines: every frame relayed
    before it was on the bus before the host's frame, every one after it
    came later.
``READY JSON`` / ``BYE JSON`` / ``L TEXT``
    (agent to host) the simulation runs (what it runs); it has ended (the
    final figures); a line of its log.

The link carries text only, so a console's line discipline cannot alter
it (the agent puts its tty in raw mode anyway).
"""

from __future__ import annotations

import json
import os
import socket
import struct
from dataclasses import dataclass

FD, BRS, EXT = 1, 2, 4
#: CAN FD data lengths (a frame is padded with zeros to the next one).
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
MAX_LINE = 400


class WireError(ValueError):
    """A line that is not a message of the link."""


@dataclass
class Frame:
    bus: int
    can_id: int
    flags: int
    data: bytes
    time: float = 0.0

    @property
    def extended(self) -> bool:
        return bool(self.flags & EXT)


def fd_length(n: int) -> int:
    """The CAN FD length that holds ``n`` bytes (``n`` <= 64)."""
    for k in FD_LENGTHS:
        if k >= n:
            return k
    raise WireError(f"a CAN frame holds at most 64 bytes, not {n}")


def frame_line(f: Frame, with_time: bool = True) -> str:
    ident = f"{f.can_id:08X}" if f.extended else f"{f.can_id:03X}"
    data = f.data.hex() or "-"
    tail = f" {f.time:.6f}" if with_time else ""
    return f"F {f.bus} {ident} {f.flags} {data}{tail}\n"


def parse_frame(words: list[str]) -> Frame:
    """A frame from the words of an ``F`` line (the ``F`` excluded)."""
    if len(words) not in (4, 5):
        raise WireError("a frame line has 4 or 5 fields")
    try:
        bus, can_id, flags = int(words[0]), int(words[1], 16), int(words[2])
        data = b"" if words[3] == "-" else bytes.fromhex(words[3])
        t = float(words[4]) if len(words) == 5 else 0.0
    except ValueError:
        raise WireError("a frame line's fields are not numbers") from None
    if not 0 <= bus <= 2 or len(data) > 64 or can_id > 0x1FFFFFFF or (can_id > 0x7FF and not flags & EXT):
        raise WireError("a frame out of range")
    return Frame(bus, can_id, flags, data, t)


def json_line(kind: str, obj, n: int | None = None) -> str:
    text = json.dumps(obj, separators=(",", ":"))
    return f"{kind} {n} {text}\n" if n is not None else f"{kind} {text}\n"


# ------------------------------------------------------------ SocketCAN raw

CAN_EFF_FLAG = 0x80000000
CAN_RTR_FLAG = 0x40000000
CAN_ERR_FLAG = 0x20000000
CANFD_BRS = 0x01
_CAN_RAW_FD_FRAMES = 5
_SOL_CAN_RAW = 101


def raw_socket(interface: str, rcvbuf: int = 8 << 20) -> socket.socket:
    """A CAN_RAW socket on ``interface`` taking CAN FD frames (queue of
    ``rcvbuf`` bytes where allowed)."""
    s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    s.setsockopt(_SOL_CAN_RAW, _CAN_RAW_FD_FRAMES, 1)
    try:
        s.setsockopt(socket.SOL_SOCKET, getattr(socket, "SO_RCVBUFFORCE", 33), rcvbuf)
    except OSError:
        pass
    s.bind((interface,))
    return s


_CAN_RAW_FILTER = 1
_CAN_RAW_RECV_OWN_MSGS = 4
#: recvmsg's flag on a frame this very socket sent (CAN_RAW_RECV_OWN_MSGS on).
MSG_CONFIRM = getattr(socket, "MSG_CONFIRM", 0x800)


def receive_own(s: socket.socket) -> None:
    """Raw socket ``s`` also reads the frames it sends, when they are on the
    bus (flagged MSG_CONFIRM), in the bus's order (when its filter takes them)."""
    s.setsockopt(_SOL_CAN_RAW, _CAN_RAW_RECV_OWN_MSGS, 1)


def set_receive(s: socket.socket, on: bool) -> None:
    """Every frame (on) or none (off, an empty filter list) on raw socket ``s``."""
    s.setsockopt(_SOL_CAN_RAW, _CAN_RAW_FILTER, struct.pack("=II", 0, 0) if on else b"")


def unpack_raw(bus: int, raw: bytes, t: float) -> Frame | None:
    """A frame read from a raw socket (16 bytes classic, 72 FD); None for
    error and remote frames."""
    can_id, length, fd_flags = struct.unpack_from("=IBB", raw)
    if can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG):
        return None
    ext = bool(can_id & CAN_EFF_FLAG)
    flags = (EXT if ext else 0)
    if len(raw) == 72:
        flags |= FD | (BRS if fd_flags & CANFD_BRS else 0)
    data = raw[8:8 + min(length, 64)]
    return Frame(bus, can_id & (0x1FFFFFFF if ext else 0x7FF), flags, bytes(data), t)


def pack_raw(f: Frame) -> bytes:
    """The raw socket's bytes of ``f``: a CAN FD frame when it is one or
    longer than 8 bytes, else a classic one."""
    can_id = f.can_id | (CAN_EFF_FLAG if f.extended else 0)
    if f.flags & FD or len(f.data) > 8:
        n = fd_length(len(f.data))
        return struct.pack("=IBBBB64s", can_id, n, CANFD_BRS if f.flags & BRS else 0, 0, 0,
                           f.data.ljust(n, b"\0"))
    return struct.pack("=IBBBB8s", can_id, len(f.data), 0, 0, 0, f.data)


class BatchReader:
    """Reads up to ``batch`` frames from a raw socket in one system call
    (Linux's recvmmsg, through ctypes: Python's socket module has none).
    Inside user-mode Linux a system call costs tens of microseconds of a
    CPU the 1 kHz pair shares: the three buses carry about 13,000 frames a
    second, one recvmsg each would take most of it."""

    def __init__(self, sock: socket.socket, batch: int = 64):
        import ctypes

        class IoVec(ctypes.Structure):
            _fields_ = [("base", ctypes.c_void_p), ("len", ctypes.c_size_t)]

        class MsgHdr(ctypes.Structure):
            _fields_ = [("name", ctypes.c_void_p), ("namelen", ctypes.c_uint32),
                        ("iov", ctypes.POINTER(IoVec)), ("iovlen", ctypes.c_size_t),
                        ("control", ctypes.c_void_p), ("controllen", ctypes.c_size_t),
                        ("flags", ctypes.c_int)]

        class MMsgHdr(ctypes.Structure):
            _fields_ = [("hdr", MsgHdr), ("len", ctypes.c_uint)]

        self._ctypes = ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        self._call = libc.recvmmsg
        self._call.argtypes = [ctypes.c_int, ctypes.POINTER(MMsgHdr), ctypes.c_uint, ctypes.c_int, ctypes.c_void_p]
        self._call.restype = ctypes.c_int
        self.sock, self.batch = sock, batch
        self._bufs = [ctypes.create_string_buffer(72) for _ in range(batch)]
        self._iovs = (IoVec * batch)()
        self._msgs = (MMsgHdr * batch)()
        for i in range(batch):
            self._iovs[i].base = ctypes.addressof(self._bufs[i])
            self._iovs[i].len = 72
            self._msgs[i].hdr.iov = ctypes.pointer(self._iovs[i])
            self._msgs[i].hdr.iovlen = 1

    def read(self) -> list[tuple[bytes, int]]:
        """The frames waiting (at most ``batch``), each as (raw bytes,
        recvmsg flags); none when nothing waits. OSError on a failure."""
        n = self._call(self.sock.fileno(), self._msgs, self.batch, socket.MSG_DONTWAIT, None)
        if n < 0:
            err = self._ctypes.get_errno()
            if err in (11, 4):  # EAGAIN, EINTR
                return []
            raise OSError(err, os.strerror(err))
        return [(self._bufs[i].raw[:self._msgs[i].len], self._msgs[i].hdr.flags) for i in range(n)]
