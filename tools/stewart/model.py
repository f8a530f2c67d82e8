# SPDX-License-Identifier: Apache-2.0
"""Independent float64 model of the paper's kinematics and dynamics (numpy).

Written from the paper (Hitaka et al., eqs (1)-(15)) with the conventions of
docs/explanation/model.md (Frames and pose), not from the C code: it is the reference that the
fixed-point firmware core is checked against, and what the plots overlay.

Conventions: a pose is [x, y, z, roll phi, pitch theta, yaw psi] (m, rad).
The paper's T (eq 2) has the platform axes as rows; the column-vector
rotation from the motion frame to the base frame is R = T^T = Rz Ry Rx.
F_i > 0 pushes the platform away from the base along the leg.

Beyond the paper (derivation in docs/explanation/identification.md, "The complete
model"): the centre of mass off o', the legs' barrels and rods as bodies on
the leg axes with their masses and their moments of inertia across the leg
(Newton-Euler with the joint reactions; docs/explanation/model.md "Leg
inertia"), and the
cylinders' viscous + smoothed Coulomb friction (``friction_force``). With
the default config (no leg masses, centre of mass at o') the forces are the
paper's. The ``*_many`` functions and ``joint_motion`` take any leading
shape of poses, for whole logs at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def orientation(rpy) -> np.ndarray:
    """The paper's T (eq 2): T = Rx'(phi) Ry'(theta) Rz'(psi), each factor the
    transpose of the column rotation. Rows are the platform axes in base
    coordinates; a motion-frame row vector a maps to a @ T + R."""
    phi, theta, psi = rpy
    return _rx(phi).T @ _ry(theta).T @ _rz(psi).T


def rotation(rpy) -> np.ndarray:
    """Column-vector rotation motion -> base (R = T^T)."""
    return orientation(rpy).T


@dataclass
class LegState:
    legs: np.ndarray     # 6x3 leg vectors l_i = A_i T + R - B_i (base frame), m
    lengths: np.ndarray  # 6, m
    units: np.ndarray    # 6x3 unit leg vectors
    arms: np.ndarray     # 6x3 platform joints in base orientation (A_i T), m


def inverse_kinematics(platform, pose) -> LegState:
    """Eq (1): leg vectors and lengths at a pose."""
    pose = np.asarray(pose, dtype=float)
    a = np.asarray(platform.platform_joints, dtype=float)
    b = np.asarray(platform.base_joints, dtype=float)
    t = orientation(pose[3:])
    arms = a @ t
    legs = arms + pose[:3] - b
    lengths = np.linalg.norm(legs, axis=1)
    return LegState(legs, lengths, legs / lengths[:, None], arms)


def body_rates(rpy, rpy_rate, rpy_acc=(0.0, 0.0, 0.0)):
    """Eq (10): body-frame angular velocity from Euler rates, and its exact
    time derivative (product-of-rates terms included). Returns (w, w_dot)."""
    phi, theta, _ = rpy
    dphi, dtheta, dpsi = rpy_rate
    ddphi, ddtheta, ddpsi = rpy_acc
    sf, cf = np.sin(phi), np.cos(phi)
    st, ct = np.sin(theta), np.cos(theta)
    w = np.array([
        dphi - dpsi * st,
        dtheta * cf + dpsi * sf * ct,
        -dtheta * sf + dpsi * cf * ct,
    ])
    w_dot = np.array([
        ddphi - ddpsi * st - dpsi * dtheta * ct,
        ddtheta * cf - dtheta * dphi * sf + ddpsi * sf * ct + dpsi * (dphi * cf * ct - dtheta * sf * st),
        -ddtheta * sf - dtheta * dphi * cf + ddpsi * cf * ct - dpsi * (dphi * sf * ct + dtheta * cf * st),
    ])
    return w, w_dot


def leg_velocities(platform, pose, vel, rpy_rate) -> np.ndarray:
    """Rate of change of each leg length, m/s: u_i . (v + omega x (R a_i))."""
    ls = inverse_kinematics(platform, pose)
    w_body, _ = body_rates(np.asarray(pose, float)[3:], rpy_rate)
    w_base = rotation(np.asarray(pose, float)[3:]) @ w_body
    joint_vel = np.asarray(vel, float) + np.cross(w_base, ls.arms)
    return np.einsum("ij,ij->i", ls.units, joint_vel)


def force_matrix(platform, pose) -> np.ndarray:
    """The 6x6 matrix of eqs (3)-(5): column i is [u_i ; (A_i T) x u_i] (base
    frame), so that A F is the wrench of the cylinder forces about o'."""
    ls = inverse_kinematics(platform, pose)
    return np.vstack([ls.units.T, np.cross(ls.arms, ls.units).T])


