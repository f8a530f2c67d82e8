# SPDX-License-Identifier: Apache-2.0
"""Generates the firmware's default platform (C source) from a config file.

Run by the firmware build (standard library only, before any venv exists):

    python3 tools/stewart/gen_platform.py config/platform_default.json OUT.c

A bad config fails the build with the validator's message, which names the
key. ``quantize`` is also used by the host tools (stewart.core), so the
struct that the tools hand to the core is bit-identical to the one compiled
into the firmware.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from stewart import config as cfg  # noqa: E402
    from stewart.drives import plan as _plan  # noqa: E402
else:
    from . import config as cfg
    from .drives import plan as _plan

import math

Q30 = 1 << 30
Q24 = 1 << 24
Q16 = 1 << 16
Q8 = 1 << 8
I32_MIN, I32_MAX = -(1 << 31), (1 << 31) - 1


def _q(v: float, scale: int, where: str) -> int:
    r = round(v * scale)
    if not I32_MIN <= r <= I32_MAX:
        raise cfg.ConfigError(f"{where}: {v:g} does not fit the firmware's fixed-point format")
    return r


def quantize(p: cfg.Platform) -> dict:
    """The platform in the core's Q formats (see sp/model/platform.h)."""
    h = p.hydraulic
    sigma0, sigma1 = cfg.bristle_parameters(p)
    return {
        "base_joint": [[_q(v, Q24, "base_joints") for v in row] for row in p.base_joints],
        "platform_joint": [[_q(v, Q24, "platform_joints") for v in row] for row in p.platform_joints],
        "mass": _q(p.mass, Q16, "mass"),
        "inertia": [[_q(v, Q16, "inertia") for v in row] for row in inertia_about_origin(p)],
        "center_of_mass": [_q(v, Q24, "center_of_mass") for v in p.center_of_mass],
        "gravity": _q(p.gravity, Q24, "gravity"),
        "home": [_q(v, Q24, "home") for v in p.home],
        "park": [_q(v, Q24, "park") for v in p.park],
        "leg_length_min": _q(p.leg_length_min, Q24, "leg_length_min"),
        "leg_length_max": _q(p.leg_length_max, Q24, "leg_length_max"),
        "force_max": _q(p.force_max, Q8, "force_max"),
        "leg_velocity_max": _q(p.leg_velocity_max, Q24, "leg_velocity_max"),
        "workspace_min": [_q(v, Q24, "workspace.min") for v in p.workspace_min],
        "workspace_max": [_q(v, Q24, "workspace.max") for v in p.workspace_max],
        "piston_area": _q(piston_area(p), Q30, "hydraulic.piston_diameter"),
        "annulus_area": _q(annulus_area(p), Q30, "hydraulic.rod_diameter"),
        "leg_mass": {
            "cylinder_mass": _q(h.get("cylinder_mass", 0.0), Q16, "hydraulic.cylinder_mass"),
            "cylinder_com": _q(h.get("cylinder_com", 0.0), Q24, "hydraulic.cylinder_com"),
            "rod_mass": _q(h.get("rod_mass", 0.0), Q16, "hydraulic.rod_mass"),
            "rod_com": _q(h.get("rod_com", 0.0), Q24, "hydraulic.rod_com"),
        },
        "viscous_friction": [_q(v, Q8, "hydraulic.viscous_friction") for v in _legs(h, "viscous_friction")],
        "coulomb_friction": [_q(v, Q8, "hydraulic.coulomb_friction") for v in _legs(h, "coulomb_friction")],
        "coulomb_velocity": _q(h.get("coulomb_velocity", 1.0e-3), Q24, "hydraulic.coulomb_velocity"),
        "breakaway_friction": [_q(v, Q8, "hydraulic.breakaway_friction") for v in _legs(h, "breakaway_friction")],
        "stribeck_velocity": _q(h.get("stribeck_velocity", cfg.FRICTION_SHAPE_KEYS["stribeck_velocity"][3]),
                                Q24, "hydraulic.stribeck_velocity"),
        "bristle_stiffness": [_q(v, 1, "hydraulic.presliding_displacement (bristle stiffness)") for v in sigma0],
        "bristle_damping": [_q(v, Q8, "hydraulic.presliding_displacement (bristle damping)") for v in sigma1],
    }


