# SPDX-License-Identifier: Apache-2.0
"""The main job's work at the tool (issue 31): a rotation about a tool tip
(the pivot) and a force hold normal to a tilted surface with a slide along
it; their scenarios, play files, figures and plots.

**Pivot.** The tool tip sits ``TOOL_TIP`` from o' (0.35 m above it, 0.15 m
off its axis along x). The platform rotates +-``PIVOT_AMPLITUDE`` rad in
roll, then pitch, then yaw at ``PIVOT_HZ`` about the tip: o' moves so that
the tip stays where it was at home (``toolpose.platform_of_tool``). The
same rotation about o' would move the tip by |R t - t| (about +-28 mm in
roll). The run streams the platform poses (STREAM, ``play``), one per tick.
The controller's stream filter (sp/motion/stream.h: a critically damped
follower of bandwidth ``STREAM_OMEGA`` per axis) would lag each axis, and
the lagged angles with the lagged positions are not a rotation about the
tip any more (0.19 mm off it at most, in float64); so the streamed targets are the filter's inverse of the
wanted path, ``T = x + (a + 2 w v) / w^2`` per axis (v, a from the path's
differences, as the filter integrates them), and the reference the
controller makes of them is the wanted path. The path's accelerations
stay below the stream's limit of 1 m/s^2 and 1 rad/s^2 per axis (fades of
1.5 s; with 1 s the limit clipped the angles and the tip moved 2.3 mm).
The figure is the tip's distance from its fixed point, from the plant's
true pose. Once the controller takes a tool frame (issue 31, w3/frames),
the same rotation is its own RUN_TRIG about the tool point.

**Tilted surface.** A plane tilted by ``TILT`` about x (free side
down-and-towards +y: the platform pushes up into it), 2 mm from the force
sensor's tool point ``forcecontrol.TOOL`` at home. The work frame W has
its origin on the surface and its axes tilted with it: its z is the
surface's normal (into the surface, the direction of the push), its x the
base x, which lies in the surface. Force control holds 2 kN along W's z,
i.e. the base-frame target ``2000 * (-n)`` on y and z (mask ``y,z``: its
part along the surface is zero), while STREAM slides the tool 100 mm along
W's x at 20 mm/s. The figures: the true normal force (the plant's contact
force along n) from 0.5 s after contact, and the tool point's x in W
against the reference (signals.csv's ``tool_*`` columns).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import forcecontrol as fc
from .analysis.toolpose import platform_of_tool, tool_in_work
from .model import rotation_many

#: The tool tip in o', m: 0.35 m above o', 0.15 m off its axis.
TOOL_TIP = (0.15, 0.0, 0.35)
PIVOT_AMPLITUDE = 0.08  #: rad
PIVOT_HZ = 0.5
PIVOT_AXES = ("roll", "pitch", "yaw")
PIVOT_CYCLES = 3  #: periods per axis, fades included
HOME = (0.0, 0.0, fc.HOME_Z, 0.0, 0.0, 0.0)
#: The controller's stream filter bandwidth (controller.c's stream_omega), rad/s.
STREAM_OMEGA = 10.0
TICK = 1e-3
#: Rest before, between and after the three rotations, s.
PIVOT_REST = 0.5
PIVOT_FADE = 1.5  #: the controller's stream takes at most 1 rad/s^2 (acc_max): 0.85 with this fade
#: The issue's figures.
PIVOT_RMS_MM = 0.1
PIVOT_MAX_MM = 0.3

#: The tilted surface: 20 degrees about x.
TILT = np.deg2rad(20.0)
FORCE_N = 2000.0
GAP = 0.002


# -- the pivot ---------------------------------------------------------------------------

def _envelope(t: np.ndarray, length: float, fade: float) -> np.ndarray:
    """0..1..0 over [0, length]: a quintic smoothstep in and out over ``fade`` s (continuous acceleration)."""
    u = np.clip(np.minimum(t, length - t) / fade, 0.0, 1.0)
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def pivot_schedule(cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES) -> list[tuple[str, float, float]]:
    """(axis, start s, end s) of each rotation from the start of the play."""
    length = cycles / PIVOT_HZ
    out, t = [], PIVOT_REST
    for axis in axes:
        out.append((axis, t, t + length))
        t += length + PIVOT_REST
    return out


def pivot_tool_path(cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES) -> tuple[np.ndarray, np.ndarray]:
    """Times (s, from the play) and the tool's wanted poses in the base
    frame (N, 6): the tip still at home's, the angles of the rotations."""
    sched = pivot_schedule(cycles, axes)
    t_end = sched[-1][2] + PIVOT_REST
    t = np.arange(0.0, t_end + TICK / 2, TICK)
    tool = np.zeros((len(t), 6))
    tool[:, :3] = np.asarray(HOME[:3]) + np.asarray(TOOL_TIP)
    for axis, a, b in sched:
        sel = (t >= a) & (t <= b)
        tt = t[sel] - a
        tool[sel, 3 + PIVOT_AXES.index(axis)] = (PIVOT_AMPLITUDE * _envelope(tt, b - a, PIVOT_FADE)
                                                 * np.sin(2 * np.pi * PIVOT_HZ * tt))
    return t, tool


