# SPDX-License-Identifier: Apache-2.0
"""The complete float64 model (centre-of-mass offset, leg masses, friction)
checked against first principles that do not share its formulae:

* power balance: sum F_i L_i' = d/dt (kinetic + potential energy), with the
  energies computed from positions only (numerical velocities), the legs'
  moments of inertia across the leg included (their kinetic energy
  I |u x u'|^2 / 2 from the numerical rate of the leg's direction);
* Lagrange's equations evaluated numerically from the same energies;
* a rod mass at the platform joint is exactly a heavier rigid platform;
* with the default config (no leg masses, centre of mass at o') the forces
  are the paper's equations (7) and (15) as the model had them before.
"""

import copy
from pathlib import Path

import numpy as np
import pytest

from stewart import model
from stewart import config as cfg

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def platform():
    """The default platform with massless legs: the paper's model (the
    tests that want leg masses add their own)."""
    return cfg.without_leg_masses(cfg.load(REPO_ROOT / "config" / "platform_default.json"))


#: Moments of inertia across the leg (kg m^2) of a 60 kg, 1.5 m barrel and a
#: 35 kg, 1.6 m rod (thin rods: m l^2 / 12).
LEG_INERTIA = (11.25, 7.5)


def heavy(platform, com=(0.12, -0.08, 0.2), legs=(60.0, 0.8, 35.0, 1.0), inertia=(0.0, 0.0)):
    """The default platform with a centre-of-mass offset, leg masses and
    the legs' moments of inertia across the leg (barrel, rod)."""
    p = copy.deepcopy(platform)
    p.center_of_mass = list(com)
    p.hydraulic = dict(p.hydraulic)
    p.hydraulic.update(cylinder_mass=legs[0], cylinder_com=legs[1], rod_mass=legs[2], rod_com=legs[3],
                       cylinder_inertia=inertia[0], rod_inertia=inertia[1])
    return p


# -- energies from positions alone -----------------------------------------------

def points(p, q):
    """Everything with mass at pose q: (centre of mass, R, barrel centres,
    rod centres, leg directions)."""
    rot = model.rotation(q[3:])
    a = np.asarray(p.platform_joints, float)
    b = np.asarray(p.base_joints, float)
    m_c, d_c, m_r, d_r = model.leg_masses(p)
    joints = (rot @ a.T).T + q[:3]
    u = (joints - b) / np.linalg.norm(joints - b, axis=1)[:, None]
    return q[:3] + rot @ np.asarray(p.center_of_mass, float), rot, b + d_c * u, joints - d_r * u, u


def energies(p, q, qd, h=1e-5):
    """(kinetic, potential) at pose q moving with pose rate qd; velocities by
    central differences along qd (T is not taken from the model)."""
    m_c, _, m_r, _ = model.leg_masses(p)
    i_legs = p.hydraulic.get("cylinder_inertia", 0.0) + p.hydraulic.get("rod_inertia", 0.0)
    g = p.gravity
    plus, minus = points(p, q + h * qd), points(p, q - h * qd)
    here = points(p, q)
    v_g, r_dot, v_c, v_r, u_dot = [(x - y) / (2 * h) for x, y in zip(plus, minus)]
    sk = here[1].T @ r_dot
    w_b = np.array([sk[2, 1], sk[0, 2], sk[1, 0]])
    w_leg = np.cross(here[4], u_dot)  # each leg's angular velocity across its axis
    kin = (0.5 * p.mass * v_g @ v_g + 0.5 * w_b @ np.asarray(p.inertia) @ w_b
           + 0.5 * m_c * np.sum(v_c * v_c) + 0.5 * m_r * np.sum(v_r * v_r) + 0.5 * i_legs * np.sum(w_leg * w_leg))
    pot = g * (p.mass * here[0][2] + m_c * here[2][:, 2].sum() + m_r * here[3][:, 2].sum())
    return kin, pot


