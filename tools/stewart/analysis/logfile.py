"""The CAN log format: candump ``-L`` lines (``(TIME) IFACE ID#DATA``, CAN FD
``ID##FDATA``) read and written, and the map from interface names to the
protocol's buses (``--bus ops=vcan0,axis_a=vcan1,axis_b=vcan2``)."""

from __future__ import annotations

import re
from dataclasses import dataclass

from .. import protocol as pr

_LINE = re.compile(r"^\((\d+(?:\.\d*)?)\)\s+(\S+)\s+([0-9A-Fa-f]{1,8})(##|#)(\S*)$")


@dataclass
class LogFrame:
    """One frame of a candump -L line."""

    time: float        #: log timestamp, s
    iface: str         #: interface name as logged (vcan0, ...)
    frame_id: int
    data: bytes
    fd: bool
    flags: int = 0     #: CAN FD flags nibble (bit 0 BRS, bit 1 ESI)
    line_no: int = 0


def parse_line(line: str, line_no: int = 0) -> LogFrame:
    """Parses one candump -L line, ``(TIME) IFACE ID#DATA`` (classic) or
    ``(TIME) IFACE ID##FDATA`` (CAN FD, F = flags nibble). Raises ValueError
    with the reason for anything else (remote frames included)."""
    m = _LINE.match(line.strip())
    if m is None:
        raise ValueError("not a candump -L frame line")
    t, iface, ident, sep, rest = m.groups()
    fd = sep == "##"
    flags = 0
    if fd:
        if not rest:
            raise ValueError("CAN FD frame without its flags nibble")
        flags = int(rest[0], 16) if rest[0] in "0123456789abcdefABCDEF" else -1
        if flags < 0:
            raise ValueError(f"bad CAN FD flags {rest[0]!r}")
        rest = rest[1:]
    if rest[:1] in ("R", "r"):
        raise ValueError("remote frame")
    if len(rest) % 2:
        raise ValueError("odd number of data digits")
    try:
        data = bytes.fromhex(rest)
    except ValueError:
        raise ValueError("data is not hexadecimal") from None
    if len(data) > (64 if fd else 8):
        raise ValueError(f"{len(data)} data bytes in a {'CAN FD' if fd else 'classic'} frame")
    frame_id = int(ident, 16)
    if len(ident) > 3:
        frame_id |= 0x80000000  # candump writes extended IDs with 8 digits
    return LogFrame(float(t), iface, frame_id, data, fd, flags, line_no)


def format_line(time_s: float, iface: str, frame_id: int, data: bytes, fd: bool = True,
                flags: int = 1) -> str:
    """One candump -L line (the inverse of :func:`parse_line`)."""
    us = int(round(time_s * 1e6))
    head = f"({us // 1_000_000:010d}.{us % 1_000_000:06d}) {iface} {frame_id:03X}"
    if fd:
        return f"{head}##{flags:X}{bytes(data).hex().upper()}"
    return f"{head}#{bytes(data).hex().upper()}"


def parse_bus_map(text: str | None) -> dict[str, str]:
    """``ops=vcan0,axis_a=vcan1,axis_b=vcan2`` -> {interface: bus}. Buses not
    given keep their default interface; a bus name is always accepted as an
    interface name too."""
    ifaces = dict(pr.BUSES)
    if text:
        for part in text.split(","):
            part = part.strip()
            if not part:
                continue
            bus, sep, iface = part.partition("=")
            bus, iface = bus.strip(), iface.strip()
            if not sep or bus not in pr.BUSES or not iface:
                raise ValueError(f"--bus: {part!r} is not BUS=IFACE with BUS one of "
                                 f"{', '.join(pr.BUSES)}")
            ifaces[bus] = iface
    if len(set(ifaces.values())) != len(ifaces):
        raise ValueError(f"--bus: two buses on one interface: "
                         f"{', '.join(f'{b}={i}' for b, i in ifaces.items())}")
    out = {iface: bus for bus, iface in ifaces.items()}
    for bus in pr.BUSES:
        out.setdefault(bus, bus)
    return out