def stream_inverse(x: np.ndarray, omega: float = STREAM_OMEGA, dt: float = TICK) -> np.ndarray:
    """The targets (N, K) that make the stream filter's output the path x
    (N, K) (sp/motion/stream.h: a_k = w^2 (T_k - x_k) - 2 w v_k, v_{k+1} =
    v_k + a_k dt, x_{k+1} = x_k + v_{k+1} dt), from rest at x[0]."""
    x = np.asarray(x, dtype=float)
    v = np.zeros_like(x)
    v[1:] = np.diff(x, axis=0) / dt          # v_k: the velocity that brought x_k
    a = np.zeros_like(x)
    a[:-1] = np.diff(v, axis=0) / dt         # a_k = (v_{k+1} - v_k) / dt
    return x + (a + 2.0 * omega * v) / (omega * omega)


def pivot_platform_path(cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES) -> tuple[np.ndarray, np.ndarray]:
    """Times and the platform poses (o' in the base frame) of the pivot."""
    t, tool = pivot_tool_path(cycles, axes)
    return t, platform_of_tool(tool, TOOL_TIP + (0.0, 0.0, 0.0))


def pivot_csv(cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES) -> str:
    """The play file: the stream filter's inverse of the pivot's platform path, one row per tick."""
    t, poses = pivot_platform_path(cycles, axes)
    target = stream_inverse(poses)
    rows = ["t,x,y,z,roll,pitch,yaw"]
    rows += [f"{tk:.3f}," + ",".join(f"{v:.9f}" for v in p) for tk, p in zip(t, target)]
    return "\n".join(rows) + "\n"


ENGAGE = "cmd ENGAGE\nwait ready 20\ndelay 0.5\n"
PARK = "cmd PARK\nwait idle 20\ndelay 0.2\n"


def pivot_segment(play: str = "pivot.csv") -> str:
    """Scenario lines, at READY: STREAM the pivot (``play``), stop, back at READY."""
    return ("mark begin pivot\n"
            "cmd STREAM\n"
            f"play {play}\n"
            "mark end pivot\n"
            "cmd STOP\n"
            "wait ready 20\n"
            "delay 0.3\n")


def pivot_scenario(play: str = "pivot.csv") -> str:
    """Engage, STREAM the pivot (``play``), stop, park."""
    return "# generated by stewart.framesdemo.pivot_scenario\n" + ENGAGE + pivot_segment(play) + PARK


def play_tick(marks: dict[str, int], name: str = "pivot.csv") -> int | None:
    """The tick the ``play`` of the file ``name`` started (hs_sim's mark), None if none."""
    ticks = [v for k, v in marks.items() if k.startswith("play ") and k.split()[1].endswith(name)]
    return ticks[0] if ticks else None