def rpy_matrix(rpy) -> list[list[float]]:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (Z-Y-X, as the platform's angles)."""
    cr, sr = math.cos(rpy[0]), math.sin(rpy[0])
    cp, sp = math.cos(rpy[1]), math.sin(rpy[1])
    cy, sy = math.cos(rpy[2]), math.sin(rpy[2])
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]


def force_sensor_setup(p: cfg.Platform) -> dict:
    """The force/torque sensor's mounting in the core's formats (sp/estimation/ftsensor.h)
    and the wrench source (0 cylinders, 1 sensor: SP_WRENCH_*)."""
    fs = p.force_sensor
    return {
        "wrench_source": cfg.WRENCH_SOURCES.index(fs["wrench_source"]),
        "axes": [[_q(v, Q30, "force_sensor.mount_rpy") for v in row] for row in rpy_matrix(fs["mount_rpy"])],
        "pos": [_q(v, Q24, "force_sensor.mount_pos") for v in fs["mount_pos"]],
    }


def _legs(h: dict, key: str) -> list[float]:
    """A per-leg friction list (0 for every leg without a hydraulic section)."""
    return h.get(key, [0.0] * cfg.LEGS)


def inertia_about_origin(p: cfg.Platform) -> list[list[float]]:
    """The config's inertia (about the centre of mass c) moved to o' by the
    parallel-axis theorem: I_o' = I_c + m (|c|^2 E - c c^T). The firmware
    writes the rotation about o', where the legs act."""
    c = p.center_of_mass
    c2 = sum(v * v for v in c)
    return [[p.inertia[r][k] + p.mass * ((c2 if r == k else 0.0) - c[r] * c[k]) for k in range(3)]
            for r in range(3)]


def piston_area(p: cfg.Platform) -> float:
    """Piston-side area, m^2 (0 without a hydraulic section)."""
    d = p.hydraulic.get("piston_diameter", 0.0)
    return math.pi * d * d / 4.0


def annulus_area(p: cfg.Platform) -> float:
    """Rod-side (annulus) area, m^2 (0 without a hydraulic section)."""
    r = p.hydraulic.get("rod_diameter", 0.0)
    return max(0.0, piston_area(p) - math.pi * r * r / 4.0) if p.hydraulic else 0.0


def _pose(v) -> str:
    return "{{%d, %d, %d}, {%d, %d, %d}}" % tuple(v)


def _rows(m) -> str:
    return "{" + ", ".join("{%s}" % ", ".join(str(x) for x in row) for row in m) + "}"


#: The firmware's drive buses, in the order the config's CANopen buses take them.
_DRIVE_BUSES = ("SP_BUS_AXIS_A", "SP_BUS_AXIS_B")
#: Master timeouts the config does not set (docs/canopen.md): boot, SDO, device state.
_BOOT_MS, _SDO_MS, _STATE_MS = 2000, 100, 100
#: sp_co_profile_t of each CANopen protocol.
_PROFILE = {"cia408": "SP_CO_PROFILE_408", "cia402": "SP_CO_PROFILE_402"}


