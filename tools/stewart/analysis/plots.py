# SPDX-License-Identifier: Apache-2.0
"""The figures of a run (matplotlib, Agg): per segment the tracking of the
moving axis and the six cylinders' stretch and force, and the tracking
errors of matching segments of several runs overlaid."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .decode import LogData
from .metrics import DEFAULT_DELAY_TICKS, error_stats, format_value, tracking_error
from .names import AXES, TICK_S, axis_unit, is_angle, motion_name
from .segments import Segment


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _axis_scale(axis: int) -> tuple[float, str]:
    """Plot scale and unit of a pose axis: mm or deg."""
    return (180.0 / math.pi, "deg") if is_angle(axis) else (1e3, "mm")


def plot_tracking(data: LogData, seg: Segment, path: str | Path,
                  delay_ticks: int = DEFAULT_DELAY_TICKS) -> None:
    """(a) reference vs estimate (and truth) on the moving axis, (b) tracking
    error over time (moving axis bold, the others thin)."""
    plt = _plt()
    ax_i = seg.axis if seg.axis is not None else 0
    m = seg.mask(data)
    t = data.time_s[m] - seg.start * TICK_S
    sc, unit = _axis_scale(ax_i)
    home = data.platform.home[ax_i] if data.platform is not None else 0.0
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    a1.plot(t, (data.reference[m, ax_i] - home) * sc, lw=1.6, label="reference")
    a1.plot(t, (data.estimate[m, ax_i] - home) * sc, lw=1.0, ls="--", label="estimate (FK)")
    if data.truth is not None:
        a1.plot(t, (data.truth["pose"][m, ax_i] - home) * sc, lw=0.8, ls=":", label="truth (plant)")
    a1.set_ylabel(f"{AXES[ax_i]} - home [{unit}]")
    a1.set_title(f"segment {seg.index}: {seg.label}")
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3)
    err = tracking_error(data, delay_ticks)
    for a in range(6):
        bold = a == ax_i
        a2.plot(t, err[m, a] * 1e3, color=f"C{a}", lw=1.6 if bold else 0.6,
                alpha=1.0 if bold else 0.7, label=f"{AXES[a]} [{axis_unit(a)}]")
    if data.truth is not None:
        et = tracking_error(data, delay_ticks, pose=data.truth["pose"])
        a2.plot(t, et[m, ax_i] * 1e3, lw=0.8, ls=":", color="k", label=f"{AXES[ax_i]}, truth")
    a2.set_ylabel(f"estimate(t) - reference(t-{delay_ticks}) [mm, mrad]")
    a2.ticklabel_format(axis="y", useOffset=False)
    a2.set_xlabel("time since the segment start [s]")
    a2.legend(ncol=4, fontsize=7)
    a2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def figure_window(seg: Segment) -> tuple[int, int]:
    """Ticks plotted against the moving axis in the cylinder figure: the last
    full period of the steady part of a RUN_TRIG, else the whole segment."""
    a, b = seg.steady()
    if seg.command == "RUN_TRIG" and seg.frequency:
        period = int(round(1.0 / seg.frequency / TICK_S))
        if b - a + 1 >= period:
            return b - period + 1, b
    return a, b


def plot_cylinders(data: LogData, seg: Segment, path: str | Path) -> None:
    """(c) stretch of the six cylinders and (d) their force, feed-forward
    (controller, solid) and measured from the pressures (plant, dashed),
    against the moving axis (estimated pose) as in the paper's Figs 4/5."""
    plt = _plt()
    ax_i = seg.axis if seg.axis is not None else 0
    a, b = figure_window(seg)
    m = (data.ticks >= a) & (data.ticks <= b)
    sc, unit = _axis_scale(ax_i)
    home = data.platform.home[ax_i] if data.platform is not None else 0.0
    x = (data.estimate[m, ax_i] - home) * sc
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7.5, 8.5), sharex=True)
    stretch, force = data.stretch[m], data.force[m]

    def known(v):   # the rows with a value: CANopen drives answer every sync_divider ticks only
        ok = np.isfinite(x) & np.isfinite(v)
        return x[ok], v[ok]

    for j in range(6):
        c = colors[j % len(colors)]
        a1.plot(*known(stretch[:, j] * 1e3), color=c, lw=1.8, alpha=0.7, label=f"cyl.{j + 1}")
        a2.plot(*known(data.force_ff[m, j] / 1e3), color=c, lw=1.8, alpha=0.7, label=f"cyl.{j + 1}")
        a2.plot(*known(force[:, j] / 1e3), color=c, lw=0.8, ls="--")
    a2.plot([], [], color="k", lw=1.8, label="feed-forward")
    a2.plot([], [], color="k", lw=0.8, ls="--", label="measured p_A A - p_B A_r")
    a1.set_ylabel("cylinder stretch (measured) [mm]")
    a2.set_ylabel("cylinder force [kN]")
    name = motion_name(ax_i)
    a2.set_xlabel(f"{name} (estimate) - home [{unit}]")
    a1.set_title(f"closed loop, segment {seg.index}: {seg.label}\n"
                 f"ticks {a}..{b}")
    a1.legend(ncol=3, fontsize=8)
    a2.legend(ncol=4, fontsize=7)
    a1.grid(alpha=0.3)
    a2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_compare(runs: list[tuple[str, LogData, Segment]], path: str | Path,
                 delay_ticks: int = DEFAULT_DELAY_TICKS) -> None:
    """Tracking error of the moving axis of matching segments of several runs,
    overlaid against the time since each segment's start."""
    plt = _plt()
    fig, ax = plt.subplots(1, 1, figsize=(8, 4.5))
    for name, data, seg in runs:
        ax_i = seg.axis if seg.axis is not None else 0
        m = seg.mask(data)
        e = tracking_error(data, delay_ticks)[m, ax_i] * 1e3
        st = error_stats(e, 1.0)
        ax.plot(data.time_s[m] - seg.start * TICK_S, e, lw=1.0,
                label=f"{name}: {seg.label} (RMS {format_value(st['rms'])} {axis_unit(ax_i)})")
    ax.set_xlabel("time since the segment start [s]")
    ax.set_ylabel(f"tracking error [mm, mrad] (delay {delay_ticks} tick)")
    ax.ticklabel_format(axis="y", useOffset=False)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_wrench(data: LogData, path: str | Path) -> None:
    """The controller's external wrench estimate against the plant's truth
    over the whole run: forces (kN) above, moments (kN m) below."""
    from .names import WRENCH_AXES

    plt = _plt()
    truth = data.truth["wrench"] if data.truth is not None and data.truth.get("wrench") is not None else None
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    t = data.time_s
    colors = ["tab:blue", "tab:orange", "tab:green"]
    for k in range(6):
        ax = a1 if k < 3 else a2
        c = colors[k % 3]
        ok = ~np.isnan(data.est_wrench[:, k])
        ax.plot(t[ok], data.est_wrench[ok, k] / 1e3, lw=0.8, color=c, label=f"{WRENCH_AXES[k]} estimate")
        if truth is not None:
            ax.plot(t, truth[:, k] / 1e3, lw=1.2, ls="--", color=c, alpha=0.8, label=f"{WRENCH_AXES[k]} truth")
    a1.set_ylabel("force on the platform [kN]")
    a2.set_ylabel("moment about o' [kN m]")
    a2.set_xlabel("time [s]")
    a1.set_title("external wrench: the controller's estimate (CTRL_WRENCH, 500 Hz) vs the plant's truth")
    for ax in (a1, a2):
        ax.legend(ncol=3, fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