class Trajectory:
    """q(t) = home + sum of three sines per axis, with exact q' and q''."""

    def __init__(self, home, rng, scale=(0.08, 0.08, 0.06, 0.1, 0.1, 0.1)):
        self.home = np.asarray(home, float)
        self.amp = rng.uniform(0.3, 1.0, (3, 6)) * np.asarray(scale)
        self.om = rng.uniform(2.0, 12.0, (3, 6))
        self.ph = rng.uniform(0, 2 * np.pi, (3, 6))

    def __call__(self, t):
        arg = self.om * t + self.ph
        q = self.home + (self.amp * np.sin(arg)).sum(axis=0)
        qd = (self.amp * self.om * np.cos(arg)).sum(axis=0)
        qdd = -(self.amp * self.om ** 2 * np.sin(arg)).sum(axis=0)
        return q, qd, qdd


def energy_rate(p, traj, t, ht):
    """d(T + V)/dt at t by the five-point central difference."""
    e = [sum(energies(p, *traj(t + k * ht)[:2])) for k in (-2, -1, 1, 2)]
    return (e[0] - 8 * e[1] + 8 * e[2] - e[3]) / (12 * ht)


def forces(p, q, qd, qdd):
    return model.inverse_dynamics(p, q, qd[:3], qd[3:], qdd[:3], qdd[3:])


# -- tests ---------------------------------------------------------------------------

def test_default_config_gives_the_papers_equations(platform):
    """No leg masses, centre of mass at o': eqs (7) and (15) as written in
    docs/explanation/model.md, solved here directly, within 1e-9 relative."""
    rng = np.random.default_rng(10)
    home = np.array(platform.home)
    inertia = np.asarray(platform.inertia)
    worst = 0.0
    for _ in range(300):
        q = home + rng.uniform(-0.2, 0.2, 6)
        v, a, ext = rng.uniform(-1, 1, 6), rng.uniform(-6, 6, 6), rng.uniform(-2e3, 2e3, 3)
        w, wd = model.body_rates(q[3:], v[3:], a[3:])
        rhs = np.concatenate([platform.mass * (a[:3] + [0, 0, platform.gravity]) - ext,
                              model.rotation(q[3:]) @ (inertia @ wd + np.cross(w, inertia @ w))])
        ref = np.linalg.solve(model.force_matrix(platform, q), rhs)
        got = model.inverse_dynamics(platform, q, v[:3], v[3:], a[:3], a[3:], ext)
        worst = max(worst, np.max(np.abs(got - ref)) / np.max(np.abs(ref)))
    assert worst < 1e-9


@pytest.mark.parametrize("inertia", [(0.0, 0.0), LEG_INERTIA])
def test_power_balance_with_leg_masses_and_com_offset(platform, inertia):
    """sum F_i L_i' = d(T + V)/dt along random smooth motions; T and V from
    positions only; point-mass legs, and legs with their moments of inertia.
    Measured: the worst mismatch is ~2e-8 of sum |F_i L_i'|."""
    p = heavy(platform, inertia=inertia)
    rng = np.random.default_rng(11)
    ht = 1e-4
    worst = 0.0
    for _ in range(20):
        traj = Trajectory(p.home, rng)
        for t in rng.uniform(0, 5, 5):
            q, qd, qdd = traj(t)
            f = forces(p, q, qd, qdd)
            rates = model.leg_velocities(p, q, qd[:3], qd[3:])
            power = f @ rates
            de = energy_rate(p, traj, t, ht)
            scale = np.abs(f * rates).sum()
            worst = max(worst, abs(power - de) / scale)
    assert worst < 1e-6, worst


