# SPDX-License-Identifier: Apache-2.0
"""Identification (stewart.identify, ``stewart identify``) on synthetic runs
of the float64 model: a payload 300 kg heavier than the config's with its
centre of mass 0.2 m off o', other inertia and per-leg friction, and the
drives' noise (leg lengths to 1 um, forces with ~45 N of pressure noise).

Tolerances are those of issue 14: mass 1 %, centre of mass 5 mm, inertia
diagonal 5 %, friction 10 %. Measured on the 60 s plan (seed 1): mass within
0.015 kg, centre of mass within 0.04 mm, inertia within 1.1 kg m^2, viscous
friction within 8.4 N s/m, Coulomb within 0.9 N (each within 2.8 of its
standard error)."""

from __future__ import annotations

import copy
import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from stewart import cli, model
from stewart import config as cfg
from stewart import identify as idf
from stewart import protocol as pr
from stewart.analysis.decode import hydraulic_areas
from stewart.analysis.logfile import format_line

REPO_ROOT = Path(__file__).resolve().parents[2]

CONFIG = REPO_ROOT / "config" / "platform_default.json"
LEG_MASSES = dict(cylinder_mass=60.0, cylinder_com=0.8, rod_mass=35.0, rod_com=1.0)
TRUE_COM = [0.12, -0.1, 0.12]                       # |c| = 0.197 m
TRUE_INERTIA = [[2100.0, 40.0, -60.0], [40.0, 2350.0, 25.0], [-60.0, 25.0, 3400.0]]
TRUE_CV = [2500.0, 3000.0, 3500.0, 2800.0, 3200.0, 3000.0]
TRUE_FC = [350.0, 400.0, 450.0, 380.0, 420.0, 400.0]
FORCE_NOISE = 45.0     # N: 5 kPa on both chambers of a 100/56 mm cylinder
LENGTH_LSB = 1e-6      # m


def raw_config():
    """The default config with leg masses (the prior the identification starts from)."""
    raw = json.loads(CONFIG.read_text())
    raw["hydraulic"].update(LEG_MASSES)
    return raw


@pytest.fixture(scope="module")
def prior():
    return cfg.from_dict(raw_config(), "prior")


@pytest.fixture(scope="module")
def truth(prior):
    raw = raw_config()
    raw["mass"] = prior.mass + 300.0
    raw["center_of_mass"] = TRUE_COM
    raw["inertia"] = TRUE_INERTIA
    raw["hydraulic"]["viscous_friction"] = TRUE_CV
    raw["hydraulic"]["coulomb_friction"] = TRUE_FC
    return cfg.from_dict(raw, "truth")


def simulate(truth, plan, rng):
    """Measured leg lengths (1 um) and cylinder forces (pressure force =
    barrel-rod force + friction, plus noise) along a planned motion."""
    args = (plan.pose, plan.rate[:, :3], plan.rate[:, 3:], plan.acc[:, :3], plan.acc[:, 3:])
    force = model.inverse_dynamics_many(truth, *args)
    force += model.friction_force(truth, model.joint_motion(truth, *args).rates)
    lengths = np.round(model.leg_lengths_many(truth, plan.pose) / LENGTH_LSB) * LENGTH_LSB
    return lengths, force + rng.normal(0.0, FORCE_NOISE, force.shape)


def check_estimate(values, truth):
    m, c, ig = values[0], values[1:4], idf.inertia_matrix(values[4:10])
    assert abs(m - truth.mass) < 0.01 * truth.mass
    assert np.max(np.abs(c - np.asarray(truth.center_of_mass))) < 5e-3
    diag_true = np.diag(np.asarray(truth.inertia))
    assert np.all(np.abs(np.diag(ig) - diag_true) < 0.05 * diag_true)
    assert np.all(np.abs(values[10:16] - TRUE_CV) < 0.1 * np.asarray(TRUE_CV))
    assert np.all(np.abs(values[16:22] - TRUE_FC) < 0.1 * np.asarray(TRUE_FC))


@pytest.fixture(scope="module")
def plan60(prior):
    return idf.plan_excitation(prior, duration=60.0, seed=1)


# -- building blocks ------------------------------------------------------------------

