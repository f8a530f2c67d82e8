# SPDX-License-Identifier: Apache-2.0
"""The design report: a self-contained HTML page (figures inline as
base64 PNG, no network), a JSON of every figure's numbers, and the verdict
as text. Both files are written whole or not at all."""

from __future__ import annotations

import base64
import html
import io
import json
import math
import os
from pathlib import Path

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    _plt().close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _extent(x, y) -> list:
    dx = (x[1] - x[0]) / 2 if len(x) > 1 else 0.01
    dy = (y[1] - y[0]) / 2 if len(y) > 1 else 0.01
    return [x[0] - dx, x[-1] + dx, y[0] - dy, y[-1] + dy]


def fig_workspace(r: dict) -> str:
    plt = _plt()
    ws = r["workspace"]
    n = len(ws["slices"]) + 1
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 4.0))
    for ax, s in zip(axes, ws["slices"]):
        ax.imshow(np.asarray(s["reachable_xy"]).T, origin="lower", extent=_extent(s["x"], s["y"]),
                  cmap="Greens", vmin=0, vmax=1.4)
        box = r["config_box"]
        ax.add_patch(plt.Rectangle((box[0][0], box[1][0]), box[0][1] - box[0][0], box[1][1] - box[1][0],
                                   fill=False, ls="--", lw=1, label="config workspace box"))
        ax.legend(fontsize=7, loc="lower right")
        ax.set_title(f"x-y at z={s['z']:.2f} m, rpy={s['rpy']}\nvolume {s['volume_m3']:.3f} m^3", fontsize=8)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    c = ws["conditioning"]
    cond = np.array([[np.nan if v is None else v for v in row] for row in c["cond"]])
    im = axes[-1].imshow(cond.T, origin="lower", extent=_extent(c["x"], c["y"]), cmap="viridis")
    fig.colorbar(im, ax=axes[-1], label="condition number")
    axes[-1].set_title("force transformation's condition number\n(home height and orientation)", fontsize=8)
    axes[-1].set_xlabel("x [m]")
    fig.tight_layout()
    return _png(fig)


def fig_orientation(r: dict) -> str:
    plt = _plt()
    ori = r["workspace"]["orientation"]
    fig, axes = plt.subplots(1, len(ori), figsize=(4.2 * len(ori), 4.0), squeeze=False)
    for ax, o in zip(axes[0], ori):
        ax.imshow(np.asarray(o["reachable_roll_pitch"]).T, origin="lower", cmap="Blues", vmin=0, vmax=1.4,
                  extent=[math.degrees(v) for v in _extent(o["roll"], o["pitch"])])
        ax.set_title(f"roll-pitch reachable (some yaw) at {o['position']}\n{o['volume_rad3']:.3f} rad^3",
                     fontsize=8)
        ax.set_xlabel("roll [deg]")
        ax.set_ylabel("pitch [deg]")
    fig.tight_layout()
    return _png(fig)


def fig_forces(r: dict) -> str:
    plt = _plt()
    f = r["forces"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.0))
    legs = np.arange(1, 7)
    ax1.bar(legs - 0.2, np.asarray(f["push_per_leg"]) / 1e3, 0.4, label="push needed")
    ax1.bar(legs + 0.2, -np.asarray(f["pull_per_leg"]) / 1e3, 0.4, label="pull needed")
    ax1.axhline(f["push_capacity_at_fraction"] / 1e3, color="C0", ls="--", lw=1, label="push capacity")
    ax1.axhline(f["pull_capacity_at_fraction"] / 1e3, color="C1", ls="--", lw=1, label="pull capacity")
    ax1.set_xlabel("cylinder")
    ax1.set_ylabel("force [kN]")
    ax1.set_title("worst forces over the envelope (friction included)", fontsize=8)
    ax1.legend(fontsize=7)
    for t in r["trajectories"]:
        ft = np.asarray(t["force"]) / 1e3
        for i in range(6):
            ax2.plot(t["t"], ft[:, i], lw=1, label=f"cyl.{i + 1}" if t is r["trajectories"][0] else None)
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel("force [kN]")
    ax2.set_title("trajectories (heaviest payload)" if r["trajectories"] else "no trajectories", fontsize=8)
    if r["trajectories"]:
        ax2.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return _png(fig)


def fig_stiffness(r: dict) -> str:
    plt = _plt()
    s = r["stiffness"]["map"]
    fmap = np.array([[np.nan if v is None else v for v in row] for row in s["lowest_hz"]])
    caps = r["forces"]["wrench_capacity"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.0))
    im = ax1.imshow(fmap.T, origin="lower", extent=_extent(s["x"], s["y"]), cmap="magma")
    fig.colorbar(im, ax=ax1, label="lowest natural frequency [Hz]")
    ax1.set_title("lowest natural frequency (home height, heaviest payload)", fontsize=8)
    ax1.set_xlabel("x [m]")
    ax1.set_ylabel("y [m]")
    names = list(caps)
    vals = [caps[k]["value"] / 1e3 for k in names]
    ax2.bar(range(len(names)), vals, color=["C0" if k[1] == "F" else "C2" for k in names])
    ax2.set_xticks(range(len(names)), names, fontsize=7)
    ax2.set_ylabel("kN (forces) / kN m (moments)")
    ax2.set_title("wrench capacity: least over the envelope", fontsize=8)
    fig.tight_layout()
    return _png(fig)