def test_power_balance_fails_without_the_leg_terms(platform):
    """The energy check can see the legs: forces of the model without leg
    masses miss the legs' power by far more than the tolerance above, and
    forces without the legs' moments of inertia miss their power too."""
    p = heavy(platform)
    bare = heavy(platform, legs=(0.0, 0.0, 0.0, 0.0))
    traj = Trajectory(p.home, np.random.default_rng(12))
    q, qd, qdd = traj(1.3)
    rates = model.leg_velocities(p, q, qd[:3], qd[3:])
    ht = 1e-4
    de = energy_rate(p, traj, 1.3, ht)
    f = forces(bare, q, qd, qdd)
    assert abs(f @ rates - de) > 1e-2 * np.abs(f * rates).sum()
    spun = heavy(platform, inertia=LEG_INERTIA)
    de = energy_rate(spun, traj, 1.3, ht)
    f = forces(p, q, qd, qdd)
    assert abs(f @ rates - de) > 1e-4 * np.abs(f * rates).sum()
    assert abs(forces(spun, q, qd, qdd) @ rates - de) < 1e-6 * np.abs(f * rates).sum()


@pytest.mark.parametrize("inertia", [(0.0, 0.0), LEG_INERTIA])
def test_lagrange_equations_numerically(platform, inertia):
    """d/dt dT/dq' - dT/dq + dV/dq = J^T F with every derivative taken
    numerically from the position-only energies: an independent derivation
    of the forces, with point-mass legs and with the legs' moments of
    inertia across the leg (their energy from the leg's numerical angular
    velocity u x u'). Measured: within 2.2e-7 of the largest force (1e-6
    allowed)."""
    p = heavy(platform, inertia=inertia)
    rng = np.random.default_rng(13)
    hx, hv, hq, ht = 1e-4, 1e-3, 1e-4, 1e-4

    def momentum(q, qd):
        out = np.empty(6)
        for j in range(6):
            e = np.zeros(6)
            e[j] = hv
            out[j] = (energies(p, q, qd + e, hx)[0] - energies(p, q, qd - e, hx)[0]) / (2 * hv)
        return out

    for _ in range(4):
        traj = Trajectory(p.home, rng)
        t = rng.uniform(0, 5)
        q, qd, qdd = traj(t)
        dp = (momentum(*traj(t + ht)[:2]) - momentum(*traj(t - ht)[:2])) / (2 * ht)
        dtq = np.empty(6)
        dvq = np.empty(6)
        jac = np.empty((6, 6))
        for j in range(6):
            e = np.zeros(6)
            e[j] = hq
            kp, vp = energies(p, q + e, qd, hx)
            km, vm = energies(p, q - e, qd, hx)
            dtq[j] = (kp - km) / (2 * hq)
            dvq[j] = (vp - vm) / (2 * hq)
            jac[:, j] = (model.inverse_kinematics(p, q + e).lengths
                         - model.inverse_kinematics(p, q - e).lengths) / (2 * hq)
        f_lagrange = np.linalg.solve(jac.T, dp - dtq + dvq)
        f = forces(p, q, qd, qdd)
        assert np.max(np.abs(f - f_lagrange)) < 1e-6 * np.max(np.abs(f)), (f, f_lagrange)


def test_rod_mass_at_the_joint_is_a_heavier_rigid_platform(platform):
    """d_r = 0 puts each rod's mass on its platform joint, d_c = 0 each barrel's
    on its base joint (which does not move): the forces must be those of a
    rigid platform of mass m + 6 m_r with the joints' mass in its centre of
    mass and inertia (parallel axes), to 1e-9 relative."""
    m_r = 40.0
    p = heavy(platform, com=(0.05, 0.02, 0.1), legs=(70.0, 0.0, m_r, 0.0))
    a = np.asarray(p.platform_joints, float)
    m = p.mass
    c = np.asarray(p.center_of_mass)
    mt = m + 6 * m_r
    ct = (m * c + m_r * a.sum(axis=0)) / mt

    def shifted(mass, r):  # inertia of a point mass about a point at -r from it
        return mass * (r @ r * np.eye(3) - np.outer(r, r))

    it = np.asarray(p.inertia) + shifted(m, c - ct) + sum(shifted(m_r, ai - ct) for ai in a)
    rigid = heavy(platform, com=ct, legs=(0.0, 0.0, 0.0, 0.0))
    rigid.mass = mt
    rigid.inertia = it.tolist()
    rng = np.random.default_rng(14)
    for _ in range(100):
        q = np.array(p.home) + rng.uniform(-0.2, 0.2, 6)
        v, acc = rng.uniform(-1, 1, 6), rng.uniform(-6, 6, 6)
        f1 = model.inverse_dynamics(p, q, v[:3], v[3:], acc[:3], acc[3:])
        f2 = model.inverse_dynamics(rigid, q, v[:3], v[3:], acc[:3], acc[3:])
        assert np.max(np.abs(f1 - f2)) < 1e-9 * np.max(np.abs(f2))


