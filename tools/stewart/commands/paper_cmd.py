# SPDX-License-Identifier: Apache-2.0
"""``stewart paper``: the paper's Figures 4 and 5, computed by the fixed-point
firmware core, with the float64 model overlaid.

Figure 4: surge, x(t) = x_home + A sin(2 pi f t), A = 90 mm, f = 0.5 Hz.
Figure 5: yaw, psi(t) = A_yaw sin(2 pi f t), f = 0.5 Hz; the paper gives
"90 mm" for both motions, and an angle has no millimetres: we read the yaw
amplitude as 0.09 rad (5.16 deg), see docs/explanation/model.md.

For each motion, one period sampled at 1 kHz: the stretch (length change
from home) and the force of all six cylinders, plotted against the surge
position (mm) or the yaw angle (deg) as in the paper, written as PNG and
CSV. The CSV has both the core's (fixed point) and the model's (float64)
values, and the run prints the largest difference between them.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import numpy as np

from .. import progress, resources
from .. import config as cfg
from .. import model
from ..core import Core

AMPLITUDE_SURGE = 0.090  # m
AMPLITUDE_YAW = 0.090    # rad (see the module docstring)
FREQUENCY = 0.5          # Hz


def trig_samples(axis: int, amplitude: float, freq: float, rate: float = 1000.0):
    """One period of the paper's trigonometric motion on one pose axis:
    arrays t, offset, velocity, acceleration."""
    t = np.arange(0.0, 1.0 / freq + 0.5 / rate, 1.0 / rate)
    w = 2.0 * math.pi * freq
    return t, amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), -amplitude * w * w * np.sin(w * t)


def compute(platform, core: Core, axis: int, amplitude: float, freq: float = FREQUENCY):
    """Rows of the figure for one motion (list of dicts)."""
    home = np.array(platform.home, dtype=float)
    t, off, vel, acc = trig_samples(axis, amplitude, freq)
    home_len = model.inverse_kinematics(platform, home).lengths
    rows = []
    for k in range(len(t)):
        pose = home.copy()
        pose[axis] += off[k]
        v6 = np.zeros(6)
        a6 = np.zeros(6)
        v6[axis] = vel[k]
        a6[axis] = acc[k]
        r = core.calc(pose, vel=v6[:3], rpy_rate=v6[3:], acc=a6[:3], rpy_acc=a6[3:])
        ik = model.inverse_kinematics(platform, pose)
        f_model = model.inverse_dynamics(platform, pose, v6[:3], v6[3:], a6[:3], a6[3:])
        row = {"t": t[k], "offset": off[k], "status": r.status}
        for i in range(6):
            row[f"stretch{i + 1}"] = r.stretch[i] if r.stretch else math.nan
            row[f"F{i + 1}"] = r.force[i] if r.force else math.nan
            row[f"stretch{i + 1}_model"] = ik.lengths[i] - home_len[i]
            row[f"F{i + 1}_model"] = f_model[i]
        rows.append(row)
    return rows


def write_csv(path: Path, rows) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in r.items()})


def plot(path: Path, rows, xlabel: str, xscale: float, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array([r["offset"] for r in rows]) * xscale
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.5, 8.5), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i in range(6):
        c = colors[i % len(colors)]
        s = np.array([r[f"stretch{i + 1}"] for r in rows]) * 1e3
        sm = np.array([r[f"stretch{i + 1}_model"] for r in rows]) * 1e3
        f = np.array([r[f"F{i + 1}"] for r in rows]) / 1e3
        fm = np.array([r[f"F{i + 1}_model"] for r in rows]) / 1e3
        ax1.plot(x, s, color=c, lw=2.2, alpha=0.6, label=f"cyl.{i + 1}")
        ax1.plot(x, sm, color="k", lw=0.6, ls="--")
        ax2.plot(x, f, color=c, lw=2.2, alpha=0.6, label=f"cyl.{i + 1}")
        ax2.plot(x, fm, color="k", lw=0.6, ls="--")
    ax1.plot([], [], color="k", lw=0.6, ls="--", label="float64 model")
    ax1.set_ylabel("cylinder stretch [mm]")
    ax2.set_ylabel("cylinder force [kN]")
    ax2.set_xlabel(xlabel)
    ax1.set_title(title)
    ax1.legend(ncol=4, fontsize=8)
    ax1.grid(alpha=0.3)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def max_difference(rows) -> tuple[float, float]:
    ds = max(abs(r[f"stretch{i}"] - r[f"stretch{i}_model"]) for r in rows for i in range(1, 7))
    df = max(abs(r[f"F{i}"] - r[f"F{i}_model"]) for r in rows for i in range(1, 7))
    return ds, df


def run(args: argparse.Namespace) -> int:
    try:
        platform = cfg.load(args.config)
    except cfg.ConfigError as e:
        print(f"stewart paper: {e}")
        return 2
    core = Core(platform)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    figures = [
        ("fig4_surge", 0, AMPLITUDE_SURGE, "surge position x - x_home [mm]", 1e3,
         "Fig. 4: surge, 90 mm, 0.5 Hz (fixed-point core; dashed: float64 model)"),
        ("fig5_yaw", 5, AMPLITUDE_YAW, "yaw angle [deg]", 180.0 / math.pi,
         "Fig. 5: yaw, 0.09 rad, 0.5 Hz (fixed-point core; dashed: float64 model)"),
    ]
    bad = 0
    steps = progress.Progress("stewart paper", "figures", len(figures), quiet=args.quiet)
    for name, axis, amp, xlabel, xscale, title in figures:
        rows = compute(platform, core, axis, amp)
        bad += sum(1 for r in rows if r["status"] != "ok")
        write_csv(out / f"{name}.csv", rows)
        plot(out / f"{name}.png", rows, xlabel, xscale, title)
        ds, df = max_difference(rows)
        print(f"{name}: {len(rows)} samples -> {out / (name + '.png')}, {out / (name + '.csv')}; "
              f"core vs float64: stretch {ds * 1e6:.3f} um, force {df:.4f} N")
        steps.advance(note=name)
    return 1 if bad else 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("paper", help="the paper's Figures 4 and 5 (stretch and force of the six cylinders)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default=str(resources.default_platform()),
                   help="platform config JSON (default: config/platform_default.json)")
    p.add_argument("--out", default="out/paper", help="output directory (default: out/paper)")
    progress.add_quiet(p)
    p.set_defaults(func=run)
