# SPDX-License-Identifier: Apache-2.0
"""Generates the firmware's default platform (C source) from a config file.

Run by the firmware build (standard library only, before any venv exists):

    python3 tools/dev/gen_platform.py config/platform_default.json OUT.c

A bad config fails the build with the validator's message, which names the
key; so does a config that ``stewart calibrate solve`` wrote and ``stewart
calibrate check --accept`` has not accepted (``calibration.status``).
The numbers come from ``stewart.fixedpoint``, which the host tools use too
(stewart.core), so the struct that the tools hand to the core is
bit-identical to the one compiled into the firmware.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tools/: this checkout's stewart
from stewart import config as cfg  # noqa: E402
from stewart.drives import plan as _plan  # noqa: E402
from stewart.fixedpoint import Q24, _q, force_sensor_setup, quantize  # noqa: E402


def _pose(v) -> str:
    return "{{%d, %d, %d}, {%d, %d, %d}}" % tuple(v)


def _rows(m) -> str:
    return "{" + ", ".join("{%s}" % ", ".join(str(x) for x in row) for row in m) + "}"


#: The firmware's drive buses, in the order the config's CANopen buses take them.
_DRIVE_BUSES = ("SP_BUS_AXIS_A", "SP_BUS_AXIS_B")
#: Master timeouts the config does not set (docs/reference/canopen.md): boot, SDO, device state.
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
                      "force_ff": int(leg.force_feedforward), "profile": _PROFILE[leg.protocol],
                      "disable_on_block": int(leg.on_block == "disabled")})
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
        f"{n['unit_prefix']}, {n['force_ff']}u, {n['profile']}, {n['disable_on_block']}u}}" for n in lay["nodes"])
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


def _frames_c(p: cfg.Platform) -> str:
    """sp_frame_slots_default: the config's named frames in Q24 (unused slots identity)."""
    fr = p.frames
    rows = {}
    for kind in ("tool", "work"):
        poses = [f["pose"] for f in fr[kind]] + [[0.0] * 6] * (4 - len(fr[kind]))
        rows[kind] = ", ".join(_pose([_q(v, Q24, f"frames.{kind}") for v in pose]) for pose in poses)
    names = "; ".join(f"{kind} {i} {f['name']}" for kind in ("tool", "work") for i, f in enumerate(fr[kind]))
    return (f"/* frames: {names} */\n"
            f"const sp_frame_slots_t sp_frame_slots_default = {{{{{rows['tool']}}}, {{{rows['work']}}}, "
            f"{(1 << len(fr['tool'])) - 1}u, {(1 << len(fr['work'])) - 1}u, {fr['active_tool']}u, "
            f"{fr['active_work']}u}};\n")


def c_source(p: cfg.Platform) -> str:
    q = quantize(p)
    lay = canopen_layout(p)
    lm = q["leg_mass"]
    fs = force_sensor_setup(p)
    e = p.estop
    es = {"category": e["category"],
          "decel": ", ".join(str(_q(e[k], Q24, "estop." + k)) for k in ("deceleration", "angular_deceleration")),
          "jerk": ", ".join(str(_q(e[k], Q24, "estop." + k)) for k in ("jerk", "angular_jerk")),
          "settle": round(e["settle"] * 1000)}  # ticks of 1 ms
    return f"""/* Generated by tools/dev/gen_platform.py from {Path(p.source).name}
 * ("{p.name}"). Do not edit: change the config file and rebuild. */
#include "sp/canopen/canopen_link.h"
#include "sp/control/controller.h"
#include "sp/estimation/ftsensor.h"
#include "sp/model/platform.h"

const uint8_t sp_wrench_source_default = {fs["wrench_source"]}u;
const sp_ft_mount_t sp_ft_mount_default = {{{{{_rows(fs["axes"])}}}, {{{", ".join(str(v) for v in fs["pos"])}}}}};

const sp_estop_config_t sp_estop_default = {{{es["category"]}u, {{{{{es["decel"]}}}, {{{es["jerk"]}}}}}, {es["settle"]}u}};

{_frames_c(p)}
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
    .leg_mass = {{{lm["cylinder_mass"]}, {lm["cylinder_com"]}, {lm["rod_mass"]}, {lm["rod_com"]},
                 {lm["cylinder_inertia"]}, {lm["rod_inertia"]}}},
    .viscous_friction = {{{", ".join(str(v) for v in q["viscous_friction"])}}},
    .coulomb_friction = {{{", ".join(str(v) for v in q["coulomb_friction"])}}},
    .coulomb_velocity = {q["coulomb_velocity"]},
    .breakaway_friction = {{{", ".join(str(v) for v in q["breakaway_friction"])}}},
    .stribeck_velocity = {q["stribeck_velocity"]},
    .bristle_stiffness = {{{", ".join(str(v) for v in q["bristle_stiffness"])}}},
    .bristle_damping = {{{", ".join(str(v) for v in q["bristle_damping"])}}},
}};

const sp_length_sensors_t sp_length_sensors_default = {{
    .zero = {{{", ".join(str(v) for v in q["length_zero"])}}},
    .scale = {{{", ".join(str(v) for v in q["length_scale"])}}},
    .scale_inv = {{{", ".join(str(v) for v in q["length_scale_inv"])}}},
}};

{_layout_c(lay)}"""


def run_generator(argv: list[str], c_source, prog: str, load=None) -> int:
    """CONFIG.json OUT.c -> OUT.c = c_source(load(config)) (default
    ``config.load``, which ignores an ``as_built`` section), rewritten only
    when it changes (so the build does not recompile). 2 usage, 1 bad config."""
    if len(argv) != 2:
        print(f"usage: {prog} CONFIG.json OUT.c", file=sys.stderr)
        return 2
    try:
        text = c_source((load or cfg.load)(argv[0]))
    except cfg.ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    out = Path(argv[1])
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists() or out.read_text() != text:
        out.write_text(text)
    return 0


def load_controller_config(path) -> cfg.Platform:
    """``config.load``, and refused (ConfigError naming the key) when the
    file is a calibrated config that ``stewart calibrate check --accept`` has
    not accepted, or whose calibrated keys changed after it did."""
    import json
    p = cfg.load(path)
    cfg.require_accepted_calibration(json.loads(Path(path).read_text()), str(path))
    return p


def main(argv: list[str]) -> int:
    return run_generator(argv, c_source, "gen_platform.py", load_controller_config)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