def about_o_prime_mm(axis: str) -> float:
    """How far the tip would move (largest |R t - t|, mm) under the same
    rotation about o' instead of about it."""
    ang = np.linspace(-PIVOT_AMPLITUDE, PIVOT_AMPLITUDE, 401)
    rpy = np.zeros((len(ang), 3))
    rpy[:, PIVOT_AXES.index(axis)] = ang
    tip = np.asarray(TOOL_TIP)
    return float(1000.0 * np.linalg.norm(rotation_many(rpy) @ tip - tip, axis=1).max())


def tip_deviation(truth_pose: np.ndarray) -> np.ndarray:
    """The tip's true position minus its fixed point (N, 3), m."""
    tip = tool_in_work(truth_pose, TOOL_TIP + (0.0, 0.0, 0.0))[:, :3]
    return tip - (np.asarray(HOME[:3]) + np.asarray(TOOL_TIP))


def streamed_windows(play_tick: int, cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES) -> list[tuple[str, int, int]]:
    """(axis, first tick, last tick) of each rotation of the streamed pivot (the play's start tick)."""
    return [(axis, play_tick + round(a / TICK), play_tick + round(b / TICK))
            for axis, a, b in pivot_schedule(cycles, axes)]


def pivot_figures(ticks: np.ndarray, truth_pose: np.ndarray, windows: list[tuple[str, int, int]]) -> dict:
    """Per rotation (``windows``: axis, first and last tick) and over all:
    the tip's distance from its fixed point (plant truth) while it
    rotates, RMS and max, mm; the same rotation about o' (mm)."""
    dev = 1000.0 * np.linalg.norm(tip_deviation(truth_pose), axis=1)
    out: dict = {"axes": {}}
    every = np.zeros(len(ticks), dtype=bool)
    for axis, a, b in windows:
        sel = (ticks >= a) & (ticks <= b)
        sel &= np.isfinite(dev)
        every |= sel
        d = dev[sel]
        out["axes"][axis] = {"rms_mm": float(np.sqrt(np.mean(d ** 2))), "max_mm": float(d.max()),
                             "about_o_prime_mm": about_o_prime_mm(axis), "n": int(d.size)}
    d = dev[every]
    out.update(rms_mm=float(np.sqrt(np.mean(d ** 2))), max_mm=float(d.max()), n=int(d.size),
               about_o_prime_mm=max(v["about_o_prime_mm"] for v in out["axes"].values()))
    return out


def pivot_lines(f: dict, how: str = "the controller's RUN_TRIG about the tool frame") -> list[str]:
    axes = ", ".join(f["axes"])
    lines = [f"pivot (tool tip {TOOL_TIP[2]:g} m above o', {TOOL_TIP[0]:g} m off its axis; +-{PIVOT_AMPLITUDE:g} rad "
             f"at {PIVOT_HZ:g} Hz in {axes}; {how}): the tip within {f['rms_mm']:.4f} mm RMS, "
             f"{f['max_mm']:.4f} mm max of its fixed point (plant truth; issue {PIVOT_RMS_MM:g} / "
             f"{PIVOT_MAX_MM:g} mm)"]
    for axis, m in f["axes"].items():
        lines.append(f"  {axis}: RMS {m['rms_mm']:.4f} mm, max {m['max_mm']:.4f} mm; the same rotation about o' "
                     f"would move it +-{m['about_o_prime_mm']:.1f} mm")
    return lines


