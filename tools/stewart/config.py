# SPDX-License-Identifier: Apache-2.0
"""The platform config: one JSON file describes a 6-6 platform.

This module reads and validates it; everything else (the host tools, the
float64 model, the firmware's generated default, the plant) takes the
validated ``Platform``. It uses the standard library only, because the
firmware build runs it before any virtual environment exists.

Every problem is reported as a ``ConfigError`` whose message names the file
and the key (for example ``platform_default.json: inertia[1][2]: ...``);
nothing here raises anything else for a bad file.

Units are SI and angles radians. Keys (see config/README.md for the default):

- ``base_joints``: six [x, y, z], base frame, origin at the base centroid, m
- ``platform_joints``: six [x, y, z], motion frame, origin at o', m
- ``mass`` (kg), ``inertia`` (3x3 about the centre of mass, axes of the
  motion frame, kg m^2), ``center_of_mass`` ([x, y, z] in the motion frame,
  m; optional, default o' = [0, 0, 0])
- ``gravity`` (m/s^2, optional, default 9.80665)
- ``home``, ``park``: [x, y, z, roll, pitch, yaw]
- ``leg_length_min``, ``leg_length_max`` (m, joint to joint)
- ``force_max`` (N), ``leg_velocity_max`` (m/s)
- ``workspace``: {"min": [6], "max": [6]}, pose limits relative to home
- ``hydraulic``, ``sensors``: plant parameters (host_sim), see config/README.md;
  ``hydraulic`` may add the optional leg masses ``cylinder_mass``,
  ``cylinder_com``, ``rod_mass``, ``rod_com`` and the legs' moments of
  inertia ``cylinder_inertia``, ``rod_inertia`` (absent = 0 = neglected);
  the friction keys (``FRICTION_KEYS``) take one number for every cylinder
  or a list of six, one per leg, and are normalised to lists of six
- ``drives`` (optional; absent = every leg on the native protocol): the
  protocol, bus, CANopen node id and scaling of each leg's drive, the
  CANopen buses' bit rates, the SYNC divider, heartbeat and watchdog times
  (``_drives``; config/README.md and docs/reference/canopen.md). A layout whose
  CANopen bus load exceeds 50 % is refused, naming the ways out.
"""

from __future__ import annotations

import json
import math
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from .drives import layout as _layout
from .drives import objects as _objects

LEGS = 6


class ConfigError(ValueError):
    """A config file that cannot be used; the message names file and key."""


# Limits that the firmware's Q formats impose (see firmware/core/include/sp/model/platform.h).
_Q24_MAX = 127.0          # m, rad (Q24 in int32 holds +-128)
_MASS_MAX = 32767.0       # kg (Q16)
_INERTIA_MAX = 32767.0    # kg m^2 (Q16)
_FORCE_MAX = 8.0e6        # N (Q8)
_COM_MAX = 2.0            # m: a centre of mass farther from o' is a config error

HYDRAULIC_KEYS = {
    # key: (min exclusive or inclusive, max, description)
    "piston_diameter": (1e-3, 1.0, "m"),
    "rod_diameter": (0.0, 1.0, "m"),
    "dead_volume": (0.0, 1.0, "m^3"),
    "piston_mass": (0.0, 1e4, "kg"),
    "bulk_modulus": (1e7, 1e11, "Pa"),
    "supply_pressure": (1e5, 1e8, "Pa"),
    "tank_pressure": (0.0, 1e7, "Pa"),
    "valve_rated_flow": (1e-6, 1.0, "m^3/s"),
    "valve_rated_pressure_drop": (1e4, 1e8, "Pa"),
    "valve_natural_frequency": (1.0, 2000.0, "Hz"),
    "valve_damping": (0.05, 5.0, "-"),
    "leakage_coefficient": (0.0, 1e-8, "m^3/(s Pa)"),
    "end_cushion_length": (0.0, 0.5, "m"),
    "end_stop_stiffness": (1e3, 1e12, "N/m"),
    "end_stop_damping": (0.0, 1e10, "N s/m"),
}

# Optional leg masses (the plant simulates them, the firmware's inverse
# dynamics and the float64 model include them; absent = 0 = neglected, the
# paper's model). Each leg is two bodies on its axis: the cylinder body at
# cylinder_com from the base joint, the rod + piston at rod_com from the
# platform joint towards the base (docs/explanation/plant.md "Leg masses"),
# each with its moment of inertia about its own centre across the leg (any
# axis through the centre perpendicular to the leg: the bodies are taken
# symmetric about the leg axis, and the legs' spin about it is neglected;
# docs/explanation/model.md "Leg inertia"). 0: a point mass.
HYDRAULIC_OPTIONAL_KEYS = {
    "cylinder_mass": (0.0, 1e4, "kg"),
    "cylinder_com": (0.0, _Q24_MAX, "m"),
    "rod_mass": (0.0, 1e4, "kg"),
    "rod_com": (0.0, _Q24_MAX, "m"),
    "cylinder_inertia": (0.0, 1e4, "kg m^2"),
    "rod_inertia": (0.0, 1e4, "kg m^2"),
}
# The moments of inertia across the leg that the legs' masses allow: a body
# of mass m no longer than the longest leg has at most m (leg_length_max /
# 2)^2 about its centre across its axis (all of it at its two ends), plus
# the share of its radius (below a metre for any hexapod's cylinder: m / 4).
LEG_INERTIA_BODIES = {"cylinder_inertia": "cylinder_mass", "rod_inertia": "rod_mass"}

# Optional keys only the designer's tool (``stewart design``) reads: the
# cylinders' outer diameter, for the legs' clearance from one another.
HYDRAULIC_DESIGN_KEYS = {
    "cylinder_outer_diameter": (1e-3, 2.0, "m"),
}

