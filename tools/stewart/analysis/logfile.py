# SPDX-License-Identifier: Apache-2.0
"""The CAN log format: candump ``-L`` lines (``(TIME) IFACE ID#DATA``, CAN FD
``ID##FDATA``) read and written, and the map from interface names to the
protocol's buses (``--bus ops=vcan0,axis_a=vcan1,axis_b=vcan2``)."""

from __future__ import annotations

import mmap
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

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



# -- the whole log at once --------------------------------------------------------

#: Largest payload of a frame (CAN FD).
MAX_DATA = 64
#: Lines of one length parsed together (bounds the temporary matrices).
_CHUNK = 1 << 15
#: Columns searched for the separators; a line whose ')', spaces and '#' come
#: later goes to the line-by-line parser.
_HEAD = 64


@dataclass
class LogFrames:
    """Every frame of a log, as arrays in log order (F frames)."""

    line_no: np.ndarray      #: (F,) int64, 1-based line number
    time: np.ndarray         #: (F,) float64, s
    iface: np.ndarray        #: (F,) int64, index into ``ifaces``
    ifaces: list[str]        #: interface names as logged
    frame_id: np.ndarray     #: (F,) int64 (extended IDs with bit 31 set, as parse_line)
    fd: np.ndarray           #: (F,) bool
    dlc: np.ndarray          #: (F,) int64, data bytes
    data: np.ndarray         #: (F, 64) uint8, payload zero-padded to 64 bytes
    lines: int               #: lines read (blank ones included)
    malformed: list[tuple[int, str]]  #: (line number, warning) of lines that are not frames


_HEX = None


def _hex_table() -> np.ndarray:
    global _HEX
    if _HEX is None:
        from .framedecode import hex_nibbles

        _HEX = hex_nibbles()
    return _HEX


_PAIRS = None


def _pair_table() -> np.ndarray:
    """65536-entry table: two ASCII characters read as a little-endian
    uint16 -> the byte they spell in hex, 0xFFFF unless both are hex digits."""
    global _PAIRS
    if _PAIRS is None:
        h = _hex_table().astype(np.uint16)
        hi, lo = np.meshgrid(h, h, indexing="ij")      # [first char, second char]
        t = np.where((hi != 255) & (lo != 255), hi * 16 + lo, 0xFFFF).astype(np.uint16)
        _PAIRS = np.ascontiguousarray(t.T).reshape(-1)   # index = first | second << 8
    return _PAIRS


def _is_digit(a: np.ndarray) -> np.ndarray:
    return (a >= 0x30) & (a <= 0x39)


def _layout_keys(M: np.ndarray, rows: np.ndarray, length: int) -> np.ndarray:
    """Per row of ``M`` (lines of ``length`` bytes): the columns of ')', the
    two spaces and '#', and CAN FD, packed into one integer."""
    head = M[rows, :min(length, _HEAD)]   # time, interface and ID come first
    cols = np.arange(head.shape[1])[None, :]
    space = head == 0x20
    p = np.argmax(head == 0x29, axis=1)                       # ')'
    s1 = np.argmax(space, axis=1)
    s2 = np.argmax(space & (cols > s1[:, None]), axis=1)
    h = np.argmax(head == 0x23, axis=1)                       # '#'
    nxt = np.minimum(h + 1, length - 1)
    fd = (M[rows, nxt] == 0x23) & (h + 1 < length)
    return p + (s1 << 12) + (s2 << 24) + (h << 36) + (fd.astype(np.int64) << 48)


def _layout_groups(M: np.ndarray, length: int) -> tuple[list[list[int]], np.ndarray]:
    """The column layouts of the rows of ``M``, each as [')', space, space,
    '#', FD], and each row's layout (index into them)."""
    # The usual case: every line has the first line's layout. Checking its
    # separator columns in all rows is cheaper than finding each row's.
    k0 = int(_layout_keys(M, np.arange(1), length)[0])
    p0, a0, b0, h0, f0 = (k0 >> sh & 0xFFF for sh in (0, 12, 24, 36, 48))
    same = (M[:, p0] == 0x29) & (M[:, a0] == 0x20) & (M[:, b0] == 0x20) & (M[:, h0] == 0x23)
    if h0 + 1 < length:
        same &= (M[:, h0 + 1] == 0x23) if f0 else (M[:, h0 + 1] != 0x23)
    key = np.full(len(M), k0, dtype=np.int64)
    if not same.all():
        others = np.flatnonzero(~same)
        key[others] = _layout_keys(M, others, length)
    if (key == k0).all():
        uniq_keys, inv = key[:1], np.zeros(len(key), dtype=np.int64)
    else:
        uniq_keys, inv = np.unique(key, return_inverse=True)
    return [[int(k) >> sh & 0xFFF for sh in (0, 12, 24, 36, 48)] for k in uniq_keys], inv


