# SPDX-License-Identifier: Apache-2.0
"""The plant's truth: ``hs_sim --truth`` writes the platform's true pose, leg
lengths, cylinder forces and the outside world's wrench on the platform per
tick; :func:`read_truth` reads that CSV and :func:`attach_truth` puts it on
the ticks of a decoded log."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Mapping

import numpy as np

from .decode import LogData
from .names import AXES, WRENCH_AXES

TRUTH_COLUMNS = (["tick"] + list(AXES) + [f"len{i}" for i in range(1, 7)]
                 + [f"force{i}" for i in range(1, 7)])
#: Optional: the external wrench (force N at o', moment N m about o', base frame).
WRENCH_COLUMNS = [f"wrench_{a}" for a in WRENCH_AXES]
#: Where hs_sim writes them (after tick, pose, len, force, drive1..6), for a
#: file without the header line.
WRENCH_POSITION = len(TRUTH_COLUMNS) + 6


def read_truth(path: str | Path) -> dict[str, np.ndarray]:
    """The plant's truth CSV (see :func:`read_truth_rows`). A file whose
    rows all parse is read by ``numpy.loadtxt`` (the columns needed only);
    any other goes row by row through :func:`read_truth_rows`, which skips
    and counts the bad rows. Same result either way
    (tests/python/test_framedecode.py)."""
    try:
        with open(path, newline="") as f:
            first = f.readline()
        rec = next(csv.reader([first])) if first.strip() else []
        header = bool(rec) and not rec[0].strip().lstrip("-").isdigit()
        if header:
            names = [c.strip() for c in rec]
            if any(c not in names for c in TRUTH_COLUMNS):
                return read_truth_rows(path)  # the row reader names what is missing
            cols = [names.index(c) for c in TRUTH_COLUMNS]
            wcols = ([names.index(c) for c in WRENCH_COLUMNS]
                     if all(c in names for c in WRENCH_COLUMNS) else [])
        else:
            cols = list(range(len(TRUTH_COLUMNS)))
            wcols = (list(range(WRENCH_POSITION, WRENCH_POSITION + 6))
                     if len(rec) >= WRENCH_POSITION + 6 else [])
        a = np.loadtxt(path, delimiter=",", skiprows=1 if header else 0, usecols=cols + wcols,
                       ndmin=2, comments=None, dtype=np.float64)
    except (ValueError, IndexError, UnicodeDecodeError):
        return read_truth_rows(path)
    n = len(TRUTH_COLUMNS)
    return {"tick": a[:, 0].astype(np.int64), "pose": a[:, 1:7].copy(), "length": a[:, 7:13].copy(),
            "force": a[:, 13:19].copy(),
            "wrench": a[:, n:n + 6].copy() if wcols else np.full((len(a), 6), np.nan),
            "bad_rows": np.array(0)}


def read_truth_rows(path: str | Path) -> dict[str, np.ndarray]:
    """The plant's truth CSV: tick, x, y, z, roll, pitch, yaw, len1..6,
    force1..6 (SI), and optionally wrench_fx..wrench_mz; extra columns
    ignored; with or without the header line (without it, hs_sim's column
    order). Returns {"tick": (M,), "pose": (M,6), "length": (M,6), "force":
    (M,6), "wrench": (M,6) (NaN where the file has no wrench)}.
    Unreadable rows are skipped (counted in "bad_rows")."""
    ticks, pose, length, force, wrench = [], [], [], [], []
    bad = 0
    nan6 = [float("nan")] * 6
    with open(path, newline="") as f:
        reader = csv.reader(f)
        cols = None
        wcols = None
        for n, rec in enumerate(reader):
            if not rec or not "".join(rec).strip():
                continue
            if n == 0 and not rec[0].strip().lstrip("-").isdigit():
                names = [c.strip() for c in rec]
                missing = [c for c in TRUTH_COLUMNS if c not in names]
                if missing:
                    raise ValueError(f"{path}: truth CSV lacks column(s) {', '.join(missing)}")
                cols = [names.index(c) for c in TRUTH_COLUMNS]
                if all(c in names for c in WRENCH_COLUMNS):
                    wcols = [names.index(c) for c in WRENCH_COLUMNS]
                else:
                    wcols = []
                continue
            idx = cols if cols is not None else list(range(len(TRUTH_COLUMNS)))
            try:
                vals = [float(rec[i]) for i in idx]
            except (ValueError, IndexError):
                bad += 1
                continue
            widx = wcols
            if widx is None:  # no header: hs_sim's layout, if the row is that long
                widx = (list(range(WRENCH_POSITION, WRENCH_POSITION + 6))
                        if len(rec) >= WRENCH_POSITION + 6 else [])
            try:
                w = [float(rec[i]) for i in widx] if widx else nan6
            except (ValueError, IndexError):
                bad += 1
                continue
            ticks.append(int(vals[0]))
            pose.append(vals[1:7])
            length.append(vals[7:13])
            force.append(vals[13:19])
            wrench.append(w)
    return {"tick": np.array(ticks, dtype=np.int64), "pose": np.array(pose).reshape(-1, 6),
            "length": np.array(length).reshape(-1, 6), "force": np.array(force).reshape(-1, 6),
            "wrench": np.array(wrench, dtype=float).reshape(-1, 6), "bad_rows": np.array(bad)}


def attach_truth(data: LogData, truth: Mapping[str, np.ndarray]) -> None:
    """Puts the truth rows on the log's ticks (truth tick t = the plant state
    sampled for the feedback of SYNC t); ticks without truth stay NaN, as
    does the wrench when ``truth`` has none."""
    out = {k: np.full((len(data), 6), np.nan) for k in ("pose", "length", "force", "wrench")}
    idx = data.index_of(truth["tick"])
    ok = idx >= 0
    for k in out:
        if k in truth:  # "wrench" is optional
            out[k][idx[ok]] = np.asarray(truth[k])[ok]
    data.truth = out