def test_wrench_regressor_is_the_models_rigid_body_wrench(truth):
    rng = np.random.default_rng(1)
    n = 50
    pose = np.asarray(truth.home) + rng.uniform(-0.2, 0.2, (n, 6))
    v, a = rng.uniform(-1, 1, (n, 6)), rng.uniform(-5, 5, (n, 6))
    jm = model.joint_motion(truth, pose, v[:, :3], v[:, 3:], a[:, :3], a[:, 3:])
    y = idf.wrench_regressor(jm, truth.gravity)
    got = np.einsum("nij,j->ni", y, idf.theta_of(truth)[:10])
    ref = model.rigid_body_wrench(truth, jm)
    assert np.max(np.abs(got - ref)) < 1e-9 * np.max(np.abs(ref))


def test_noise_free_regression_returns_the_true_parameters(truth, plan60):
    """Exact motion and forces: the least squares reproduce theta to 1e-6."""
    sub = slice(None, None, 20)
    pose, rate, acc = plan60.pose[sub], plan60.rate[sub], plan60.acc[sub]
    args = (pose, rate[:, :3], rate[:, 3:], acc[:, :3], acc[:, 3:])
    force = model.inverse_dynamics_many(truth, *args) + model.friction_force(
        truth, model.joint_motion(truth, *args).rates)
    reg = idf.build_regression(truth, pose, rate, acc, force, idf.min_leg_rate(truth))
    res = idf.solve(reg, truth, idf.min_leg_rate(truth))
    expect = idf.theta_of(truth)
    assert np.max(np.abs(res.theta - expect) / np.maximum(np.abs(expect), 1.0)) < 1e-6
    assert np.max(np.abs(res.values - idf.derived(expect)) / np.maximum(np.abs(idf.derived(expect)), 1.0)) < 1e-6


def test_forward_kinematics_many_inverts_the_lengths(prior):
    rng = np.random.default_rng(2)
    poses = np.asarray(prior.home) + rng.uniform([-0.2] * 3 + [-0.25] * 3, [0.2] * 3 + [0.25] * 3, (300, 6))
    got, ok = idf.forward_kinematics_many(prior, model.leg_lengths_many(prior, poses),
                                          np.tile(prior.home, (300, 1)))
    assert ok.all()
    assert np.max(np.abs(got - poses)) < 1e-9


def test_savitzky_golay_is_exact_for_polynomials_and_zero_phase():
    t = np.arange(0, 1.0, 1e-3)
    x = 1.0 + 2.0 * t - 3.0 * t ** 2 + 0.5 * t ** 3 + 0.25 * t ** 4
    s, r, a = idf.differentiate(x, 1e-3, half=50, order=4)
    inner = slice(50, -50)
    assert np.all(np.isnan(s[:50])) and np.all(np.isnan(a[-50:]))
    assert np.allclose(s[inner], x[inner], atol=1e-10)
    assert np.allclose(r[inner], (2 - 6 * t + 1.5 * t ** 2 + t ** 3)[inner], atol=1e-7)
    assert np.allclose(a[inner], (-6 + 3 * t + 3 * t ** 2)[inner], atol=1e-5)
    # a 1 Hz sine: no lag, amplitude within 1e-4
    y = np.sin(2 * np.pi * t * 1.0)
    s, r, _ = idf.differentiate(y, 1e-3)
    assert np.max(np.abs(r[inner] - 2 * np.pi * np.cos(2 * np.pi * t[inner]))) < 1e-4 * 2 * np.pi


# -- identification on synthetic runs -----------------------------------------------

def test_identifies_payload_and_friction_from_noisy_run(prior, truth, plan60):
    lengths, force = simulate(truth, plan60, np.random.default_rng(3))
    ticks = np.arange(plan60.t.size)
    motion = idf.motion_from_lengths(prior, ticks, lengths, force, np.ones(ticks.size, bool))
    res = idf.identify_motion(prior, motion)
    check_estimate(res.values, truth)
    # the standard errors are honest: every error within 4 of them
    err = res.values - idf.derived(idf.theta_of(truth))
    assert np.all(np.abs(err) < 4 * res.se + 1e-9), err / res.se
    assert res.condition < 100
    assert 40 < res.residual_rms < 50                # the force noise and nothing else
    new = cfg.from_dict(idf.updated_config(raw_config(), res), "identified")
    assert new.hydraulic["rod_mass"] == LEG_MASSES["rod_mass"]
    assert math.isclose(new.mass, truth.mass, rel_tol=0.01)


