# SPDX-License-Identifier: Apache-2.0
"""Figures of a run: the tracking error, per-segment metrics, the summary
(``summary.json``) and its printed form.

The tracking error is ``estimate(t) - reference(t - d)`` with d = 0 by
default: the drives move their target along the setpoint's velocity through
the cycle, so a perfect servo is at reference(t) when SYNC(t) samples it
(docs/reference/analysis.md).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from .. import protocol as pr
from .decode import LogData
from .names import AXES, STATES, TICK_S, axis_unit
from .segments import Segment, find_segments

#: Default delay of the tracking error, ticks (docs/reference/analysis.md).
DEFAULT_DELAY_TICKS = 0


def _wrap(e: np.ndarray) -> np.ndarray:
    """Angle differences into (-pi, pi]."""
    return (e + np.pi) % (2 * np.pi) - np.pi


def delayed(data: LogData, values: np.ndarray, delay_ticks: int) -> np.ndarray:
    """values(t - delay) on each row's tick (NaN where the log has no such tick)."""
    idx = data.index_of(data.ticks - int(delay_ticks))
    out = np.full_like(values, np.nan, dtype=float)
    ok = idx >= 0
    out[ok] = values[idx[ok]]
    return out


def tracking_error(data: LogData, delay_ticks: int = DEFAULT_DELAY_TICKS,
                   pose: np.ndarray | None = None) -> np.ndarray:
    """(N, 6) error ``pose(t) - reference(t - d)``, m / rad (angles wrapped);
    ``pose`` defaults to the controller's estimate (pass ``data.truth['pose']``
    for the true tracking error)."""
    p = data.estimate if pose is None else pose
    e = p - delayed(data, data.reference, delay_ticks)
    e[:, 3:] = _wrap(e[:, 3:])
    return e


def error_stats(e: np.ndarray, scale: float) -> dict[str, float | int]:
    e = e[np.isfinite(e)]
    if len(e) == 0:
        return {"rms": None, "max": None, "mean": None, "n": 0}
    return {"rms": float(np.sqrt(np.mean(e * e)) * scale), "max": float(np.max(np.abs(e)) * scale),
            "mean": float(np.mean(e) * scale), "n": int(len(e))}


def error_metrics(err: np.ndarray, mask: np.ndarray) -> dict[str, dict]:
    """RMS, max |error| and mean per axis over the rows of ``mask`` (finite
    values only; ``n`` of them), in mm / mrad."""
    return {AXES[a]: dict(error_stats(err[mask, a], 1e3), unit=axis_unit(a)) for a in range(6)}


def segment_metrics(data: LogData, seg: Segment, delay_ticks: int = DEFAULT_DELAY_TICKS) -> dict[str, Any]:
    """Tracking error (estimate and, with truth, the true pose), estimation
    error (estimate - truth, same tick) and peak forces of one segment."""
    m = seg.mask(data)
    out: dict[str, Any] = dict(seg.as_dict())
    err = tracking_error(data, delay_ticks)
    out["error"] = error_metrics(err, m)
    out["moving_axis_error"] = out["error"][AXES[seg.axis]] if seg.axis is not None else None
    a, b = seg.steady()
    ms = (data.ticks >= a) & (data.ticks <= b)
    out["steady_error"] = error_metrics(err, ms)
    if data.truth is not None:
        et = tracking_error(data, delay_ticks, pose=data.truth["pose"])
        out["truth_error"] = error_metrics(et, m)
        out["moving_axis_truth_error"] = (out["truth_error"][AXES[seg.axis]]
                                          if seg.axis is not None else None)
        ee = data.estimate - data.truth["pose"]
        ee[:, 3:] = _wrap(ee[:, 3:])
        out["estimation_error"] = error_metrics(ee, m)
    ff = np.abs(data.force_ff[m])
    fm = np.abs(data.force[m])
    out["peak_force_ff_N"] = [float(np.nanmax(c)) if np.isfinite(c).any() else None for c in ff.T]
    out["peak_force_measured_N"] = [float(np.nanmax(c)) if np.isfinite(c).any() else None for c in fm.T]
    if data.truth is not None:
        ft = np.abs(data.truth["force"][m])
        out["peak_force_truth_N"] = [float(np.nanmax(c)) if np.isfinite(c).any() else None for c in ft.T]
    d = data.force[m] - data.force_ff[m]
    out["force_measured_minus_ff_rms_N"] = [error_stats(c, 1.0)["rms"] for c in d.T]
    st = data.stretch[m]
    out["stretch_range_mm"] = [[float(np.nanmin(c) * 1e3), float(np.nanmax(c) * 1e3)]
                               if np.isfinite(c).any() else None for c in st.T]
    return out


