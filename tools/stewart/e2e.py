# SPDX-License-Identifier: Apache-2.0
"""End-to-end protection of the CAN frames: CRCs and the alive-counter check.

The pattern of the AUTOSAR E2E profiles, as fixed for this project
(docs/reference/protocol.md, section "E2E protection"):

* every message carries a 4-bit ``Counter`` (+1 modulo 16 per transmission of
  that message by its sender) and a ``Crc`` in its last byte(s);
* frames of at most 12 bytes use CRC-8 SAE J1850 (poly 0x1D, init 0xFF,
  xorout 0xFF) in the last byte; longer frames use CRC-16/CCITT-FALSE (poly
  0x1021, init 0xFFFF, no xorout) in the last two bytes, little-endian;
* the CRC covers the data ID (the 11-bit CAN ID as two bytes, little-endian),
  then every payload byte before the CRC bytes, so a frame that arrives on the
  wrong ID fails its CRC.

The receiver's counter check (:class:`E2EReceiver`) is a small state machine,
one per message and sender (per bus):

========================  ==================================  =========
counter delta (mod 16)    status                              delivered
========================  ==================================  =========
no reference yet          ``init`` (first frame, or resync)   yes
1                         ``ok``                              yes
2 or 3                    ``lost`` (delta - 1 frames lost)    yes
0                         ``repeated``                        no
4 .. 15                   ``wrong-sequence``; drop reference  no
========================  ==================================  =========

After a wrong sequence the receiver has no reference: the next frame is
accepted as ``init`` and becomes the reference (resynchronisation on the next
frame). A frame with a bad CRC never reaches the counter check.
"""

from __future__ import annotations

import binascii

from dataclasses import dataclass

import numpy as np

#: Frames up to this many bytes carry a CRC-8; longer frames a CRC-16.
CRC8_MAX_LEN = 12
COUNTER_MODULO = 16
#: Largest counter delta still accepted (delta - 1 frames were lost).
MAX_DELTA = 3

# Receiver statuses.
INIT = "init"
OK = "ok"
LOST = "lost"
REPEATED = "repeated"
WRONG_SEQUENCE = "wrong-sequence"
ACCEPTED = (INIT, OK, LOST)


def _table8(poly: int) -> tuple[int, ...]:
    out = []
    for byte in range(256):
        c = byte
        for _ in range(8):
            c = ((c << 1) ^ poly) & 0xFF if c & 0x80 else (c << 1) & 0xFF
        out.append(c)
    return tuple(out)


def _table16(poly: int) -> tuple[int, ...]:
    out = []
    for byte in range(256):
        c = byte << 8
        for _ in range(8):
            c = ((c << 1) ^ poly) & 0xFFFF if c & 0x8000 else (c << 1) & 0xFFFF
        out.append(c)
    return tuple(out)


_T8 = _table8(0x1D)
_T16 = _table16(0x1021)


def crc8_j1850(data: bytes) -> int:
    """CRC-8 SAE J1850: poly 0x1D, init 0xFF, not reflected, xorout 0xFF."""
    c = 0xFF
    for b in data:
        c = _T8[c ^ b]
    return c ^ 0xFF


def crc16_ccitt_false(data: bytes) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, not reflected, no xorout.

    The standard library's C routine (``binascii.crc_hqx`` is this CRC with
    the initial value given): an operator node checks about 2,000 frames a
    second, and the byte loop in Python was a large part of its CPU time.
    tests/python/test_protocol.py holds it equal to the table's byte loop."""
    return binascii.crc_hqx(bytes(data), 0xFFFF)


def crc_length(frame_length: int) -> int:
    """Bytes of CRC at the end of a frame of ``frame_length`` bytes (1 or 2)."""
    return 1 if frame_length <= CRC8_MAX_LEN else 2


def data_id_bytes(frame_id: int) -> bytes:
    """The data ID that starts every CRC: the 11-bit CAN ID, two bytes little-endian."""
    if not 0 <= frame_id <= 0x7FF:
        raise ValueError(f"0x{frame_id:X} is not an 11-bit CAN ID")
    return bytes((frame_id & 0xFF, frame_id >> 8))


def frame_crc(frame_id: int, data: bytes) -> int:
    """The CRC a frame of ``len(data)`` bytes must carry; the CRC bytes
    themselves (the last 1 or 2 of ``data``) are not covered."""
    n = crc_length(len(data))
    covered = data_id_bytes(frame_id) + bytes(data[:-n])
    return crc8_j1850(covered) if n == 1 else crc16_ccitt_false(covered)


