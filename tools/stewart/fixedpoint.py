# SPDX-License-Identifier: Apache-2.0
"""A validated platform config in the firmware core's fixed-point formats.

The firmware's default platform is generated from these numbers
(tools/dev/gen_platform.py) and the host tools hand the same numbers to the
core library (stewart.core), so the struct the tools pass is bit-identical
to the one compiled into the firmware.
"""

from __future__ import annotations

import math

from . import config as cfg

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
            "cylinder_inertia": _q(h.get("cylinder_inertia", 0.0), Q16, "hydraulic.cylinder_inertia"),
            "rod_inertia": _q(h.get("rod_inertia", 0.0), Q16, "hydraulic.rod_inertia"),
        },
        "viscous_friction": [_q(v, Q8, "hydraulic.viscous_friction") for v in _legs(h, "viscous_friction")],
        "coulomb_friction": [_q(v, Q8, "hydraulic.coulomb_friction") for v in _legs(h, "coulomb_friction")],
        "coulomb_velocity": _q(h.get("coulomb_velocity", 1.0e-3), Q24, "hydraulic.coulomb_velocity"),
        "breakaway_friction": [_q(v, Q8, "hydraulic.breakaway_friction") for v in _legs(h, "breakaway_friction")],
        "stribeck_velocity": _q(h.get("stribeck_velocity", cfg.FRICTION_SHAPE_KEYS["stribeck_velocity"][3]),
                                Q24, "hydraulic.stribeck_velocity"),
        "bristle_stiffness": [_q(v, 1, "hydraulic.presliding_displacement (bristle stiffness)") for v in sigma0],
        "bristle_damping": [_q(v, Q8, "hydraulic.presliding_displacement (bristle damping)") for v in sigma1],
        "length_zero": [_q(v, Q24, "length_sensors.zero") for v in p.length_sensors["zero"]],
        "length_scale": [_q(v, Q30, "length_sensors.scale") for v in p.length_sensors["scale"]],
        "length_scale_inv": [_q(1.0 / (1.0 + v) - 1.0, Q30, "length_sensors.scale") for v in p.length_sensors["scale"]],
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