def jsonable(obj):
    """NaN and infinities -> None, numpy scalars -> Python (for JSON)."""
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _max_or_none(v: list) -> float | None:
    v = [x for x in v if x is not None]
    return max(v) if v else None


def _bits_seen(bits: np.ndarray) -> int:
    """OR of the fault masks of the rows that have one (-1: missing)."""
    b = bits[bits >= 0]
    return int(np.bitwise_or.reduce(b)) if len(b) else 0


def summarize(data: LogData, segments: list[Segment] | None = None,
              delay_ticks: int = DEFAULT_DELAY_TICKS) -> dict[str, Any]:
    """Everything summary.json holds."""
    if segments is None:
        segments = find_segments(data)
    faults = _bits_seen(data.faults)
    dfaults = [pr.fault_names(_bits_seen(data.drive_faults[:, j]), pr.DRIVE_FAULTS) for j in range(6)]
    known = np.nonzero(data.state >= 0)[0]
    final = data.state_name(int(known[-1])) if len(known) else None
    visited = []
    states = data.state[known]
    changes = np.flatnonzero(np.concatenate(([True], states[1:] != states[:-1]))) if len(states) else []
    for s in states[changes].tolist():   # the first row of each run of one state
        name = STATES[s] if 0 <= s < len(STATES) else str(s)
        if not visited or visited[-1] != name:
            visited.append(name)
    segs = [segment_metrics(data, s, delay_ticks) for s in segments]
    return {
        "log": data.source,
        "ticks": {"first": int(data.ticks[0]) if len(data) else None,
                  "last": int(data.ticks[-1]) if len(data) else None, "rows": len(data)},
        "duration_s": float((data.ticks[-1] - data.ticks[0] + 1) * TICK_S) if len(data) else 0.0,
        "delay_ticks": int(delay_ticks),
        "frames": data.stats.as_dict(),
        "bad_frames": data.stats.bad_frames,
        "malformed_lines": data.stats.malformed,
        "faults_seen": pr.fault_names(faults, pr.CONTROLLER_FAULTS),
        "drive_faults_seen": {f"leg{j + 1}": dfaults[j] for j in range(6) if dfaults[j]},
        "final_state": final,
        "states": visited,
        "commands": [c.as_dict() for c in data.commands],
        "truth": data.truth is not None,
        "segments": segs,
        "peak_force_ff_N": _max_or_none([_max_or_none(s["peak_force_ff_N"]) for s in segs]),
        "peak_force_measured_N": _max_or_none([_max_or_none(s["peak_force_measured_N"]) for s in segs]),
    }


def format_value(v, spec=".3f") -> str:
    return "-" if v is None else format(v, spec)


