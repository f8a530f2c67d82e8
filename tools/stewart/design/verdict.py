# SPDX-License-Identifier: Apache-2.0
"""The verdict: per requirement, pass or fail, the margin and what limits it."""

from __future__ import annotations


def _item(name: str, margin: float, unit: str, limit: str, need: float = 0.0) -> dict:
    return {"requirement": name, "pass": bool(margin >= need), "margin": float(margin), "unit": unit,
            "limit": limit}


def _spare(have: float, need: float) -> float:
    """have / need - 1, the relative margin (infinite when nothing is needed)."""
    return have / need - 1.0 if need > 0 else float("inf")


def _pose(p) -> str:
    return "[" + ", ".join(f"{v:.3f}" for v in p) + "]"


def _force_items(platform, duty, f: dict, traj: list) -> list:
    need = duty.requirements.get("force_margin", 0.0)
    frac = duty.load_pressure_fraction
    push_cap = f["push_capacity_at_fraction"]
    pull_cap = f["pull_capacity_at_fraction"]
    out = [
        _item(f"cylinder push within {frac:.2f} of the supply pressure", _spare(push_cap, f["push"]["value"]),
              "relative",
              f"cylinder {f['push']['leg']} push {f['push']['value'] / 1e3:.1f} kN at pose {_pose(f['push']['pose'])}",
              need),
        _item(f"cylinder pull within {frac:.2f} of the supply pressure", _spare(pull_cap, -f["pull"]["value"]),
              "relative",
              f"cylinder {f['pull']['leg']} pull {-f['pull']['value'] / 1e3:.1f} kN at pose {_pose(f['pull']['pose'])}",
              need),
    ]
    peak = max(f["push"]["value"], -f["pull"]["value"])
    out.append(_item("forces within the controller's force_max", _spare(platform.force_max, peak), "relative",
                     f"peak cylinder force {peak / 1e3:.1f} kN against force_max {platform.force_max / 1e3:.1f} kN"))
    for t in traj:
        tp = max(t["chamber_max"] / push_cap, -t["chamber_min"] / pull_cap)
        out.append(_item(f"trajectory {t['name']}: forces within the cylinders", _spare(1.0, tp), "relative",
                         f"peak chamber force {t['chamber_max'] / 1e3:.1f} kN push, {max(0.0, -t['chamber_min']) / 1e3:.1f} kN pull"))
    return out


def verdict(platform, duty, result: dict) -> list:
    items = []
    env = result["envelope"]
    items.append(_item("envelope inside the workspace", env["margin"], "m or rad",
                       f"{env['limit']} at pose {_pose(env['pose'])}"))
    for t in result["trajectories"]:
        items.append(_item(f"trajectory {t['name']} inside the workspace", t["margin"], "m or rad",
                           f"{t['limit']} at row {t['row']}"))
    items += _force_items(platform, duty, result["forces"], result["trajectories"])
    h = result["hydraulics"]
    rate = max(h["rate_max_per_leg"])
    leg = h["rate_max_per_leg"].index(rate) + 1
    items.append(_item("leg rates within leg_velocity_max", _spare(platform.leg_velocity_max, rate), "relative",
                       f"leg {leg} at {rate:.3f} m/s"))
    items.append(_item("valve's rated flow", _spare(h["valve_rated_flow"], h["valve_rated_flow_needed"]),
                       "relative", f"needs {h['valve_rated_flow_needed'] * 6e4:.0f} l/min at "
                       f"{h['valve_rated_pressure_drop'] / 1e5:.0f} bar per land"))
    pm = min(h["pressure_margin_per_leg"])
    leg = h["pressure_margin_per_leg"].index(pm) + 1
    items.append(_item("pressure left at peak flow and peak push", pm / 1e5, "bar",
                       f"cylinder {leg}: supply less load pressure less valve drop"))
    s = result["stiffness"]
    if "bandwidth_hz" in duty.requirements:
        want = duty.requirements["bandwidth_hz"]
        items.append(_item(f"position loop bandwidth {want:g} Hz", _spare(s["bandwidth_hz"], want), "relative",
                           f"lowest natural frequency {s['lowest_hz']:.1f} Hz at pose {_pose(s['lowest_pose'])}"))
    if "condition_max" in duty.requirements:
        c = result["envelope"]["cond_max"]
        items.append(_item("force transformation's condition number", _spare(duty.requirements["condition_max"], c),
                           "relative", f"condition number {c:.2f} over the envelope"))
    return items
