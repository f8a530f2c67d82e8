# SPDX-License-Identifier: Apache-2.0
"""One design analysis: a platform config and a duty in, every figure's
numbers and the verdict out (a JSON-ready dict; ``report`` draws it)."""

from __future__ import annotations

import math

import numpy as np

from .. import model
from . import forces, hydraulics, limits, verdict, workspace

DIRECTIONS = ["+Fx", "-Fx", "+Fy", "-Fy", "+Fz", "-Fz", "+Mx", "-Mx", "+My", "-My", "+Mz", "-Mz"]


def check_config(platform) -> None:
    """The keys the analyses need (MissingKey names the first one absent)."""
    limits.need(platform, "hydraulic.piston_diameter", "hydraulic.rod_diameter", "hydraulic.dead_volume",
                "hydraulic.bulk_modulus", "hydraulic.supply_pressure", "hydraulic.valve_rated_flow",
                "hydraulic.cylinder_outer_diameter", "joints.base_cone_max", "joints.platform_cone_max")


def _pose_list(p) -> list:
    return [round(float(v), 6) for v in p]


def workspace_part(platform, duty) -> dict:
    home = np.asarray(platform.home, dtype=float)
    slices = []
    for rpy in duty.orientations:
        w = workspace.constant_orientation(platform, home[3:] + np.asarray(rpy), duty.position_step)
        mid = int(np.argmin(np.abs(w["z"] - home[2])))
        slices.append({"rpy": rpy, "volume_m3": w["volume"], "x": w["x"].tolist(), "y": w["y"].tolist(),
                       "z": float(w["z"][mid]), "reachable_xy": w["mask"][:, :, mid].astype(int).tolist()})
    orient = []
    for pos in duty.positions:
        o = workspace.orientation_workspace(platform, home[:3] + np.asarray(pos), duty.angle_step)
        orient.append({"position": pos, "volume_rad3": o["volume"], "alone": o["alone"],
                       "roll": o["roll"].tolist(), "pitch": o["pitch"].tolist(),
                       "reachable_roll_pitch": o["mask"].any(axis=2).astype(int).tolist()})
    cm = workspace.conditioning_map(platform, home[3:], duty.position_step)
    return {"slices": slices, "orientation": orient,
            "conditioning": {"x": cm["x"].tolist(), "y": cm["y"].tolist(),
                             "cond": np.where(np.isnan(cm["cond"]), None, cm["cond"]).tolist(),
                             "cond_max": float(np.nanmax(cm["cond"])),
                             "smin_min": float(np.nanmin(cm["smin"]))}}


def _argworst(values: np.ndarray, poses: np.ndarray, largest: bool) -> dict:
    idx = np.unravel_index(np.argmax(values) if largest else np.argmin(values), values.shape)
    return {"value": float(values[idx]), "leg": int(idx[1]) + 1, "pose": _pose_list(poses[idx[0]])}


def force_part(platform, duty, poses: np.ndarray) -> tuple[dict, dict]:
    ef = forces.envelope_forces(platform, duty, poses)
    push_cap, pull_cap = hydraulics.capacities(platform)
    worst_push = _argworst(ef["push"], poses, True)
    worst_pull = _argworst(ef["pull"], poses, False)
    size = hydraulics.sizing(platform, worst_push["value"], -worst_pull["value"], duty.load_pressure_fraction)
    cap = wrench_capacity(platform, duty, poses, ef["static"], push_cap, pull_cap)
    out = {"push": worst_push, "pull": worst_pull, "push_per_leg": ef["push"].max(axis=0).tolist(),
           "pull_per_leg": ef["pull"].min(axis=0).tolist(), "push_capacity": push_cap,
           "pull_capacity": pull_cap, "sizing": size, "wrench_capacity": cap}
    return out, ef


