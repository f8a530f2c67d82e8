# SPDX-License-Identifier: Apache-2.0
"""Force control in closed loop (issue 15): the scenario segments an
operator would play (approach a surface, hold a force, slide, lose the
contact, hand guiding) and the figures of a run, from the CAN log (the
controller's CTRL_STATUS: state, faults, force mode, contact, refusals; the
operator's OP_FORCE) and the plant's truth (the true contact wrench and
pose).

The surface: a plane above the tool, normal (0, 0, -1) (pointing into free
space, down), touched by the tool point ``TOOL`` of the motion frame (the
force/torque sensor's origin of the default config). Pushing it means a
target of +Fz (the platform exerts +z on the world); the world's wrench on
the platform is then -Fz.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import protocol as pr

#: The tool point touching the surface, motion frame, m.
TOOL = (0.0, 0.0, 0.05)
#: The platform's home height (config/platform_default.json), m.
HOME_Z = 2.55
#: What counts as contact in the truth: the controller's default "made" level, N.
CONTACT_N = 100.0
#: The issue's figures.
HOLD_RMS_SENSOR_PCT = 1.0
HOLD_RMS_CYLINDERS_PCT = 2.0
HOLD_OVERSHOOT_PCT = 10.0
HOLD_PP_PCT = 2.0
SLIDE_RMS_PCT = 3.0
SLIDE_POS_MM = 0.5
LOSS_TICKS = 10
LOSS_REST_MM = 5.0
FAULT_CONTACT_LOST = 0x200

MODES = pr.value_names("CTRL_STATUS", "ForceMode")  # OFF, FORCE, GUIDE, RELEASE, HOLD


def surface(stiffness: float, gap: float = 0.002, damping: float = 1000.0) -> str:
    """Scenario line: the plane ``gap`` m above the tool at home."""
    height = HOME_Z + TOOL[2] + gap
    return (f"contact plane 0 0 -1 {-height:.6f} {TOOL[0]:g} {TOOL[1]:g} {TOOL[2]:g} "
            f"stiffness={stiffness:g} damping={damping:g}\n")


def approach_and_hold(stiffness: float, force: float = 2000.0, hold: float = 3.0, gap: float = 0.002) -> str:
    """Scenario lines, at READY with the sensor tared: the surface, FORCE on
    z with ``force`` N, held ``hold`` s after the approach (2 mm at the
    default 2 mm/s per 2 kN take about 1 s; the lines allow 1.5 s)."""
    return (surface(stiffness, gap)
            + "mark begin hold\n"
            f"force z 0 0 {force:g} 0 0 0\n"
            f"delay {1.5 + hold:.3f}\n"
            "mark end hold\n")


def tare(seconds: float = 0.8) -> str:
    """Scenario lines: TARE at rest and the time its 500 readings take."""
    return f"tare\ndelay {seconds:.3f}\n"


def bad_force_command() -> str:
    """Scenario lines: a FORCE update beyond the controller's 8 kN (refused;
    the hold goes on) and one with an empty mask (refused)."""
    return ("mark bad force\n"
            "force z 0 0 12000 0 0 0\n"
            "delay 0.2\n"
            "force 0 0 0 2000 0 0 0\n"
            "delay 0.3\n"
            "mark end bad\n")


def remove_surface(after: float = 1.0) -> str:
    return f"mark remove\ncontact off\ndelay {after:.3f}\n"


# -- reading a run ------------------------------------------------------------------------

@dataclass
class Status:
    """CTRL_STATUS per frame, in tick order."""
    tick: np.ndarray
    state: np.ndarray
    faults: np.ndarray
    force_mode: np.ndarray
    contact: np.ndarray
    cmd_rejected: np.ndarray


def read_status(log: str | Path) -> Status:
    """Every CTRL_STATUS of a candump -L log (the ops bus, vcan0)."""
    proto = pr.Protocol()
    msg = proto.message("CTRL_STATUS")
    rows = []
    with open(log) as f:
        for line in f:
            if " vcan0 100#" not in line:
                continue
            data = line.split("#", 1)[1].strip()
            raw = bytes.fromhex(data[2:] if data.startswith("#") else data)  # FD: "##<flags><hex>"
            s = msg.decode(raw, decode_choices=False, scaling=False)
            rows.append((s["Tick"], s["State"], s["Faults"], s["ForceMode"], s["Contact"], s["CmdRejected"]))
    a = np.array(rows, dtype=np.int64).reshape(-1, 6)
    return Status(*(a[:, k] for k in range(6)))


def marks(plant_out: str) -> dict[str, int]:
    """hs_sim's mark lines as {text: tick} (the first one of each text)."""
    out: dict[str, int] = {}
    for m in re.finditer(r"^hs_sim mark tick (\d+): (.*)$", plant_out, re.M):
        out.setdefault(m.group(2).strip(), int(m.group(1)))
    return out


