# SPDX-License-Identifier: Apache-2.0
"""The float64 model checked against first principles, so that it can serve
as the reference for the fixed-point core (tolerances are float64 ones)."""

import math
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


def random_pose(rng, home):
    return home + rng.uniform([-0.2, -0.2, -0.15, -0.26, -0.26, -0.26], [0.2, 0.2, 0.15, 0.26, 0.26, 0.26])


def test_orientation_is_zyx_and_matches_the_paper(platform):
    rpy = np.array([0.1, -0.2, 0.3])
    t = model.orientation(rpy)
    # rows of T are the platform axes; T is a rotation
    assert np.allclose(t @ t.T, np.eye(3), atol=1e-15)
    assert math.isclose(np.linalg.det(t), 1.0, abs_tol=1e-15)
    # pure yaw turns the platform x axis towards +y (right-handed)
    ty = model.orientation([0, 0, 0.5])
    assert np.allclose(ty[0], [math.cos(0.5), math.sin(0.5), 0], atol=1e-15)
    # R = T^T = Rz(psi) Ry(theta) Rx(phi): roll about the already yawed and pitched x axis
    r = model.rotation(rpy)
    assert np.allclose(r @ np.array([1.0, 0, 0]), t[0], atol=1e-15)


def test_home_legs_and_symmetry(platform):
    ls = model.inverse_kinematics(platform, platform.home)
    assert np.allclose(ls.lengths, ls.lengths[0], atol=1e-6)  # the default is symmetric
    assert np.allclose(np.linalg.norm(ls.units, axis=1), 1.0, atol=1e-15)


def test_body_rates_match_the_rotation_derivative(platform):
    rng = np.random.default_rng(1)
    h = 1e-6
    for _ in range(200):
        rpy = rng.uniform(-0.3, 0.3, 3)
        rate = rng.uniform(-1, 1, 3)
        acc = rng.uniform(-10, 10, 3)
        w, w_dot = model.body_rates(rpy, rate, acc)
        # skew(w) = R^T dR/dt, by central differences along the motion
        def rot_at(s):
            return model.rotation(rpy + rate * s + 0.5 * acc * s * s)
        dr = (rot_at(h) - rot_at(-h)) / (2 * h)
        sk = model.rotation(rpy).T @ dr
        assert np.allclose([sk[2, 1], sk[0, 2], sk[1, 0]], w, atol=1e-8)
        def w_at(s):
            return model.body_rates(rpy + rate * s + 0.5 * acc * s * s, rate + acc * s, acc)[0]
        assert np.allclose((w_at(h) - w_at(-h)) / (2 * h), w_dot, atol=1e-6)


def test_leg_velocities_are_the_derivative_of_the_lengths(platform):
    rng = np.random.default_rng(2)
    home = np.array(platform.home)
    h = 1e-6
    for _ in range(200):
        pose = random_pose(rng, home)
        v6 = rng.uniform(-1, 1, 6)
        num = (model.inverse_kinematics(platform, pose + v6 * h).lengths
               - model.inverse_kinematics(platform, pose - v6 * h).lengths) / (2 * h)
        assert np.allclose(model.leg_velocities(platform, pose, v6[:3], v6[3:]), num, atol=1e-7)


def test_inverse_dynamics_static_balance(platform):
    # at rest the forces carry the weight and nothing else
    f = model.inverse_dynamics(platform, platform.home, [0] * 3, [0] * 3, [0] * 3, [0] * 3)
    ls = model.inverse_kinematics(platform, platform.home)
    total = (f[:, None] * ls.units).sum(axis=0)
    assert np.allclose(total, [0, 0, platform.mass * platform.gravity], atol=1e-6)
    moment = (np.cross(ls.arms, ls.units) * f[:, None]).sum(axis=0)
    assert np.allclose(moment, 0, atol=1e-6)


def test_inverse_dynamics_newton_euler_by_simulation(platform):
    """Forces from the model, applied to a rigid body integrated from
    Newton-Euler in the body frame, reproduce the commanded motion over a
    short horizon: an independent check of eq (15) with the full tensor."""
    inertia = np.asarray(platform.inertia)
    m = platform.mass
    home = np.array(platform.home)
    w_f = 2 * math.pi * 0.7

    def traj(t):
        amp = np.array([0.05, -0.04, 0.03, 0.08, -0.06, 0.1])
        return home + amp * np.sin(w_f * t), amp * w_f * np.cos(w_f * t), -amp * w_f * w_f * np.sin(w_f * t)

    dt = 1e-4
    pose, vel, _ = traj(0.0)
    p = pose[:3].copy()
    v = vel[:3].copy()
    r = model.rotation(pose[3:])
    w, _ = model.body_rates(pose[3:], vel[3:])
    for k in range(5000):
        t = k * dt
        pz, vz, az = traj(t)
        f = model.inverse_dynamics(platform, pz, vz[:3], vz[3:], az[:3], az[3:])
        ls = model.inverse_kinematics(platform, pz)
        force = (f[:, None] * ls.units).sum(axis=0) - [0, 0, m * platform.gravity]
        moment_base = (np.cross(ls.arms, ls.units) * f[:, None]).sum(axis=0)
        moment_body = model.rotation(pz[3:]).T @ moment_base
        w_dot = np.linalg.solve(inertia, moment_body - np.cross(w, inertia @ w))
        v = v + force / m * dt
        p = p + v * dt
        w = w + w_dot * dt
        wx = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        r = r @ (np.eye(3) + wx * dt + wx @ wx * dt * dt / 2)
        u, _, vt = np.linalg.svd(r)
        r = u @ vt
    pz, _, _ = traj(5000 * dt)
    assert np.max(np.abs(p - pz[:3])) < 2e-4
    assert np.max(np.abs(r - model.rotation(pz[3:]))) < 2e-4


def test_forward_kinematics_recovers_random_poses(platform):
    rng = np.random.default_rng(4)
    home = np.array(platform.home)
    for _ in range(50):
        pose = random_pose(rng, home)
        got, it = model.forward_kinematics(platform, model.inverse_kinematics(platform, pose).lengths, home)
        assert np.allclose(got, pose, atol=1e-9)
        assert it <= 10