def test_ignoring_the_leg_masses_would_bias_the_mass(prior, truth, plan60):
    """The legs are known and taken off: identifying with a config that
    forgets them gives a mass wrong by far more than 1 % (so the test above
    depends on the leg model)."""
    lengths, force = simulate(truth, plan60, np.random.default_rng(3))
    raw = raw_config()
    for k in list(LEG_MASSES) + ["cylinder_inertia", "rod_inertia"]:
        raw["hydraulic"].pop(k, None)
    bare = cfg.from_dict(raw, "bare")
    ticks = np.arange(plan60.t.size)
    motion = idf.motion_from_lengths(bare, ticks, lengths, force, np.ones(ticks.size, bool))
    res = idf.identify_motion(bare, motion, check=False)
    assert abs(res.values[0] - truth.mass) > 0.03 * truth.mass


def _axes_only(plan, axes):
    """The plan with the other axes held at home."""
    p = copy.deepcopy(plan)
    keep = np.zeros(6, bool)
    keep[list(axes)] = True
    p.pose[:, ~keep] = np.asarray(plan.pose[0])[~keep]
    p.rate[:, ~keep] = 0.0
    p.acc[:, ~keep] = 0.0
    return p


@pytest.mark.parametrize("axes, names", [
    ((2,), ("inertia", "center_of_mass")),                 # heave only
    ((0, 1, 2, 5), ("inertia Ixx", "inertia Iyy", "inertia Ixy")),   # no roll, no pitch
])
def test_unobservable_excitation_is_refused_with_the_parameter(prior, truth, plan60, axes, names):
    plan = _axes_only(plan60, axes)
    lengths, force = simulate(truth, plan, np.random.default_rng(4))
    ticks = np.arange(plan.t.size)
    motion = idf.motion_from_lengths(prior, ticks, lengths, force, np.ones(ticks.size, bool))
    with pytest.raises(idf.Unobservable) as exc:
        idf.identify_motion(prior, motion)
    assert exc.value.parameter.startswith(names), str(exc.value)
    assert ": unobservable: " in str(exc.value) and "the log needs" in str(exc.value)


def test_only_running_ticks_count(prior, truth, plan60):
    lengths, force = simulate(truth, plan60, np.random.default_rng(5))
    ticks = np.arange(plan60.t.size)
    motion = idf.motion_from_lengths(prior, ticks, lengths, force, np.zeros(ticks.size, bool))
    with pytest.raises(idf.IdentifyError, match="usable rows"):
        idf.identify_motion(prior, motion)


# -- the planned excitation -------------------------------------------------------

def test_plan_keeps_the_limits_and_starts_and_ends_at_home(prior, plan60):
    home = np.asarray(prior.home)
    rel = plan60.pose - home
    assert np.all(rel >= np.asarray(prior.workspace_min)) and np.all(rel <= np.asarray(prior.workspace_max))
    lengths = model.leg_lengths_many(prior, plan60.pose)
    assert lengths.min() >= prior.leg_length_min + 0.03 and lengths.max() <= prior.leg_length_max - 0.03
    jm = model.joint_motion(prior, plan60.pose, plan60.rate[:, :3], plan60.rate[:, 3:],
                            plan60.acc[:, :3], plan60.acc[:, 3:])
    assert np.abs(jm.rates).max() <= 0.8 * prior.leg_velocity_max
    assert np.abs(plan60.rate).max() <= 0.8 * idf.MOVE_LIMITS[0] + 1e-12
    assert np.abs(plan60.acc).max() <= 0.8 * idf.MOVE_LIMITS[1] + 1e-12
    assert np.allclose(plan60.pose[[0, -1]], home, atol=1e-12)
    assert np.allclose(plan60.rate[[0, -1]], 0, atol=1e-12)
    # the analytic rates are the derivative of the poses
    num = np.gradient(plan60.pose, plan60.t, axis=0)
    assert np.max(np.abs(num - plan60.rate)[1:-1]) < 1e-4
    # every axis moves, on frequency lines no other axis has
    assert np.all(np.abs(rel).max(axis=0) > 0.05)
    lines = [set(np.round(f, 9)) for f in plan60.report["lines_hz"]]
    assert all(not (lines[i] & lines[j]) for i in range(6) for j in range(i))