# Optional ``joints`` section (``stewart design``): the largest angle each
# passive joint allows between the leg and the leg's direction at home.
JOINT_KEYS = {
    "base_cone_max": (1e-3, 1.5, "rad"),
    "platform_cone_max": (1e-3, 1.5, "rad"),
}

# Friction per cylinder: one number for all six or a list of six (leg 1
# first); ``Platform.hydraulic`` holds them as lists of six. The firmware
# compensates viscous + smoothed Coulomb friction; the plant adds the
# break-away (static) force with its Stribeck curve. breakaway_friction is
# optional (absent = the Coulomb level: no stiction) and must not be below
# coulomb_friction.
FRICTION_KEYS = {
    "viscous_friction": (0.0, 1e7, "N s/m"),
    "coulomb_friction": (0.0, 1e6, "N"),
}
FRICTION_OPTIONAL_KEYS = {
    "breakaway_friction": (0.0, 1e6, "N"),
}
# Optional scalars of the friction curves, with their defaults.
FRICTION_SHAPE_KEYS = {
    "coulomb_velocity": (1e-6, 1.0, "m/s", 1.0e-3),   # Coulomb smoothing: full level from |v| = this
    "stribeck_velocity": (1e-6, 1.0, "m/s", 5.0e-3),  # decay of the break-away excess
    "presliding_displacement": (1e-7, 1e-2, "m", 1.0e-4),  # seal's bristle deflection at the Coulomb level
}

# max over v of |v| exp(-(v/v_s)^2) / v_s = exp(-1/2) / sqrt(2), rounded up;
# the plant's dissipativity bound on sigma_1 (host_sim/src/plant/params.c checks it).
FADE_PEAK = 0.42889


def bristle_parameters(platform) -> tuple[list[float], list[float]]:
    """The LuGre bristle stiffness sigma_0 (N/m) and damping sigma_1 (N s/m)
    of every cylinder (leg 1 first): the one place they are computed. The
    plant (gen_plant.py -> hs_config) and the firmware's friction observer
    (gen_platform.py -> sp_platform_t) both take them from here.

    sigma_0 = F_c / presliding_displacement; sigma_1 = 2 sqrt(sigma_0 m_leg),
    critical damping against m_leg = mass / 6 + piston_mass, capped at
    4 F_c / (FADE_PEAK v_s) so that the friction stays dissipative. A leg
    without a Coulomb level (F_c = 0) has no bristles: (0, 0), memoryless.
    The operation order is the one the plant used, so the doubles are
    bit-identical to what host_sim derived before. Without a hydraulic
    section: six zeros each."""
    h = platform.hydraulic
    if not h:
        return [0.0] * LEGS, [0.0] * LEGS
    deflection = h.get("presliding_displacement", FRICTION_SHAPE_KEYS["presliding_displacement"][3])
    vs = h.get("stribeck_velocity", FRICTION_SHAPE_KEYS["stribeck_velocity"][3])
    m_leg = platform.mass / LEGS + h.get("piston_mass", 0.0)
    s0, s1 = [], []
    for fc in h["coulomb_friction"]:
        fc = float(fc)
        if fc > 0.0:
            s1max = 4.0 * fc / (FADE_PEAK * vs)
            k = fc / deflection
            d = 2.0 * math.sqrt(k * m_leg)
            if d > s1max:
                d = s1max
            s0.append(k)
            s1.append(d)
        else:
            s0.append(0.0)
            s1.append(0.0)
    return s0, s1

SENSOR_KEYS = {
    "length_resolution": (1e-9, 1e-2, "m"),
    "pressure_resolution": (1.0, 1e6, "Pa"),
    "pressure_noise": (0.0, 1e7, "Pa"),
}


#: The force/torque sensor section (``force_sensor``, optional): which wrench
#: force control uses and where the sensor sits (docs/explanation/force_control.md).
WRENCH_SOURCES = ("cylinders", "sensor")
FORCE_SENSOR_DEFAULT = {"wrench_source": "cylinders", "mount_pos": [0.0, 0.0, 0.0],
                        "mount_rpy": [0.0, 0.0, 0.0], "rate_hz": 7000.0}
_FORCE_SENSOR_KEYS = set(FORCE_SENSOR_DEFAULT)


def _force_sensor(d) -> dict:
    s = d.get("force_sensor", {})
    if not isinstance(s, dict):
        raise ConfigError("force_sensor: expected an object")
    for key in s:
        if key not in _FORCE_SENSOR_KEYS:
            raise ConfigError(f"force_sensor.{key}: unknown key (known: {', '.join(sorted(_FORCE_SENSOR_KEYS))})")
    src = s.get("wrench_source", FORCE_SENSOR_DEFAULT["wrench_source"])
    if src not in WRENCH_SOURCES:
        raise ConfigError(f"force_sensor.wrench_source: {json.dumps(src)[:40]} is not one of "
                          f"{', '.join(WRENCH_SOURCES)}")
    return {
        "wrench_source": src,
        "mount_pos": _vector("force_sensor.mount_pos", s.get("mount_pos", FORCE_SENSOR_DEFAULT["mount_pos"]), 3,
                             -10.0, 10.0),
        "mount_rpy": _vector("force_sensor.mount_rpy", s.get("mount_rpy", FORCE_SENSOR_DEFAULT["mount_rpy"]), 3,
                             -math.pi, math.pi),
        "rate_hz": _number("force_sensor.rate_hz", s.get("rate_hz", FORCE_SENSOR_DEFAULT["rate_hz"]), 100.0, 1e5),
    }


#: Largest distance of the tool point from o', m (SP_FRAME_TOOL_REACH_MAX).
TOOL_REACH_MAX = 5.0
#: Largest |component| of the work frame's origin, m (SP_FRAME_WORK_REACH_MAX).
WORK_REACH_MAX = 16.0
#: Largest |angle| of a frame, rad (SP_FRAME_ANGLE_MAX).
ANGLE_MAX = 52707178 / float(1 << 24)
#: Slots of each kind in the config and on the bus.
SLOTS = 4



