# SPDX-License-Identifier: Apache-2.0
"""Motion segments: the RUNNING intervals of a run, each labelled with the
operator command that started it (OP_COMMAND RUN_TRIG, MOVE_TO, STREAM) and
the force feed-forward flag, and the pairing of matching segments of two
runs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .decode import LogData
from .names import AXES, STATES, TICK_S, axis_unit, motion_name

#: Fade-in/out of RUN_TRIG when OP_COMMAND.FadeTime is 0 (sp_ctrl_default_config: 2 s).
DEFAULT_FADE_S = 2.0
RUNNING = STATES.index("RUNNING")
#: Commands that start a RUNNING interval.
MOTION_COMMANDS = ("RUN_TRIG", "MOVE_TO", "STREAM")
#: Commands that end one.
STOP_COMMANDS = ("STOP", "PARK", "ESTOP")


@dataclass
class Segment:
    """One RUNNING interval (ticks ``start``..``end`` inclusive)."""

    index: int
    start: int
    end: int
    command: str | None = None     #: RUN_TRIG, MOVE_TO, STREAM or None (not in the log)
    axis: int | None = None        #: moving axis (0..5)
    amplitude: float | None = None
    frequency: float | None = None
    fade_time: float | None = None
    stop_tick: int | None = None   #: tick of the STOP/PARK/ESTOP that ended it
    feedforward: str = "?"         #: on, off, mixed, ?
    label: str = ""

    @property
    def duration_s(self) -> float:
        return (self.end - self.start + 1) * TICK_S

    def mask(self, data: LogData) -> np.ndarray:
        return (data.ticks >= self.start) & (data.ticks <= self.end)

    def steady(self) -> tuple[int, int]:
        """Ticks of the full-amplitude part of a RUN_TRIG (after the fade-in,
        before the stop); the whole segment for other motions."""
        if self.command != "RUN_TRIG":
            return self.start, self.end
        fade = self.fade_time if self.fade_time else DEFAULT_FADE_S
        a = self.start + int(round(fade / TICK_S))
        b = self.stop_tick if self.stop_tick is not None else self.end - int(round(fade / TICK_S))
        if b <= a:
            return self.start, self.end
        return a, min(b, self.end)

    def as_dict(self) -> dict[str, Any]:
        return {"index": self.index, "label": self.label, "start_tick": self.start,
                "end_tick": self.end, "duration_s": self.duration_s, "command": self.command,
                "axis": AXES[self.axis] if self.axis is not None else None,
                "amplitude": self.amplitude, "frequency": self.frequency,
                "fade_time": self.fade_time, "stop_tick": self.stop_tick,
                "feedforward": self.feedforward, "steady_ticks": list(self.steady())}


def _label(seg: Segment) -> str:
    ff = f"ff={seg.feedforward}"
    if seg.axis is None:
        return f"{(seg.command or 'running').lower()} {ff}"
    ax = seg.axis
    motion = motion_name(ax)
    if seg.command == "RUN_TRIG":
        return (f"{motion} {seg.amplitude:.3f} {axis_unit(ax, False)} {seg.frequency:g} Hz {ff}")
    what = (seg.command or "running").lower().replace("_", "-")
    amp = f" {seg.amplitude:.3f} {axis_unit(ax, False)}" if seg.amplitude is not None else ""
    return f"{what} {motion}{amp} {ff}"


def find_segments(data: LogData) -> list[Segment]:
    """The RUNNING intervals, each labelled from the operator command that
    started it (the last RUN_TRIG/MOVE_TO/STREAM executed at or before its
    first tick and after the previous interval) and from CTRL_STATUS's
    FeedForward flag. Rows without a status do not split an interval. Without
    a command the moving axis is the one whose reference moved most."""
    known = data.state >= 0
    ticks = data.ticks[known]
    run = data.state[known] == RUNNING
    intervals: list[tuple[int, int]] = []
    start = None
    for k in range(len(ticks)):
        if run[k] and start is None:
            start = k
        elif not run[k] and start is not None:
            intervals.append((int(ticks[start]), int(ticks[k - 1])))
            start = None
    if start is not None:
        intervals.append((int(ticks[start]), int(ticks[-1])))
    segs = []
    prev_end = None
    for n, (a, b) in enumerate(intervals):
        seg = Segment(n + 1, a, b)
        cands = [c for c in data.commands if c.command in MOTION_COMMANDS and c.tick is not None
                 and c.tick <= a and (prev_end is None or c.tick > prev_end)]
        if cands:
            c = cands[-1]
            seg.command = c.command
            if c.command == "RUN_TRIG":
                seg.axis, seg.amplitude, seg.frequency = c.axis, c.amplitude, c.frequency
                seg.fade_time = c.fade_time if c.fade_time > 0 else DEFAULT_FADE_S
        stops = [c for c in data.commands if c.command in STOP_COMMANDS and c.tick is not None
                 and a <= c.tick <= b]
        if stops:
            seg.stop_tick = stops[0].tick
        m = seg.mask(data)
        ref = data.reference[m]
        if seg.axis is None and np.isfinite(ref).any():
            span = np.nanmax(ref, axis=0) - np.nanmin(ref, axis=0)
            span = np.nan_to_num(span, nan=0.0)
            if span.max() > 0:
                seg.axis = int(np.argmax(span))
                centre = ref[0, seg.axis]
                seg.amplitude = float(np.nanmax(np.abs(ref[:, seg.axis] - centre)))
        ff = data.feedforward[m]
        ff = ff[ff >= 0]
        if len(ff):
            seg.feedforward = "on" if ff.all() else ("off" if not ff.any() else "mixed")
        seg.label = _label(seg)
        segs.append(seg)
        prev_end = b
    return segs


def match_segments(a: list[Segment], b: list[Segment]) -> list[tuple[Segment, Segment]]:
    """Pairs segments of two runs with the same motion (command, axis,
    amplitude, frequency), in order; falls back to pairing by position."""
    pairs = []
    used: set[int] = set()

    def key(s):
        return (s.command, s.axis, None if s.amplitude is None else round(s.amplitude, 5),
                None if s.frequency is None else round(s.frequency, 3))

    for s in a:
        for k, t in enumerate(b):
            if k not in used and key(t) == key(s):
                pairs.append((s, t))
                used.add(k)
                break
    if not pairs:
        pairs = list(zip(a, b))
    return pairs
