# SPDX-License-Identifier: Apache-2.0
"""``signals.csv``: one row per tick of a decoded run, SI units, blank where
a value is missing (columns: :func:`signal_columns`).

The controller's wrench estimate (``est_wrench_*``, CTRL_WRENCH) is sent on
every 2nd tick: the other rows leave it blank, as every value without a
frame for its tick (not held from the previous frame); ``est_wrench_valid``
is 1 or 0 on the ticks with a frame and the components are blank unless it
is 1. ``control_mode``: force control's mode from CTRL_STATUS (position,
force or guide; RELEASE and HOLD count as position), ``force_target_*``:
the commanded wrench in force mode (the accepted OP_FORCE, 0 otherwise;
stewart.analysis.decode.force_targets). ``truth_wrench_*``: the plant's
true external wrench (external + contact), blank if the truth CSV has no
wrench columns. With tool and work frames (issue 31; ``LogData.tool``,
:func:`.toolpose.attach_tool`) the tool's pose in the work frame follows:
``tool_ref_*``, ``tool_est_*`` and (with the truth) ``tool_truth_*``; with
identity frames there are no such columns."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .. import protocol as pr
from .decode import CONTROL_MODES, FORCE_MODES, LogData
from .names import AXES, DRIVE_MODES, DRIVE_STATES, STATES, TICK_S, WRENCH_AXES


def signal_columns(truth: bool, tool: bool = False) -> list[str]:
    cols = ["tick", "time_s", "state", "faults", "fault_names", "drive_mode", "feedforward",
            "estimate_valid"]
    cols += [f"ref_{a}" for a in AXES] + [f"est_{a}" for a in AXES]
    for group in ("length_sp", "force_ff", "length", "stretch", "force", "drive_state", "drive_faults"):
        cols += [f"{group}{i}" for i in range(1, 7)]
    cols += ["est_wrench_valid"] + [f"est_wrench_{a}" for a in WRENCH_AXES]
    cols += ["control_mode"] + [f"force_target_{a}" for a in WRENCH_AXES]
    if truth:
        cols += [f"truth_{a}" for a in AXES]
        cols += [f"truth_length{i}" for i in range(1, 7)] + [f"truth_force{i}" for i in range(1, 7)]
        cols += [f"truth_wrench_{a}" for a in WRENCH_AXES]
    if tool:
        for group in ("tool_ref", "tool_est") + (("tool_truth",) if truth else ()):
            cols += [f"{group}_{a}" for a in AXES]
    return cols


def _tool_arrays(data: LogData) -> list[np.ndarray]:
    """The tool pose columns' arrays (none without tool frames)."""
    if data.tool is None:
        return []
    return [data.tool[k] for k in ("ref", "est", "truth") if k in data.tool]


