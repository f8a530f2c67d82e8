# SPDX-License-Identifier: Apache-2.0
"""The fixed-point firmware core (the C code, through ctypes) against the
independent float64 model, on 10,000 random poses and motions around home.

Bounds (from the issue): leg lengths within 1 um, cylinder forces within
0.05 N, forward kinematics within 1 um and 5 urad of the true pose and at
most 3 Newton steps when warm-started from the previous 1 kHz tick.
"""

import pytest
from pathlib import Path

from stewart import accuracy
from stewart import config as cfg

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def platform():
    return cfg.load(REPO_ROOT / "config" / "platform_default.json")


def test_core_matches_float64_model_on_10000_random_motions(platform):
    rep = accuracy.measure(platform, n=10000, seed=1)
    print("\n".join(rep.lines()))
    assert rep.failures == 0
    assert rep.length <= accuracy.BOUND_LENGTH
    assert rep.stretch <= accuracy.BOUND_LENGTH
    assert rep.force <= accuracy.BOUND_FORCE
    assert rep.fk_pos <= accuracy.BOUND_FK_POS
    assert rep.fk_rot <= accuracy.BOUND_FK_ROT
    assert rep.fk_iter_max <= accuracy.BOUND_FK_ITER


def _massless(platform):
    import dataclasses
    hyd = dict(platform.hydraulic)
    hyd["cylinder_mass"] = 0.0
    hyd["rod_mass"] = 0.0
    hyd["cylinder_inertia"] = 0.0
    hyd["rod_inertia"] = 0.0
    return dataclasses.replace(platform, hydraulic=hyd)


def test_inverse_dynamics_with_leg_masses_matches_model(platform):
    """The fixed-point inverse dynamics with the default config's leg masses
    (60 kg barrels, 35 kg rods, 11.25 and 7.5 kg m^2 across the leg) against the float64 Newton-Euler model, on
    1,500 motions: 1,200 inside the fast path's envelope (dynamics.c
    leg_terms; up to 2 m/s, 2 rad/s, 20 m/s^2, 20 rad/s^2) and 300 beyond it
    (one component at 4.1-5 m/s: the saturating leg_terms_wide path). Bound: the ID bound of
    the other tests, 0.05 N + 1e-6 |F|, on the forces and on the legs' share
    of them (with legs minus massless, core against model). Measured: forces
    0.0051 N, legs' share 0.0048 N (fast path); 0.0053 N, 0.0042 N (wide
    path), with the legs' share up to 6.8 kN."""
    import numpy as np

    from stewart import model
    from stewart.core import Core

    assert platform.hydraulic["cylinder_mass"] > 0 and platform.hydraulic["rod_mass"] > 0
    bare = _massless(platform)
    core, core_bare = Core(platform), Core(bare)
    rng = np.random.default_rng(15)
    home = np.array(platform.home, dtype=float)
    lo = np.array([-0.2, -0.2, -0.15] + [-0.25] * 3)
    q = lambda v: np.round(np.asarray(v, dtype=float) * 2.0**24) / 2.0**24  # noqa: E731
    worst = {"fast": [0.0, 0.0], "wide": [0.0, 0.0]}
    share = 0.0
    for n in range(1500):
        path = "fast" if n < 1200 else "wide"
        pose = q(home + rng.uniform(lo, -lo))
        vel = q(rng.uniform(-2, 2, 3))
        if path == "wide":
            vel[n % 3] = q(rng.choice([-1.0, 1.0]) * rng.uniform(4.1, 5.0))
        rate = q(rng.uniform(-2, 2, 3))
        acc = q(rng.uniform(-20, 20, 3))
        racc = q(rng.uniform(-20, 20, 3))
        r = core.calc(pose, vel, rate, acc, racc)
        rb = core_bare.calc(pose, vel, rate, acc, racc)
        assert r.force is not None and rb.force is not None, (n, r.status)
        f_model = np.asarray(model.inverse_dynamics(platform, pose, vel, rate, acc, racc))
        fb_model = np.asarray(model.inverse_dynamics(bare, pose, vel, rate, acc, racc))
        err = np.abs(np.asarray(r.force) - f_model)
        err_share = np.abs((np.asarray(r.force) - np.asarray(rb.force)) - (f_model - fb_model))
        assert np.all(err <= 0.05 + 1e-6 * np.abs(f_model)), (n, path, err.max())
        assert np.all(err_share <= 0.05 + 1e-6 * np.abs(f_model - fb_model)), (n, path, err_share.max())
        worst[path][0] = max(worst[path][0], float(err.max()))
        worst[path][1] = max(worst[path][1], float(err_share.max()))
        share = max(share, float(np.max(np.abs(f_model - fb_model))))
    print(f"\nID with leg masses vs float64: fast path force {worst['fast'][0]:.4f} N, legs' share "
          f"{worst['fast'][1]:.4f} N; wide path {worst['wide'][0]:.4f} N, {worst['wide'][1]:.4f} N "
          f"(legs' share up to {share:.0f} N)")