def format_summary(summary: Mapping[str, Any]) -> str:
    """The printed human summary."""
    fr = summary["frames"]
    lines = [f"log {summary['log']}: ticks {summary['ticks']['first']}..{summary['ticks']['last']} "
             f"({summary['duration_s']:.3f} s), final state {summary['final_state']}",
             f"frames: {fr['frames']} read, {fr['accepted']} accepted, bad {summary['bad_frames']}"
             + (f" ({', '.join(f'{k} {v}' for k, v in fr['rejected'].items())})" if fr["rejected"] else "")
             + f", malformed lines {fr['malformed_lines']}, lost {fr['lost_frames']}"
             + (f", unknown interface {fr['unknown_interface']}" if fr["unknown_interface"] else "")
             + (f", CANopen {fr['canopen']}" if fr.get("canopen") else "")
             + (f", stale feedback {fr['stale_feedback']}" if fr["stale_feedback"] else ""),
             f"states: {' -> '.join(summary['states']) or '-'}; controller faults seen: "
             f"{', '.join(summary['faults_seen']) or 'none'}"
             + ("; drive faults: " + ", ".join(f"{k} {'+'.join(v)}" for k, v in
                                                summary["drive_faults_seen"].items())
                if summary["drive_faults_seen"] else ""),
             f"tracking error = estimate(t) - reference(t - {summary['delay_ticks']} tick)"]
    co = fr.get("canopen_feedback")
    if co:
        out = [f"{k.replace('_', ' ')} {co[k]}" for k in ("unplaced", "unknown_node", "short", "repeated") if co[k]]
        lines.append(f"CANopen feedback ({co['layout']} layout): {co['answers']} TPDOs into the leg columns, "
                     f"{co['syncs']} SYNCs placed on ticks"
                     + (f", {co['syncs_unplaced']} not" if co["syncs_unplaced"] else "")
                     + (f"; left out: {', '.join(out)}" if out else ""))
    if fr["setpoint_checked"] and fr["setpoint_mismatch"]:
        lines.append(f"WARNING: CTRL_MONITOR and AXIS_SETPOINTS length setpoints differ on "
                     f"{fr['setpoint_mismatch']} of {fr['setpoint_checked']} ticks")
    if not summary["segments"]:
        lines.append("no RUNNING segment")
    for s in summary["segments"]:
        lines.append(f"segment {s['index']}: {s['label']}, ticks {s['start_tick']}..{s['end_tick']} "
                     f"({s['duration_s']:.3f} s)")
        me = s["moving_axis_error"]
        if me is not None:
            lines.append(f"  moving axis {s['axis']}: RMS {format_value(me['rms'])} {me['unit']}, "
                         f"max {format_value(me['max'])} {me['unit']}")
            if s.get("moving_axis_truth_error"):
                te = s["moving_axis_truth_error"]
                lines.append(f"  against truth:  RMS {format_value(te['rms'])} {te['unit']}, "
                             f"max {format_value(te['max'])} {te['unit']}")
        lines.append("  all axes RMS/max: " + "; ".join(
            f"{a} {format_value(v['rms'])}/{format_value(v['max'])} {v['unit']}"
            for a, v in s["error"].items()))
        peak_ff = format_value(_max_or_none(s["peak_force_ff_N"]), ".0f")
        peak_measured = format_value(_max_or_none(s["peak_force_measured_N"]), ".0f")
        lines.append(f"  peak force: feed-forward {peak_ff} N, measured {peak_measured} N")
    lines += format_tool_tracking(summary.get("tool_tracking"))
    return "\n".join(lines)


def format_tool_tracking(tt: Mapping[str, Any] | None) -> list[str]:
    """The tracking at the tool point (issue 31; .toolpose.tool_tracking) as
    printed lines; none without tool frames."""
    if not tt:
        return []
    fr = tt["frames"]
    lines = [f"tool point: tool frame {' '.join(f'{v:g}' for v in fr['tool'])} (in o'), work frame "
             f"{' '.join(f'{v:g}' for v in fr['work'])} (in the base frame), {tt['ticks']} RUNNING ticks"]
    for key, name in (("est", "estimate"), ("truth", "truth")):
        m = tt.get(key)
        if m:
            lines.append(f"  tool point vs reference, {name}: position RMS {m['position_rms_mm']:.4f} mm, max "
                         f"{m['position_max_mm']:.4f} mm; orientation RMS {m['angle_rms_rad']:.2e} rad, max "
                         f"{m['angle_max_rad']:.2e} rad")
    return lines