def signal_table(data: LogData) -> tuple[list[str], list[list[str]]]:
    """Header and rows (strings; blank where missing) of signals.csv."""
    cols = signal_columns(data.truth is not None, data.tool is not None)
    tool = _tool_arrays(data)

    def f(v, spec):
        return "" if not np.isfinite(v) else format(v, spec)

    def i(v):
        return "" if v < 0 else str(int(v))

    stretch, force = data.stretch, data.force
    truth_wrench = None
    if data.truth is not None:
        truth_wrench = data.truth.get("wrench")
        if truth_wrench is None:
            truth_wrench = np.full((len(data), 6), np.nan)
    rows = []
    for k in range(len(data)):
        st = int(data.state[k])
        r = [str(int(data.ticks[k])), f"{data.ticks[k] * TICK_S:.3f}", data.state_name(k),
             i(data.faults[k]),
             "+".join(pr.fault_names(int(data.faults[k]), pr.CONTROLLER_FAULTS)) if st >= 0 else "",
             DRIVE_MODES[data.drive_mode[k]] if data.drive_mode[k] >= 0 else "",
             i(data.feedforward[k]), i(data.estimate_valid[k])]
        r += [f(v, ".6f") for v in data.reference[k]] + [f(v, ".6f") for v in data.estimate[k]]
        r += [f(v, ".6f") for v in data.length_sp[k]] + [f(v, ".2f") for v in data.force_ff[k]]
        r += [f(v, ".7f") for v in data.length[k]] + [f(v, ".7f") for v in stretch[k]]
        r += [f(v, ".1f") for v in force[k]]
        r += [DRIVE_STATES[s] if 0 <= s < len(DRIVE_STATES) else i(s) for s in data.drive_state[k]]
        r += [i(v) for v in data.drive_faults[k]]
        r += [i(data.est_wrench_valid[k])] + [f(v, ".2f") for v in data.est_wrench[k]]
        r += [_control_mode(int(data.force_mode[k]))] + [f(v, ".2f") for v in data.force_target[k]]
        if data.truth is not None:
            r += [f(v, ".9f") for v in data.truth["pose"][k]]
            r += [f(v, ".9f") for v in data.truth["length"][k]]
            r += [f(v, ".3f") for v in data.truth["force"][k]]
            r += [f(v, ".3f") for v in truth_wrench[k]]
        for a in tool:
            r += [f(v, ".9f") for v in a[k]]
        rows.append(r)
    return cols, rows


def _control_mode(m: int) -> str:
    return CONTROL_MODES[FORCE_MODES[m]] if 0 <= m < len(FORCE_MODES) else ""


class _Numbers:
    """K columns of numbers with ``decimals`` places: ``format(x,
    f".{decimals}f")`` of each finite value, blank for NaN and inf. Sign,
    integer digits, point and fraction digits of the value rounded to
    ``decimals`` places (to the even neighbour on an exact tie), in a field
    of :attr:`width` characters padded with zero bytes (dropped when the
    file is written)."""

    def __init__(self, v: np.ndarray, decimals: int):
        v = np.asarray(v, dtype=np.float64)
        if v.ndim == 1:
            v = v[:, None]
        self.k = v.shape[1]
        self.ok = np.isfinite(v)
        self.minus = np.signbit(v) & self.ok
        scaled = np.where(self.ok, np.abs(v), 0.0) * float(10 ** decimals)
        if (scaled >= 9.0e18).any():
            raise ValueError("value too large for the CSV's fixed-point columns")
        self.ip, self.fp = np.divmod(np.rint(scaled).astype(np.int64), 10 ** decimals)
        self.decimals = decimals
        self.nd = len(str(int(self.ip.max()))) if self.ip.size else 1
        self.width = 1 + self.nd + (decimals + 1 if decimals > 0 else 0)

    def fill(self, out: np.ndarray) -> None:
        """Writes the fields into ``out`` ((N, K, width) bytes, zeroed)."""
        w, nd = self.width, self.nd
        out[..., 0] = np.where(self.minus, ord("-"), 0)
        # digits from the last: q // 10 by a constant is cheap in numpy, and
        # cheaper on 32-bit integers (the fraction always fits: < 10**9)
        fp = _narrow(self.fp)
        for j in range(self.decimals):
            nxt = fp // 10
            out[..., w - 1 - j] = fp - nxt * 10 + 0x30
            fp = nxt
        if self.decimals > 0:
            out[..., nd + 1] = ord(".")
        ip = _narrow(self.ip)
        out[..., nd] = ip % 10 + 0x30
        for j in range(1, nd):      # no leading zeros
            ip = ip // 10
            out[..., nd - j] = np.where(ip > 0, ip % 10 + 0x30, 0)
        out[~self.ok] = 0


def _narrow(q: np.ndarray) -> np.ndarray:
    """Non-negative integers as int32 when they all fit."""
    return q.astype(np.int32) if not q.size or int(q.max()) < 2 ** 31 else q