def rotation_many(rpy) -> np.ndarray:
    """``rotation`` for any number of poses: rpy (..., 3) -> (..., 3, 3),
    Rz(psi) Ry(theta) Rx(phi) written out element by element."""
    rpy = np.asarray(rpy, dtype=float)
    cf, sf = np.cos(rpy[..., 0]), np.sin(rpy[..., 0])
    ct, st = np.cos(rpy[..., 1]), np.sin(rpy[..., 1])
    cp, sp = np.cos(rpy[..., 2]), np.sin(rpy[..., 2])
    out = np.empty(rpy.shape[:-1] + (3, 3))
    out[..., 0, 0] = cp * ct
    out[..., 0, 1] = cp * st * sf - sp * cf
    out[..., 0, 2] = cp * st * cf + sp * sf
    out[..., 1, 0] = sp * ct
    out[..., 1, 1] = sp * st * sf + cp * cf
    out[..., 1, 2] = sp * st * cf - cp * sf
    out[..., 2, 0] = -st
    out[..., 2, 1] = ct * sf
    out[..., 2, 2] = ct * cf
    return out


def leg_lengths_many(platform, poses) -> np.ndarray:
    """Eq (1) for any number of poses: (..., 6) poses -> (..., 6) lengths, m."""
    poses = np.asarray(poses, dtype=float)
    a = np.asarray(platform.platform_joints, dtype=float)
    b = np.asarray(platform.base_joints, dtype=float)
    arms = np.einsum("...jk,ik->...ij", rotation_many(poses[..., 3:]), a)
    return np.linalg.norm(arms + poses[..., None, :3] - b, axis=-1)


def leg_masses(platform) -> tuple[float, float, float, float]:
    """(m_c, d_c, m_r, d_r): barrel mass and its centre's distance from the
    base joint, rod + piston mass and its centre's distance from the
    platform joint (kg, m); all 0 when the config has none."""
    hyd = getattr(platform, "hydraulic", None) or {}
    return (float(hyd.get("cylinder_mass", 0.0)), float(hyd.get("cylinder_com", 0.0)),
            float(hyd.get("rod_mass", 0.0)), float(hyd.get("rod_com", 0.0)))


def leg_inertias(platform) -> tuple[float, float]:
    """(I_c, I_r): the barrel's and the rod's moments of inertia about their
    own centres across the leg (kg m^2); 0 when the config has none."""
    hyd = getattr(platform, "hydraulic", None) or {}
    return float(hyd.get("cylinder_inertia", 0.0)), float(hyd.get("rod_inertia", 0.0))


@dataclass
class JointMotion:
    """Position, velocity and acceleration of everything a pose trajectory
    moves, base frame, for any leading shape (...) of poses. Legs are the
    second-to-last axis of the (..., 6, 3) arrays."""
    rot: np.ndarray       # (..., 3, 3) motion -> base
    w_body: np.ndarray    # (..., 3) angular velocity, motion frame
    wd_body: np.ndarray   # (..., 3) its derivative
    w: np.ndarray         # (..., 3) angular velocity, base frame (R w_body)
    wd: np.ndarray        # (..., 3) angular acceleration, base frame (R wd_body)
    acc: np.ndarray       # (..., 3) acceleration of o'
    arms: np.ndarray      # (..., 6, 3) R a_i
    units: np.ndarray     # (..., 6, 3) u_i
    lengths: np.ndarray   # (..., 6) L_i
    rates: np.ndarray     # (..., 6) L_i'
    joint_acc: np.ndarray  # (..., 6, 3) acceleration of the platform joint A_i
    unit_rate: np.ndarray  # (..., 6, 3) u_i'
    unit_acc: np.ndarray   # (..., 6, 3) u_i''