def check_frame(values, key: str = "frame", kind: str = "tool") -> tuple[float, ...]:
    """Six finite numbers within the core's bounds, else ValueError naming key."""
    try:
        v = tuple(float(x) for x in values)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: six numbers x y z roll pitch yaw expected") from None
    if len(v) != 6:
        raise ValueError(f"{key}: six numbers x y z roll pitch yaw expected, got {len(v)}")
    if not all(math.isfinite(x) for x in v):
        raise ValueError(f"{key}: not a finite number")
    if kind == "tool" and math.sqrt(sum(x * x for x in v[:3])) > TOOL_REACH_MAX:
        raise ValueError(f"{key}: the tool point is more than {TOOL_REACH_MAX:g} m from o'")
    if kind == "work" and any(abs(x) > WORK_REACH_MAX for x in v[:3]):
        raise ValueError(f"{key}: the work origin is more than {WORK_REACH_MAX:g} m out on an axis")
    if any(abs(x) > ANGLE_MAX for x in v[3:]):
        raise ValueError(f"{key}: an angle beyond pi")
    return v


#: The named frames when the config has none: one identity tool and work frame.
FRAMES_DEFAULT = {"tool": [{"name": "flange", "pose": [0.0] * 6}],
                  "work": [{"name": "base", "pose": [0.0] * 6}],
                  "active_tool": "flange", "active_work": "base"}
_FRAMES_KEYS = set(FRAMES_DEFAULT)


def _frame_list(fr: dict, kind: str) -> list[dict]:
    items = fr.get(kind, FRAMES_DEFAULT[kind])
    if not isinstance(items, list) or not 1 <= len(items) <= SLOTS:
        raise ConfigError(f"frames.{kind}: expected a list of 1 to {SLOTS} frames")
    out, names = [], set()
    for i, item in enumerate(items):
        where = f"frames.{kind}[{i}]"
        if not isinstance(item, dict) or set(item) - {"name", "pose"} or "pose" not in item:
            raise ConfigError(f"{where}: expected an object with \"name\" and \"pose\" [x, y, z, roll, pitch, yaw]")
        name = item.get("name", f"{kind}{i}")
        if not isinstance(name, str) or not name or name in names:
            raise ConfigError(f"{where}.name: expected a unique non-empty string")
        names.add(name)
        try:
            pose = check_frame(item["pose"], f"{where}.pose", kind)
        except ValueError as e:
            raise ConfigError(str(e)) from None
        out.append({"name": name, "pose": list(pose)})
    return out


def _frames_config(d) -> dict:
    """The named tool and work frames (sp_frame_slots_t): up to 4 each,
    validated by stewart.frames.check_frame; the active ones by name."""
    fr = d.get("frames", FRAMES_DEFAULT)
    if not isinstance(fr, dict):
        raise ConfigError("frames: expected an object")
    for key in fr:
        if key not in _FRAMES_KEYS:
            raise ConfigError(f"frames.{key}: unknown key (known: {', '.join(sorted(_FRAMES_KEYS))})")
    out = {"tool": _frame_list(fr, "tool"), "work": _frame_list(fr, "work")}
    for kind in ("tool", "work"):
        key = f"active_{kind}"
        active = fr.get(key, out[kind][0]["name"])
        names = [f["name"] for f in out[kind]]
        if active not in names:
            raise ConfigError(f"frames.{key}: {json.dumps(active)[:40]} is not one of {', '.join(names)}")
        out[key] = names.index(active)
    return out


#: ESTOP's reaction (``estop``, optional; docs/reference/safety.md): the stop
#: category (1: decelerate along the path, then hold and block; 0: hold and
#: block at once), the controlled stop's limits (linear m/s^2, m/s^3;
#: angular rad/s^2, rad/s^3) and the time at rest before the blocking
#: valves close (s). The firmware's sp_stop_limits_check ranges.
ESTOP_DEFAULT = {"category": 1, "deceleration": 4.0, "angular_deceleration": 4.0, "jerk": 25.0,
                 "angular_jerk": 25.0, "settle": 0.03}
ESTOP_RANGES = {"deceleration": (0.1, 50.0), "angular_deceleration": (0.1, 50.0), "jerk": (1.0, 100.0),
                "angular_jerk": (1.0, 100.0), "settle": (0.0, 1.0)}


def _estop(d) -> dict:
    s = d.get("estop", {})
    if not isinstance(s, dict):
        raise ConfigError("estop: expected an object")
    for key in s:
        if key not in ESTOP_DEFAULT:
            raise ConfigError(f"estop.{key}: unknown key (known: {', '.join(sorted(ESTOP_DEFAULT))})")
    cat = s.get("category", ESTOP_DEFAULT["category"])
    if isinstance(cat, bool) or cat not in (0, 1):
        raise ConfigError(f"estop.category: {json.dumps(cat)[:40]} is not 0 (immediate) or 1 (controlled stop)")
    out = {"category": int(cat)}
    for key, (lo, hi) in ESTOP_RANGES.items():
        out[key] = _number(f"estop.{key}", s.get(key, ESTOP_DEFAULT[key]), lo, hi)
    return out


@dataclass
class Platform:
    name: str
    base_joints: list[list[float]]
    platform_joints: list[list[float]]
    mass: float
    inertia: list[list[float]]
    gravity: float
    home: list[float]
    park: list[float]
    leg_length_min: float
    leg_length_max: float
    force_max: float
    leg_velocity_max: float
    workspace_min: list[float]
    workspace_max: list[float]
    hydraulic: dict = field(default_factory=dict)
    sensors: dict[str, float] = field(default_factory=dict)
    source: str = "<dict>"
    center_of_mass: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    drives: _layout.Drives = field(default_factory=_layout.native_default)
    force_sensor: dict = field(default_factory=lambda: dict(FORCE_SENSOR_DEFAULT))
    joints: dict = field(default_factory=dict)
    length_sensors: dict = field(default_factory=lambda: {"zero": [0.0] * LEGS, "scale": [0.0] * LEGS})
    frames: dict = field(default_factory=lambda: _frames_config({}))
    estop: dict = field(default_factory=lambda: dict(ESTOP_DEFAULT))