def hold_figures(truth: dict, begin: int, end: int, target: float, settle: int = 500) -> dict:
    """The true normal force (-Fz of the world's wrench) of a hold that starts
    (FORCE sent) at tick ``begin`` and ends at ``end``: contact when it first
    reaches CONTACT_N; RMS error from ``settle`` ticks after contact; the
    overshoot; peak-to-peak in the last second. Percent of ``target``."""
    tick = truth["tick"]
    fn = -truth["wrench"][:, 2]
    seg = (tick >= begin) & (tick < end)
    idx = np.flatnonzero(seg & (fn >= CONTACT_N))
    if idx.size == 0:
        return {"contact_tick": None}
    c = idx[0]
    e = np.searchsorted(tick, end)
    settled = fn[c + settle:e]
    last = fn[max(c + settle, e - 1000):e]
    return {
        "contact_tick": int(tick[c]),
        "approach_s": float((tick[c] - begin) / 1000.0),
        "mean_N": float(settled.mean()),
        "rms_pct": float(100.0 * np.sqrt(np.mean((settled - target) ** 2)) / target),
        "overshoot_pct": float(max(0.0, 100.0 * (fn[c:e].max() - target) / target)),
        "pp_pct": float(100.0 * (last.max() - last.min()) / target),
        "n": int(settled.size),
    }


def loss_figures(truth: dict, status: Status, removed: int) -> dict:
    """The reaction to the surface removed at tick ``removed``: ticks until
    CTRL_STATUS reports CONTACT_LOST, the travel of o' from where it was
    then (largest and final), and its speed over the last 100 ticks."""
    lost = np.flatnonzero((status.tick >= removed) & ((status.faults & FAULT_CONTACT_LOST) != 0))
    tick = truth["tick"]
    r = np.searchsorted(tick, removed)
    p = truth["pose"][:, :3]
    d = np.linalg.norm(p[r:] - p[r], axis=1)
    speed = float(np.linalg.norm(p[-1] - p[-101]) / 0.1) if len(p) > r + 101 else float("nan")
    return {
        "detected_ticks": int(status.tick[lost[0]] - removed) if lost.size else None,
        "travel_max_mm": float(1000.0 * d.max()),
        "travel_final_mm": float(1000.0 * d[-1]),
        "final_speed_mm_s": 1000.0 * speed,
        "fault_latched": bool(lost.size and (status.faults[-1] & FAULT_CONTACT_LOST)),
        "state": pr.value_names("CTRL_STATUS", "State")[int(status.state[-1])],
    }


def refusals(status: Status, begin: int, end: int) -> int:
    """Ticks in [begin, end) whose command the controller refused."""
    sel = (status.tick >= begin) & (status.tick < end)
    return int(status.cmd_rejected[sel].sum())


# -- the demo's segment ----------------------------------------------------------------------

#: The slide: 100 mm along x at 20 mm/s.
SLIDE_M = 0.100
SLIDE_SPEED = 0.020
#: Hand guiding: a 200 N push along x (the guide damping 2500 N s/m: 80 mm/s,
#: below the admittance's speed limit 0.1 m/s; the deflection limit 50 mm).
PUSH_N = 200.0
GUIDE_DAMPING = 2500.0
GUIDE_V_MAX = 0.1
DEFLECTION_M = 0.050


def slide_csv(home=(0.0, 0.0, HOME_Z, 0.0, 0.0, 0.0)) -> str:
    """A play file: x from home to home + SLIDE_M at SLIDE_SPEED, then held 1 s."""
    t_end = SLIDE_M / SLIDE_SPEED
    rows = ["t,x,y,z,roll,pitch,yaw"]
    for t, x in ((0.0, 0.0), (t_end, SLIDE_M), (t_end + 1.0, SLIDE_M)):
        rows.append(f"{t:.3f},{home[0] + x:.6f},{home[1]:.6f},{home[2]:.6f},{home[3]:.6f},{home[4]:.6f},"
                    f"{home[5]:.6f}")
    return "\n".join(rows) + "\n"