def joint_motion(platform, pose, vel, rpy_rate, acc, rpy_acc) -> JointMotion:
    """Kinematics of the platform joints and of the leg axes (docs/explanation/identification.md,
    "The legs"). Arguments are (..., 6) poses and (..., 3) rates and
    accelerations of the position and of the Euler angles."""
    pose = np.asarray(pose, dtype=float)
    vel = np.asarray(vel, dtype=float)
    acc = np.asarray(acc, dtype=float)
    rpy_rate = np.asarray(rpy_rate, dtype=float)
    rpy_acc = np.asarray(rpy_acc, dtype=float)
    rot = rotation_many(pose[..., 3:])
    w_b, wd_b = body_rates(np.moveaxis(pose[..., 3:], -1, 0), np.moveaxis(rpy_rate, -1, 0),
                           np.moveaxis(rpy_acc, -1, 0))
    w_b = np.moveaxis(np.asarray(w_b, float), 0, -1)
    wd_b = np.moveaxis(np.asarray(wd_b, float), 0, -1)
    w = np.einsum("...jk,...k->...j", rot, w_b)
    wd = np.einsum("...jk,...k->...j", rot, wd_b)
    a = np.asarray(platform.platform_joints, dtype=float)
    b = np.asarray(platform.base_joints, dtype=float)
    arms = np.einsum("...jk,ik->...ij", rot, a)
    legs = arms + pose[..., None, :3] - b
    lengths = np.linalg.norm(legs, axis=-1)
    units = legs / lengths[..., None]
    wl = np.broadcast_to(w[..., None, :], arms.shape)
    wdl = np.broadcast_to(wd[..., None, :], arms.shape)
    v_joint = vel[..., None, :] + np.cross(wl, arms)
    a_joint = acc[..., None, :] + np.cross(wdl, arms) + np.cross(wl, np.cross(wl, arms))
    rates = np.einsum("...k,...k->...", units, v_joint)
    unit_rate = (v_joint - rates[..., None] * units) / lengths[..., None]
    # L'' = u' . v_A + u . a_A ;  l'' = a_A = L'' u + 2 L' u' + L u''
    racc = np.einsum("...k,...k->...", unit_rate, v_joint) + np.einsum("...k,...k->...", units, a_joint)
    unit_acc = (a_joint - racc[..., None] * units - 2.0 * rates[..., None] * unit_rate) / lengths[..., None]
    return JointMotion(rot, w_b, wd_b, w, wd, acc, arms, units, lengths, rates, a_joint, unit_rate, unit_acc)


def leg_joint_forces(platform, jm: JointMotion) -> np.ndarray:
    """The force each massive leg exerts on the platform at its joint A_i,
    less the cylinder force F_i u_i: (..., 6, 3), base frame, N. Zero for
    massless legs. From Newton-Euler of the barrel and the rod
    (docs/explanation/identification.md, "The legs"):

        h_i = m_r u u.(g - c2'') + (1/L) P [m_c d_c (g - c1'') + m_r (L - d_r)(g - c2'')]

    with g = (0, 0, -g), P = 1 - u u^T, c1'' = d_c u'', c2'' = a_A - d_r u'',
    plus the legs' moments of inertia across the leg (``leg_inertia_forces``)."""
    m_c, d_c, m_r, d_r = leg_masses(platform)
    i_c, i_r = leg_inertias(platform)
    if m_c == 0.0 and m_r == 0.0 and i_c == 0.0 and i_r == 0.0:
        return np.zeros(jm.arms.shape)
    g = np.array([0.0, 0.0, -float(platform.gravity)])
    u = jm.units
    c1dd = d_c * jm.unit_acc
    c2dd = jm.joint_acc - d_r * jm.unit_acc
    axial = m_r * np.einsum("...k,...k->...", u, g - c2dd)[..., None] * u
    q = m_c * d_c * (g - c1dd) + m_r * (jm.lengths[..., None] - d_r) * (g - c2dd)
    transverse = (q - np.einsum("...k,...k->...", u, q)[..., None] * u) / jm.lengths[..., None]
    if i_c != 0.0 or i_r != 0.0:
        transverse = transverse + (i_c + i_r) * leg_inertia_forces(jm)
    return axial + transverse


def leg_inertia_forces(jm: JointMotion) -> np.ndarray:
    """The force (..., 6, 3) each leg exerts on the platform at A_i per kg m^2
    of moment of inertia across the leg (the barrel's and the rod's add).
    The barrel and the rod turn with the leg, at the angular velocity
    w_L = u x u' (no spin about the axis), so w_L' = u x u''. Symmetric about
    the axis, each has the angular momentum I w_L about its centre, whose
    rate I u x u'' the moment of the joint reactions must supply. About the
    base joint B_i (where the joint gives no moment across the leg) the
    platform's force -f on the leg at L u gives it: L u x (-f) = I u x u'',
    and f across the leg (a force along it has no moment about B_i and is
    the rod's balance) is

        f = -(1/L) P u''    per unit I,  P = 1 - u u^T."""
    u = jm.units
    udd = jm.unit_acc
    return -(udd - np.einsum("...k,...k->...", u, udd)[..., None] * u) / jm.lengths[..., None]