def _with_inertia(platform, cylinder, rod):
    import dataclasses
    hyd = dict(platform.hydraulic, cylinder_inertia=cylinder, rod_inertia=rod)
    return dataclasses.replace(platform, hydraulic=hyd)


@pytest.mark.parametrize("inertia,path", [((11.25, 7.5), "fast"), ((11.25, 7.5), "wide"), ((100.0, 40.0), "wide")])
def test_inverse_dynamics_with_leg_inertia_matches_model(platform, inertia, path):
    """The legs' moments of inertia across the leg (a 60 kg 1.5 m barrel's
    11.25 kg m^2 and a 35 kg 1.6 m rod's 7.5 kg m^2; and 140 kg m^2 in all,
    beyond the fast path's 128 kg m^2, which takes leg_terms_wide) in the
    fixed-point inverse dynamics against the float64 model, on 400 motions
    each (fast: up to 2 m/s, 2 rad/s, 20 m/s^2, 20 rad/s^2; wide: one
    velocity component at 4.1-5 m/s as above). Bound: 0.05 N + 1e-6 |F| on
    the forces and on the inertia's share of them (with inertia minus
    without, core against model). Measured: forces 0.0047 N, the inertia's
    share 0.0047 N (fast, share up to 469 N); 0.0044, 0.0047 N (wide by
    speed, share up to 538 N); 0.0051, 0.0047 N (wide by inertia, share up
    to 3.5 kN)."""
    import numpy as np

    from stewart import model
    from stewart.core import Core

    spun = _with_inertia(platform, *inertia)
    point = _with_inertia(platform, 0.0, 0.0)
    core, core_point = Core(spun), Core(point)
    rng = np.random.default_rng(16)
    home = np.array(platform.home, dtype=float)
    lo = np.array([-0.2, -0.2, -0.15] + [-0.25] * 3)
    q = lambda v: np.round(np.asarray(v, dtype=float) * 2.0**24) / 2.0**24  # noqa: E731
    worst, worst_share, share = 0.0, 0.0, 0.0
    for n in range(400):
        pose = q(home + rng.uniform(lo, -lo))
        vel = q(rng.uniform(-2, 2, 3))
        if path == "wide" and inertia[0] + inertia[1] < 128.0:
            vel[n % 3] = q(rng.choice([-1.0, 1.0]) * rng.uniform(4.1, 5.0))
        rate = q(rng.uniform(-2, 2, 3))
        acc = q(rng.uniform(-20, 20, 3))
        racc = q(rng.uniform(-20, 20, 3))
        r = core.calc(pose, vel, rate, acc, racc)
        rp = core_point.calc(pose, vel, rate, acc, racc)
        assert r.force is not None and rp.force is not None, (n, r.status)
        f_model = np.asarray(model.inverse_dynamics(spun, pose, vel, rate, acc, racc))
        fp_model = np.asarray(model.inverse_dynamics(point, pose, vel, rate, acc, racc))
        err = np.abs(np.asarray(r.force) - f_model)
        err_share = np.abs((np.asarray(r.force) - np.asarray(rp.force)) - (f_model - fp_model))
        assert np.all(err <= 0.05 + 1e-6 * np.abs(f_model)), (n, err.max())
        assert np.all(err_share <= 0.05 + 1e-6 * np.abs(f_model - fp_model)), (n, err_share.max())
        worst = max(worst, float(err.max()))
        worst_share = max(worst_share, float(err_share.max()))
        share = max(share, float(np.max(np.abs(f_model - fp_model))))
    assert share > 1.0  # the inertia shows in the forces
    print(f"\nID with leg inertia {inertia} ({path}) vs float64: force {worst:.4f} N, the inertia's share "
          f"{worst_share:.4f} N (share up to {share:.0f} N)")