def canopen_layout(p: cfg.Platform) -> dict:
    """The config's ``drives`` section as the firmware's sp_co_layout_t
    fields; when every leg is native only the master's heartbeat period and
    node id (which the ports' built-in CANopen layout takes). Raises ConfigError (naming the
    key) for what the firmware cannot drive: native drives with CANopen ones
    (one drive protocol per image; CiA 408 and CiA 402 drives may share the
    master), more than two CANopen buses, a resolution that is not a whole
    number of nm per count, a drive with the master's heartbeat node id."""
    d = p.drives
    protos = {leg.protocol for leg in d.legs}
    if protos == {"native"}:
        return {"master_heartbeat_ms": d.master_heartbeat_ms, "master_node_id": d.master_node_id}
    if "native" in protos:
        raise cfg.ConfigError("drives.legs: the firmware drives every leg with one protocol (one per image); "
                              f"the config mixes {', '.join(sorted(protos))}")
    buses = d.buses()
    if len(buses) > len(_DRIVE_BUSES):
        raise cfg.ConfigError(f"drives.legs: {len(buses)} CANopen buses ({', '.join(buses)}); the controller "
                              f"has {len(_DRIVE_BUSES)} drive buses (axis_a, axis_b)")
    nodes, scaling = [], []
    for leg in d.legs:
        w = f"drives.legs[{leg.leg - 1}]"
        nm = leg.scaling.position_per_count * 1e9
        if abs(nm - round(nm)) > 1e-6 * max(1.0, nm) or not 1 <= round(nm) <= 1_000_000:
            raise cfg.ConfigError(f"{w}.scaling.position_per_count: {leg.scaling.position_per_count:g} m is not "
                                  "a whole number of nm per count in 1..1000000 (the firmware's scaling)")
        if d.master_heartbeat_ms and leg.node_id == d.master_node_id:
            raise cfg.ConfigError(f"{w}.node_id: {leg.node_id} is the master's own heartbeat id "
                                  "(drives.master_node_id)")
        prefix = _plan.unit_prefix(leg.scaling.position_per_count) if leg.protocol == "cia408" else None
        nodes.append({"node_id": leg.node_id, "bus": _DRIVE_BUSES[buses.index(leg.bus)], "leg": leg.leg,
                      "control_mode": leg.control_mode, "write_prefix": int(prefix is not None),
                      "unit_prefix": prefix if prefix is not None else 0,
                      "force_ff": int(leg.force_feedforward), "profile": _PROFILE[leg.protocol]})
        scaling.append({"nm_per_count": int(round(nm)), "zero_q24": _q(leg.scaling.length_at_zero, Q24,
                                                                       f"{w}.scaling.length_at_zero"),
                        "direction": leg.scaling.direction,
                        "rated_force_n": int(round(leg.scaling.rated_force or 0))})
    return {"nodes": nodes, "scaling": scaling, "sync_divider": d.sync_divider,
            "pressure": int(d.pressure_feedback and "cia408" in protos),
            "heartbeat_ms": d.heartbeat_ms, "heartbeat_timeout_ms": d.heartbeat_timeout_ms,
            "setpoint_timeout_ms": d.setpoint_timeout_ms, "pdo_timeout_ms": max(10, 3 * d.sync_divider + 1),
            "bitrate": {_DRIVE_BUSES[i]: d.bitrates.get(b, 1_000_000) for i, b in enumerate(buses)},
            "master_heartbeat_ms": d.master_heartbeat_ms, "master_node_id": d.master_node_id}


def _layout_c(lay: dict) -> str:
    if "nodes" not in lay:  # native drives: the master's heartbeat keys only (the ports' built-in layout)
        return f"""/* the config's drives are native; the built-in CANopen layout takes the master's heartbeat */
const sp_co_layout_t sp_co_layout_default = {{
    .present = 0u,
    .master = {{.master_heartbeat_ms = {lay["master_heartbeat_ms"]}u, .master_node_id = {lay["master_node_id"]}u}},
}};
"""
    nodes = ",\n".join(
        f"            {{{n['node_id']}u, {n['bus']}, {n['leg']}u, {n['control_mode']}, {n['write_prefix']}u, "
        f"{n['unit_prefix']}, {n['force_ff']}u, {n['profile']}}}" for n in lay["nodes"])
    scal = ",\n".join(f"        {{{s['nm_per_count']}u, {s['zero_q24']}, {s['direction']}, {s['rated_force_n']}u, "
                       "0u, 0u, 0u, 0}"
                       for s in lay["scaling"])
    rates = ", ".join(f"[{b}] = {r}u" for b, r in lay["bitrate"].items())
    return f"""const sp_co_layout_t sp_co_layout_default = {{
    .present = 1u,
    .master = {{
        .node = {{
{nodes}
        }},
        .n_nodes = {len(lay["nodes"])}u,
        .sync_divider = {lay["sync_divider"]}u,
        .pressure_feedback = {lay["pressure"]}u,
        .heartbeat_ms = {lay["heartbeat_ms"]}u,
        .heartbeat_timeout_ms = {lay["heartbeat_timeout_ms"]}u,
        .setpoint_timeout_ms = {lay["setpoint_timeout_ms"]}u,
        .boot_timeout_ms = {_BOOT_MS}u,
        .sdo_timeout_ms = {_SDO_MS}u,
        .state_timeout_ms = {_STATE_MS}u,
        .pdo_timeout_ms = {lay["pdo_timeout_ms"]}u,
        .master_heartbeat_ms = {lay["master_heartbeat_ms"]}u,
        .master_node_id = {lay["master_node_id"]}u,
    }},
    .scaling = {{
{scal}
    }},
    .bitrate = {{{rates}}},
}};
"""


