# SPDX-License-Identifier: Apache-2.0
"""Pose sources of ``stewart op stream``: a timestamped CSV file, and UDP
datagrams from motion software (docs/guides/operator.md has the formats).

UDP datagrams, one per pose (or per telemetry sample in cueing mode), each
with a 32-bit sequence number that the sender increments by one per
datagram (wrapping at 2^32):

- text (UTF-8/ASCII): ``SEQ X Y Z ROLL PITCH YAW`` (whitespace or commas;
  m and rad; a trailing newline allowed); cueing: ``SEQ AX AY AZ WX WY WZ``
  (specific force m/s^2 and angular rate rad/s, vehicle axes x forward, y
  left, z up);
- binary, little-endian, 56 bytes: the magic ``b"SPP1"`` (pose) or
  ``b"SPC1"`` (cueing telemetry), uint32 SEQ, then six float64 as above.

A datagram whose SEQ is not newer than the last one taken (within half the
number space) is dropped: ``duplicate`` when equal, ``late`` when older
(out of order); a jump forward counts the skipped numbers as ``lost``; an
unreadable datagram (wrong size, bad magic, not six finite numbers) is
``bad``.
"""

from __future__ import annotations

import csv
import math
import socket
import struct
from dataclasses import dataclass, field

POSE_MAGIC = b"SPP1"
CUE_MAGIC = b"SPC1"
BINARY = struct.Struct("<4sI6d")
SEQ_MOD = 1 << 32


class SourceError(Exception):
    """A pose source that cannot be used (message for the user)."""


# -- CSV ---------------------------------------------------------------------

@dataclass
class PoseTrack:
    """Poses at increasing times; :meth:`at` interpolates linearly."""

    t: list[float]
    poses: list[list[float]]

    @property
    def duration(self) -> float:
        return self.t[-1] - self.t[0]

    def at(self, time_s: float, _hint: list[int] = [0]) -> list[float]:  # noqa: B006 - a cursor
        t = self.t
        if time_s <= t[0]:
            return list(self.poses[0])
        if time_s >= t[-1]:
            return list(self.poses[-1])
        i = _hint[0] if 0 <= _hint[0] < len(t) - 1 and t[_hint[0]] <= time_s else 0
        while t[i + 1] < time_s:
            i += 1
        _hint[0] = i
        a = (time_s - t[i]) / (t[i + 1] - t[i])
        p, q = self.poses[i], self.poses[i + 1]
        return [p[k] + a * (q[k] - p[k]) for k in range(6)]


CSV_COLUMNS = ("t", "x", "y", "z", "roll", "pitch", "yaw")


def read_pose_csv(path) -> PoseTrack:
    """A CSV with a header naming t (s), x, y, z (m), roll, pitch, yaw (rad),
    times strictly increasing; raises SourceError naming the line."""
    try:
        f = open(path, newline="")
    except OSError as e:
        raise SourceError(f"{path}: cannot read: {e.strerror}") from None
    with f:
        rows = csv.reader(line for line in f if line.strip() and not line.lstrip().startswith("#"))
        try:
            header = [h.strip().lower() for h in next(rows)]
        except StopIteration:
            raise SourceError(f"{path}: empty file") from None
        except csv.Error as e:
            raise SourceError(f"{path}: not CSV: {e}") from None
        if "time" in header and "t" not in header:
            header[header.index("time")] = "t"
        missing = [c for c in CSV_COLUMNS if c not in header]
        if missing:
            raise SourceError(f"{path}: header must name {', '.join(CSV_COLUMNS)}; missing {', '.join(missing)}")
        idx = [header.index(c) for c in CSV_COLUMNS]
        ts: list[float] = []
        poses: list[list[float]] = []
        try:
            for n, row in enumerate(rows, start=2):
                try:
                    vals = [float(row[i]) for i in idx]
                except (IndexError, ValueError):
                    raise SourceError(f"{path}: line {n}: expected 7 numbers in columns "
                                      f"{', '.join(CSV_COLUMNS)}") from None
                if not all(math.isfinite(v) for v in vals):
                    raise SourceError(f"{path}: line {n}: not a finite number")
                if ts and vals[0] <= ts[-1]:
                    raise SourceError(f"{path}: line {n}: time {vals[0]:g} s is not after {ts[-1]:g} s")
                ts.append(vals[0])
                poses.append(vals[1:])
        except csv.Error as e:
            raise SourceError(f"{path}: not CSV: {e}") from None
    if len(ts) < 2:
        raise SourceError(f"{path}: needs at least two poses")
    return PoseTrack(ts, poses)