def test_plan_refuses_a_too_short_run(prior):
    with pytest.raises(idf.IdentifyError, match="too short"):
        idf.plan_excitation(prior, duration=8.0)


# -- the command line ---------------------------------------------------------------

def write_can_log(path, platform, truth, plan, rng, running=True):
    """A candump -L log of the run as the controller and drives send it:
    AXIS_FEEDBACK (length, chamber pressures) and CTRL_STATUS per tick."""
    p = pr.Protocol()
    ap, ar = hydraulic_areas(platform)
    lengths, force = simulate(truth, plan, rng)
    p_b = 5.0e6 + rng.normal(0.0, 5e3, force.shape)
    p_a = (force + p_b * ar) / ap
    state = "RUNNING" if running else "READY"
    out = []
    ifs = {"ops": "vcan0", "axis_a": "vcan1", "axis_b": "vcan2"}

    def emit(t, bus, name, sig):
        out.append(format_line(t, ifs[bus], p.message(name).frame_id, p.encode(name, sig, bus=bus)))

    for k in range(plan.t.size):
        tick = 1000 + k
        t = tick * 1e-3
        for leg in range(1, 7):
            bus, slot = pr.LEG_BUS[leg]
            emit(t, bus, pr.feedback_name(slot), {
                "Length": lengths[k, leg - 1], "PressureA": p_a[k, leg - 1], "PressureB": p_b[k, leg - 1],
                "State": "ACTIVE", "Faults": 0, "TickEcho": tick & 0xFFFF})
        status = {"Tick": tick, "State": state, "Faults": 0, "FkIterations": 2, "EstimateValid": 1,
                  "CmdRejected": 0, "DriveMode": "ACTIVE", "FeedForward": 1}
        status.update(pr.pose_to_signals([round(v, 6) for v in plan.pose[k]]))
        emit(t, "ops", "CTRL_STATUS", status)
    path.write_text("\n".join(out) + "\n")


@pytest.fixture(scope="module")
def short_plan(prior):
    return idf.plan_excitation(prior, duration=24.0, seed=2)


