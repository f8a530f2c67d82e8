"""``signals.csv``: one row per tick of a decoded run, SI units, blank where
a value is missing (columns: :func:`signal_columns`).

The controller's wrench estimate (``est_wrench_*``, CTRL_WRENCH) is sent on
every 2nd tick: the other rows leave it blank, as every value without a
frame for its tick (not held from the previous frame); ``est_wrench_valid``
is 1 or 0 on the ticks with a frame and the components are blank unless it
is 1. ``truth_wrench_*``: the plant's true external wrench (external +
contact), blank if the truth CSV has no wrench columns."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .. import protocol as pr
from .decode import LogData
from .names import AXES, DRIVE_MODES, DRIVE_STATES, TICK_S, WRENCH_AXES


def signal_columns(truth: bool) -> list[str]:
    cols = ["tick", "time_s", "state", "faults", "fault_names", "drive_mode", "feedforward",
            "estimate_valid"]
    cols += [f"ref_{a}" for a in AXES] + [f"est_{a}" for a in AXES]
    for group in ("length_sp", "force_ff", "length", "stretch", "force", "drive_state", "drive_faults"):
        cols += [f"{group}{i}" for i in range(1, 7)]
    cols += ["est_wrench_valid"] + [f"est_wrench_{a}" for a in WRENCH_AXES]
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
        r += [f(v, ".6f") for v in data.length[k]] + [f(v, ".6f") for v in stretch[k]]
        r += [f(v, ".1f") for v in force[k]]
        r += [DRIVE_STATES[s] if 0 <= s < len(DRIVE_STATES) else i(s) for s in data.drive_state[k]]
        r += [i(v) for v in data.drive_faults[k]]
        r += [i(data.est_wrench_valid[k])] + [f(v, ".2f") for v in data.est_wrench[k]]
        if data.truth is not None:
            r += [f(v, ".9f") for v in data.truth["pose"][k]]
            r += [f(v, ".9f") for v in data.truth["length"][k]]
            r += [f(v, ".3f") for v in data.truth["force"][k]]
            r += [f(v, ".3f") for v in truth_wrench[k]]
        rows.append(r)
    return cols, rows


def write_signals_csv(data: LogData, path: str | Path) -> None:
    """signals.csv: one row per tick, SI units, blank for missing values."""
    cols, rows = signal_table(data)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        w.writerows(rows)
