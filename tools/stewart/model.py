"""Independent float64 model of the paper's kinematics and dynamics (numpy).

Written from the paper (Hitaka et al., eqs (1)-(15)) with the conventions of
docs/model.md (Frames and pose), not from the C code: it is the reference that the
fixed-point firmware core is checked against, and what the plots overlay.

Conventions: a pose is [x, y, z, roll phi, pitch theta, yaw psi] (m, rad).
The paper's T (eq 2) has the platform axes as rows; the column-vector
rotation from the motion frame to the base frame is R = T^T = Rz Ry Rx.
F_i > 0 pushes the platform away from the base along the leg.
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


def inverse_dynamics(platform, pose, vel, rpy_rate, acc, rpy_acc, external=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Eqs (7) and (15): the six cylinder forces (N) that produce the motion,
    with gravity (0, 0, -m g) and an external force L at o'.

    Translation: sum F_i u_i + L - m g e_z = m a.
    Rotation about o' (body frame, full inertia): sum (A_i T) x F_i u_i
    = R (I w_dot + w x I w)."""
    pose = np.asarray(pose, dtype=float)
    m = float(platform.mass)
    inertia = np.asarray(platform.inertia, dtype=float)
    g = float(platform.gravity)
    w, w_dot = body_rates(pose[3:], rpy_rate, rpy_acc)
    torque_body = inertia @ w_dot + np.cross(w, inertia @ w)
    rhs = np.concatenate([
        m * np.asarray(acc, float) - np.asarray(external, float) + np.array([0.0, 0.0, m * g]),
        rotation(pose[3:]) @ torque_body,
    ])
    return np.linalg.solve(force_matrix(platform, pose), rhs)


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
