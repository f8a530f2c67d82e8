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
