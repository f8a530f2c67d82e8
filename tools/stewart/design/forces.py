# SPDX-License-Identifier: Apache-2.0
"""Cylinder forces over a duty: the paper's equations (``stewart.model``:
inverse dynamics with the legs' masses, friction) applied over a whole
motion envelope, the cylinders they need, and the platform's wrench
capacity.

At a fixed pose the inverse dynamics is exactly

    F(v, a) = F_s + M a + G(v),

F_s the static forces (gravity, the external wrench), M a linear in the
accelerations (pose and Euler-angle accelerations, as ``stewart calc``
takes them) and G homogeneous quadratic in the velocities. The largest
push over the envelope's accelerations is then F_s + max(M a) (exact, at a
corner of the acceleration box or on its ball when ``combined`` limits
bound the resultant); G is bounded by the absolute values of its quadratic
form's coefficients (polarisation), and friction at each leg's fastest rate
adds on top.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import model
from . import limits


def with_payload(platform, duty, mass: float):
    """The platform carrying a payload of ``mass`` (the duty's centre of
    mass and inertia): combined mass, centre of mass and inertia about it.
    The duty's inertia is the heaviest payload's; a lighter one's scales
    with its mass (same shape)."""
    m0, mp = float(platform.mass), float(mass)
    c0 = np.asarray(platform.center_of_mass, dtype=float)
    cp = np.asarray(duty.payload_com, dtype=float)
    m = m0 + mp
    c = (m0 * c0 + mp * cp) / m

    def shift(d):
        return float(d @ d) * np.eye(3) - np.outer(d, d)

    scale = mp / duty.mass_max if duty.mass_max > 0 else 0.0
    inertia = (np.asarray(platform.inertia, dtype=float) + m0 * shift(c0 - c)
               + scale * np.asarray(duty.payload_inertia, dtype=float) + mp * shift(cp - c))
    return dataclasses.replace(platform, mass=m, center_of_mass=c.tolist(), inertia=inertia.tolist())


def _id(p, poses, vel6, acc6, external) -> np.ndarray:
    vel6 = np.broadcast_to(np.asarray(vel6, float), poses.shape)
    acc6 = np.broadcast_to(np.asarray(acc6, float), poses.shape)
    return model.inverse_dynamics_many(p, poses, vel6[..., :3], vel6[..., 3:], acc6[..., :3], acc6[..., 3:],
                                       external)


def _external(platform, poses, duty) -> np.ndarray:
    """The cylinder forces that hold the duty's external wrench at o'."""
    if not np.any(duty.force) and not np.any(duty.moment):
        return np.zeros(poses.shape[:-1] + (6,))
    a = limits.force_matrix(limits.legs(platform, poses))
    rhs = -np.concatenate([np.asarray(duty.force, dtype=float), np.asarray(duty.moment, dtype=float)])
    return np.linalg.solve(a, np.broadcast_to(rhs, poses.shape)[..., None])[..., 0]


def ball_box_max(coef: np.ndarray, lim: np.ndarray, radius: float | None) -> np.ndarray:
    """max of coef . a over |a_j| <= lim_j and |a| <= radius (coef (..., 3)):
    the KKT point a_j = min(lam |c_j|, lim_j), lam set by bisection."""
    c = np.abs(coef)
    corner = (c * lim).sum(axis=-1)
    if radius is None or np.linalg.norm(lim) <= radius:
        return corner
    # from lam = hi on every component with c_j > 0 is at its limit
    lo = np.zeros(c.shape[:-1])
    hi = np.where(c > 0, lim / np.where(c > 0, c, 1.0), 0.0).max(axis=-1)
    for _ in range(54):
        mid = 0.5 * (lo + hi)
        big = np.linalg.norm(np.minimum(mid[..., None] * c, lim), axis=-1) > radius
        hi = np.where(big, mid, hi)
        lo = np.where(big, lo, mid)
    return (c * np.minimum(lo[..., None] * c, lim)).sum(axis=-1)


def linear_max(coef: np.ndarray, lim, combined: dict, lin_key: str, ang_key: str) -> np.ndarray:
    """max of coef . x over the duty's box ``lim`` (6) and its combined limits."""
    lim = np.asarray(lim, dtype=float)
    return (ball_box_max(coef[..., :3], lim[:3], combined.get(lin_key))
            + ball_box_max(coef[..., 3:], lim[3:], combined.get(ang_key)))