def _number(where: str, v, lo: float | None = None, hi: float | None = None, positive=False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"{where}: expected a number, got {json.dumps(v)[:40]}")
    x = float(v)
    if not math.isfinite(x):
        raise ConfigError(f"{where}: expected a finite number, got {v}")
    if positive and x <= 0.0:
        raise ConfigError(f"{where}: must be positive, got {x:g}")
    if lo is not None and x < lo:
        raise ConfigError(f"{where}: {x:g} is below the allowed minimum {lo:g}")
    if hi is not None and x > hi:
        raise ConfigError(f"{where}: {x:g} is above the allowed maximum {hi:g}")
    return x


def _vector(where: str, v, n: int, lo=None, hi=None) -> list[float]:
    if not isinstance(v, list) or len(v) != n:
        raise ConfigError(f"{where}: expected a list of {n} numbers, got {json.dumps(v)[:60]}")
    return [_number(f"{where}[{i}]", x, lo, hi) for i, x in enumerate(v)]


def _per_leg(where: str, v, lo=None, hi=None) -> list[float]:
    """One number for every leg, or a list of LEGS numbers."""
    if isinstance(v, list):
        return _vector(where, v, LEGS, lo, hi)
    return [_number(where, v, lo, hi)] * LEGS


def _matrix(where: str, v, rows: int, cols: int, lo=None, hi=None) -> list[list[float]]:
    if not isinstance(v, list) or len(v) != rows:
        raise ConfigError(f"{where}: expected {rows} rows of {cols} numbers")
    return [_vector(f"{where}[{r}]", row, cols, lo, hi) for r, row in enumerate(v)]


def _require(d: dict, key: str, where: str = ""):
    if key not in d:
        raise ConfigError(f"{where}{key}: missing")
    return d[key]


def _rot(rpy):
    """Column-vector rotation motion -> base, Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(rpy[0]), math.sin(rpy[0])
    cp, sp = math.cos(rpy[1]), math.sin(rpy[1])
    cy, sy = math.cos(rpy[2]), math.sin(rpy[2])
    return [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]


def leg_lengths(p: Platform, pose) -> list[float]:
    """Joint-to-joint leg lengths at a pose (a minimal check used by the
    validator; the full model is stewart.model)."""
    r = _rot(pose[3:])
    out = []
    for a, b in zip(p.platform_joints, p.base_joints):
        v = [sum(r[i][k] * a[k] for k in range(3)) + pose[i] - b[i] for i in range(3)]
        out.append(math.sqrt(sum(c * c for c in v)))
    return out


def _symmetric_positive_definite(m) -> bool:
    if any(abs(m[i][j] - m[j][i]) > 1e-9 * max(1.0, abs(m[i][j])) for i in range(3) for j in range(3)):
        return False
    a, b, c = m[0][0], m[0][1], m[0][2]
    e, f, i = m[1][1], m[1][2], m[2][2]
    d1 = a
    d2 = a * e - b * b
    d3 = a * (e * i - f * f) - b * (b * i - f * c) + c * (b * f - e * c)
    return d1 > 0 and d2 > 0 and d3 > 0


def from_dict(d, source: str = "<dict>", check_bus_load: bool = True) -> Platform:
    """Validates a parsed config; raises ConfigError naming the key.
    ``check_bus_load=False`` accepts a drive layout whose CANopen bus load is
    above 50 % (``stewart busload`` uses it to show the table and the ways out)."""
    pre = f"{source}: "
    try:
        p = _from_dict(d)
        if check_bus_load:
            _check_bus_load(p.drives)
        return p
    except ConfigError as e:
        raise ConfigError(pre + str(e)) from None


def _integer(where: str, v, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise ConfigError(f"{where}: expected an integer, got {json.dumps(v)[:40]}")
    if not lo <= v <= hi:
        raise ConfigError(f"{where}: {v} is outside {lo}..{hi}")
    return v


_DRIVES_KEYS = {"legs", "buses", "sync_divider", "heartbeat_ms", "heartbeat_timeout_ms",
                "setpoint_timeout_ms", "pressure_feedback", "master_heartbeat_ms", "master_node_id"}
#: The master's heartbeat period's ceiling (ms): a drive's consumer time,
#: three periods, must fit 0x1016.1's 16 bits.
MASTER_HEARTBEAT_MAX_MS = 0xFFFF // 3
_LEG_KEYS = {"protocol", "bus", "node_id", "scaling", "control_mode", "force_feedforward", "on_block"}
#: A CANopen drive's state once the controller blocks its drives (a stop done, a FAULT holding).
ON_BLOCK = ("hold", "disabled")
_SCALING_KEYS = {"position_per_count", "length_at_zero", "direction", "rated_force"}
#: CiA 402's rated force along the leg (N at 1000 per mille of 0x60B2): the firmware's bounds.
RATED_FORCE_RANGE = (100.0, 10_000_000.0)


def _drives(d, lmin: float, lmax: float) -> _layout.Drives:
    """The ``drives`` section: per leg protocol, bus, node id, scaling; the
    CANopen buses' bit rates; SYNC divider, heartbeat and watchdog times."""
    if "drives" not in d:
        return _layout.native_default()
    s = d["drives"]
    if not isinstance(s, dict):
        raise ConfigError("drives: expected an object")
    for key in s:
        if key not in _DRIVES_KEYS:
            raise ConfigError(f"drives.{key}: unknown key (known: {', '.join(sorted(_DRIVES_KEYS))})")
    master_hb = _integer("drives.master_heartbeat_ms", s.get("master_heartbeat_ms", _objects.MASTER_HEARTBEAT_MS),
                         0, MASTER_HEARTBEAT_MAX_MS)
    master_node = _integer("drives.master_node_id", s.get("master_node_id", _objects.MASTER_NODE_ID), 1, 127)
    if "legs" not in s and set(s) <= {"master_heartbeat_ms", "master_node_id"}:
        # native drives with the master's keys only (the built-in CANopen layout uses them)
        return dataclasses.replace(_layout.native_default(), master_heartbeat_ms=master_hb,
                                   master_node_id=master_node)
    legs_in = _require(s, "legs", "drives.")
    if not isinstance(legs_in, list) or len(legs_in) != LEGS:
        raise ConfigError(f"drives.legs: expected a list of {LEGS} objects, leg 1 first")
    bitrates = _drive_bitrates(s)
    divider, hb, hb_timeout, wd = _drive_times(s)
    pressure = s.get("pressure_feedback", True)
    if not isinstance(pressure, bool):
        raise ConfigError("drives.pressure_feedback: expected true or false")
    legs = []
    used: dict[tuple[str, int], int] = {}
    for i, leg in enumerate(legs_in):
        legs.append(_drive(i, leg, bitrates, master_hb, master_node, used, lmin, lmax))
    _check_drive_buses(legs, bitrates)
    return _layout.Drives(tuple(legs), bitrates, divider, hb, hb_timeout, wd, pressure, master_hb, master_node)