def rigid_body_wrench(platform, jm: JointMotion, external=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The wrench [force; moment about o'] (base frame, (..., 6)) that the legs
    must apply to the platform for the motion: with the centre of mass c
    (motion frame) and the inertia I_G about it,

        f = m (a_G + g e_z) - L,    a_G = a + w' x Rc + w x (w x Rc)
        n = R (I_G w_b' + w_b x I_G w_b) + Rc x m (a_G + g e_z)

    (L: an external force at o')."""
    m = float(platform.mass)
    inertia = np.asarray(platform.inertia, dtype=float)
    com = np.asarray(getattr(platform, "center_of_mass", None) or [0.0, 0.0, 0.0], dtype=float)
    g = float(platform.gravity)
    rc = np.einsum("...jk,k->...j", jm.rot, com)
    a_g = jm.acc + np.cross(jm.wd, rc) + np.cross(jm.w, np.cross(jm.w, rc))
    lin = m * (a_g + np.array([0.0, 0.0, g]))
    force = lin - np.asarray(external, dtype=float)
    iw = np.einsum("jk,...k->...j", inertia, jm.w_body)
    torque_body = np.einsum("jk,...k->...j", inertia, jm.wd_body) + np.cross(jm.w_body, iw)
    moment = np.einsum("...jk,...k->...j", jm.rot, torque_body) + np.cross(rc, lin)
    return np.concatenate([force, moment], axis=-1)


def force_matrix_of(jm: JointMotion) -> np.ndarray:
    """(..., 6, 6): column i is [u_i ; (R a_i) x u_i]."""
    return np.concatenate([np.swapaxes(jm.units, -1, -2),
                           np.swapaxes(np.cross(jm.arms, jm.units), -1, -2)], axis=-2)


def inverse_dynamics_many(platform, pose, vel, rpy_rate, acc, rpy_acc, external=(0.0, 0.0, 0.0)) -> np.ndarray:
    """``inverse_dynamics`` for any leading shape: (..., 6) forces, N."""
    jm = joint_motion(platform, pose, vel, rpy_rate, acc, rpy_acc)
    h = leg_joint_forces(platform, jm)
    rhs = rigid_body_wrench(platform, jm, external) - np.concatenate(
        [h.sum(axis=-2), np.cross(jm.arms, h).sum(axis=-2)], axis=-1)
    return np.linalg.solve(force_matrix_of(jm), rhs[..., None])[..., 0]


def inverse_dynamics(platform, pose, vel, rpy_rate, acc, rpy_acc, external=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Eqs (7) and (15), completed: the six cylinder forces F_i (N), each the
    axial force between barrel and rod (what the chamber pressures measure
    once friction is taken off, see ``friction_force``) that produces the
    motion, with gravity (0, 0, -m g), an external force L at o', the centre
    of mass ``center_of_mass`` (motion frame), ``inertia`` about it, and the
    legs' barrels and rods when the config gives them masses.

    The platform, with f_i the force leg i exerts on it at A_i:
        sum f_i + L - m g e_z = m a_G
        sum (R a_i) x f_i = R (I_G w_b' + w_b x I_G w_b) + Rc x m (a_G + g e_z)
    and f_i = F_i u_i + h_i (``leg_joint_forces``; h_i = 0 for massless
    legs, which gives the paper's equations when c = 0)."""
    return inverse_dynamics_many(platform, pose, vel, rpy_rate, acc, rpy_acc, external)


def coulomb_shape(x) -> np.ndarray:
    """The smoothed sign of the Coulomb term, s(x) = x for |x| <= 1, sign(x)
    beyond: a linear ramp that saturates (what the firmware implements)."""
    return np.clip(np.asarray(x, dtype=float), -1.0, 1.0)


def friction_force(platform, leg_rates) -> np.ndarray:
    """Friction of each cylinder (N, (..., 6)) at the leg rates (m/s):
    F_fric = c_v v + F_c s(v / v_c), viscous_friction c_v and
    coulomb_friction F_c per leg, v_c = coulomb_velocity, s = ``coulomb_shape``.
    The chamber pressures push with F_i + F_fric (F_i from ``inverse_dynamics``).
    Zero without a hydraulic section."""
    v = np.asarray(leg_rates, dtype=float)
    hyd = getattr(platform, "hydraulic", None) or {}
    if "viscous_friction" not in hyd:
        return np.zeros(v.shape)
    cv = np.asarray(hyd["viscous_friction"], dtype=float)
    fc = np.asarray(hyd["coulomb_friction"], dtype=float)
    vc = float(hyd.get("coulomb_velocity", 1.0e-3))
    return cv * v + fc * coulomb_shape(v / vc)


def forward_kinematics(platform, lengths, guess, tol=1e-12, max_iterations=50):
    """Pose from six leg lengths: Newton-Raphson on the pose parameters with
    a central-difference Jacobian (deliberately not the core's analytic
    one). Returns (pose, iterations); raises RuntimeError if it does not
    converge."""
    lengths = np.asarray(lengths, dtype=float)
    x = np.asarray(guess, dtype=float).copy()
    h = 1e-7
    for it in range(1, max_iterations + 1):
        r = inverse_kinematics(platform, x).lengths - lengths
        jac = np.empty((6, 6))
        for k in range(6):
            d = np.zeros(6)
            d[k] = h
            jac[:, k] = (inverse_kinematics(platform, x + d).lengths
                         - inverse_kinematics(platform, x - d).lengths) / (2 * h)
        step = np.linalg.solve(jac, r)
        x -= step
        if np.max(np.abs(step)) < tol:
            return x, it
    raise RuntimeError("forward kinematics did not converge")