def seal(frame_id: int, data: bytes) -> bytes:
    """Returns ``data`` with its last CRC byte(s) set (CRC-16 little-endian)."""
    n = crc_length(len(data))
    crc = frame_crc(frame_id, data)
    return bytes(data[:-n]) + crc.to_bytes(n, "little")


def crc_ok(frame_id: int, data: bytes) -> bool:
    """True when the frame's stored CRC matches its ID and payload."""
    if len(data) < 2:
        return False
    n = crc_length(len(data))
    return int.from_bytes(data[-n:], "little") == frame_crc(frame_id, data)


@dataclass
class CounterCheck:
    """Result of :meth:`E2EReceiver.check`."""

    status: str
    lost: int = 0  #: frames lost before this one (status ``lost``)

    @property
    def accepted(self) -> bool:
        return self.status in ACCEPTED


class E2EReceiver:
    """Alive-counter check of one message from one sender."""

    def __init__(self) -> None:
        self.last: int | None = None

    def check(self, counter: int) -> CounterCheck:
        if not 0 <= counter < COUNTER_MODULO:
            raise ValueError(f"counter {counter} is not a 4-bit value")
        if self.last is None:
            self.last = counter
            return CounterCheck(INIT)
        delta = (counter - self.last) % COUNTER_MODULO
        if delta == 0:
            return CounterCheck(REPEATED)
        if delta > MAX_DELTA:
            self.last = None
            return CounterCheck(WRONG_SEQUENCE)
        self.last = counter
        if delta == 1:
            return CounterCheck(OK)
        return CounterCheck(LOST, lost=delta - 1)

    def reset(self) -> None:
        self.last = None


def next_counter(counter: int) -> int:
    return (counter + 1) % COUNTER_MODULO


def crc_ok_many(frame_id: int, data) -> np.ndarray:
    """:func:`crc_ok` for N frames of one ID and one length at once: ``data``
    is an (N, length) uint8 matrix; returns N booleans. The same tables as
    :func:`crc8_j1850` / :func:`crc16_ccitt_false`, one payload column per
    step (tests/python/test_framedecode.py holds it to :func:`crc_ok`)."""
    data = np.asarray(data, dtype=np.uint8)
    n_rows, length = data.shape
    if length < 2:
        return np.zeros(n_rows, dtype=bool)
    n = crc_length(length)
    covered = [np.full(n_rows, b, dtype=np.uint8) for b in data_id_bytes(frame_id)]
    covered += [data[:, j] for j in range(length - n)]
    if n == 1:
        t8 = np.array(_T8, dtype=np.uint8)
        c = np.full(n_rows, 0xFF, dtype=np.uint8)
        for col in covered:
            c = t8[c ^ col]
        return data[:, -1] == (c ^ 0xFF)
    t16 = np.array(_T16, dtype=np.uint16)
    c16 = np.full(n_rows, 0xFFFF, dtype=np.uint16)
    for col in covered:
        c16 = (c16 << 8) ^ t16[(c16 >> 8) ^ col]
    stored = data[:, -2].astype(np.uint16) | (data[:, -1].astype(np.uint16) << 8)
    return stored == c16


#: Status codes of :func:`check_counters`: index into this tuple.
STATUS_CODES = (INIT, OK, LOST, REPEATED, WRONG_SEQUENCE)


def check_counters(counters) -> tuple[np.ndarray, np.ndarray]:
    """:class:`E2EReceiver` over a sequence of counters of one message and
    sender, in order: (status code per frame, an index into
    :data:`STATUS_CODES`; frames lost before each). A clean sequence (every
    step 1, 2 or 3) is checked at once; otherwise the receiver runs frame by
    frame."""
    c = np.asarray(counters, dtype=np.int64)
    if c.size == 0:
        return np.zeros(0, dtype=np.int8), np.zeros(0, dtype=np.int64)
    if ((c < 0) | (c >= COUNTER_MODULO)).any():
        raise ValueError("a counter is not a 4-bit value")
    delta = np.diff(c) % COUNTER_MODULO
    if ((delta >= 1) & (delta <= MAX_DELTA)).all():
        codes = np.concatenate([[0], np.where(delta == 1, 1, 2)]).astype(np.int8)
        return codes, np.concatenate([[0], delta - 1]).astype(np.int64)
    rx = E2EReceiver()
    index = {s: k for k, s in enumerate(STATUS_CODES)}
    codes = np.empty(len(c), dtype=np.int8)
    lost = np.empty(len(c), dtype=np.int64)
    for k, v in enumerate(c.tolist()):
        r = rx.check(v)
        codes[k] = index[r.status]
        lost[k] = r.lost
    return codes, lost
