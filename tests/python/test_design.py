# SPDX-License-Identifier: Apache-2.0
"""``stewart design``: the report's figures against the float64 model, the
fixed-point core and the paper-figure command; the workspace's convergence;
bad input refused by name. Small grids keep it quick."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from stewart import cli, model
from stewart import config as cfg
from stewart.commands import paper_cmd
from stewart.core import Core
from stewart.design import analysis, forces, hydraulics, limits, workspace
from stewart.design import duty as duty_mod

REPO_ROOT = Path(__file__).resolve().parents[2]
CONFIG = REPO_ROOT / "config" / "platform_default.json"

SMALL = {
    "payload": {"mass_min": 0, "mass_max": 400, "center_of_mass": [0.1, 0, 0.3],
                "inertia": [[50, 0, 0], [0, 60, 0], [0, 0, 70]]},
    "envelope": {"excursion_min": [-0.1, -0.1, -0.08, -0.08, -0.08, -0.1],
                 "excursion_max": [0.1, 0.1, 0.08, 0.08, 0.08, 0.1],
                 "velocity": [0.1, 0.1, 0.08, 0.1, 0.1, 0.1],
                 "acceleration": [2, 2, 2, 1.5, 1.5, 1.5]},
    "external_wrench": {"force": [500, 0, -1000], "moment": [0, 200, 0]},
    "workspace": {"position_step": 0.1, "angle_step": 0.1, "envelope_points": 3},
    "requirements": {"bandwidth_hz": 2, "condition_max": 10},
}


@pytest.fixture(scope="module")
def platform():
    return cfg.load(CONFIG)


def write_duty(path: Path, d: dict) -> Path:
    path.write_text(json.dumps(d))
    return path


def write_traj(path: Path, t, pose, vel=None, acc=None) -> Path:
    cols = ["t", "x", "y", "z", "roll", "pitch", "yaw"]
    if vel is not None:
        cols += ["vx", "vy", "vz", "roll_rate", "pitch_rate", "yaw_rate", "ax", "ay", "az",
                 "roll_acc", "pitch_acc", "yaw_acc"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for k in range(len(t)):
            row = [t[k]] + list(pose[k])
            if vel is not None:
                row += list(vel[k]) + list(acc[k])
            w.writerow([f"{v:.12g}" for v in row])
    return path


def test_default_report_key_figures(tmp_path, platform):
    """The whole report through the command line; its key figures recomputed
    from the float64 model."""
    duty = write_duty(tmp_path / "duty.json", SMALL)
    out = tmp_path / "out"
    status = cli.main(["design", str(CONFIG), "--duty", str(duty), "--out", str(out)])
    assert status in (0, 1)
    r = json.loads((out / "report.json").read_text())
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 4 and "http" not in page.replace("http-equiv", "")
    d = duty_mod.from_dict(SMALL)
    # The worst push: at its pose no sampled motion of the envelope pushes harder.
    pose = np.array(r["forces"]["push"]["pose"])
    leg = r["forces"]["push"]["leg"] - 1
    rng = np.random.default_rng(3)
    for mass in (0.0, 400.0):
        p = forces.with_payload(platform, d, mass)
        for _ in range(200):
            v = rng.uniform(-1, 1, 6) * d.velocity
            a = rng.uniform(-1, 1, 6) * d.acceleration
            f = model.inverse_dynamics(p, pose, v[:3], v[3:], a[:3], a[3:], external=d.force)
            f += forces._external(p, pose[None, :], duty_mod.Duty(moment=d.moment))[0]
            rates = model.leg_velocities(p, pose, v[:3], v[3:])
            assert f[leg] + abs(model.friction_force(p, rates)[leg]) <= r["forces"]["push"]["value"] + 1e-6
    # Capacities from the areas and the pressures.
    a_a = math.pi * 0.1 ** 2 / 4
    a_b = a_a - math.pi * 0.056 ** 2 / 4
    assert r["forces"]["push_capacity"] == pytest.approx(a_a * 21e6 - a_b * 0.3e6)
    assert r["forces"]["pull_capacity"] == pytest.approx(a_b * 21e6 - a_a * 0.3e6)
    # The verdict names a limit for each requirement.
    assert all(v["limit"] for v in r["verdict"])


def test_acceleration_bound_is_exact_at_rest(platform):
    """With no velocity the envelope's push is the largest over the
    acceleration box's corners (forces are affine in the accelerations)."""
    d = duty_mod.from_dict({"envelope": {"acceleration": [2, 1, 3, 1, 2, 0.5]}})
    pose = np.array(platform.home) + [0.05, -0.03, 0.02, 0.03, -0.02, 0.04]
    ef = forces.envelope_forces(platform, d, pose[None, :])
    corners = np.array(np.meshgrid(*[[-1, 1]] * 6, indexing="ij")).reshape(6, -1).T * d.acceleration
    brute = np.array([model.inverse_dynamics(platform, pose, [0] * 3, [0] * 3, c[:3], c[3:]) for c in corners])
    fric = np.asarray(platform.hydraulic["coulomb_friction"]) * 0  # at rest: no friction bound
    assert np.allclose(ef["push"][0], brute.max(axis=0) + fric, atol=1e-6)
    assert np.allclose(ef["pull"][0], brute.min(axis=0) - fric, atol=1e-6)