def verdict_text(r: dict) -> str:
    lines = []
    for v in r["verdict"]:
        m = v["margin"]
        ms = f"{m * 100:+.1f} %" if v["unit"] == "relative" else f"{m:+.4g} {v['unit']}"
        lines.append(f"{'PASS' if v['pass'] else 'FAIL'}  {v['requirement']}: margin {ms} ({v['limit']})")
    ok = all(v["pass"] for v in r["verdict"])
    lines.append(f"verdict: {'every requirement met' if ok else 'some requirement not met'}")
    return "\n".join(lines)


def _table(rows: list, head: list) -> str:
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{th}</tr>{body}</table>"


def _numbers(r: dict) -> list:
    f, h, s = r["forces"], r["hydraulics"], r["stiffness"]
    sz = f["sizing"]
    return [
        ("worst push", f"{f['push']['value'] / 1e3:.2f} kN, cylinder {f['push']['leg']}"),
        ("worst pull", f"{-f['pull']['value'] / 1e3:.2f} kN, cylinder {f['pull']['leg']}"),
        ("bore needed / fitted", f"{sz['bore_min'] * 1e3:.1f} mm / {sz['bore'] * 1e3:.1f} mm"),
        ("largest rod the pull allows / fitted", f"{sz['rod_max'] * 1e3:.1f} mm / {sz['rod'] * 1e3:.1f} mm"),
        ("peak flow per cylinder", f"{max(h['flow_peak_per_leg']) * 6e4:.1f} l/min"),
        ("mean flow per cylinder", f"{max(h['flow_mean_per_leg']) * 6e4:.1f} l/min ({h['flow_mean_source']})"),
        ("supply flow, peak", f"{h['supply_flow_peak'] * 6e4:.1f} l/min"),
        ("supply power, peak", f"{h['supply_power_peak'] / 1e3:.1f} kW"),
        ("valve rated flow needed / fitted", f"{h['valve_rated_flow_needed'] * 6e4:.1f} / "
         f"{h['valve_rated_flow'] * 6e4:.1f} l/min at {h['valve_rated_pressure_drop'] / 1e5:.0f} bar per land"),
        ("lowest natural frequency", f"{s['lowest_hz']:.2f} Hz at pose {s['lowest_pose']}"),
        ("natural frequencies at home", ", ".join(f"{v:.1f}" for v in s["home_hz"]) + " Hz"),
        ("position loop bandwidth (2 zeta f_min)", f"{s['bandwidth_hz']:.2f} Hz with zeta = {s['loop_damping']:g}"),
        ("condition number, largest (home plane / envelope)",
         f"{r['workspace']['conditioning']['cond_max']:.2f} / {r['envelope']['cond_max']:.2f}"),
        ("smallest singular value (home plane / envelope)",
         f"{r['workspace']['conditioning']['smin_min']:.3f} / {r['envelope']['smin_min']:.3f}"),
    ] + [(f"constant-orientation volume at {sl['rpy']}", f"{sl['volume_m3']:.4f} m^3")
         for sl in r["workspace"]["slices"]]


def html_page(r: dict) -> str:
    figs = [("Workspace", fig_workspace(r)), ("Orientation workspace", fig_orientation(r)),
            ("Cylinder forces", fig_forces(r)), ("Stiffness and wrench capacity", fig_stiffness(r))]
    verdict_rows = [("PASS" if v["pass"] else "FAIL", v["requirement"],
                     f"{v['margin'] * 100:+.1f} %" if v["unit"] == "relative" else f"{v['margin']:+.4g} {v['unit']}",
                     v["limit"]) for v in r["verdict"]]
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>stewart design: {html.escape(r['platform'])}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:2px 6px;font-size:13px}"
        "img{max-width:100%}</style></head><body>",
        f"<h1>Design report: {html.escape(r['platform'])}</h1>",
        f"<p>config {html.escape(r['config'])}, duty {html.escape(r['duty'])}, "
        f"{r['envelope_poses']} envelope poses</p>",
        "<h2>Verdict</h2>", _table(verdict_rows, ["", "requirement", "margin", "what limits it"]),
        "<h2>Key figures</h2>", _table(_numbers(r), ["", "value"]),
    ]
    for title, png in figs:
        parts.append(f"<h2>{title}</h2><img alt='{title}' src='data:image/png;base64,{png}'>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _clean(x):
    """JSON-safe: NaN and infinities become null."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def write(r: dict, out: Path) -> tuple[Path, Path]:
    """report.html and report.json in ``out``, each written to a temporary
    name first and renamed once both are complete."""
    out.mkdir(parents=True, exist_ok=True)
    page = html_page(r)
    data = json.dumps(_clean(r), indent=1, allow_nan=False)
    paths = (out / "report.html", out / "report.json")
    for path, text in zip(paths, (page, data)):
        tmp = path.with_suffix(path.suffix + ".part")
        tmp.write_text(text)
    for path in paths:
        os.replace(path.with_suffix(path.suffix + ".part"), path)
    return paths