def test_com_offset_static_moment(platform):
    """At rest the forces carry the weight at the centre of mass: their
    resultant is m g e_z through R c (the moment about o' is R c x m g e_z)."""
    p = heavy(platform, com=(0.2, -0.1, 0.3), legs=(0.0, 0.0, 0.0, 0.0))
    q = np.array(p.home) + [0.05, -0.02, 0.03, 0.1, -0.05, 0.2]
    f = model.inverse_dynamics(p, q, [0] * 3, [0] * 3, [0] * 3, [0] * 3)
    ls = model.inverse_kinematics(p, q)
    weight = np.array([0, 0, p.mass * p.gravity])
    assert np.allclose((f[:, None] * ls.units).sum(axis=0), weight, atol=1e-6)
    rc = model.rotation(q[3:]) @ np.asarray(p.center_of_mass)
    assert np.allclose((np.cross(ls.arms, ls.units) * f[:, None]).sum(axis=0), np.cross(rc, weight), atol=1e-6)


def test_batched_dynamics_equals_one_pose_at_a_time(platform):
    p = heavy(platform)
    rng = np.random.default_rng(15)
    q = np.array(p.home) + rng.uniform(-0.2, 0.2, (40, 6))
    v, a = rng.uniform(-1, 1, (40, 6)), rng.uniform(-5, 5, (40, 6))
    many = model.inverse_dynamics_many(p, q, v[:, :3], v[:, 3:], a[:, :3], a[:, 3:])
    one = np.array([model.inverse_dynamics(p, q[k], v[k, :3], v[k, 3:], a[k, :3], a[k, 3:]) for k in range(40)])
    assert np.array_equal(many.shape, (40, 6))
    assert np.allclose(many, one, rtol=0, atol=1e-9)
    assert np.allclose(model.leg_lengths_many(p, q), [model.inverse_kinematics(p, x).lengths for x in q],
                       rtol=0, atol=1e-12)


def test_friction_force_is_viscous_plus_saturating_ramp(platform):
    p = copy.deepcopy(platform)
    p.hydraulic = dict(p.hydraulic)
    p.hydraulic.update(viscous_friction=[1000.0, 2000, 3000, 4000, 5000, 6000],
                       coulomb_friction=[100.0, 200, 300, 400, 500, 600], coulomb_velocity=2e-3)
    v = np.array([0.1, -0.1, 1e-3, -5e-4, 2e-3, 0.0])
    expect = np.array([1000 * 0.1 + 100, -2000 * 0.1 - 200, 3000 * 1e-3 + 300 * 0.5,
                       -4000 * 5e-4 - 400 * 0.25, 5000 * 2e-3 + 500, 0.0])
    assert np.allclose(model.friction_force(p, v), expect, rtol=1e-12, atol=1e-12)
    assert np.array_equal(model.coulomb_shape([-3.0, -1.0, -0.25, 0.0, 0.5, 1.0, 7.0]),
                          [-1.0, -1.0, -0.25, 0.0, 0.5, 1.0, 1.0])
    bare = copy.deepcopy(platform)
    bare.hydraulic = {}
    assert np.array_equal(model.friction_force(bare, v), np.zeros(6))