def test_ball_box_max_against_brute_force():
    rng = np.random.default_rng(5)
    c = rng.normal(size=(50, 3))
    lim = np.array([1.0, 2.0, 0.5])
    got = forces.ball_box_max(c, lim, 1.2)
    # The optimum lies on the sphere, on a face of the box or on their
    # intersection: sample the sphere and the box, keep what is feasible.
    dirs = rng.normal(size=(400000, 3))
    pts = np.concatenate([1.2 * dirs / np.linalg.norm(dirs, axis=1)[:, None],
                          np.clip(dirs, -1, 1) * lim])
    pts = np.clip(pts, -lim, lim)
    pts = pts[np.linalg.norm(pts, axis=1) <= 1.2 + 1e-12]
    brute = (c @ pts.T).max(axis=1)
    assert np.all(got >= brute - 1e-9) and np.all(got <= brute * 1.005 + 1e-9)


def test_mass_matrix_against_inverse_dynamics(platform):
    """The mass matrix (rigid body and legs) equals the one the float64
    inverse dynamics implies, A F(a) at rest without gravity."""
    import dataclasses

    p = dataclasses.replace(platform, gravity=0.0, center_of_mass=[0.1, -0.05, 0.2])
    pose = np.array(p.home) + [0.1, 0.05, -0.05, 0.0, 0.0, 0.0]
    a = model.force_matrix(p, pose)
    implied = np.stack([a @ model.inverse_dynamics(p, pose, [0] * 3, [0] * 3, e[:3], e[3:]) for e in np.eye(6)],
                       axis=1)
    got = hydraulics.mass_matrix(p, limits.legs(p, pose))
    assert np.allclose(got, implied, rtol=1e-9, atol=1e-6)


def test_natural_frequencies_independently(platform):
    """The natural frequencies from a stiffness by finite differences of the
    leg lengths (at zero angles Euler angles are a rotation vector to first
    order) and the mass matrix the inverse dynamics implies."""
    import dataclasses

    p = dataclasses.replace(platform, gravity=0.0)
    pose = np.array(p.home) + [0.05, -0.1, 0.1, 0.0, 0.0, 0.0]
    k = hydraulics.column_stiffness(p, model.inverse_kinematics(p, pose).lengths)
    a = model.force_matrix(p, pose)
    h = 1e-6
    dl = np.stack([(model.inverse_kinematics(p, pose + e * h).lengths
                    - model.inverse_kinematics(p, pose - e * h).lengths) / (2 * h) for e in np.eye(6)], axis=1)
    stiff = a @ (k[:, None] * dl)
    mass = np.stack([a @ model.inverse_dynamics(p, pose, [0] * 3, [0] * 3, e[:3], e[3:]) for e in np.eye(6)], axis=1)
    want = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(mass, stiff)).real)) / (2 * math.pi)
    got = hydraulics.natural_frequencies(p, pose[None, :])[0]
    assert np.allclose(got, want, rtol=1e-5)
    assert 3.0 < got[0] < 40.0