#: How long after a change of the true wrench the estimate is judged (issue 14).
WRENCH_SETTLE_TICKS = 20
#: Bounds of the estimate against the truth (issue 14): unloaded |error|, and
#: loaded 2 % of the load plus these.
WRENCH_UNLOADED = (150.0, 75.0)   # N, N m
WRENCH_LOADED_ABS = (100.0, 50.0)  # N, N m
WRENCH_LOADED_REL = 0.02


def wrench_metrics(data: LogData, settle_ticks: int = WRENCH_SETTLE_TICKS) -> dict[str, Any] | None:
    """The controller's external wrench estimate (CTRL_WRENCH) against the
    plant's truth, on the ticks with a valid estimate that are at least
    ``settle_ticks`` after the last change of the true wrench: the largest
    |error| of force (N) and moment (N m) while unloaded (in RUNNING and in
    every state), and while loaded per axis against 2 % of the load plus
    100 N / 50 N m. None without truth wrench columns; ``{"valid_ticks": 0}``
    when the estimate was never valid (CTRL_WRENCH Valid 0 throughout: e.g.
    drives that measure no cylinder force, CiA 402)."""
    if data.truth is None or data.truth.get("wrench") is None:
        return None
    truth = data.truth["wrench"]
    est = data.est_wrench
    ok = np.isfinite(est).all(axis=1) & np.isfinite(truth).all(axis=1)
    if not ok.any():
        return {"settle_ticks": int(settle_ticks), "valid_ticks": 0}
    # ticks since the last change of the true wrench
    changed = np.ones(len(data.ticks), dtype=bool)
    changed[1:] = np.any(truth[1:] != truth[:-1], axis=1) | (np.diff(data.ticks) != 1)
    last = np.maximum.accumulate(np.where(changed, data.ticks, -(1 << 62)))
    settled = ok & (data.ticks - last >= settle_ticks)
    err = est - truth
    loaded = np.any(truth != 0.0, axis=1)
    running = data.state == STATES.index("RUNNING")

    def worst(mask):
        if not mask.any():
            return None
        e = np.abs(err[mask])
        return {"force_N": float(np.max(e[:, :3])), "moment_Nm": float(np.max(e[:, 3:])),
                "rms": [float(x) for x in np.sqrt(np.mean(err[mask] ** 2, axis=0))], "n": int(mask.sum())}

    out: dict[str, Any] = {"settle_ticks": int(settle_ticks), "valid_ticks": int(ok.sum()),
                           "unloaded_running": worst(settled & ~loaded & running),
                           "unloaded": worst(settled & ~loaded)}
    m = settled & loaded
    if m.any():
        absolute = np.array([WRENCH_LOADED_ABS[0]] * 3 + [WRENCH_LOADED_ABS[1]] * 3)
        bound = WRENCH_LOADED_REL * np.abs(truth[m]) + absolute
        excess = np.abs(err[m]) / bound
        out["loaded"] = dict(worst(m), worst_share_of_bound=float(np.max(excess)),
                             within=bool(np.all(excess <= 1.0)))
    return out


def format_wrench(w: Mapping[str, Any] | None) -> list[str]:
    """Printed lines of :func:`wrench_metrics`."""
    if not w:
        return ["wrench estimate: no truth to compare with"]
    if w.get("valid_ticks") == 0:
        return ["wrench estimate: never valid (CTRL_WRENCH Valid 0 on every tick: "
                "the drives measure no cylinder force)"]
    lines = []
    for key, what in (("unloaded_running", "no load, RUNNING"), ("unloaded", "no load, any state"),
                      ("loaded", "constant load")):
        v = w.get(key)
        if v:
            lines.append(f"wrench estimate - truth ({what}, {w['settle_ticks']} ms after each change): "
                         f"max {v['force_N']:.0f} N, {v['moment_Nm']:.0f} N m; RMS "
                         + " ".join(f"{x:.0f}" for x in v["rms"])
                         + (f"; {v['worst_share_of_bound']:.2f} of the bound 2 % + 100 N / 50 N m"
                            if "worst_share_of_bound" in v else ""))
    return lines
