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
wrench columns."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .. import protocol as pr
from .decode import CONTROL_MODES, FORCE_MODES, LogData
from .names import AXES, DRIVE_MODES, DRIVE_STATES, STATES, TICK_S, WRENCH_AXES


def signal_columns(truth: bool) -> list[str]:
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
    return cols


def signal_table(data: LogData) -> tuple[list[str], list[list[str]]]:
    """Header and rows (strings; blank where missing) of signals.csv."""
    cols = signal_columns(data.truth is not None)

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
        rows.append(r)
    return cols, rows


def _control_mode(m: int) -> str:
    return CONTROL_MODES[FORCE_MODES[m]] if 0 <= m < len(FORCE_MODES) else ""


def _number_chars(v: np.ndarray, decimals: int) -> np.ndarray:
    """``format(x, f".{decimals}f")`` of each finite value, blank for NaN and
    inf, as characters: ``v`` of shape (N, K) gives (N, K, W) bytes, padded
    with zero bytes (dropped when the file is written). Sign, integer
    digits, point and fraction digits of the value rounded to ``decimals``
    places (to the even neighbour on an exact tie)."""
    v = np.asarray(v, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    ok = np.isfinite(v)
    scaled = np.where(ok, np.abs(v), 0.0) * float(10 ** decimals)
    if (scaled >= 9.0e18).any():
        raise ValueError("value too large for the CSV's fixed-point columns")
    q = np.rint(scaled).astype(np.int64)
    ip, fp = np.divmod(q, 10 ** decimals)
    nd = len(str(int(ip.max()))) if ip.size else 1
    w = 1 + nd + (decimals + 1 if decimals > 0 else 0)
    out = np.zeros(v.shape + (w,), dtype=np.uint8)
    out[..., 0] = np.where(np.signbit(v) & ok, ord("-"), 0)
    # digits from the last, dividing by the scalar 10 (fast in numpy)
    for j in range(decimals):
        fp, r = np.divmod(fp, 10)
        out[..., w - 1 - j] = r + 0x30
    if decimals > 0:
        out[..., nd + 1] = ord(".")
    for j in range(nd):
        ip, r = np.divmod(ip, 10)
        col = np.where(r + ip > 0, r + 0x30, 0) if j else r + 0x30  # no leading zeros
        out[..., nd - j] = col
    out[~ok] = 0
    return out


def _int_chars(v: np.ndarray) -> np.ndarray:
    """Integers, blank where negative (missing)."""
    v = np.asarray(v, dtype=np.int64)
    return _number_chars(np.where(v >= 0, v, np.nan), 0)


def _text_chars(texts: list[str]) -> np.ndarray:
    """Character matrix (one row per text, zero-padded) of a few texts."""
    enc = [t.encode("utf-8") for t in texts]
    table = np.zeros((len(enc), max([1] + [len(e) for e in enc])), dtype=np.uint8)
    for k, e in enumerate(enc):
        table[k, :len(e)] = np.frombuffer(e, dtype=np.uint8)
    return table


def _coded_text(codes: np.ndarray, name) -> np.ndarray:
    """Text of integer codes through ``name(code)`` (called once per distinct
    code): (N, K) codes -> (N, K, W) bytes."""
    codes = np.asarray(codes, dtype=np.int64)
    if codes.ndim == 1:
        codes = codes[:, None]
    uniq, inv = np.unique(codes, return_inverse=True)
    return _text_chars([name(int(c)) for c in uniq] or [""])[inv.reshape(codes.shape)]


def _table_chars(data: LogData, rows: slice) -> list[np.ndarray]:
    """The columns of signals.csv for ``rows``, in blocks of (N, K, W) bytes."""
    def name_or_int(table):
        return lambda s: table[s] if 0 <= s < len(table) else ("" if s < 0 else str(s))

    ticks = data.ticks[rows]
    st = data.state[rows]
    fault_key = np.where(st >= 0, np.maximum(data.faults[rows], 0), -1)
    cols = [_int_chars(ticks), _number_chars(ticks * TICK_S, 3),
            _coded_text(st, name_or_int(STATES)), _int_chars(data.faults[rows]),
            _coded_text(fault_key, lambda f: "" if f < 0 else
                        "+".join(pr.fault_names(f, pr.CONTROLLER_FAULTS))),
            _coded_text(data.drive_mode[rows], lambda m: DRIVE_MODES[m] if m >= 0 else ""),
            _int_chars(np.stack([data.feedforward[rows], data.estimate_valid[rows]], axis=1)),
            _number_chars(np.concatenate([data.reference[rows], data.estimate[rows],
                                          data.length_sp[rows]], axis=1), 6),
            _number_chars(data.force_ff[rows], 2),
            # measured lengths in 0.1 um (AXIS_FEEDBACK's step): 7 decimals
            _number_chars(np.concatenate([data.length[rows], data.stretch[rows]], axis=1), 7),
            _number_chars(data.force[rows], 1),
            _coded_text(data.drive_state[rows], name_or_int(DRIVE_STATES)),
            _int_chars(np.concatenate([data.drive_faults[rows], data.est_wrench_valid[rows, None]],
                                      axis=1)),
            _number_chars(data.est_wrench[rows], 2),
            _coded_text(data.force_mode[rows], _control_mode),
            _number_chars(data.force_target[rows], 2)]
    if data.truth is not None:
        tw = data.truth.get("wrench")
        if tw is None:
            tw = np.full((len(data), 6), np.nan)
        cols += [_number_chars(np.concatenate([data.truth["pose"][rows], data.truth["length"][rows]],
                                              axis=1), 9),
                 _number_chars(np.concatenate([data.truth["force"][rows], tw[rows]], axis=1), 3)]
    return cols


#: Rows formatted at a time (bounds the character matrices).
_CSV_CHUNK = 16384


def write_signals_csv(data: LogData, path: str | Path) -> None:
    """signals.csv: one row per tick, SI units, blank for missing values.

    Every column is formatted at once with numpy (:func:`_number_chars`):
    the same text as :func:`signal_table` row by row (the plain reference,
    tests/python/test_framedecode.py), about 20x faster."""
    cols = signal_columns(data.truth is not None)
    with open(path, "wb") as fh:
        fh.write((",".join(cols) + "\r\n").encode())
        for a in range(0, len(data), _CSV_CHUNK):
            blocks = _table_chars(data, slice(a, min(a + _CSV_CHUNK, len(data))))
            n = blocks[0].shape[0]
            seq = []
            for blk in blocks:  # every field followed by a comma
                sep = np.full(blk.shape[:2] + (1,), ord(","), dtype=np.uint8)
                seq.append(np.concatenate([blk, sep], axis=2).reshape(n, -1))
            text = np.concatenate(seq, axis=1)
            text[:, -1] = 0     # the last field's comma: the row ends with CR LF
            text = np.concatenate([text, np.tile(np.frombuffer(b"\r\n", dtype=np.uint8), (n, 1))],
                                  axis=1).reshape(-1)
            fh.write(text[text != 0].tobytes())


def write_signals_csv_reference(data: LogData, path: str | Path) -> None:
    """signals.csv through :func:`signal_table` and the csv module, row by
    row: the plain reference of :func:`write_signals_csv`."""
    cols, rows = signal_table(data)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        w.writerows(rows)
