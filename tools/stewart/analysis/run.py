# SPDX-License-Identifier: Apache-2.0
"""``analyze()``: everything ``stewart analyze`` does for one log. Reads the
log (and the plant's truth), finds the segments, and writes signals.csv,
summary.json and the plots of each segment."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from .. import config as cfg
from .. import resources
from ..protocol import Protocol
from .csvout import TruthText, write_signals_csv
from .decode import LogData, read_log
from .metrics import DEFAULT_DELAY_TICKS, jsonable, summarize
from .prefetch import Beside, read_frames_beside
from .plots import plot_cylinders, plot_tracking
from .segments import Segment, find_segments
from .toolpose import IDENTITY, attach_tool, tool_tracking
from .truth import attach_truth, read_truth

DEFAULT_PLATFORM = resources.default_platform()


@dataclass
class Analysis:
    """What :func:`analyze` returns."""

    data: LogData
    segments: list[Segment]
    summary: dict[str, Any]
    files: list[Path]


def analyze(log: str | Path, out: str | Path, truth: str | Path | None = None,
            platform: str | Path | None = None, delay_ticks: int = DEFAULT_DELAY_TICKS,
            buses: str | None = None, plots: bool = True,
            progress: Callable[[str], None] | None = None, frames: Beside | None = None,
            tool=None, work=None) -> Analysis:
    """Reads ``log`` (and ``truth``), writes signals.csv, summary.json and the
    plots into ``out``; returns the data, segments, summary and files.
    ``progress(text)`` is told each step as it starts (the command prints
    them once a run takes more than a moment). ``frames``: the log's frames
    already being read (:func:`.prefetch.read_frames_beside`); else they
    are started on here, and the truth CSV is read while they are read.
    ``tool``, ``work``: the run's tool and work frames (x y z roll pitch
    yaw; issue 31): signals.csv gets the tool's pose in the work frame and
    the summary the tracking at the tool point (nothing with identity
    frames or None)."""
    def step(text: str) -> None:
        if progress is not None:
            progress(text)

    step(f"reading {log}")
    if frames is None:
        frames = read_frames_beside(log)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plat = cfg.load(platform or DEFAULT_PLATFORM)
    t = truth_text = None
    if truth is not None:  # while the log's frames are being read
        step(f"reading {truth}")
        t = read_truth(truth)
        truth_text = TruthText(t)  # its columns of signals.csv
    Protocol()  # the DBC parsed (and kept) while the frames are still being read
    data = read_log(log, buses=buses, platform=plat, frames=frames.result())
    if t is not None:
        attach_truth(data, t)
    if tool is not None or work is not None:
        attach_tool(data, tool if tool is not None else IDENTITY, work if work is not None else IDENTITY)
    segs = find_segments(data)
    files = [out / "signals.csv", out / "summary.json"]
    step(f"writing {files[0]}")
    write_signals_csv(data, files[0], truth_text)
    summary = summarize(data, segs, delay_ticks)
    if data.tool is not None:
        summary["tool_tracking"] = tool_tracking(data, delay_ticks)
    if data.stats.canopen:  # CiA 408 drives: their frames decoded into canopen.csv (docs/reference/canopen.md)
        from ..drives import traffic
        from .decode import CANOPEN_BUSES
        from .logfile import parse_bus_map

        ifmap = {i: b for i, b in parse_bus_map(buses).items() if b in CANOPEN_BUSES}
        step(f"writing {out / 'canopen.csv'}")
        # each node's device state by its profile (the config's drives; else its 0x1000 in the log)
        rows = traffic.decode(frames.result(), ifmap, traffic.profiles_from_drives(plat.drives))
        traffic.write_csv(rows, out / "canopen.csv")
        files.append(out / "canopen.csv")
        summary["canopen"] = traffic.summary(rows)
    if truth is not None:
        summary["truth_file"] = str(truth)
        summary["truth_bad_rows"] = int(t["bad_rows"])
    if plots:
        for s in segs:
            step(f"plotting segment {s.index} of {len(segs)}")
            p1 = out / f"seg{s.index}_tracking.png"
            p2 = out / f"seg{s.index}_cylinders.png"
            plot_tracking(data, s, p1, delay_ticks)
            plot_cylinders(data, s, p2)
            files += [p1, p2]
    summary["files"] = [str(f) for f in files]
    files[1].write_text(json.dumps(jsonable(summary), indent=1, allow_nan=False) + "\n")
    return Analysis(data, segs, summary, files)
