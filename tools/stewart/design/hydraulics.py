# SPDX-License-Identifier: Apache-2.0
"""Cylinders, valves, supply and the oil columns' stiffness.

Chamber A is the piston side (area A_A = pi d^2 / 4), B the annulus
(A_B = A_A - pi d_rod^2 / 4). A cylinder pushes at most A_A p_S - A_B p_T
and pulls at most A_B p_S - A_A p_T. The plant's volumes (docs/explanation/plant.md):
V_A = V_0 + A_A s, V_B = V_0 + A_B (S - s), s = L - L_min, S = L_max - L_min,
so the oil column's stiffness is k = beta (A_A^2 / V_A + A_B^2 / V_B).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .. import model
from . import limits


def areas(platform) -> tuple[float, float]:
    h = platform.hydraulic
    a_a = math.pi * h["piston_diameter"] ** 2 / 4.0
    return a_a, a_a - math.pi * h["rod_diameter"] ** 2 / 4.0


def capacities(platform, fraction: float = 1.0) -> tuple[float, float]:
    """(push, pull) the cylinder can exert (N, both positive) with the load
    pressure at ``fraction`` of the supply."""
    h = platform.hydraulic
    a_a, a_b = areas(platform)
    ps, pt = fraction * h["supply_pressure"], h["tank_pressure"]
    return a_a * ps - a_b * pt, a_b * ps - a_a * pt


def sizing(platform, push: float, pull: float, fraction: float) -> dict:
    """The bore the push needs and the largest rod the pull allows with
    that bore, at ``fraction`` of the supply pressure (m)."""
    h = platform.hydraulic
    ps, pt = fraction * h["supply_pressure"], h["tank_pressure"]
    a_a, a_b = areas(platform)
    need_a = (max(push, 0.0) + a_b * pt) / ps
    bore = math.sqrt(4.0 * need_a / math.pi)
    a_bore = max(need_a, a_a)
    need_b = (max(pull, 0.0) + a_bore * pt) / ps
    rod2 = 4.0 * (a_bore - need_b) / math.pi
    return {"bore_min": bore, "rod_max": math.sqrt(rod2) if rod2 > 0 else math.nan,
            "bore": h["piston_diameter"], "rod": h["rod_diameter"]}


def supply_flow(platform, jac: np.ndarray, duty) -> np.ndarray:
    """Largest total flow (m^3/s) into the cylinders at each pose over the
    duty's velocities. Each cylinder takes max(A_A r, -A_B r) at rate r,
    so the total is the largest over the 64 choices of side of a linear
    function of the velocity, each maximised exactly (``forces.linear_max``)."""
    from .forces import linear_max

    a_a, a_b = areas(platform)
    sides = np.array(list(itertools.product([a_a, -a_b], repeat=6)))
    coef = np.einsum("sl,nlj->snj", sides, jac)
    return linear_max(coef, duty.velocity, duty.combined, "linear_velocity", "angular_velocity").max(axis=0)


def valve(platform, flow_peak: np.ndarray, push: np.ndarray) -> dict:
    """Per leg: the rated flow a valve needs (at the config's rated drop per
    land) to pass the peak flow while the cylinder carries its peak push,
    and the pressure left (Pa) with the config's valve."""
    h = platform.hydraulic
    a_a, _ = areas(platform)
    ps, pt, dpn = h["supply_pressure"], h["tank_pressure"], h["valve_rated_pressure_drop"]
    load = np.maximum(push, 0.0) / a_a
    land = (ps - pt - load) / 2.0
    need = np.where(land > 0, flow_peak * np.sqrt(dpn / np.where(land > 0, land, 1.0)), np.inf)
    used = 2.0 * dpn * (flow_peak / h["valve_rated_flow"]) ** 2
    return {"rated_flow_needed": need, "pressure_margin": ps - pt - load - used}


def column_stiffness(platform, lengths: np.ndarray) -> np.ndarray:
    """Oil-column stiffness of each cylinder (N/m) at the leg lengths."""
    h = platform.hydraulic
    a_a, a_b = areas(platform)
    s = lengths - platform.leg_length_min
    stroke = platform.leg_length_max - platform.leg_length_min
    v0 = h["dead_volume"]
    v_a = np.maximum(v0 + a_a * s, 0.5 * v0)
    v_b = np.maximum(v0 + a_b * (stroke - s), 0.5 * v0)
    return h["bulk_modulus"] * (a_a ** 2 / v_a + a_b ** 2 / v_b)


def _skew(v: np.ndarray) -> np.ndarray:
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1), np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def mass_matrix(platform, lg: limits.Legs) -> np.ndarray:
    """(..., 6, 6) mass matrix for the twist [v of o'; w] (base frame): the
    rigid body with its centre of mass off o', and each leg's barrel and
    rod as masses on its axis (``model.leg_masses``) with their moments of
    inertia across the leg (``model.leg_inertias``)."""
    m = float(platform.mass)
    rc = np.einsum("...jk,k->...j", lg.rot, np.asarray(platform.center_of_mass, dtype=float))
    ig = lg.rot @ np.asarray(platform.inertia, dtype=float) @ np.swapaxes(lg.rot, -1, -2)
    s = _skew(rc)
    eye = np.broadcast_to(np.eye(3), ig.shape)
    top = np.concatenate([m * eye, -m * s], axis=-1)
    bottom = np.concatenate([m * s, ig - m * s @ s], axis=-1)
    mm = np.concatenate([top, bottom], axis=-2)
    m_c, d_c, m_r, d_r = model.leg_masses(platform)
    i_legs = sum(model.leg_inertias(platform))
    if m_c == 0.0 and m_r == 0.0 and i_legs == 0.0:
        return mm
    uu = np.einsum("...i,...j->...ij", lg.units, lg.units)
    trans = (m_c * d_c ** 2 + i_legs + m_r * (lg.lengths - d_r) ** 2) / lg.lengths ** 2
    m_leg = m_r * uu + trans[..., None, None] * (np.eye(3) - uu)
    g = np.concatenate([np.broadcast_to(np.eye(3), lg.arms.shape[:-1] + (3, 3)), -_skew(lg.arms)], axis=-1)
    return mm + np.einsum("...iaj,...iab,...ibk->...jk", g, m_leg, g)


def modes(platform, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (..., 6) (Hz, ascending) and mode shapes
    (..., 6, 6) (columns, twists [dx; dtheta], mass-normalised) of the
    platform on its oil columns: K = A diag(k) A^T through the force
    transformation A, and the mass matrix, K phi = w^2 M phi."""
    lg = limits.legs(platform, poses)
    a = limits.force_matrix(lg)
    k = column_stiffness(platform, lg.lengths)
    kk = np.einsum("...ij,...j,...kj->...ik", a, k, a)
    chol = np.linalg.cholesky(mass_matrix(platform, lg))
    li = np.linalg.inv(chol)
    w2, vec = np.linalg.eigh(li @ kk @ np.swapaxes(li, -1, -2))
    return np.sqrt(np.maximum(w2, 0.0)) / (2.0 * math.pi), np.swapaxes(li, -1, -2) @ vec


def natural_frequencies(platform, poses: np.ndarray) -> np.ndarray:
    """(..., 6) natural frequencies (Hz, ascending): ``modes``' frequencies."""
    return modes(platform, poses)[0]