def demo_scenario(stiffness: float = 1e6, force: float = 2000.0) -> str:
    """Approach a surface, hold ``force``, slide along it while holding,
    release, then hand guiding with a push; park. Needs slide.csv
    (slide_csv) beside the scenario file."""
    return ("cmd ENGAGE\n"
            "wait ready 20\n"
            "delay 0.3\n"
            + tare()
            + approach_and_hold(stiffness, force, hold=2.5)
            + "mark begin slide\n"
            "cmd STREAM\n"
            "play slide.csv\n"
            "mark end slide\n"
            "mark release\n"
            "position\n"
            "delay 1.0\n"
            "contact off\n"
            "cmd STOP\n"
            "wait ready 20\n"
            "delay 0.5\n"
            "mark begin guide\n"
            "guide x\n"
            "delay 0.3\n"
            f"push {PUSH_N:g} 0 0 0 0 0 rise=0.02 hold=0.9\n"
            "delay 1.5\n"
            "mark end guide\n"
            "position\n"
            "delay 1.0\n"
            "cmd PARK\n"
            "wait idle 20\n"
            "delay 0.2\n")


def read_ft(log: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """FT_SENSOR frames of a lockstep log: (simulated time s, (N, 6) wrench
    in sensor axes, N / N m)."""
    proto = pr.Protocol()
    msg = proto.message("FT_SENSOR")
    ts, rows = [], []
    with open(log) as f:
        for line in f:
            if " vcan2 038#" not in line:
                continue
            data = line.split("#", 1)[1].strip()
            raw = bytes.fromhex(data[2:] if data.startswith("#") else data)
            s = msg.decode(raw, decode_choices=False)
            ts.append(float(line[1:line.index(")")]))
            rows.append([s[a] for a in pr.WRENCH_SIGNALS])
    return np.asarray(ts), np.asarray(rows, dtype=float).reshape(-1, 6)


def slide_figures(data, m: dict[str, int], target: float) -> dict:
    """The slide: the true normal force against ``target`` and the true x
    against the reference (CTRL_MONITOR) while the reference moves."""
    t = data.ticks
    ref_x = data.reference[:, 0]
    sel = (t >= m["begin slide"]) & (t < m["end slide"])
    moving = sel & np.isfinite(ref_x) & (np.abs(np.gradient(np.nan_to_num(ref_x))) * 1000.0 > 0.5 * SLIDE_SPEED)
    fn = -data.truth["wrench"][:, 2]
    x = data.truth["pose"][:, 0]
    err = x[moving] - ref_x[moving]
    return {
        "force_rms_pct": float(100.0 * np.sqrt(np.mean((fn[moving] - target) ** 2)) / target),
        "force_max_dev_pct": float(100.0 * np.max(np.abs(fn[moving] - target)) / target),
        "position_max_mm": float(1000.0 * np.max(np.abs(err))),
        "position_rms_mm": float(1000.0 * np.sqrt(np.mean(err ** 2))),
        "travel_mm": float(1000.0 * (np.nanmax(ref_x[sel]) - np.nanmin(ref_x[sel]))),
        "speed_mm_s": float(np.median(np.gradient(np.nan_to_num(ref_x))[moving]) / 1e-3 * 1000.0),
        "n": int(moving.sum()),
    }


def guide_figures(data, m: dict[str, int], push_tick: int) -> dict:
    """Hand guiding: the speed of o' along x while the push holds and the
    axis is not yet braking, against the admittance's min(F / D, v_max);
    the largest x against the deflection bound around the position
    reference (home)."""
    t = data.ticks
    x = data.truth["pose"][:, 0]
    v = np.gradient(x) / 1e-3
    expect = min(PUSH_N / GUIDE_DAMPING, GUIDE_V_MAX)
    sel = (t >= push_tick + 60) & (x < 0.6 * DEFLECTION_M) & (t < m["end guide"])
    seg = (t >= m["begin guide"]) & (t < m["end guide"])
    return {
        "speed_mm_s": float(1000.0 * np.median(v[sel])) if sel.any() else None,
        "expected_mm_s": 1000.0 * expect,
        "speed_error_pct": float(100.0 * abs(np.median(v[sel]) - expect) / expect) if sel.any() else None,
        "max_x_mm": float(1000.0 * x[seg].max()),
        "max_ref_x_mm": float(1000.0 * np.nanmax(data.reference[seg, 0])),
        "bound_mm": 1000.0 * DEFLECTION_M,
        "overshoot_mm": float(max(0.0, 1000.0 * (x[seg].max() - DEFLECTION_M))),
    }


def plot_force(data, ft: tuple[np.ndarray, np.ndarray], path: str | Path, title: str,
               window: tuple[float, float] | None = None) -> None:
    """Commanded, estimated (the cylinders' estimate and the sensor) and
    true contact force along z, and the pose (x, z) against the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = data.ticks * 1e-3
    fig, ax = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    a = ax[0]
    a.plot(t, data.force_target[:, 2], color="k", lw=1.2, label="commanded (target fz)")
    ok = np.isfinite(data.est_wrench[:, 2])
    a.plot(t[ok], -data.est_wrench[ok, 2], lw=0.6, color="tab:orange", label="cylinders' estimate (-CTRL_WRENCH fz)")
    if len(ft[0]):
        a.plot(ft[0], -(ft[1][:, 2] - np.median(ft[1][:200, 2])), lw=0.6, color="tab:blue",
               label="force/torque sensor (-fz, less its bias at start)")
    a.plot(t, -data.truth["wrench"][:, 2], lw=1.0, color="tab:green", label="true (plant)")
    a.set_ylabel("push along z, N")
    a.legend(loc="upper right", fontsize=8)
    a.set_title(title)
    a = ax[1]
    a.plot(t, 1000 * (data.truth["pose"][:, 2] - HOME_Z), color="tab:green", label="z true - home")
    a.plot(t, 1000 * (data.reference[:, 2] - HOME_Z), color="k", lw=0.8, ls="--", label="z reference - home")
    a.set_ylabel("mm")
    a.legend(loc="upper right", fontsize=8)
    a = ax[2]
    a.plot(t, 1000 * data.truth["pose"][:, 0], color="tab:green", label="x true")
    a.plot(t, 1000 * data.reference[:, 0], color="k", lw=0.8, ls="--", label="x reference")
    a.set_ylabel("mm")
    a.set_xlabel("simulated time, s")
    a.legend(loc="upper right", fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    if window is not None:
        ax[0].set_xlim(*window)
        sel = (t >= window[0]) & (t <= window[1])
        for a, k in ((ax[1], 2), (ax[2], 0)):
            vals = 1000 * (data.truth["pose"][sel, k] - (HOME_Z if k == 2 else 0.0))
            if vals.size:
                a.set_ylim(vals.min() - 2.0, vals.max() + 2.0)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def demo_figures(name: str, data, plant_out: str, ft, out: Path) -> tuple[dict, list[str]]:
    """The figures of one demo run (the hold, the slide, hand guiding) and
    the summary lines; draws <out>/<name>.png."""
    m = marks(plant_out)
    tr = {"tick": data.ticks, "wrench": data.truth["wrench"], "pose": data.truth["pose"]}
    fig: dict = {}
    lines = []
    source = name.replace("force_", "")
    t0 = (m.get("begin hold", 0) - 1000) * 1e-3
    t1 = (m.get("end guide", int(data.ticks[-1])) + 1500) * 1e-3
    plot_force(data, ft, Path(out) / f"{name}.png", f"force control ({source} as the wrench source)", (t0, t1))
    status = read_status(Path(out) / f"{name}.log")
    lost = np.flatnonzero((status.faults & FAULT_CONTACT_LOST) != 0)
    if lost.size:
        fig["contact_lost_tick"] = int(status.tick[lost[0]])
        lines.append(f"force hold ({source}): CONTACT_LOST latched at tick {status.tick[lost[0]]} "
                     "while the surface was there: the hold failed (docs/explanation/force_control.md)")
        return fig, lines
    if "begin hold" in m and "end hold" in m:
        fig["hold"] = h = hold_figures(tr, m["begin hold"], m["end hold"], 2000.0)
        if h.get("contact_tick") is not None:
            lim = HOLD_RMS_SENSOR_PCT if source == "sensor" else HOLD_RMS_CYLINDERS_PCT
            lines.append(f"force hold 2 kN on 1e6 N/m ({source}): true force RMS error {h['rms_pct']:.2f} % "
                         f"(issue {lim:g} %), overshoot {h['overshoot_pct']:.2f} % ({HOLD_OVERSHOOT_PCT:g} %), "
                         f"p-p last second {h['pp_pct']:.2f} % ({HOLD_PP_PCT:g} %)")
    if "begin slide" in m and "end slide" in m:
        fig["slide"] = s = slide_figures(data, m, 2000.0)
        lines.append(f"slide 100 mm at 20 mm/s holding 2 kN ({source}): true force RMS error "
                     f"{s['force_rms_pct']:.2f} % (issue {SLIDE_RMS_PCT:g} %), position along the slide within "
                     f"{s['position_max_mm']:.3f} mm of its reference ({SLIDE_POS_MM:g} mm)")
    push = [v for k, v in m.items() if k.startswith("push ")]
    if push and "end guide" in m:
        fig["guide"] = g = guide_figures(data, m, push[0])
        if g["speed_mm_s"] is not None:
            lines.append(f"hand guiding, {PUSH_N:g} N push ({source}): {g['speed_mm_s']:.1f} mm/s for the "
                         f"admittance's {g['expected_mm_s']:.0f} (min(F/D, v_max)): {g['speed_error_pct']:.1f} % "
                         f"(issue 10 %); at the {g['bound_mm']:.0f} mm deflection bound the reference stops at "
                         f"{g['max_ref_x_mm']:.2f} mm, the platform at {g['max_x_mm']:.2f} mm")
    return fig, lines
