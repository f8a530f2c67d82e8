"""The plant's truth: ``hs_sim --truth`` writes the platform's true pose, leg
lengths and cylinder forces per tick; :func:`read_truth` reads that CSV and
:func:`attach_truth` puts it on the ticks of a decoded log."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Mapping

import numpy as np

from .decode import LogData
from .names import AXES

TRUTH_COLUMNS = (["tick"] + list(AXES) + [f"len{i}" for i in range(1, 7)]
                 + [f"force{i}" for i in range(1, 7)])


def read_truth(path: str | Path) -> dict[str, np.ndarray]:
    """The plant's truth CSV: tick, x, y, z, roll, pitch, yaw, len1..6,
    force1..6 (SI), extra columns ignored; with or without the header line.
    Returns {"tick": (M,), "pose": (M,6), "length": (M,6), "force": (M,6)}.
    Unreadable rows are skipped (counted in "bad_rows")."""
    ticks, pose, length, force = [], [], [], []
    bad = 0
    with open(path, newline="") as f:
        reader = csv.reader(f)
        cols = None
        for n, rec in enumerate(reader):
            if not rec or not "".join(rec).strip():
                continue
            if n == 0 and not rec[0].strip().lstrip("-").isdigit():
                names = [c.strip() for c in rec]
                missing = [c for c in TRUTH_COLUMNS if c not in names]
                if missing:
                    raise ValueError(f"{path}: truth CSV lacks column(s) {', '.join(missing)}")
                cols = [names.index(c) for c in TRUTH_COLUMNS]
                continue
            idx = cols if cols is not None else list(range(len(TRUTH_COLUMNS)))
            try:
                vals = [float(rec[i]) for i in idx]
            except (ValueError, IndexError):
                bad += 1
                continue
            ticks.append(int(vals[0]))
            pose.append(vals[1:7])
            length.append(vals[7:13])
            force.append(vals[13:19])
    return {"tick": np.array(ticks, dtype=np.int64), "pose": np.array(pose).reshape(-1, 6),
            "length": np.array(length).reshape(-1, 6), "force": np.array(force).reshape(-1, 6),
            "bad_rows": np.array(bad)}


def attach_truth(data: LogData, truth: Mapping[str, np.ndarray]) -> None:
    """Puts the truth rows on the log's ticks (truth tick t = the plant state
    sampled for the feedback of SYNC t); ticks without truth stay NaN."""
    out = {k: np.full((len(data), 6), np.nan) for k in ("pose", "length", "force")}
    idx = data.index_of(truth["tick"])
    ok = idx >= 0
    for k in out:
        out[k][idx[ok]] = np.asarray(truth[k])[ok]
    data.truth = out