# -- UDP -----------------------------------------------------------------------

@dataclass
class UdpCounters:
    accepted: int = 0
    duplicate: int = 0
    late: int = 0
    lost: int = 0
    bad: int = 0
    last_bad: str = ""

    def line(self) -> str:
        return (f"datagrams accepted {self.accepted}, duplicate {self.duplicate}, late {self.late}, "
                f"lost {self.lost}, bad {self.bad}")


def parse_datagram(data: bytes, cueing: bool = False) -> tuple[int, list[float]]:
    """(seq, six values) of one datagram; ValueError with the reason."""
    magic = CUE_MAGIC if cueing else POSE_MAGIC
    other = POSE_MAGIC if cueing else CUE_MAGIC
    if data[:4] in (magic, other):
        if data[:4] == other:
            raise ValueError("a " + ("pose" if cueing else "cueing telemetry") + " datagram "
                             + ("without --cueing" if not cueing else "with --cueing"))
        if len(data) != BINARY.size:
            raise ValueError(f"binary datagram of {len(data)} bytes, expected {BINARY.size}")
        _, seq, *vals = BINARY.unpack(data)
    else:
        try:
            text = data.decode("ascii").strip()
        except UnicodeDecodeError:
            raise ValueError("neither the binary format nor ASCII text") from None
        parts = text.replace(",", " ").split()
        if len(parts) != 7:
            raise ValueError(f"text datagram with {len(parts)} fields, expected 7 (SEQ and six values)")
        try:
            seq = int(parts[0])
            vals = [float(p) for p in parts[1:]]
        except ValueError:
            raise ValueError("text datagram: SEQ must be an integer and the six values numbers") from None
        if not 0 <= seq < SEQ_MOD:
            raise ValueError("SEQ outside 0..2^32-1")
    if not all(math.isfinite(v) for v in vals):
        raise ValueError("a value is not finite")
    return seq, list(vals)


def encode_datagram(seq: int, values, cueing: bool = False, binary: bool = True) -> bytes:
    """A datagram in the documented format (for senders and tests)."""
    if binary:
        return BINARY.pack(CUE_MAGIC if cueing else POSE_MAGIC, seq % SEQ_MOD, *map(float, values))
    return (f"{seq % SEQ_MOD} " + " ".join(f"{float(v):.9g}" for v in values) + "\n").encode()


@dataclass
class SequenceFilter:
    """Takes a sequence number when newer than the last one taken."""

    counters: UdpCounters = field(default_factory=UdpCounters)
    last: int | None = None

    def take(self, seq: int) -> bool:
        c = self.counters
        if self.last is None:
            self.last = seq
            c.accepted += 1
            return True
        d = (seq - self.last) % SEQ_MOD
        if d == 0:
            c.duplicate += 1
            return False
        if d >= SEQ_MOD // 2:
            c.late += 1
            return False
        c.lost += d - 1
        c.accepted += 1
        self.last = seq
        return True


def parse_host_port(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep:
        raise SourceError(f"--udp {text!r}: expected HOST:PORT")
    try:
        p = int(port)
    except ValueError:
        raise SourceError(f"--udp {text!r}: the port is not a number") from None
    if not 0 <= p <= 65535:
        raise SourceError(f"--udp {text!r}: port outside 0..65535")
    return host.strip("[]") or "0.0.0.0", p


class UdpSource:
    """Non-blocking UDP receiver of poses or telemetry."""

    def __init__(self, host: str, port: int, cueing: bool = False):
        self.cueing = cueing
        self.filter = SequenceFilter()
        try:
            info = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)[0]
            self.sock = socket.socket(info[0], socket.SOCK_DGRAM)
            self.sock.bind(info[4])
        except OSError as e:
            raise SourceError(f"cannot listen on UDP {host}:{port}: {e.strerror or e}") from None
        self.sock.setblocking(False)
        self.address = self.sock.getsockname()

    @property
    def counters(self) -> UdpCounters:
        return self.filter.counters

    def poll(self) -> list[float] | None:
        """Reads every waiting datagram; the newest valid values taken, or None."""
        newest = None
        while True:
            try:
                data = self.sock.recv(2048)
            except BlockingIOError:
                return newest
            except OSError:
                return newest
            try:
                seq, vals = parse_datagram(data, self.cueing)
            except ValueError as e:
                self.counters.bad += 1
                self.counters.last_bad = str(e)
                continue
            if self.filter.take(seq):
                newest = vals

    def close(self) -> None:
        self.sock.close()
