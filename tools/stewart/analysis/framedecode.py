# SPDX-License-Identifier: Apache-2.0
"""Whole-message decoding: many frames of one message at once, with numpy.

A :class:`MessageLayout` reads the bit layout of every signal of a message
from its cantools definition (start bit, length, byte order, signedness,
IEEE float, scale and offset, multiplexer), so the DBC stays the one source
of the layout: nothing here knows a bit position. :meth:`MessageLayout.raw`
takes the payloads of N frames as an (N, length) uint8 matrix and returns
each signal's N raw values in one pass over the bytes the signal touches;
:meth:`MessageLayout.scaled` applies the conversion cantools applies
(``raw * scale + offset``: integers when scale and offset are integers and
the signal is not a float, float64 otherwise).

Multiplexed signals: a signal whose multiplexer (possibly nested) selects
another value is absent from that frame; :meth:`MessageLayout.present` gives
the mask, and a frame whose multiplexer value selects no signal group that
the DBC defines is flagged by :meth:`MessageLayout.bad_multiplexer` (cantools
refuses to decode it).

The plain reference is cantools' own ``Message.decode`` frame by frame; the
tests (tests/python/test_framedecode.py) hold this module to it on the
project's DBC with a real log and on a DBC with big-endian, odd-sized,
signed, scaled, float and multiplexed signals.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SignalLayout:
    """Where one signal sits and how it converts (read from cantools)."""

    name: str
    first_byte: int       #: first payload byte the signal touches
    n_bytes: int          #: bytes touched
    shift: int            #: right shift of the combined bytes to the signal's LSB
    length: int           #: bits
    big_endian: bool
    signed: bool
    is_float: bool
    scale: float | int
    offset: float | int
    integer: bool         #: scaled values are integers (as cantools returns them)
    mux_signal: str | None
    mux_ids: frozenset[int] | None

    @staticmethod
    def of(signal) -> "SignalLayout":
        length = int(signal.length)
        if signal.byte_order == "little_endian":
            lsb = int(signal.start)
            first, last = lsb // 8, (lsb + length - 1) // 8
            shift = lsb - 8 * first
            big = False
        else:
            # cantools keeps the DBC's start bit of a Motorola signal: the MSB
            # as byte * 8 + bit-in-byte. Counted from the first payload bit
            # (MSB first), the signal is bits msb .. msb + length - 1.
            msb = 8 * (int(signal.start) // 8) + 7 - int(signal.start) % 8
            first, last = msb // 8, (msb + length - 1) // 8
            shift = 8 * (last + 1) - (msb + length)
            big = True
        scale, offset = signal.scale, signal.offset
        integer = (not signal.is_float and isinstance(scale, int) and isinstance(offset, int))
        ids = None if signal.multiplexer_ids is None else frozenset(int(i) for i in signal.multiplexer_ids)
        return SignalLayout(signal.name, first, last - first + 1, shift, length, big,
                            bool(signal.is_signed), bool(signal.is_float), scale, offset, integer,
                            signal.multiplexer_signal, ids)


def _combine(data: np.ndarray, sig: SignalLayout) -> np.ndarray:
    """The signal's raw bits as uint64 (before sign and float handling)."""
    n = data.shape[0]
    mask = np.uint64((1 << sig.length) - 1) if sig.length < 64 else np.uint64(0xFFFFFFFFFFFFFFFF)
    if sig.n_bytes <= 8:
        # the bytes the signal touches, copied into 8-byte rows read as one
        # integer in the signal's byte order (one pass instead of one per byte)
        cols = data[:, sig.first_byte:sig.first_byte + sig.n_bytes]
        if sig.n_bytes == 1:
            v = cols[:, 0].astype(np.uint64)
        elif sig.big_endian:
            word = np.zeros((n, 8), dtype=np.uint8)
            word[:, 8 - sig.n_bytes:] = cols
            v = word.view(">u8")[:, 0].astype(np.uint64)
        else:
            word = np.zeros((n, 8), dtype=np.uint8)
            word[:, :sig.n_bytes] = cols
            v = word.view("<u8")[:, 0].astype(np.uint64)
        return (v >> np.uint64(sig.shift)) & mask
    cols = data[:, sig.first_byte:sig.first_byte + sig.n_bytes].astype(np.uint64)
    # 9 bytes: a signal of more than 57 bits that is not byte-aligned.
    if sig.big_endian:
        hi = np.zeros(n, dtype=np.uint64)
        for j in range(8):
            hi |= cols[:, j] << np.uint64(8 * (7 - j))
        v = (hi << np.uint64(8 - sig.shift)) | (cols[:, 8] >> np.uint64(sig.shift))
    else:
        lo = np.zeros(n, dtype=np.uint64)
        for j in range(8):
            lo |= cols[:, j] << np.uint64(8 * j)
        v = (lo >> np.uint64(sig.shift)) | (cols[:, 8] << np.uint64(64 - sig.shift))
    return v & mask