def c_source(p: cfg.Platform) -> str:
    q = quantize(p)
    lay = canopen_layout(p)
    lm = q["leg_mass"]
    fs = force_sensor_setup(p)
    return f"""/* Generated by tools/stewart/gen_platform.py from {Path(p.source).name}
 * ("{p.name}"). Do not edit: change the config file and rebuild. */
#include "sp/canopen/canopen_link.h"
#include "sp/estimation/ftsensor.h"
#include "sp/model/platform.h"

const uint8_t sp_wrench_source_default = {fs["wrench_source"]}u;
const sp_ft_mount_t sp_ft_mount_default = {{{{{_rows(fs["axes"])}}}, {{{", ".join(str(v) for v in fs["pos"])}}}}};

const sp_platform_t sp_platform_default = {{
    .base_joint = {_rows(q["base_joint"])},
    .platform_joint = {_rows(q["platform_joint"])},
    .mass = {q["mass"]},
    .inertia = {_rows(q["inertia"])},
    .gravity = {q["gravity"]},
    .home = {_pose(q["home"])},
    .park = {_pose(q["park"])},
    .leg_length_min = {q["leg_length_min"]},
    .leg_length_max = {q["leg_length_max"]},
    .force_max = {q["force_max"]},
    .leg_velocity_max = {q["leg_velocity_max"]},
    .workspace_min = {_pose(q["workspace_min"])},
    .workspace_max = {_pose(q["workspace_max"])},
    .piston_area = {q["piston_area"]},
    .annulus_area = {q["annulus_area"]},
    .center_of_mass = {{{", ".join(str(v) for v in q["center_of_mass"])}}},
    .leg_mass = {{{lm["cylinder_mass"]}, {lm["cylinder_com"]}, {lm["rod_mass"]}, {lm["rod_com"]}}},
    .viscous_friction = {{{", ".join(str(v) for v in q["viscous_friction"])}}},
    .coulomb_friction = {{{", ".join(str(v) for v in q["coulomb_friction"])}}},
    .coulomb_velocity = {q["coulomb_velocity"]},
    .breakaway_friction = {{{", ".join(str(v) for v in q["breakaway_friction"])}}},
    .stribeck_velocity = {q["stribeck_velocity"]},
    .bristle_stiffness = {{{", ".join(str(v) for v in q["bristle_stiffness"])}}},
    .bristle_damping = {{{", ".join(str(v) for v in q["bristle_damping"])}}},
}};

{_layout_c(lay)}"""


def run_generator(argv: list[str], c_source, prog: str) -> int:
    """CONFIG.json OUT.c -> OUT.c = c_source(config), rewritten only when it
    changes (so the build does not recompile). 2 usage, 1 bad config."""
    if len(argv) != 2:
        print(f"usage: {prog} CONFIG.json OUT.c", file=sys.stderr)
        return 2
    try:
        text = c_source(cfg.load(argv[0]))
    except cfg.ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    out = Path(argv[1])
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists() or out.read_text() != text:
        out.write_text(text)
    return 0


def main(argv: list[str]) -> int:
    return run_generator(argv, c_source, "gen_platform.py")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