def _drive_bitrates(s: dict) -> dict[str, int]:
    """``drives.buses``: the CANopen buses' classic bit rates by bus name."""
    buses_in = s.get("buses", {})
    if not isinstance(buses_in, dict):
        raise ConfigError("drives.buses: expected an object: bus name -> {\"bitrate\": bit/s}")
    bitrates = {}
    for name, b in buses_in.items():
        if not isinstance(b, dict) or set(b) - {"bitrate"}:
            raise ConfigError(f"drives.buses.{name}: expected {{\"bitrate\": bit/s}}")
        rate = _require(b, "bitrate", f"drives.buses.{name}.")
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or int(rate) != rate \
                or int(rate) not in _layout.CLASSIC_BITRATES:
            raise ConfigError(f"drives.buses.{name}.bitrate: {json.dumps(rate)[:20]} is not a classic CAN "
                              f"bit rate ({', '.join(str(r) for r in _layout.CLASSIC_BITRATES)})")
        bitrates[name] = int(rate)
    return bitrates


def _drive_times(s: dict) -> tuple[int, int, int, int]:
    """(SYNC divider, heartbeat ms, heartbeat timeout ms, setpoint timeout ms)."""
    divider = _integer("drives.sync_divider", s.get("sync_divider", 1), 1, 10)
    hb = _integer("drives.heartbeat_ms", s.get("heartbeat_ms", 20), 1, 65535)
    hb_timeout = _integer("drives.heartbeat_timeout_ms", s.get("heartbeat_timeout_ms", 50), 1, 65535)
    if hb_timeout <= hb:
        raise ConfigError(f"drives.heartbeat_timeout_ms: {hb_timeout} must exceed heartbeat_ms {hb} "
                          "(a drive would be declared silent between two heartbeats)")
    wd = _integer("drives.setpoint_timeout_ms", s.get("setpoint_timeout_ms", 3 * divider), 1, 65535)
    if wd < 2 * divider:
        raise ConfigError(f"drives.setpoint_timeout_ms: {wd} ms is below two SYNC periods "
                          f"({2 * divider} ms): one late frame would stop the drive")
    return divider, hb, hb_timeout, wd


def _drive(i: int, leg, bitrates: dict[str, int], master_hb: int, master_node: int,
           used: dict[tuple[str, int], int], lmin: float, lmax: float) -> _layout.Drive:
    """``drives.legs[i]``; ``used``: the (bus, node id) pairs taken so far
    (this leg's is added)."""
    w = f"drives.legs[{i}]"
    if not isinstance(leg, dict):
        raise ConfigError(f"{w}: expected an object")
    for key in leg:
        if key not in _LEG_KEYS:
            raise ConfigError(f"{w}.{key}: unknown key (known: {', '.join(sorted(_LEG_KEYS))})")
    proto = leg.get("protocol", "native")
    if proto not in _objects.PROTOCOLS:
        raise ConfigError(f"{w}.protocol: {json.dumps(proto)[:30]} is not one of "
                          f"{', '.join(_objects.PROTOCOLS)}")
    bus = leg.get("bus", _layout.NATIVE_BUS[i])
    if not isinstance(bus, str) or not bus:
        raise ConfigError(f"{w}.bus: expected a bus name")
    if proto == "native":
        if bus != _layout.NATIVE_BUS[i]:
            raise ConfigError(f"{w}.bus: a native drive of leg {i + 1} is on {_layout.NATIVE_BUS[i]} "
                              f"(fixed by protocol/stewart.dbc), not {bus}")
        for key in ("node_id", "scaling", "control_mode", "force_feedforward", "on_block"):
            if key in leg:
                raise ConfigError(f"{w}.{key}: only for CANopen drives (protocol cia408 or cia402)")
        return _layout.Drive(i + 1, proto, bus)
    if bus not in bitrates:
        raise ConfigError(f"{w}.bus: {bus} has no bit rate in drives.buses")
    node = _integer(f"{w}.node_id", _require(leg, "node_id", f"{w}."), 1, 127)
    if master_hb and node == master_node:
        raise ConfigError(f"{w}.node_id: {node} is the master's own heartbeat id (drives.master_node_id)")
    if (bus, node) in used:
        raise ConfigError(f"{w}.node_id: node {node} on bus {bus} is already leg {used[(bus, node)]}'s")
    used[(bus, node)] = i + 1
    sc = _require(leg, "scaling", f"{w}.")
    res, zero, direction = _drive_position_scaling(w, sc, lmin, lmax)
    mode = _integer(f"{w}.control_mode", leg.get("control_mode", _objects.CIA408_CONTROL_MODE_AXIS_POSITION),
                    -128, 127)
    if proto != "cia408" and "control_mode" in leg:
        raise ConfigError(f"{w}.control_mode: only for cia408 drives (CiA 402 uses mode 8, CSP)")
    ff = leg.get("force_feedforward", False)
    if not isinstance(ff, bool):
        raise ConfigError(f"{w}.force_feedforward: expected true or false")
    rated = None
    if "rated_force" in sc:
        if proto != "cia402":
            raise ConfigError(f"{w}.scaling.rated_force: only for cia402 drives (the force of 1000 per mille "
                              "of the torque/force offset 0x60B2)")
        rated = _number(f"{w}.scaling.rated_force", sc["rated_force"], *RATED_FORCE_RANGE)
    if ff and proto == "cia402" and rated is None:
        raise ConfigError(f"{w}.force_feedforward: a cia402 drive takes the force as its torque/force offset "
                          "0x60B2, in per mille of its rated force: give scaling.rated_force (N along the leg)")
    on_block = leg.get("on_block", "hold")
    if on_block not in ON_BLOCK:
        raise ConfigError(f"{w}.on_block: {json.dumps(on_block)[:30]} is not one of {', '.join(ON_BLOCK)} (the "
                          "drive's state once a stop is done: hold by its own loop, or disabled, its valve's "
                          "fail-safe spool position)")
    return _layout.Drive(i + 1, proto, bus, node, _layout.Scaling(res, zero, direction, rated), mode, ff, on_block)