def test_cli_identifies_from_a_can_log(tmp_path, prior, truth, short_plan, capsys):
    log = tmp_path / "run.log"
    write_can_log(log, prior, truth, short_plan, np.random.default_rng(6))
    cfg_in = tmp_path / "prior.json"
    cfg_in.write_text(json.dumps(raw_config()))
    out = tmp_path / "new.json"
    assert cli.main(["identify", "--log", str(log), "--config", str(cfg_in), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "condition number of the scaled regressor" in text and "inertia Ixz" in text and "+-" in text
    new = cfg.load(out)
    check_estimate(np.concatenate([[new.mass], new.center_of_mass,
                                   np.asarray(new.inertia)[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]],
                                   new.hydraulic["viscous_friction"], new.hydraulic["coulomb_friction"]]), truth)
    raw_new = json.loads(out.read_text())
    raw_old = raw_config()
    for key in raw_old:
        if key not in ("mass", "center_of_mass", "inertia", "hydraulic"):
            assert raw_new[key] == raw_old[key], key
    for key in raw_old["hydraulic"]:
        if key not in ("viscous_friction", "coulomb_friction"):
            assert raw_new["hydraulic"][key] == raw_old["hydraulic"][key], key


def test_cli_bad_inputs(tmp_path, prior, truth, capsys):
    cfg_in = tmp_path / "prior.json"
    cfg_in.write_text(json.dumps(raw_config()))
    out = tmp_path / "new.json"
    # missing log
    assert cli.main(["identify", "--log", str(tmp_path / "nope.log"), "--config", str(cfg_in),
                     "--out", str(out)]) == 2
    assert "no such file" in capsys.readouterr().err
    # a log without RUNNING ticks
    plan = idf.plan_excitation(prior, duration=14.0, f_min=0.2, f_max=2.0, seed=3)
    log = tmp_path / "ready.log"
    write_can_log(log, prior, truth, plan, np.random.default_rng(7), running=False)
    assert cli.main(["identify", "--log", str(log), "--config", str(cfg_in), "--out", str(out)]) == 1
    assert "no tick in which the platform is RUNNING" in capsys.readouterr().err
    # heave only: refused, naming the parameter
    heave = _axes_only(plan, (2,))
    write_can_log(log, prior, truth, heave, np.random.default_rng(8))
    assert cli.main(["identify", "--log", str(log), "--config", str(cfg_in), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "refused" in err and ": unobservable: " in err
    # a bad config names its key
    bad = raw_config()
    bad["mass"] = -1
    cfg_bad = tmp_path / "bad.json"
    cfg_bad.write_text(json.dumps(bad))
    assert cli.main(["identify", "--log", str(log), "--config", str(cfg_bad), "--out", str(out)]) == 2
    assert "mass" in capsys.readouterr().err
    # neither or both modes, --log without --out
    assert cli.main(["identify", "--config", str(cfg_in)]) == 2
    assert cli.main(["identify", "--log", str(log), "--scenario", str(tmp_path / "s.txt")]) == 2
    assert cli.main(["identify", "--log", str(log), "--config", str(cfg_in)]) == 2
    capsys.readouterr()
    assert not out.exists()


def test_cli_scenario_writes_scenario_and_csv(tmp_path, prior, capsys):
    scen = tmp_path / "excite.txt"
    assert cli.main(["identify", "--scenario", str(scen), "--config", str(CONFIG), "--duration", "30"]) == 0
    csv_path = tmp_path / "excite.csv"
    assert f"wrote {scen}, {csv_path}" in capsys.readouterr().out
    words = [ln.split() for ln in scen.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    assert [w[0] for w in words] == ["cmd", "wait", "cmd", "wait", "mark", "play", "mark", "cmd", "wait",
                                     "cmd", "wait", "end"]
    assert ["cmd", "ENGAGE"] in words and ["cmd", "STREAM"] in words and ["play", str(csv_path)] in words
    with open(csv_path) as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "x", "y", "z", "roll", "pitch", "yaw"]
    data = np.array(rows[1:], float)
    assert np.allclose(np.diff(data[:, 0]), 0.01, atol=1e-9) and math.isclose(data[-1, 0], 30.0)
    assert np.allclose(data[[0, -1], 1:], prior.home, atol=1e-7)
    lengths = model.leg_lengths_many(prior, data[:, 1:])
    assert lengths.min() > prior.leg_length_min and lengths.max() < prior.leg_length_max
    assert cli.main(["identify", "--scenario", str(scen), "--duration", "7"]) == 1
    assert "too short" in capsys.readouterr().err


@pytest.mark.parametrize("step", [2, 3])
def test_feedback_every_few_ticks(prior, truth, plan60, step):
    """Drives that answer every `step` ticks (CANopen at a SYNC divider):
    the same motion sampled on those ticks alone gives the parameters
    within the issue's tolerances, the derivatives taken over the same
    50 ms window (17 samples at 3 ticks); `feedback_step` finds the period
    from the ticks that have lengths."""
    lengths, force = simulate(truth, plan60, np.random.default_rng(3))
    ticks = np.arange(plan60.t.size)
    gap = np.full((ticks.size, 6), np.nan)
    sampled = np.where((ticks % step == 0)[:, None], lengths, gap)
    assert idf.feedback_step(ticks, sampled) == step
    keep = ticks % step == 0
    motion = idf.motion_from_lengths(prior, ticks[keep], lengths[keep], force[keep], np.ones(keep.sum(), bool),
                                     step=step)
    res = idf.identify_motion(prior, motion)
    check_estimate(res.values, truth)
    err = res.values - idf.derived(idf.theta_of(truth))
    assert np.all(np.abs(err) < 4 * res.se + 1e-9), err / res.se
    assert res.info["feedback_every_ticks"] == step
    assert f"feedback every {step} ticks" in idf.format_result(res)
    # taken as consecutive 1 ms samples, the same rows give accelerations step^2 too large: refused or wrong
    wrong = idf.motion_from_lengths(prior, np.arange(keep.sum()), lengths[keep], force[keep],
                                    np.ones(keep.sum(), bool))
    try:
        bad = idf.identify_motion(prior, wrong, check=False)
        assert abs(bad.values[0] - truth.mass) > 0.05 * truth.mass
    except idf.IdentifyError:
        pass


def test_feedback_step_of_native_and_sparse_logs():
    ticks = np.arange(10)
    full = np.ones((10, 6))
    assert idf.feedback_step(ticks, full) == 1
    one = np.full((10, 6), np.nan)
    one[4] = 1.0
    assert idf.feedback_step(ticks, one) == 1          # fewer than two samples: native
    every3 = np.full((10, 6), np.nan)
    every3[[0, 3, 6, 9]] = 1.0
    every3[7] = 1.0                                      # a stray extra answer does not change the mode
    assert idf.feedback_step(ticks, every3) == 3


# -- the legs' moments of inertia -------------------------------------------------------

def test_leg_inertia_identified_or_held(prior, truth, plan60):
    """The legs' moments of inertia across the leg: the truth's barrels and
    rods have 14 + 6 kg m^2, the prior says 11.25 + 7.5. Held (the default)
    the prior's values are used and the 22 parameters still meet their
    tolerances; identified (``leg_inertia=True``) their sum comes back
    within 1.5 kg m^2 and 3 standard errors, and the written config shares
    it between barrel and rod as the prior does. Measured (60 s, seed 3):
    20.18 +- 0.48 kg m^2 (true 20)."""
    raw_p = raw_config()
    raw_p["hydraulic"].update(cylinder_inertia=11.25, rod_inertia=7.5)
    prior_i = cfg.from_dict(raw_p, "prior")
    raw_t = raw_config()
    raw_t.update(mass=truth.mass, center_of_mass=TRUE_COM, inertia=TRUE_INERTIA)
    raw_t["hydraulic"].update(viscous_friction=TRUE_CV, coulomb_friction=TRUE_FC, cylinder_inertia=14.0,
                              rod_inertia=6.0)
    truth_i = cfg.from_dict(raw_t, "truth")
    lengths, force = simulate(truth_i, plan60, np.random.default_rng(3))
    ticks = np.arange(plan60.t.size)
    motion = idf.motion_from_lengths(prior_i, ticks, lengths, force, np.ones(ticks.size, bool))
    held = idf.identify_motion(prior_i, motion)
    assert held.values.size == idf.N_THETA
    check_estimate(held.values, truth_i)
    res = idf.identify_motion(prior_i, motion, leg_inertia=True)
    check_estimate(res.values, truth_i)
    assert res.names[-1] == idf.LEG_INERTIA_NAME and res.values.size == idf.N_THETA + 1
    assert abs(res.values[-1] - 20.0) < 1.5 and abs(res.values[-1] - 20.0) < 3 * res.se[-1]
    assert "leg inertia I_c + I_r" in idf.format_result(res)
    new = cfg.from_dict(idf.updated_config(raw_p, res), "identified")
    total = new.hydraulic["cylinder_inertia"] + new.hydraulic["rod_inertia"]
    assert abs(total - res.values[-1]) < 0.01
    assert abs(new.hydraulic["cylinder_inertia"] / total - 0.6) < 1e-3   # the prior's 11.25 : 7.5
    # the regressor's inertia column is the model's: noise-free rows fit exactly
    sub = slice(None, None, 40)
    args = (plan60.pose[sub], plan60.rate[sub, :3], plan60.rate[sub, 3:], plan60.acc[sub, :3],
            plan60.acc[sub, 3:])
    exact = model.inverse_dynamics_many(truth_i, *args) + model.friction_force(
        truth_i, model.joint_motion(truth_i, *args).rates)
    reg = idf.build_regression(prior_i, plan60.pose[sub], plan60.rate[sub], plan60.acc[sub], exact,
                               idf.min_leg_rate(prior_i), leg_inertia=True)
    theta = idf.theta_of(truth_i, leg_inertia=True)
    assert np.max(np.abs(reg.x @ theta - reg.y)) < 1e-6 * np.max(np.abs(reg.y))