def _integers(v: np.ndarray) -> _Numbers:
    """Integers, blank where negative (missing)."""
    v = np.asarray(v, dtype=np.int64)
    return _Numbers(np.where(v >= 0, v, np.nan), 0)


class _Texts:
    """Columns of text through ``name(code)`` (called once per distinct
    code): (N, K) integer codes -> fields of :attr:`width` bytes."""

    def __init__(self, codes: np.ndarray, name):
        codes = np.asarray(codes, dtype=np.int64)
        if codes.ndim == 1:
            codes = codes[:, None]
        self.k = codes.shape[1]
        uniq, inv = np.unique(codes, return_inverse=True)
        enc = [name(int(c)).encode("utf-8") for c in uniq] or [b""]
        self.table = np.zeros((len(enc), max([1] + [len(e) for e in enc])), dtype=np.uint8)
        for k, e in enumerate(enc):
            self.table[k, :len(e)] = np.frombuffer(e, dtype=np.uint8)
        self.inv = inv.reshape(codes.shape)
        self.width = self.table.shape[1]

    def fill(self, out: np.ndarray) -> None:
        out[...] = self.table[self.inv]


def _table_blocks(data: LogData, rows: slice, truth_text: "TruthText | None" = None,
                  truth_rows: np.ndarray | None = None) -> list:
    """The columns of signals.csv for ``rows``, in blocks of K alike (the
    truth's from ``truth_text`` where given, ``truth_rows`` its row per row
    of the table)."""
    def name_or_int(table):
        return lambda s: table[s] if 0 <= s < len(table) else ("" if s < 0 else str(s))

    ticks = data.ticks[rows]
    st = data.state[rows]
    fault_key = np.where(st >= 0, np.maximum(data.faults[rows], 0), -1)
    cols = [_integers(ticks), _Numbers(ticks * TICK_S, 3),
            _Texts(st, name_or_int(STATES)), _integers(data.faults[rows]),
            _Texts(fault_key, lambda f: "" if f < 0 else "+".join(pr.fault_names(f, pr.CONTROLLER_FAULTS))),
            _Texts(data.drive_mode[rows], lambda m: DRIVE_MODES[m] if m >= 0 else ""),
            _integers(np.stack([data.feedforward[rows], data.estimate_valid[rows]], axis=1)),
            _Numbers(np.concatenate([data.reference[rows], data.estimate[rows], data.length_sp[rows]],
                                    axis=1), 6),
            _Numbers(data.force_ff[rows], 2),
            # measured lengths in 0.1 um (AXIS_FEEDBACK's step): 7 decimals
            _Numbers(np.concatenate([data.length[rows], data.stretch[rows]], axis=1), 7),
            _Numbers(data.force[rows], 1),
            _Texts(data.drive_state[rows], name_or_int(DRIVE_STATES)),
            _integers(np.concatenate([data.drive_faults[rows], data.est_wrench_valid[rows, None]], axis=1)),
            _Numbers(data.est_wrench[rows], 2),
            _Texts(data.force_mode[rows], _control_mode),
            _Numbers(data.force_target[rows], 2)]
    if data.truth is not None and truth_rows is not None:
        cols += [_Picked(chars, truth_rows[rows]) for chars in truth_text.chars]
    elif data.truth is not None:
        cols += _truth_blocks(data.truth, rows)
    tool = _tool_arrays(data)
    if tool:
        cols.append(_Numbers(np.concatenate([a[rows] for a in tool], axis=1), 9))
    return cols


def _truth_blocks(truth, rows) -> list:
    tw = truth.get("wrench")
    if tw is None:
        tw = np.full((len(truth["pose"]), 6), np.nan)
    return [_Numbers(np.concatenate([truth["pose"][rows], truth["length"][rows]], axis=1), 9),
            _Numbers(np.concatenate([truth["force"][rows], tw[rows]], axis=1), 3)]