def _drive_position_scaling(w: str, sc, lmin: float, lmax: float) -> tuple[float, float, int]:
    """(position_per_count, length_at_zero, direction) of a CANopen leg's
    ``scaling`` (at ``w``); the stroke must fit the drive's 32-bit position."""
    if not isinstance(sc, dict):
        raise ConfigError(f"{w}.scaling: expected an object with position_per_count and length_at_zero")
    for key in sc:
        if key not in _SCALING_KEYS:
            raise ConfigError(f"{w}.scaling.{key}: unknown key (known: {', '.join(sorted(_SCALING_KEYS))})")
    res = _number(f"{w}.scaling.position_per_count", _require(sc, "position_per_count", f"{w}.scaling."),
                  1e-9, 1e-2)
    zero = _number(f"{w}.scaling.length_at_zero", _require(sc, "length_at_zero", f"{w}.scaling."),
                   0.0, _Q24_MAX)
    direction = sc.get("direction", 1)
    if direction not in (1, -1) or isinstance(direction, bool):
        raise ConfigError(f"{w}.scaling.direction: expected 1 or -1")
    for end in (lmin, lmax):
        counts = abs(end - zero) / res
        if counts > 2**31 - 1:
            raise ConfigError(f"{w}.scaling: leg length {end:g} m is {counts:.3g} counts from "
                              "length_at_zero, beyond the drive's 32-bit position")
    return res, zero, direction


def _check_drive_buses(legs: list[_layout.Drive], bitrates: dict[str, int]) -> None:
    """A native drive is not on a CANopen bus; every bus given a bit rate
    carries a CANopen drive."""
    canopen_buses = {dr.bus for dr in legs if dr.is_canopen}
    for dr in legs:
        if dr.protocol == "native" and dr.bus in canopen_buses:
            raise ConfigError(f"drives.legs[{dr.leg - 1}].bus: {dr.bus} carries CANopen drives; the native "
                              "protocol needs its own bus")
    for name in bitrates:
        if name not in canopen_buses:
            raise ConfigError(f"drives.buses.{name}: no CANopen drive is on this bus")


def _check_bus_load(drives: _layout.Drives) -> None:
    bad = _layout.overloaded(drives)
    if bad:
        bus, pct = bad[0]
        ways = "; ".join(_layout.ways_out(drives, bus))
        raise ConfigError(f"drives.legs: bus {bus}: worst-case load {pct:.1f} % is above "
                          f"{_layout.LOAD_LIMIT:g} %. Ways out: {ways} (stewart busload shows the table)")