def test_forces_match_the_fixed_point_core(platform):
    """Along a trajectory the report's forces are the core's within 0.05 N."""
    d = duty_mod.from_dict({})
    rng = np.random.default_rng(7)
    n = 40
    pose = np.array(platform.home) + rng.uniform(-1, 1, (n, 6)) * [0.15, 0.15, 0.1, 0.1, 0.1, 0.1]
    vel = rng.uniform(-1, 1, (n, 6)) * 0.2
    acc = rng.uniform(-1, 1, (n, 6)) * 2.0
    traj = duty_mod.Trajectory("t", np.arange(n) * 0.01, pose, vel, acc)
    f = forces.trajectory_forces(platform, d, traj)[0.0]["force"]
    core = Core(platform)
    for k in range(n):
        c = core.calc(pose[k], vel=vel[k, :3], rpy_rate=vel[k, 3:], acc=acc[k, :3], rpy_acc=acc[k, 3:])
        assert c.force is not None
        assert np.max(np.abs(np.array(c.force) - f[k])) < 0.05


def test_paper_motions_match_the_paper_command(tmp_path, platform):
    """On the paper's surge and yaw, the report's peak cylinder forces are
    ``stewart paper``'s within 0.1 %."""
    core = Core(platform)
    names = []
    peaks = []
    for axis, amp in ((0, paper_cmd.AMPLITUDE_SURGE), (5, paper_cmd.AMPLITUDE_YAW)):
        rows = paper_cmd.compute(platform, core, axis, amp)
        peaks.append(np.array([max(abs(r[f"F{i}"]) for r in rows) for i in range(1, 7)]))
        t, off, vel, acc = paper_cmd.trig_samples(axis, amp, paper_cmd.FREQUENCY)
        pose = np.tile(platform.home, (t.size, 1))
        pose[:, axis] += off
        v6 = np.zeros((t.size, 6))
        a6 = np.zeros((t.size, 6))
        v6[:, axis], a6[:, axis] = vel, acc
        names.append(write_traj(tmp_path / f"paper{axis}.csv", t, pose, v6, a6).name)
    d = dict(SMALL, trajectories=names, payload={"mass_max": 0}, external_wrench={})
    r = analysis.trajectory_part(platform, duty_mod.from_dict(d, base=tmp_path))
    for got, want in zip(r, peaks):
        assert np.allclose(got["force_peak_per_leg"], want, rtol=1e-3)


def test_workspace_volume_converges(platform):
    """Halving the grid step changes the volume by at most 1 %."""
    coarse = workspace.constant_orientation(platform, [0, 0, 0], 0.08)["volume"]
    fine = workspace.constant_orientation(platform, [0, 0, 0], 0.04)["volume"]
    assert abs(fine - coarse) <= 0.01 * fine
    assert not workspace.constant_orientation(platform, [0, 0, 0], 0.08)["mask"][0].any()


def test_supply_flow_against_sampled_velocities(platform):
    """The supply's peak flow bounds every sampled velocity's and is
    reached closely by one."""
    d = duty_mod.from_dict({"envelope": {"velocity": [0.2, 0.2, 0.15, 0.2, 0.2, 0.2],
                                         "combined": {"linear_velocity": 0.25, "angular_velocity": 0.2}}})
    pose = np.array(platform.home) + [0.1, -0.05, 0.05, 0.05, 0.0, 0.1]
    jac = forces.rate_jacobian(platform, pose[None, :])
    peak = hydraulics.supply_flow(platform, jac, d)[0]
    a_a, a_b = hydraulics.areas(platform)
    rng = np.random.default_rng(11)
    v = rng.uniform(-1, 1, (400000, 6)) * d.velocity
    for sl, r in ((slice(0, 3), 0.25), (slice(3, 6), 0.2)):
        n = np.linalg.norm(v[:, sl], axis=1)
        v[:, sl] *= np.minimum(1.0, r / n)[:, None]
    rates = v @ jac[0].T
    flows = np.where(rates > 0, a_a * rates, -a_b * rates).sum(axis=1)
    assert flows.max() <= peak + 1e-12
    assert flows.max() >= 0.97 * peak