class _Picked:
    """Fields formatted beforehand ((M, K, W) bytes), one row of them per
    row of the table (``rows``: indices into M)."""

    def __init__(self, chars: np.ndarray, rows: np.ndarray):
        self.chars, self.rows = chars, rows
        self.k, self.width = chars.shape[1], chars.shape[2]

    def fill(self, out: np.ndarray) -> None:
        out[...] = self.chars[self.rows]


class TruthText:
    """The truth's columns of signals.csv (``truth_*``) formatted from a
    truth CSV as :func:`.truth.read_truth` returns it, one row per truth
    row, before the log is decoded: ``stewart analyze`` formats them while
    the log's frames are being read. Pass it to :func:`write_signals_csv`
    with the data the same truth was attached to (:func:`.truth.attach_truth`)."""

    def __init__(self, truth: dict[str, np.ndarray]):
        self.ticks = np.asarray(truth["tick"], dtype=np.int64)
        m = len(self.ticks)
        blank = {k: np.full((1, 6), np.nan) for k in ("pose", "length", "force", "wrench")}
        padded = {k: np.concatenate([np.asarray(truth[k], dtype=np.float64).reshape(-1, 6), blank[k]])
                  for k in blank if k in truth}
        self.chars = []   # per block: (M + 1, K, W) bytes; the last row blank
        for blk in _truth_blocks(padded, slice(0, m + 1)):
            chars = np.zeros((m + 1, blk.k, blk.width), dtype=np.uint8)
            blk.fill(chars)
            self.chars.append(chars)

    def rows_of(self, data: LogData) -> np.ndarray:
        """Per row of ``data``, its truth row (as :func:`.truth.attach_truth`
        puts them; the blank row where there is none)."""
        out = np.full(len(data), len(self.ticks), dtype=np.int64)
        idx = data.index_of(self.ticks)
        ok = idx >= 0
        out[idx[ok]] = np.flatnonzero(ok)
        return out


#: Rows formatted at a time (bounds the character matrix).
_CSV_CHUNK = 16384


def write_signals_csv(data: LogData, path: str | Path, truth_text: TruthText | None = None) -> None:
    """signals.csv: one row per tick, SI units, blank for missing values.

    Every column is formatted at once with numpy (:class:`_Numbers`) into
    one character matrix of fixed-width fields, one row per tick, and the
    padding is dropped as the rows are written: the same text as
    :func:`signal_table` row by row (the plain reference,
    tests/python/test_framedecode.py), about 40x faster. ``truth_text``:
    the truth's columns formatted beforehand (:class:`TruthText`) from the
    truth attached to ``data``."""
    cols = signal_columns(data.truth is not None, data.tool is not None)
    truth_rows = truth_text.rows_of(data) if truth_text is not None and data.truth is not None else None
    with open(path, "wb") as fh:
        fh.write((",".join(cols) + "\r\n").encode())
        for a in range(0, len(data), _CSV_CHUNK):
            blocks = _table_blocks(data, slice(a, min(a + _CSV_CHUNK, len(data))), truth_text, truth_rows)
            n = min(a + _CSV_CHUNK, len(data)) - a
            seq = []
            for b in blocks:  # every field followed by a comma ...
                fields = np.zeros((n, b.k, b.width + 1), dtype=np.uint8)
                b.fill(fields[:, :, :b.width])
                fields[:, :, b.width] = ord(",")
                seq.append(fields.reshape(n, -1))
            seq.append(np.full((n, 1), ord("\n"), dtype=np.uint8))
            text = np.concatenate(seq, axis=1)
            text[:, -2] = ord("\r")  # ... but the last: the row ends with CR LF
            text = text.reshape(-1)
            fh.write(text[text != 0])


def write_signals_csv_reference(data: LogData, path: str | Path) -> None:
    """signals.csv through :func:`signal_table` and the csv module, row by
    row: the plain reference of :func:`write_signals_csv`."""
    cols, rows = signal_table(data)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        w.writerows(rows)