def _from_dict(d) -> Platform:
    if not isinstance(d, dict):
        raise ConfigError("the top level must be a JSON object")
    name = d.get("name", "unnamed")
    if not isinstance(name, str):
        raise ConfigError("name: expected a string")
    base = _matrix("base_joints", _require(d, "base_joints"), LEGS, 3, -_Q24_MAX, _Q24_MAX)
    plat = _matrix("platform_joints", _require(d, "platform_joints"), LEGS, 3, -_Q24_MAX, _Q24_MAX)
    mass = _number("mass", _require(d, "mass"), hi=_MASS_MAX, positive=True)
    inertia = _inertia(d)
    gravity = _number("gravity", d.get("gravity", 9.80665), 0.0, 100.0)
    com = _vector("center_of_mass", d.get("center_of_mass", [0.0, 0.0, 0.0]), 3, -_COM_MAX, _COM_MAX)
    home = _vector("home", _require(d, "home"), 6, -_Q24_MAX, _Q24_MAX)
    park = _vector("park", d.get("park", home), 6, -_Q24_MAX, _Q24_MAX)
    for k in range(3, 6):
        if abs(home[k]) > 1.2:
            raise ConfigError(f"home[{k}]: angle {home[k]:g} rad is beyond 1.2 rad")
    lmin = _number("leg_length_min", _require(d, "leg_length_min"), hi=_Q24_MAX, positive=True)
    lmax = _number("leg_length_max", _require(d, "leg_length_max"), hi=_Q24_MAX, positive=True)
    if lmax <= lmin:
        raise ConfigError(f"leg_length_max: {lmax:g} must exceed leg_length_min {lmin:g}")
    fmax = _number("force_max", _require(d, "force_max"), hi=_FORCE_MAX, positive=True)
    vmax = _number("leg_velocity_max", d.get("leg_velocity_max", 1.0), hi=100.0, positive=True)
    wmin, wmax = _workspace(d)
    hyd = _hydraulic(d["hydraulic"], lmax) if "hydraulic" in d else {}
    sens = _sensors(d["sensors"]) if "sensors" in d else {}
    drives = _drives(d, lmin, lmax)
    p = Platform(name, base, plat, mass, inertia, gravity, home, park, lmin, lmax, fmax, vmax,
                 wmin, wmax, hyd, sens, center_of_mass=com, drives=drives, force_sensor=_force_sensor(d),
                 joints=_joints(d.get("joints", {})), length_sensors=_length_sensors(d.get("length_sensors", {})),
                 frames=_frames_config(d), estop=_estop(d))
    for label, pose in (("home", home), ("park", park)):
        for i, length in enumerate(leg_lengths(p, pose)):
            if not lmin <= length <= lmax:
                raise ConfigError(
                    f"{label}: leg {i + 1} is {length:.4f} m long there, outside the stroke "
                    f"[leg_length_min {lmin:g}, leg_length_max {lmax:g}]")
    return p


def _inertia(d) -> list[list[float]]:
    """The platform's inertia matrix: symmetric, positive definite, a rigid body's."""
    inertia = _matrix("inertia", _require(d, "inertia"), 3, 3, -_INERTIA_MAX, _INERTIA_MAX)
    if not _symmetric_positive_definite(inertia):
        raise ConfigError("inertia: must be symmetric and positive definite")
    ev = [inertia[0][0], inertia[1][1], inertia[2][2]]
    if ev[0] + ev[1] < ev[2] or ev[1] + ev[2] < ev[0] or ev[0] + ev[2] < ev[1]:
        raise ConfigError("inertia: diagonal violates the triangle inequality (not a rigid body)")
    return inertia


def _workspace(d) -> tuple[list[float], list[float]]:
    """(min, max) of the ``workspace`` relative to home."""
    ws = d.get("workspace", {"min": [-0.1] * 3 + [-0.1] * 3, "max": [0.1] * 3 + [0.1] * 3})
    if not isinstance(ws, dict):
        raise ConfigError("workspace: expected an object with min and max")
    wmin = _vector("workspace.min", _require(ws, "min", "workspace."), 6, -_Q24_MAX, _Q24_MAX)
    wmax = _vector("workspace.max", _require(ws, "max", "workspace."), 6, -_Q24_MAX, _Q24_MAX)
    for k in range(6):
        if not wmin[k] <= 0.0 <= wmax[k]:
            raise ConfigError(f"workspace: min[{k}] <= 0 <= max[{k}] is required (limits are relative to home)")
        if k >= 3 and max(-wmin[k], wmax[k]) > 1.2:
            raise ConfigError(f"workspace: angle limit {k} beyond 1.2 rad (Euler angles near gimbal lock)")
    return wmin, wmax


def _hydraulic(h, lmax: float) -> dict:
    """The ``hydraulic`` section: cylinders, supply, friction per leg."""
    hyd: dict = {}
    if not isinstance(h, dict):
        raise ConfigError("hydraulic: expected an object")
    for key, (lo, hi, _unit) in HYDRAULIC_KEYS.items():
        hyd[key] = _number(f"hydraulic.{key}", _require(h, key, "hydraulic."), lo, hi)
    if hyd["rod_diameter"] >= hyd["piston_diameter"]:
        raise ConfigError("hydraulic.rod_diameter: must be smaller than piston_diameter")
    if hyd["tank_pressure"] >= hyd["supply_pressure"]:
        raise ConfigError("hydraulic.tank_pressure: must be below supply_pressure")
    for key, (lo, hi, _unit) in HYDRAULIC_OPTIONAL_KEYS.items():
        hyd[key] = _number(f"hydraulic.{key}", h.get(key, 0.0), lo, hi)
    for key, (lo, hi, _unit) in FRICTION_KEYS.items():
        hyd[key] = _per_leg(f"hydraulic.{key}", _require(h, key, "hydraulic."), lo, hi)
    for key, (lo, hi, _unit) in FRICTION_OPTIONAL_KEYS.items():
        hyd[key] = _per_leg(f"hydraulic.{key}", h.get(key, hyd["coulomb_friction"]), lo, hi)
    for i, (fs, fc) in enumerate(zip(hyd["breakaway_friction"], hyd["coulomb_friction"])):
        if fs < fc:
            raise ConfigError(f"hydraulic.breakaway_friction: leg {i + 1}: {fs:g} N is below "
                              f"its coulomb_friction {fc:g} N")
    for key, (lo, hi, _unit, default) in FRICTION_SHAPE_KEYS.items():
        hyd[key] = _number(f"hydraulic.{key}", h.get(key, default), lo, hi)
    for key, (lo, hi, _unit) in HYDRAULIC_DESIGN_KEYS.items():
        if key in h:
            hyd[key] = _number(f"hydraulic.{key}", h[key], lo, hi)
    if hyd.get("cylinder_outer_diameter", math.inf) <= hyd["piston_diameter"]:
        raise ConfigError("hydraulic.cylinder_outer_diameter: must exceed piston_diameter")
    for key in ("cylinder_com", "rod_com"):
        if hyd[key] > lmax:
            raise ConfigError(f"hydraulic.{key}: {hyd[key]:g} m is beyond leg_length_max {lmax:g}")
    _leg_inertia(hyd, lmax)
    return hyd


