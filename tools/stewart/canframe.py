# SPDX-License-Identifier: Apache-2.0
"""Worst-case length of one CAN frame, the one formula that `stewart busload`
and the CANopen layouts (stewart/drives/layout.py) both use.

Bits of one frame, 11-bit ID, ``n`` data bytes, worst-case bit stuffing:

* classic CAN (ISO 11898-1 base frame, worst-case stuffing): ``47 + 8n + floor((34 + 8n - 1) / 4)`` bits,
  all at the nominal rate;
* CAN FD with bit-rate switch (ISO 11898-1:2015 frame layout):

  - nominal rate: 17 arbitration bits (SOF, 11-bit ID, RRS, IDE, FDF, res,
    BRS) + ``floor((17 - 1) / 4) = 4`` dynamic stuff bits + 13 bits after the
    CRC (CRC delimiter, ACK slot, ACK delimiter, 7 EOF, 3 intermission; the
    delimiter counted at the nominal rate, an upper bound) = 34 bits;
  - data rate: ESI + 4 DLC + ``8n`` data bits + ``floor((5 + 8n) / 4)`` dynamic
    stuff bits (the continuation of the worst-case run from the arbitration
    field), + 4 stuff-count bits + CRC (17 bits up to 16 data bytes, 21
    above) + fixed stuff bits (one before the stuff count and one after every
    4 bits: 6 for CRC-17, 7 for CRC-21).
"""

from __future__ import annotations

import math

#: CAN FD payload lengths (the DLC codes 0..15).
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
FD_ARBITRATION_BITS = 17
FD_ARBITRATION_STUFF = (FD_ARBITRATION_BITS - 1) // 4
FD_TAIL_BITS = 13


def fd_payload_length(n: int) -> int:
    """Smallest CAN FD payload length that holds ``n`` bytes."""
    for length in FD_LENGTHS:
        if length >= n:
            return length
    raise ValueError(f"{n} bytes do not fit a CAN FD frame")


def classic_frame_bits(n: int) -> int:
    """Worst-case bits of a classic CAN base frame with ``n`` (0..8) data bytes."""
    if not 0 <= n <= 8:
        raise ValueError("classic CAN frames carry 0..8 bytes")
    return 47 + 8 * n + (34 + 8 * n - 1) // 4


def fd_frame_bits(n: int) -> tuple[int, int]:
    """Worst-case (nominal-rate bits, data-rate bits) of a CAN FD base frame
    with bit-rate switch and ``n`` data bytes (rounded up to a DLC length)."""
    n = fd_payload_length(n)
    nominal = FD_ARBITRATION_BITS + FD_ARBITRATION_STUFF + FD_TAIL_BITS
    dynamic = 1 + 4 + 8 * n           # ESI, DLC, data
    dynamic_stuff = dynamic // 4
    crc = 17 if n <= 16 else 21
    fixed_stuff = math.ceil((4 + crc) / 4)
    data = dynamic + dynamic_stuff + 4 + crc + fixed_stuff
    return nominal, data


def frame_time_us(n: int, is_fd: bool, nominal: float, data: float) -> float:
    """Worst-case duration of one frame in microseconds."""
    if is_fd:
        bn, bd = fd_frame_bits(n)
        return (bn / nominal + bd / data) * 1e6
    return classic_frame_bits(n) / nominal * 1e6
