# SPDX-License-Identifier: Apache-2.0
"""The calibration in closed loop: the firmware (sp_controller) drives the
plan's poses on the plant (hs_sim) in lockstep over vcan
(:mod:`stewart.closedloop`). The laser tracker is simulated here, from the
plant's truth log (``hs_sim --truth``: the platform's true pose each tick),
at the tick of each ``mark calibrate pose N``; the leg length readings are
the drives' AXIS_FEEDBACK in the CAN log at that tick, as on a real machine.
(The tracker lives in Python, not in hs_sim: it needs the plant's true pose
at a handful of ticks only, and the same code serves the float64 machine.)"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import closedloop as cl
from .io import scenario
from .kin import Tracker, poses_to_pr, rotation_angle
from .solve import Data

SETTLE = 1.5   # s at rest before each reading
FADE = 2.0     # s of each MOVE_TO


def pose_ticks(plant_out: str, n: int, what="calibrate pose") -> np.ndarray:
    m = cl.marks(plant_out)
    missing = [i + 1 for i in range(n) if f"{what} {i + 1}" not in m]
    if missing:
        raise RuntimeError(f"the run did not reach pose(s) {', '.join(map(str, missing[:8]))} "
                           "(see the plant's output: a fault, or a pose the machine cannot reach)")
    return np.array([m[f"{what} {i + 1}"] for i in range(n)])


def _run_inproc(spec: cl.RunSpec, out: Path, build, timeout):
    """One lockstep run in one process (``hs_sim --inproc``: the firmware's
    node linked into the plant, the CAN frames passed in memory in the order
    one vcan socket delivers them, the same log byte for byte): no vcan."""
    import subprocess

    from .. import auth
    bins = cl.Binaries.find(build)
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    scn = out / f"{spec.name}.scenario"
    scn.write_text(spec.scenario)
    log, truth = out / f"{spec.name}.log", out / f"{spec.name}.truth.csv"
    argv = [str(bins.plant), "--inproc", "--scenario", str(scn), "--log", str(log), "--truth", str(truth),
            "--key", str(auth.run_key(out).resolve()), "--session", str(cl.LOCKSTEP_SESSION),
            *spec.plant_args]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    (out / f"{spec.name}.plant.txt").write_text(r.stdout + r.stderr)
    return cl.RunResult(spec, log, truth, r.returncode, r.stdout + r.stderr, "")


def run_poses(platform, poses, build, out, name, extra="", timeout=1800, plant_args=(), inproc=False):
    """One lockstep run through ``poses`` (marks at rest), then ``extra``
    scenario lines before parking. ``plant_args``: more hs_sim options (the
    as-built machine: ``--as-built FILE``); ``inproc``: the controller in the
    plant's process (``hs_sim --inproc``), else sp_controller over vcan.
    Returns (RunResult, ticks of the marks)."""
    from .io import move_times
    text = scenario(poses, SETTLE, FADE, move_times(platform, poses, FADE), home=platform.home)
    text = text.replace("cmd PARK\n", extra + "cmd PARK\n", 1)
    spec = cl.RunSpec(name=name, scenario=text, timeout_ms=5000, plant_args=tuple(plant_args))
    if inproc:
        res = _run_inproc(spec, out, build, timeout)
    else:
        (res,) = cl.run([spec], out, build, progress=False, timeout=timeout)
    if not res.ok:
        last = res.plant_out.strip().splitlines()[-1:]
        raise RuntimeError(f"{name}: the closed loop failed (hs_sim exit {res.plant_rc}): "
                           + (last[0] if last else "no output"))
    return res, pose_ticks(res.plant_out, len(poses))


def truth_at(truth_csv, ticks):
    from ..analysis.truth import read_truth
    t = read_truth(truth_csv)
    idx = np.searchsorted(t["tick"], ticks)
    if np.any(idx >= len(t["tick"])) or np.any(t["tick"][np.minimum(idx, len(t["tick"]) - 1)] != ticks):
        raise RuntimeError(f"{truth_csv}: no truth at some marked tick")
    return t["pose"][idx]


def readings_at(log, platform, ticks):
    from ..analysis.decode import read_log
    d = read_log(log, platform=platform)
    idx = np.searchsorted(d.ticks, ticks)
    return d.length[np.minimum(idx, len(d.ticks) - 1)], d


def measure(platform, poses, build, out, tracker: Tracker, rng, fiducials=None, repeats=20, name="calibrate",
            plant_args=(), inproc=False) -> Data:
    """Drives ``poses`` and returns the measurements (readings from the log,
    the tracker's readings from the truth)."""
    res, ticks = run_poses(platform, poses, build, out, name, plant_args=plant_args, inproc=inproc)
    true_pose = truth_at(res.truth, ticks)
    readings, _ = readings_at(res.log, platform, ticks)
    p, r = poses_to_pr(true_pose)
    obs = tracker.observe(p, r) + rng.normal(0.0, tracker.noise, (len(p), len(tracker.targets), 3))
    data = Data(readings, obs, np.asarray(poses, float), ticks=ticks)
    if fiducials is not None:
        f = np.tile(np.asarray(fiducials, float), (repeats, 1))
        data.fiducials = (f - tracker.pos) @ tracker.rot + rng.normal(0.0, tracker.noise, f.shape)
        data.fiducials_base = f
    return data


def pose_errors(truth_csv, plant_out, poses):
    """Absolute position (m) and orientation (rad) error at each marked rest:
    the plant's true pose against the commanded one, in the plant's frame
    (the fiducials')."""
    ticks = pose_ticks(plant_out, len(poses))
    pt, rt = poses_to_pr(truth_at(truth_csv, ticks))
    pc, rc = poses_to_pr(poses)
    return np.linalg.norm(pt - pc, axis=1), rotation_angle(rt @ np.transpose(rc, (0, 2, 1)))


def surge_tracking(platform, log, truth_csv, plant_out):
    """RMS and max of the true surge minus the reference between the marks
    ``begin x`` and ``end x`` (m)."""
    from ..analysis.decode import read_log
    from ..analysis.truth import read_truth
    m = cl.marks(plant_out)
    d = read_log(log, platform=platform)
    t = read_truth(truth_csv)
    sel = (d.ticks >= m["begin x 0.09 0.5"]) & (d.ticks <= m["end x"])
    idx = np.searchsorted(t["tick"], d.ticks[sel])
    ok = idx < len(t["tick"])
    err = t["pose"][idx[ok], 0] - d.reference[sel][ok, 0]
    err = err[np.isfinite(err)]
    return float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(err)))


def validate(platform, poses, build, out, name, plant_args=(), inproc=False):
    """Absolute error at rest after each move and the paper's surge (from
    home, truth minus reference), from one run."""
    extra = cl.trig("x", 0.09, 0.5, 8.0, 1.0)   # from home (the scenario returns there first)
    res, _ = run_poses(platform, poses, build, out, name, extra=extra, plant_args=plant_args, inproc=inproc)
    pos, rot = pose_errors(res.truth, res.plant_out, poses)
    rms, peak = surge_tracking(platform, res.log, res.truth, res.plant_out)
    return {"pos": pos, "rot": rot, "surge_rms": rms, "surge_max": peak}