def _probes(duty) -> tuple[np.ndarray, np.ndarray, list, list]:
    """The velocity and acceleration probes of one batched inverse dynamics:
    rest, each unit acceleration, each velocity axis at its limit, each
    pair of velocity axes at their limits."""
    v = np.asarray(duty.velocity, dtype=float)
    axes = [j for j in range(6) if v[j] > 0]
    pairs = [(a, b) for a in axes for b in axes if b > a]
    vel = np.zeros((7 + len(axes) + len(pairs), 6))
    acc = np.zeros(vel.shape)
    acc[1:7] = np.eye(6)
    for k, j in enumerate(axes):
        vel[7 + k, j] = v[j]
    for k, (a, b) in enumerate(pairs):
        vel[7 + len(axes) + k, [a, b]] = v[a], v[b]
    return vel, acc, axes, pairs


def _dynamics_terms(p, poses, duty) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At each pose: the forces at rest without external load (n, 6), the
    acceleration matrix M (n, 6 legs, 6 axes) and the bound on |G(v)| over
    the velocity box by polarisation (n, 6)."""
    vel, acc, axes, pairs = _probes(duty)
    pp = np.broadcast_to(poses, (vel.shape[0],) + poses.shape)
    shape = (vel.shape[0],) + poses.shape
    f = _id(p, pp, np.broadcast_to(vel[:, None, :], shape), np.broadcast_to(acc[:, None, :], shape),
            (0.0, 0.0, 0.0))
    g0 = f[0]
    macc = np.moveaxis(f[1:7] - g0, 0, -1)
    diag = f[7:7 + len(axes)] - g0
    bound = np.abs(diag).sum(axis=0)
    for k, (a, b) in enumerate(pairs):
        bound += np.abs(f[7 + len(axes) + k] - g0 - diag[axes.index(a)] - diag[axes.index(b)])
    return g0, macc, bound


def rate_jacobian(platform, poses) -> np.ndarray:
    """(n, 6 legs, 6 axes): leg rates per unit velocity of each pose axis
    (Euler-angle rates for the angles)."""
    e = np.broadcast_to(np.eye(6)[:, None, :], (6,) + poses.shape)
    z = np.zeros((6,) + poses.shape[:-1] + (3,))
    pp = np.broadcast_to(poses, (6,) + poses.shape)
    return np.moveaxis(model.joint_motion(platform, pp, e[..., :3], e[..., 3:], z, z).rates, 0, -1)


def friction_bound(platform, rate_max: np.ndarray) -> np.ndarray:
    """Largest friction force (N) of each leg at rates up to ``rate_max``."""
    return np.abs(model.friction_force(platform, rate_max))


def envelope_forces(platform, duty, poses: np.ndarray, chunk: int = 2048) -> dict:
    """Worst push and pull of each cylinder at each pose over the envelope's
    velocities and accelerations, both payload masses: (n, 6) arrays, N;
    ``push``/``pull`` include friction, the ``static`` forces do not.
    Computed ``chunk`` poses at a time to bound the memory."""
    parts = [_envelope_chunk(platform, duty, poses[s:s + chunk]) for s in range(0, poses.shape[0], chunk)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _envelope_chunk(platform, duty, poses: np.ndarray) -> dict:
    jac = rate_jacobian(platform, poses)
    rate_max = linear_max(jac, duty.velocity, duty.combined, "linear_velocity", "angular_velocity")
    fric = friction_bound(platform, rate_max)
    push = np.full(poses.shape[:-1] + (6,), -np.inf)
    pull = np.full(poses.shape[:-1] + (6,), np.inf)
    static_max = None
    for mass in sorted({duty.mass_min, duty.mass_max}):
        p = with_payload(platform, duty, mass)
        g0, macc, quad = _dynamics_terms(p, poses, duty)
        static = g0 + _external(p, poses, duty)
        acc = linear_max(macc, duty.acceleration, duty.combined, "linear_acceleration", "angular_acceleration")
        push = np.maximum(push, static + acc + quad + fric)
        pull = np.minimum(pull, static - acc - quad - fric)
        static_max = static
    return {"push": push, "pull": pull, "static": static_max, "rate_max": rate_max, "jacobian": jac}


def trajectory_forces(platform, duty, traj) -> dict:
    """Along a trajectory, for each payload mass: the cylinder forces F
    (``model.inverse_dynamics``, what ``stewart calc`` computes) and the
    chamber forces F + friction; (n, 6) each, the largest magnitude kept."""
    out = {}
    for mass in sorted({duty.mass_min, duty.mass_max}):
        p = with_payload(platform, duty, mass)
        f = _id(p, traj.pose, traj.vel, traj.acc, (0.0, 0.0, 0.0)) + _external(p, traj.pose, duty)
        rates = model.joint_motion(p, traj.pose, traj.vel[:, :3], traj.vel[:, 3:], traj.acc[:, :3],
                                   traj.acc[:, 3:]).rates
        out[mass] = {"force": f, "chamber": f + model.friction_force(p, rates), "rates": rates}
    return out