def _template_rows(buf: np.ndarray, starts: np.ndarray, length: int):
    """Splits the lines of one length into groups with one column layout and
    checks each group's columns as :data:`_LINE` would. Yields (rows, fields)
    of the good rows; the indices of rows that need the line-by-line parser
    are yielded as (rows, None)."""
    M = np.lib.stride_tricks.sliding_window_view(buf, length)[starts]
    uniq, inv = _layout_groups(M, length)
    for g, (pg, a, b, hg, fg) in enumerate(uniq):
        if len(uniq) == 1:
            rows, S = np.arange(len(M)), M
        else:
            rows = np.flatnonzero(inv == g)
            S = M[rows]
        d0 = hg + (3 if fg else 1)                            # first data digit
        nd = length - d0
        shape_ok = (pg >= 2 and a == pg + 1 and b > a + 1 and hg > b + 1 and hg - b - 1 <= 8
                    and nd >= 0 and nd % 2 == 0 and nd // 2 <= (MAX_DATA if fg else 8))
        if not shape_ok:
            yield rows, None
            continue
        yield from _group_fields(S, rows, pg, a, b, hg, fg, d0)


def _group_fields(S: np.ndarray, rows: np.ndarray, pg: int, a: int, b: int, hg: int, fg: int, d0: int):
    """The rows ``S`` of one column layout (')' at ``pg``, spaces at ``a``
    and ``b``, '#' at ``hg``, CAN FD ``fg``, data from ``d0``) checked and
    parsed: yields (rows, fields) of the good ones, (rows, None) of the others."""
    hexv = _hex_table()
    ts = S[:, 1:pg]
    dots = (ts == 0x2E).sum(axis=1)
    ok = (S[:, 0] == 0x28) & _is_digit(S[:, 1]) & (_is_digit(ts) | (ts == 0x2E)).all(axis=1) & (dots <= 1)
    ifc = S[:, a + 1:b]
    ok &= ((ifc > 0x20) & (ifc < 0x7F)).all(axis=1)
    idn = hexv[S[:, b + 1:hg]]
    ok &= (idn != 255).all(axis=1)
    if fg:
        flags = hexv[S[:, hg + 2]]
        ok &= flags != 255
    else:
        flags = np.zeros(len(S), dtype=np.uint8)
    dn = _pair_table()[np.ascontiguousarray(S[:, d0:]).view("<u2")]  # two digits -> a byte
    ok &= (dn != 0xFFFF).all(axis=1)
    if not ok.all():
        yield rows[~ok], None
        if not ok.any():
            return
        S, ts, ifc, idn, dn, flags = S[ok], ts[ok], ifc[ok], idn[ok], dn[ok], flags[ok]
        rows = rows[ok]
    time = _times(ts)
    if ifc.shape[1] <= 8:  # names as one integer each: cheaper to sort than bytes
        wide = np.zeros((len(ifc), 8), dtype=np.uint8)
        wide[:, :ifc.shape[1]] = ifc
        names = wide.view("<u8").reshape(-1)
    else:
        names = np.ascontiguousarray(ifc).view(f"S{ifc.shape[1]}").reshape(-1)
    fid = np.zeros(len(S), dtype=np.int64)
    for j in range(idn.shape[1]):
        fid = (fid << 4) | idn[:, j]
    if idn.shape[1] > 3:
        fid |= 0x80000000
    data = dn.astype(np.uint8)
    yield rows, (time, names, fid, bool(fg), flags, data)


def _times(ts: np.ndarray) -> np.ndarray:
    """Timestamps (rows of digits with at most one '.') to seconds, as
    ``float(text)`` gives them: digits at fixed places make one exact integer
    N and a power of ten P, and N / P is the correctly rounded value while N
    < 2**53; otherwise numpy parses the text."""
    dot = ts == 0x2E
    width = ts.shape[1]
    cols = np.flatnonzero(dot.any(axis=0))
    if len(cols) <= 1 and (len(cols) == 0 or dot[:, cols[0]].all()) and width - len(cols) <= 17:
        digits = ts[:, ~dot.any(axis=0)].astype(np.int64) - 0x30
        num = np.zeros(len(ts), dtype=np.int64)
        for j in range(digits.shape[1]):
            num = num * 10 + digits[:, j]
        frac = width - 1 - int(cols[0]) if len(cols) else 0
        if (num < (1 << 53)).all():
            return num.astype(np.float64) / float(10 ** frac)
    return np.ascontiguousarray(ts).view(f"S{width}").reshape(-1).astype(np.float64)


def _name_codes(names: np.ndarray, code_of) -> np.ndarray:
    """Interface names (uint64 of up to 8 bytes, or bytes) -> codes through
    ``code_of(str)``. A log has a few interfaces: one comparison per name
    found, instead of sorting."""
    def text(x) -> str:
        b = int(x).to_bytes(8, "little").rstrip(b"\0") if names.dtype.kind == "u" else bytes(x)
        return b.decode("ascii")

    out = np.empty(len(names), dtype=np.int64)
    left = np.ones(len(names), dtype=bool)
    for _ in range(8):
        if not left.any():
            return out
        v = names[int(np.argmax(left))]
        hit = names == v
        out[hit] = code_of(text(v))
        left &= ~hit
    u, inv = np.unique(names[left], return_inverse=True)   # many names: sort the rest
    out[left] = np.array([code_of(text(x)) for x in u], dtype=np.int64)[inv.reshape(-1)]
    return out


def _file_bytes(path: str | Path) -> np.ndarray:
    """The file's bytes, line ends made \\n. Mapped rather than read where
    the file can be: a read copies the log into fresh memory, and on the VM
    of docs/reference/analysis.md faulting in 30 MB of fresh pages costs more than the
    read itself."""
    with open(path, "rb") as f:
        try:
            mapped = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except (ValueError, OSError):  # empty, or not a regular file
            return np.frombuffer(_unix_line_ends(f.read()), dtype=np.uint8)
    if mapped.find(b"\r") >= 0:
        return np.frombuffer(_unix_line_ends(mapped[:]), dtype=np.uint8)
    return np.frombuffer(mapped, dtype=np.uint8)


def _unix_line_ends(raw: bytes) -> bytes:
    """Line ends as Python's text files see them: \\n, \\r\\n or \\r -> \\n."""
    if b"\r" in raw:
        raw = raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return raw


def read_frames(source) -> LogFrames:
    """Every frame of a candump -L log (a path, bytes, or an iterable of
    lines) at once. Lines in the usual layout are parsed column-wise with
    numpy, grouped by length and column layout; any other line goes through
    :func:`parse_line` (which gives the reason a line is not a frame). Same
    frames, times, IDs and payloads as :func:`parse_line` line by line
    (tests/python/test_framedecode.py)."""
    buf = _source_bytes(source)
    starts, ends = _line_bounds(buf)
    parts, slow = _parse_columnwise(buf, starts, ends - starts)
    # Slow lines first (they may add frames), then every frame goes to its
    # place in log order: position = rank of its line among the frame lines.
    slow_frames, malformed = _parse_slow(buf, starts, ends, slow)
    n_lines = len(starts)
    is_frame = np.zeros(n_lines + 1, dtype=bool)
    for rows, _ in parts:
        is_frame[rows] = True
    for i, _ in slow_frames:
        is_frame[i] = True
    rank = np.cumsum(is_frame) - 1          # position of each frame line
    F = int(is_frame.sum())
    line_no = np.flatnonzero(is_frame).astype(np.int64) + 1
    time_a = np.zeros(F)
    iface_a = np.zeros(F, dtype=np.int64)
    fid_a = np.zeros(F, dtype=np.int64)
    fd_a = np.zeros(F, dtype=bool)
    dlc_a = np.zeros(F, dtype=np.int64)
    data_a = np.zeros((F, MAX_DATA), dtype=np.uint8)
    iface_names: list[str] = []
    iface_id = _interface_codes(iface_names)
    for rows, (time, names, fid, fd, flags, data) in parts:
        dest = rank[rows]
        time_a[dest] = time
        iface_a[dest] = _name_codes(names, iface_id)
        fid_a[dest] = fid
        fd_a[dest] = fd
        dlc_a[dest] = data.shape[1]
        data_a[dest, :data.shape[1]] = data
    for i, f in slow_frames:
        k = rank[i]
        time_a[k], iface_a[k], fid_a[k], fd_a[k] = f.time, iface_id(f.iface), f.frame_id, f.fd
        dlc_a[k] = len(f.data)
        data_a[k, :len(f.data)] = np.frombuffer(f.data, dtype=np.uint8)
    return LogFrames(line_no=line_no, time=time_a, iface=iface_a, ifaces=iface_names,
                     frame_id=fid_a, fd=fd_a, dlc=dlc_a, data=data_a, lines=n_lines,
                     malformed=malformed)


def _source_bytes(source) -> np.ndarray:
    """The log's bytes with \\n line ends (a path, bytes, or lines)."""
    if isinstance(source, (str, Path)):
        return _file_bytes(source)
    if isinstance(source, (bytes, bytearray)):
        return np.frombuffer(_unix_line_ends(bytes(source)), dtype=np.uint8)
    lines = [str(s).rstrip("\r\n") for s in source]
    raw = "\n".join(lines).encode("utf-8", "replace")
    if lines:  # one newline per line, an empty one included
        raw += b"\n"
    return np.frombuffer(raw, dtype=np.uint8)


def _line_bounds(buf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(start, end) offsets of each line, its \\n (and a \\r before it) left out."""
    nl = np.flatnonzero(buf == 0x0A)
    starts = np.concatenate(([0], nl + 1)).astype(np.int64)
    ends = np.concatenate((nl, [len(buf)])).astype(np.int64)
    if len(buf) == 0 or buf[-1] == 0x0A:
        starts, ends = starts[:-1], ends[:-1]
    cr = (ends > starts) & (buf[np.maximum(ends - 1, 0)] == 0x0D) if len(buf) else np.zeros(0, bool)
    return starts, ends - cr


def _parse_columnwise(buf: np.ndarray, starts: np.ndarray, lengths: np.ndarray):
    """(parts, slow): the lines parsed column-wise by length and layout as
    (line indices, fields), and the indices of the lines left to
    :func:`parse_line`."""
    parts = []          # (line indices, fields)
    slow: list[np.ndarray] = []
    for L in np.unique(lengths).tolist():
        grp = np.flatnonzero(lengths == L)
        if L < 8 or L >= 4096:
            slow.append(grp)
            continue
        for c0 in range(0, len(grp), _CHUNK):
            sub = grp[c0:c0 + _CHUNK]
            for rows, fields in _template_rows(buf, starts[sub], L):
                if fields is None:
                    slow.append(sub[rows])
                else:
                    parts.append((sub[rows], fields))
    return parts, slow


def _parse_slow(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, slow: list[np.ndarray]):
    """(frames, malformed): the lines ``slow`` through :func:`parse_line`,
    as (line index, frame) and (line number, warning); blank lines are skipped."""
    malformed: list[tuple[int, str]] = []
    slow_frames: list[tuple[int, LogFrame]] = []
    if slow:
        for i in np.sort(np.concatenate(slow)).tolist():
            line = buf[starts[i]:ends[i]].tobytes().decode("utf-8", "replace")
            if not line.strip():
                continue
            try:
                slow_frames.append((i, parse_line(line, i + 1)))
            except ValueError as exc:
                malformed.append((i + 1, f"line {i + 1}: malformed ({exc}): {line.strip()[:80]}"))
    return slow_frames, malformed


def _interface_codes(names: list[str]):
    """A function giving each interface name its code, the index in
    ``names`` (appended when new)."""
    index: dict[str, int] = {}

    def iface_id(name: str) -> int:
        k = index.get(name)
        if k is None:
            k = index[name] = len(names)
            names.append(name)
        return k

    return iface_id