def _leg_inertia(hyd: dict, lmax: float) -> None:
    """The legs' moments of inertia across the leg against their masses
    (``LEG_INERTIA_BODIES``): none without a mass, none beyond what a body of
    that mass and length can have."""
    for key, mass_key in LEG_INERTIA_BODIES.items():
        inertia, mass = hyd[key], hyd[mass_key]
        if inertia > 0.0 and mass == 0.0:
            raise ConfigError(f"hydraulic.{key}: {inertia:g} kg m^2 but {mass_key} is 0 (a body without "
                              f"mass has no moment of inertia)")
        most = mass * (0.25 * lmax * lmax + 0.25)
        if inertia > most:
            raise ConfigError(f"hydraulic.{key}: {inertia:g} kg m^2 is more than a {mass:g} kg body "
                              f"no longer than leg_length_max {lmax:g} m can have ({most:.4g} kg m^2: "
                              f"all of it at both ends)")


def _joints(j) -> dict:
    """The optional ``joints`` section: the joints' cone angles (design only)."""
    if not isinstance(j, dict):
        raise ConfigError("joints: expected an object")
    for key in j:
        if key not in JOINT_KEYS:
            raise ConfigError(f"joints.{key}: unknown key (known: {', '.join(sorted(JOINT_KEYS))})")
    return {key: _number(f"joints.{key}", v, lo, hi) for key, v in j.items() for lo, hi, _u in [JOINT_KEYS[key]]}


#: The optional ``length_sensors`` section (``stewart calibrate solve`` writes
#: it): leg i's sensor reads leg_length_min + (1 + scale[i]) (l - leg_length_min)
#: + zero[i] at the joint-to-joint length l; the firmware maps every reading
#: and setpoint through it (sp_length_from_sensor / sp_length_to_sensor).
LENGTH_SENSOR_LIMITS = {"zero": 0.05, "scale": 0.01}


def _length_sensors(s) -> dict:
    if not isinstance(s, dict):
        raise ConfigError("length_sensors: expected an object with zero and scale")
    for key in s:
        if key not in LENGTH_SENSOR_LIMITS:
            raise ConfigError(f"length_sensors.{key}: unknown key (known: zero, scale)")
    return {key: _vector(f"length_sensors.{key}", s.get(key, [0.0] * LEGS), LEGS, -lim, lim)
            for key, lim in LENGTH_SENSOR_LIMITS.items()}


#: The ``calibration`` record ``stewart calibrate`` writes: ``status`` is
#: ``CALIBRATION_SOLVED`` after ``solve`` and ``CALIBRATION_ACCEPTED`` after
#: ``check --accept``, which also stores ``digest`` (:func:`calibration_digest`).
#: The firmware's generator builds only from a config without the record or
#: with an accepted one whose calibrated keys are unchanged
#: (:func:`require_accepted_calibration`); the tools read either.
CALIBRATION_SOLVED = "solved, not checked"
CALIBRATION_ACCEPTED = "accepted"
CALIBRATED_KEYS = ("base_joints", "platform_joints", "length_sensors")


def calibration_digest(d: dict) -> str:
    """SHA-256 (hex) of the calibrated keys of a raw config dict, as JSON
    with sorted keys: what ``check --accept`` accepted."""
    import hashlib
    text = json.dumps({k: d.get(k) for k in CALIBRATED_KEYS}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def require_accepted_calibration(d, source: str = "<dict>") -> None:
    """Raises ConfigError (naming the key) unless the raw config ``d`` has
    no ``calibration`` record, or one that ``stewart calibrate check
    --accept`` accepted and whose base_joints, platform_joints and
    length_sensors are still the ones it checked."""
    if not isinstance(d, dict) or "calibration" not in d:
        return
    c = d["calibration"]
    how = "run `stewart calibrate check --measurements CHECK.csv --calibrated FILE --accept OUT.json` " \
          "and build from OUT.json"
    if not isinstance(c, dict):
        raise ConfigError(f"{source}: calibration: expected an object (the record stewart calibrate writes)")
    status = c.get("status")
    if status != CALIBRATION_ACCEPTED:
        raise ConfigError(f"{source}: calibration.status: {json.dumps(status)[:60]}: a calibrated config that "
                          f"has not passed `stewart calibrate check --accept`; the firmware is not built from it: "
                          + how)
    if c.get("digest") != calibration_digest(d):
        raise ConfigError(f"{source}: calibration.digest: base_joints, platform_joints or length_sensors "
                          "differ from what `stewart calibrate check --accept` accepted; " + how)


def _sensors(s) -> dict:
    """The ``sensors`` section: the simulated sensors' resolution and noise, and the seed."""
    if not isinstance(s, dict):
        raise ConfigError("sensors: expected an object")
    sens = {}
    for key, (lo, hi, _unit) in SENSOR_KEYS.items():
        sens[key] = _number(f"sensors.{key}", _require(s, key, "sensors."), lo, hi)
    seed = s.get("seed", 1)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError("sensors.seed: expected a non-negative integer")
    sens["seed"] = seed
    return sens


def load(path, check_bus_load: bool = True) -> Platform:
    """Reads and validates a config file; raises ConfigError naming the key."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise ConfigError(f"{path}: cannot read: {e.strerror}") from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as e:
        raise ConfigError(f"{path}: not valid JSON: {e.msg} at line {e.lineno} column {e.colno}") from None
    p = from_dict(d, str(path), check_bus_load)
    p.source = str(path)
    return p


def without_leg_masses(p: Platform) -> Platform:
    """A copy of ``p`` with massless legs (the paper's model)."""
    hyd = dict(p.hydraulic)
    for key in HYDRAULIC_OPTIONAL_KEYS:
        hyd[key] = 0.0
    return dataclasses.replace(p, hydraulic=hyd)