def raw_values(data: np.ndarray, sig: SignalLayout) -> np.ndarray:
    """Raw values of one signal: int64 (uint64 for an unsigned 64-bit
    signal), float64 for an IEEE float signal."""
    v = _combine(data, sig)
    if sig.is_float:
        if sig.length == 32:
            return v.astype(np.uint32).view(np.float32).astype(np.float64)
        return v.view(np.float64)
    if sig.length == 64:
        return v.view(np.int64) if sig.signed else v
    out = v.astype(np.int64)
    if sig.signed:
        out -= ((out >> (sig.length - 1)) & 1) << sig.length
    return out


class MessageLayout:
    """The signals of one cantools message, decoded many frames at a time."""

    def __init__(self, message):
        self.name = message.name
        self.frame_id = int(message.frame_id)
        self.length = int(message.length)
        self.signals = [SignalLayout.of(s) for s in message.signals]
        self.by_name = {s.name: s for s in self.signals}
        for s in self.signals:
            if s.first_byte + s.n_bytes > self.length:
                raise ValueError(f"{self.name}.{s.name} ends beyond the message's {self.length} bytes")
        self.multiplexed = any(s.mux_signal is not None for s in self.signals)

    def _check(self, data: np.ndarray) -> np.ndarray:
        data = np.asarray(data, dtype=np.uint8)
        if data.ndim != 2 or data.shape[1] < self.length:
            raise ValueError(f"{self.name}: expected an (N, {self.length}) byte matrix, "
                             f"got shape {data.shape}")
        return data

    def raw(self, data: np.ndarray) -> dict[str, np.ndarray]:
        """Raw values of every signal for the N frames of ``data`` (N rows,
        at least ``length`` columns). Multiplexed signals are decoded in
        every row; :meth:`present` says where they exist."""
        data = self._check(data)
        return {s.name: raw_values(data, s) for s in self.signals}

    def scaled(self, raw: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Physical values from :meth:`raw`'s output, as cantools converts
        (choices not decoded)."""
        return {s.name: self.scale(s.name, raw[s.name]) for s in self.signals}

    def scale(self, name: str, raw: np.ndarray) -> np.ndarray:
        """One signal's physical values from its raw values (:meth:`scaled`)."""
        s = self.by_name[name]
        if s.integer:
            return raw if (s.scale == 1 and s.offset == 0) else raw * s.scale + s.offset
        return raw.astype(np.float64) * float(s.scale) + float(s.offset)

    def present(self, raw: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Per signal, the rows where the frame carries it (all rows unless
        the signal hangs on a multiplexer)."""
        n = len(next(iter(raw.values()))) if raw else 0
        out: dict[str, np.ndarray] = {}

        def mask(s: SignalLayout) -> np.ndarray:
            if s.name in out:
                return out[s.name]
            if s.mux_signal is None:
                m = np.ones(n, dtype=bool)
            else:
                parent = self.by_name[s.mux_signal]
                m = mask(parent) & np.isin(raw[parent.name], sorted(s.mux_ids or ()))
            out[s.name] = m
            return m

        for s in self.signals:
            mask(s)
        return out

    def bad_multiplexer(self, raw: dict[str, np.ndarray]) -> np.ndarray:
        """Rows where a present multiplexer signal has a value no signal of
        the DBC is defined for."""
        n = len(next(iter(raw.values()))) if raw else 0
        bad = np.zeros(n, dtype=bool)
        if not self.multiplexed:
            return bad
        pres = self.present(raw)
        for mux in {s.mux_signal for s in self.signals if s.mux_signal is not None}:
            ids = set()
            for s in self.signals:
                if s.mux_signal == mux:
                    ids |= set(s.mux_ids or ())
            bad |= pres[mux] & ~np.isin(raw[mux], sorted(ids))
        return bad


def hex_nibbles() -> np.ndarray:
    """256-entry table: ASCII code -> hex digit value, 255 for a non-digit."""
    t = np.full(256, 255, dtype=np.uint8)
    for i, c in enumerate(b"0123456789"):
        t[c] = i
    for i, c in enumerate(b"abcdef"):
        t[c] = 10 + i
        t[c - 32] = 10 + i
    return t