def wrench_capacity(platform, duty, poses, static, push_cap, pull_cap) -> dict:
    """Largest force and moment in each direction that the cylinders' limits
    allow on top of the static load (heaviest payload), least over the poses."""
    a = limits.force_matrix(limits.legs(platform, poses))
    inv = np.linalg.inv(a)
    out = {}
    for j, name in enumerate(DIRECTIONS):
        c = inv[:, :, j // 2] * (1.0 if j % 2 == 0 else -1.0)
        room = np.where(c > 0, (push_cap - static) / np.where(c > 0, c, 1.0),
                        np.where(c < 0, (-pull_cap - static) / np.where(c < 0, c, -1.0), np.inf))
        best = room.min(axis=1)
        k = int(np.argmin(best))
        out[name] = {"value": float(best[k]), "pose": _pose_list(poses[k])}
    return out


def hydraulic_part(platform, duty, poses, ef: dict) -> dict:
    """Flows (the envelope's and the trajectories' peaks), supply, valve and
    pressure margins."""
    a_a, a_b = hydraulics.areas(platform)
    rate = ef["rate_max"].max(axis=0)
    supply = float(hydraulics.supply_flow(platform, ef["jacobian"], duty).max())
    mean = [float(2.0 / math.pi * a_a * r) for r in rate]
    src = "sinusoidal motion at the peak velocity (2/pi of the peak)"
    if duty.trajectories:
        rates = [_traj_rates(platform, t) for t in duty.trajectories]
        flows = [np.where(r > 0, a_a * r, -a_b * r) for r in rates]
        rate = np.maximum(rate, np.max([np.abs(r).max(axis=0) for r in rates], axis=0))
        supply = max(supply, float(max(f.sum(axis=1).max() for f in flows)))
        mean = np.max([f.mean(axis=0) for f in flows], axis=0).tolist()
        src = "the trajectories (largest mean)"
    flow_leg = a_a * rate
    v = hydraulics.valve(platform, flow_leg, ef["push"].max(axis=0))
    h = platform.hydraulic
    return {"rate_max_per_leg": rate.tolist(), "flow_peak_per_leg": flow_leg.tolist(),
            "flow_mean_per_leg": mean, "flow_mean_source": src,
            "supply_flow_peak": supply, "supply_power_peak": supply * h["supply_pressure"],
            "valve_rated_flow_needed": float(np.max(v["rated_flow_needed"])),
            "valve_rated_flow": h["valve_rated_flow"], "valve_rated_pressure_drop": h["valve_rated_pressure_drop"],
            "pressure_margin_per_leg": v["pressure_margin"].tolist()}


def _traj_rates(platform, t) -> np.ndarray:
    return model.joint_motion(platform, t.pose, t.vel[:, :3], t.vel[:, 3:], t.acc[:, :3], t.acc[:, 3:]).rates


def stiffness_part(platform, duty, poses, with_map: bool = True) -> dict:
    heavy = forces.with_payload(platform, duty, duty.mass_max)
    f = hydraulics.natural_frequencies(heavy, poses)
    k = int(np.argmin(f[:, 0]))
    home = np.asarray(platform.home, dtype=float)
    f_home = hydraulics.natural_frequencies(heavy, home[None, :])[0]
    lowest = float(f[k, 0])
    out = {"lowest_hz": lowest, "lowest_pose": _pose_list(poses[k]), "home_hz": f_home.tolist(),
           "loop_damping": duty.loop_damping, "bandwidth_hz": 2.0 * duty.loop_damping * lowest}
    if not with_map:
        return out
    cm = workspace.conditioning_map(platform, home[3:], duty.position_step)
    xx, yy = np.meshgrid(cm["x"], cm["y"], indexing="ij")
    plane = np.zeros(xx.shape + (6,))
    plane[..., 0], plane[..., 1], plane[..., 2:] = xx, yy, home[2:]
    fmap = np.where(np.isnan(cm["cond"]), np.nan, hydraulics.natural_frequencies(heavy, plane)[..., 0])
    out["map"] = {"x": cm["x"].tolist(), "y": cm["y"].tolist(),
                  "lowest_hz": np.where(np.isnan(fmap), None, fmap).tolist()}
    return out


def trajectory_part(platform, duty) -> list:
    """Each trajectory as it is: its tightest limit (naming the row) and its
    peak forces, for both payload masses."""
    out = []
    for t in duty.trajectories:
        m = limits.margins(platform, t.pose)
        worst = np.minimum(np.minimum(m.stroke, m.clearance), np.minimum(m.base_cone, m.platform_cone))
        row = int(np.argmin(worst))
        margin, what = limits.limiter(platform, t.pose[row])
        tf = forces.trajectory_forces(platform, duty, t)
        f = np.stack([v["force"] for v in tf.values()])
        ch = np.stack([v["chamber"] for v in tf.values()])
        rates = np.stack([v["rates"] for v in tf.values()])
        out.append({"name": t.name, "rows": int(t.t.size), "margin": margin, "limit": what,
                    "row": row + 2, "force_max": float(f.max()), "force_min": float(f.min()),
                    "force_peak_per_leg": np.abs(f).max(axis=(0, 1)).tolist(),
                    "chamber_max": float(ch.max()), "chamber_min": float(ch.min()),
                    "rate_peak": float(np.abs(rates).max()), "t": t.t.tolist(),
                    "force": f[-1].tolist()})
    return out


def run(platform, duty, full: bool = True, points: int | None = None) -> dict:
    """Every analysis of the report; raises MissingKey before computing
    anything when the config lacks a key. ``full=False`` leaves out the
    workspace maps (what a sweep's candidate needs), ``points`` overrides
    the envelope grid's points per axis."""
    check_config(platform)
    poses = workspace.envelope_poses(platform, duty, points)
    result = {"platform": platform.name, "config": platform.source, "duty": duty.source,
              "envelope_poses": int(poses.shape[0]),
              "config_box": [[platform.home[k] + platform.workspace_min[k], platform.home[k] + platform.workspace_max[k]]
                             for k in range(6)]}
    result["envelope"] = workspace.envelope_check(platform, duty, poses)
    if full:
        result["workspace"] = workspace_part(platform, duty)
    result["forces"], ef = force_part(platform, duty, poses)
    push, pull = hydraulics.capacities(platform, duty.load_pressure_fraction)
    result["forces"]["push_capacity_at_fraction"] = push
    result["forces"]["pull_capacity_at_fraction"] = pull
    result["hydraulics"] = hydraulic_part(platform, duty, poses, ef)
    result["stiffness"] = stiffness_part(platform, duty, poses, full)
    result["trajectories"] = trajectory_part(platform, duty)
    result["verdict"] = verdict.verdict(platform, duty, result)
    return result