def plot_pivot(ticks: np.ndarray, truth_pose: np.ndarray, windows: list[tuple[str, int, int]],
               path: str | Path) -> None:
    """The tip's true path (deviation from its fixed point, x y z in um)
    and the same rotation about o' for scale; the angles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = windows[0][1] - round(PIVOT_REST / TICK)
    t1 = windows[-1][2] + round(PIVOT_REST / TICK)
    sel = (ticks >= t0) & (ticks <= t1)
    t = (ticks[sel] - windows[0][1]) * TICK
    dev = 1e6 * tip_deviation(truth_pose[sel])
    tip = np.asarray(TOOL_TIP)
    about_o = 1e3 * (rotation_many(truth_pose[sel, 3:]) @ tip - tip)
    fig, ax = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    for k, name in enumerate("xyz"):
        ax[0].plot(t, dev[:, k], lw=0.8, label=f"tip {name} - fixed point")
    ax[0].plot(t, np.linalg.norm(dev, axis=1), color="k", lw=0.8, label="distance")
    ax[0].set_ylabel("um (plant truth)")
    ax[0].set_title(f"rotation about the tool tip ({TOOL_TIP[0]:g}, {TOOL_TIP[1]:g}, {TOOL_TIP[2]:g}) m: "
                    "the tip's true path")
    ax[0].legend(loc="upper right", fontsize=8, ncol=4)
    for k, name in enumerate("xyz"):
        ax[1].plot(t, about_o[:, k], lw=0.8, label=f"tip {name}, same rotation about o'")
    ax[1].set_ylabel("mm")
    ax[1].legend(loc="upper right", fontsize=8)
    for k, name in enumerate(PIVOT_AXES):
        ax[2].plot(t, truth_pose[sel, 3 + k], lw=0.8, label=name)
    ax[2].set_ylabel("rad")
    ax[2].set_xlabel("s from the start of the first rotation")
    ax[2].legend(loc="upper right", fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -- the tilted surface -------------------------------------------------------------------

def surface_normal(tilt: float = TILT) -> np.ndarray:
    """The surface's normal into free space (the scenario's ``contact
    surface down``, rolled by ``tilt``): Rx(tilt) (0, 0, -1)."""
    return np.array([0.0, np.sin(tilt), -np.cos(tilt)])


def work_frame(tilt: float = TILT, gap: float = GAP) -> tuple[float, ...]:
    """W: on the surface where the tool point meets it, rolled with it by
    ``tilt`` (its z = -n, into the surface: the push; its x the base x,
    its y up the slope)."""
    n = surface_normal(tilt)
    tool_home = np.asarray(HOME[:3]) + np.asarray(fc.TOOL)
    origin = tool_home - gap * n
    return (float(origin[0]), float(origin[1]), float(origin[2]), float(tilt), 0.0, 0.0)


def tool_frame() -> tuple[float, ...]:
    return tuple(float(v) for v in fc.TOOL) + (0.0, 0.0, 0.0)


def tilted_surface(stiffness: float = 1e6, damping: float = 1000.0, tilt: float = TILT, gap: float = GAP) -> str:
    """Scenario line: the tilted surface, ``gap`` m from the tool point at home along its normal."""
    w = work_frame(tilt, gap)
    return (f"contact surface down {w[0]:.6f} {w[1]:.6f} {w[2]:.6f} {tilt:.6f} 0 "
            f"{fc.TOOL[0]:g} {fc.TOOL[1]:g} {fc.TOOL[2]:g} stiffness={stiffness:g} damping={damping:g}\n")


def tilted_target(force: float = FORCE_N, tilt: float = TILT) -> tuple[float, float]:
    """The base-frame target (fy, fz) of a push ``force`` N into the surface: ``force * (-n)``."""
    p = -force * surface_normal(tilt)
    return float(p[1]), float(p[2])


def tilted_segment(stiffness: float = 1e6, force: float = FORCE_N, hold: float = 2.5,
                   slide: str | None = "slide.csv") -> str:
    """Scenario lines, at READY: tare, the tilted surface, FORCE on y and z
    along its normal, hold, slide (``play slide``, forcecontrol.slide_csv:
    100 mm along x; none if None), release, the surface removed, back at
    READY."""
    fy, fz = tilted_target(force)
    text = (fc.tare()
            + tilted_surface(stiffness)
            + "mark begin hold\n"
            f"force y,z 0 {fy:.3f} {fz:.3f} 0 0 0\n"
            f"delay {1.5 + hold:.3f}\n"
            "mark end hold\n")
    if slide:
        text += ("mark begin slide\n"
                 "cmd STREAM\n"
                 f"play {slide}\n"
                 "mark end slide\n")
    text += ("mark release\n"
             "position\n"
             "delay 1.0\n"
             "contact off\n")
    if slide:
        text += "cmd STOP\nwait ready 20\n"
    return text + "delay 0.5\n"


def tilted_scenario(stiffness: float = 1e6, force: float = FORCE_N, hold: float = 2.5,
                    slide: str | None = "slide.csv") -> str:
    """Engage, :func:`tilted_segment`, park."""
    return ("# generated by stewart.framesdemo.tilted_scenario\n" + ENGAGE
            + tilted_segment(stiffness, force, hold, slide) + PARK)


def normal_force(truth_wrench: np.ndarray, tilt: float = TILT) -> np.ndarray:
    """The true push along the surface's normal: the world's force on the platform along n, N."""
    return np.asarray(truth_wrench)[:, :3] @ surface_normal(tilt)


def tilted_figures(data, m: dict[str, int], force: float = FORCE_N, settle: int = 500) -> dict:
    """The hold (true normal force from ``settle`` ticks after contact to
    the end of the hold) and the slide (the normal force and the tool
    point's x in W against its reference while the reference moves; its
    drift along the slope, W's y) of a run with ``data.tool`` attached."""
    t = data.ticks
    fn = normal_force(data.truth["wrench"])
    out: dict = {}
    b, e = m["begin hold"], m["end hold"]
    idx = np.flatnonzero((t >= b) & (t < e) & (fn >= fc.CONTACT_N))
    if idx.size == 0:
        return {"contact_tick": None}
    c = idx[0]
    end = np.searchsorted(t, e)
    settled = fn[c + settle:end]
    out["hold"] = {"contact_tick": int(t[c]), "approach_s": float((t[c] - b) * TICK),
                   "mean_N": float(settled.mean()),
                   "rms_pct": float(100.0 * np.sqrt(np.mean((settled - force) ** 2)) / force),
                   "overshoot_pct": float(max(0.0, 100.0 * (fn[c:end].max() - force) / force)),
                   "n": int(settled.size)}
    if "begin slide" in m and "end slide" in m and data.tool is not None:
        ref_x = data.tool["ref"][:, 0]
        sel = (t >= m["begin slide"]) & (t < m["end slide"])
        speed = np.abs(np.gradient(np.nan_to_num(ref_x))) / TICK
        moving = sel & np.isfinite(ref_x) & (speed > 0.5 * fc.SLIDE_SPEED)
        tx = data.tool["truth"]
        err = tx[moving, 0] - ref_x[moving]
        lateral = tx[moving, 1] - tx[np.flatnonzero(moving)[0], 1]
        out["slide"] = {
            "force_rms_pct": float(100.0 * np.sqrt(np.mean((fn[moving] - force) ** 2)) / force),
            "force_max_dev_pct": float(100.0 * np.max(np.abs(fn[moving] - force)) / force),
            "position_max_mm": float(1000.0 * np.max(np.abs(err))),
            "position_rms_mm": float(1000.0 * np.sqrt(np.mean(err ** 2))),
            "drift_along_slope_mm": float(1000.0 * np.max(np.abs(lateral))),
            "travel_mm": float(1000.0 * (np.nanmax(ref_x[sel]) - np.nanmin(ref_x[sel]))),
            "n": int(moving.sum())}
    return out


def frames_ticks(marks: dict[str, int]) -> tuple[int, int] | None:
    """The ticks the demo's frames were active (from the first `frame ... set` to the last `frame ... select 0`)."""
    sets = [v for k, v in marks.items() if k.startswith("frame ") and " set " in k]
    back = [v for k, v in marks.items() if k.startswith("frame ") and " select 0" in k]
    return (min(sets), max(back)) if sets and back else None


def tilted_lines(source: str, f: dict) -> list[str]:
    h = f.get("hold")
    if not h:
        return [f"tilted surface ({source}): no contact"]
    lim = fc.HOLD_RMS_SENSOR_PCT if source == "sensor" else fc.HOLD_RMS_CYLINDERS_PCT
    lines = [f"tilted surface ({np.rad2deg(TILT):.0f} deg), 2 kN along its normal ({source}): true normal force "
             f"RMS error {h['rms_pct']:.2f} % from 0.5 s after contact (issue {lim:g} %), mean {h['mean_N']:.0f} N, "
             f"overshoot {h['overshoot_pct']:.2f} %"]
    s = f.get("slide")
    if s:
        lines.append(f"  slide {s['travel_mm']:.0f} mm along the surface (work frame x) at 20 mm/s ({source}): "
                     f"normal force RMS error {s['force_rms_pct']:.2f} % (issue {fc.SLIDE_RMS_PCT:g} %), the tool "
                     f"point within {s['position_max_mm']:.3f} mm of its path (issue {fc.SLIDE_POS_MM:g} mm), "
                     f"drift along the slope {s['drift_along_slope_mm']:.3f} mm")
    return lines


def plot_tilted(data, ft, path: str | Path, title: str, window: tuple[float, float] | None = None,
                work_ticks: tuple[int, int] | None = None) -> None:
    """The push along the surface's normal: commanded, the cylinders'
    estimate, the sensor (less its bias at start) and the truth; the tool
    point in W against its reference. ``work_ticks``: the ticks with the
    frames active, where the controller's target and CTRL_WRENCH are in
    W's axes at the tool point (the push is their z); elsewhere in the
    base frame."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = surface_normal()
    t = data.ticks * TICK
    fig, ax = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    a = ax[0]
    in_w = np.zeros(len(t), dtype=bool) if work_ticks is None else \
        (data.ticks >= work_ticks[0]) & (data.ticks < work_ticks[1])
    cmd = np.where(in_w, data.force_target[:, 2], data.force_target[:, :3] @ -n)
    a.plot(t, cmd, color="k", lw=1.2, label="commanded (target along -n)")
    ok = np.isfinite(data.est_wrench[:, 2])
    est = np.where(in_w, -data.est_wrench[:, 2], data.est_wrench[:, :3] @ n)[ok]
    a.plot(t[ok], est, lw=0.6, color="tab:orange", label="cylinders' estimate")
    if len(ft[0]):
        a.plot(ft[0], (ft[1][:, :3] - np.median(ft[1][:200, :3], axis=0)) @ n, lw=0.6, color="tab:blue",
               label="force/torque sensor (less its bias at start)")
    a.plot(t, normal_force(data.truth["wrench"]), lw=1.0, color="tab:green", label="true (plant)")
    a.set_ylabel("push along the normal, N")
    a.legend(loc="upper right", fontsize=8)
    a.set_title(title)
    if data.tool is not None:
        for k, (axn, name) in enumerate(((ax[1], "z (normal)"), (ax[2], "x (along the slide)"))):
            j = 2 if k == 0 else 0
            axn.plot(t, 1000 * data.tool["truth"][:, j], color="tab:green", label=f"tool {name} in W, true")
            axn.plot(t, 1000 * data.tool["ref"][:, j], color="k", lw=0.8, ls="--", label="reference")
            axn.set_ylabel("mm")
            axn.legend(loc="upper right", fontsize=8)
    ax[2].set_xlabel("simulated time, s")
    for a in ax:
        a.grid(alpha=0.3)
    if window is not None:
        ax[0].set_xlim(*window)
        sel = (t >= window[0]) & (t <= window[1])
        if data.tool is not None and sel.any():
            for a, j in ((ax[1], 2), (ax[2], 0)):
                v = 1000 * data.tool["truth"][sel, j]
                v = v[np.isfinite(v)]
                if v.size:
                    a.set_ylim(v.min() - 2.0, v.max() + 2.0)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -- with the controller's own frames (OP_FRAME: the scenario's `frame`) ------------------------

#: The slots the demo sets (slot 0 of each kind stays the config's identity).
SLOT = 1


def frame_lines(tool=None, work=None, slot: int = SLOT) -> str:
    """Scenario lines, at READY: set (and so make active) the tool and/or work frame in ``slot``."""
    text = ""
    for kind, fr in (("tool", tool), ("work", work)):
        if fr is not None:
            text += f"frame {kind} set {slot} " + " ".join(f"{v:.9f}" for v in fr) + "\n"
    return text + "delay 0.2\n"


def identity_lines() -> str:
    """Scenario lines, at READY: back to the identity frames (slot 0)."""
    return "frame tool select 0\nframe work select 0\ndelay 0.2\n"


def pivot_segment_core(cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES, fade: float = 1.0) -> str:
    """Scenario lines, at READY: the tool frame at the tip, then the
    controller's own RUN_TRIG about it (+-PIVOT_AMPLITUDE at PIVOT_HZ) on
    each axis in turn, then the identity frames again."""
    from . import closedloop as cl

    text = "mark begin pivot\n" + frame_lines(tool=TOOL_TIP + (0.0, 0.0, 0.0))
    for axis in axes:
        text += cl.trig(axis, PIVOT_AMPLITUDE, PIVOT_HZ, cycles / PIVOT_HZ, fade) + "delay 0.5\n"
    return text + identity_lines() + "mark end pivot\n"


def pivot_windows(marks: dict[str, int], cycles: int = PIVOT_CYCLES, axes=PIVOT_AXES) -> list[tuple[str, int, int]]:
    """(axis, first tick, last tick) of each RUN_TRIG of :func:`pivot_segment_core` (its marks)."""
    out = []
    for axis in axes:
        b = marks.get(f"begin {axis} {PIVOT_AMPLITUDE:g} {PIVOT_HZ:g}")
        if b is not None:
            out.append((axis, b, b + round(cycles / PIVOT_HZ / TICK)))
    return out


def slide_csv_work(tilt: float = TILT, gap: float = GAP) -> str:
    """The slide as tool poses in the work frame: x from 0 to SLIDE_M at
    SLIDE_SPEED, then held 1 s; z (force-controlled) at home's, the tool's
    orientation in W (roll -tilt) held."""
    return fc.slide_csv(home=(0.0, 0.0, -gap, -tilt, 0.0, 0.0))


def tilted_segment_core(stiffness: float = 1e6, force: float = FORCE_N, hold: float = 2.5,
                        slide: str | None = "slide.csv") -> str:
    """Scenario lines, at READY: tare, the tilted surface; first the slide
    (``slide``, forcecontrol.slide_csv, 100 mm along the base x, which is
    W's x): FORCE on the base y and z along the normal
    (:func:`tilted_target`), STREAM, release; then the tool frame at the
    sensor's point and the work frame on the surface, FORCE on W's z with
    ``force`` N (the controller's force control in W's axes at the tool
    point), hold, release, the identity frames again, the surface removed.
    The slide goes first and in the base frame's axes: streaming tool poses
    in W while FORCE holds W's z does not work yet (frames code at 3cd815b:
    the contact lost at once, even back at identity frames; at 9fb0d69 the
    slide stalls after 8 mm with the normal force far above its target)."""
    fy, fz = tilted_target(force)
    text = fc.tare() + tilted_surface(stiffness)
    if slide:
        text += ("mark begin hold base\n"
                 f"force y,z 0 {fy:.3f} {fz:.3f} 0 0 0\n"
                 "delay 2.0\n"
                 "mark begin slide\n"
                 "cmd STREAM\n"
                 f"play {slide}\n"
                 "mark end slide\n"
                 "position\n"
                 "delay 1.0\n"
                 "cmd STOP\n"
                 "wait ready 20\n"
                 "delay 0.3\n")
    return (text + frame_lines(tool=tool_frame(), work=work_frame())
            + "mark begin hold\n"
            f"force z 0 0 {force:g} 0 0 0\n"
            f"delay {1.5 + hold:.3f}\n"
            "mark end hold\n"
            "position\n"
            "delay 0.5\n"
            + identity_lines()
            + "contact off\ndelay 0.5\n")


def core_scenario(cycles: int = PIVOT_CYCLES) -> str:
    """The demo's run with the controller's frames: engage, the pivot, park."""
    return "# generated by stewart.framesdemo.core_scenario\n" + ENGAGE + pivot_segment_core(cycles) + PARK


def tilted_core_scenario() -> str:
    return "# generated by stewart.framesdemo.tilted_core_scenario\n" + ENGAGE + tilted_segment_core() + PARK
