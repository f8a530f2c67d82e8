# SPDX-License-Identifier: Apache-2.0
"""Analysis of a closed-loop run: a CAN log (candump -L format) in, a per-tick
CSV, the motion segments, tracking errors, plots and a summary out.

The theory and the reasons behind every choice (tick alignment, the one-tick
delay of the tracking error, measured force from the chamber pressures) are
in docs/reference/analysis.md. One module per job:

* :mod:`.logfile`: the candump -L line format and the interface -> bus map.
* :mod:`.decode`: :func:`~.decode.read_log`, frames checked with the
  protocol and decoded into one row per tick (:class:`~.decode.LogData`).
* :mod:`.truth`: the plant's truth CSV, put on the log's ticks.
* :mod:`.segments`: the RUNNING intervals, labelled from the operator
  command that started each (OP_COMMAND RUN_TRIG, MOVE_TO, STREAM).
* :mod:`.metrics`: the tracking error ``estimate(t) - reference(t - d)``,
  d = 1 tick, per-segment figures, the summary and its printed form.
* :mod:`.csvout`: signals.csv. :mod:`.plots`: the figures.
* :mod:`.run`: :func:`analyze`, all of the above for one log.
* :mod:`.names`: the axes, units and the DBC's state and command names.

Python API (numbers are numpy arrays in SI units: m, rad, N, Pa)::

    data = decode.read_log("run.log", buses=None, platform=cfg.load(...))
    truth.attach_truth(data, truth.read_truth("truth.csv"))    # optional
    segs = segments.find_segments(data)
    err = metrics.tracking_error(data, delay_ticks=0)           # (N, 6)
    m = metrics.segment_metrics(data, segs[0], delay_ticks=0)   # dict
    summary = metrics.summarize(data, segs, delay_ticks=0)      # dict (summary.json)
    csvout.write_signals_csv(data, "signals.csv")
    analyze("run.log", "out/", truth="truth.csv")               # everything
"""

import importlib

__all__ = ["Analysis", "LogData", "analyze", "read_log"]
_HOME = {"Analysis": ".run", "analyze": ".run", "LogData": ".decode", "read_log": ".decode"}


def __getattr__(name: str):
    """The names above, imported on first use: the package itself stays
    light (no DBC parse), so that :mod:`.prefetch` can start reading a log
    before the protocol is loaded."""
    if name in _HOME:
        return getattr(importlib.import_module(_HOME[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
