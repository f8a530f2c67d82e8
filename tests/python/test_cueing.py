# SPDX-License-Identifier: Apache-2.0
"""stewart.cueing: the classical washout filter and ``stewart cueing``.

Tolerances: the linear filters are exact ZOH discretisations, so step
responses are compared with the continuous ones to 1e-6 of the step; the
workspace checks are exact comparisons against the config's limits."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from stewart import cli
from stewart import config as cfg
from stewart import cueing as cu
from stewart import model

PLATFORM = cfg.load(cu.DEFAULT_PLATFORM)
HOME = np.array(PLATFORM.home)
G = PLATFORM.gravity
LO = np.array(PLATFORM.workspace_min)
HI = np.array(PLATFORM.workspace_max)


def constant(n, f=(0.0, 0.0, G), w=(0.0, 0.0, 0.0), dt=0.001):
    t = np.arange(n) * dt
    return t, np.tile(np.asarray(f, float), (n, 1)), np.tile(np.asarray(w, float), (n, 1))


def test_at_rest_stays_home():
    t, f, w = constant(2000)
    poses = cu.Washout().run(t, f, w)
    assert np.abs(poses - HOME).max() < 1e-12


def test_every_pose_inside_the_workspace_for_an_aggressive_drive():
    t, f, w = cu.synthetic_drive(severity=1.5)
    wo = cu.Washout()
    poses = wo.run(t, f, w)
    cue = poses - HOME
    assert (cue >= LO).all() and (cue <= HI).all()
    assert wo.clipped.sum() == 0, "the defaults must not need the last-resort clip"
    lengths = model.leg_lengths_many(PLATFORM, poses)
    assert lengths.min() >= PLATFORM.leg_length_min and lengths.max() <= PLATFORM.leg_length_max
    speed = np.abs(np.diff(lengths, axis=0)).max() / wo.dt
    assert speed <= PLATFORM.leg_velocity_max
    # the drive does use the platform (a filter that outputs home would pass the above)
    assert np.abs(cue[:, 0]).max() > 0.2 * HI[0] and np.abs(cue[:, 4]).max() > 0.1


def test_sustained_acceleration_tilts_the_right_way_within_the_rate_limit():
    p = cu.WashoutParams()
    wo = cu.Washout()
    t, f, w = constant(20000, f=(2.0, -1.5, G))        # forward, and to the right
    poses = wo.run(t, f, w)
    roll, pitch = poses[:, 3] - HOME[3], poses[:, 4] - HOME[4]
    # forward acceleration pushes the occupant back: nose up = negative pitch;
    # a specific force to the right (-y) needs the right side down = negative roll
    want_pitch = -math.asin(p.tilt_scale * 2.0 / G)
    want_roll = math.asin(p.tilt_scale * -1.5 / (G * math.cos(want_pitch)))
    assert pitch[-1] == pytest.approx(want_pitch, abs=1e-4)
    assert roll[-1] == pytest.approx(want_roll, abs=1e-4)
    # the rotation path sees no angular rate, so the tilt is all there is:
    # its rate never exceeds the limit
    rate = np.abs(np.diff(np.stack([roll, pitch], axis=1), axis=0)) / wo.dt
    assert rate.max() <= p.tilt_rate_max * (1 + 1e-9)
    assert rate.max() >= 0.99 * p.tilt_rate_max       # and the limit is what shapes it
    # gravity tilt reproduces the sustained specific force on the platform
    fp = cu.platform_specific_force(poses, wo.dt, G)
    assert fp[-1, 0] == pytest.approx(p.tilt_scale * 2.0, rel=1e-3)
    assert fp[-1, 1] == pytest.approx(p.tilt_scale * -1.5, rel=1e-3)


def test_translation_returns_home_after_an_acceleration_step():
    t, f, w = constant(40000, f=(3.0, -2.0, G + 1.0))
    params = cu.with_params(tilt_scale=0.0)            # translation only
    poses = cu.Washout(params).run(t, f, w)
    cue = poses[:, :3] - HOME[:3]
    k = int(0.5 / 0.001)
    assert cue[k, 0] > 0.01 and cue[k, 1] < -0.01 and cue[k, 2] > 0.005   # onset cue, right sign
    assert np.abs(cue[-1]).max() < 1e-4                                   # washed out
    assert np.abs(poses[-1, 3:] - HOME[3:]).max() < 1e-12


def test_rotation_returns_home_after_a_rate_step():
    t, f, w = constant(30000, w=(0.2, -0.1, 0.3))
    params = cu.with_params(tilt_scale=0.0)
    poses = cu.Washout(params).run(t, f, w)
    att = poses[:, 3:] - HOME[3:]
    k = int(0.3 / 0.001)
    assert att[k, 0] > 0 and att[k, 1] < 0 and att[k, 2] > 0
    assert np.abs(att[-1]).max() < 1e-5


def test_translation_filter_matches_its_continuous_step_response():
    """Acceleration step a on x (zeta = 1): X(s) = k a / ((s + w)^2 (s + wb)),
    whose inverse transform is k a (e^(-wb t) - e^(-w t)) / (w - wb)^2
    + k a t e^(-w t) / (wb - w). The ZOH discretisation is exact for a held
    step, so the samples match to rounding."""
    p = cu.WashoutParams()
    k, w, wb = p.translation_scale[0], p.translation_omega[0], p.translation_washout[0]
    a = 1.0
    t, f, wr = constant(5000, f=(a, 0.0, G))
    x = cu.Washout(cu.with_params(tilt_scale=0.0)).run(t, f, wr)[:, 0]
    tt = t + 0.001   # sample k has seen k + 1 periods of the held input
    ref = k * a * ((np.exp(-wb * tt) - np.exp(-w * tt)) / (w - wb) ** 2
                   + tt * np.exp(-w * tt) / (wb - w))
    assert np.abs(x - HOME[0] - ref).max() < 1e-9


def test_step_equals_run():
    t, f, w = cu.synthetic_drive(duration=4.0, severity=1.5)
    a = cu.Washout().run(t, f, w)
    wo = cu.Washout()
    b = np.array([wo.step(fi, wi) for fi, wi in zip(f, w)])
    assert np.array_equal(a, b)


def test_clip_is_the_last_resort_and_counted():
    params = cu.with_params(translation_scale=(3.0, 3.0, 3.0))
    t, f, w = cu.synthetic_drive(duration=20.0, severity=2.0)
    wo = cu.Washout(params)
    poses = wo.run(t, f, w)
    assert wo.clipped[0] > 0
    cue = poses - HOME
    assert (cue >= params.margin * LO - 1e-12).all() and (cue <= params.margin * HI + 1e-12).all()


def test_figures():
    t, f, w = cu.synthetic_drive()
    wo = cu.Washout()
    poses = wo.run(t, f, w)
    fig = cu.figures(wo, t, f, w, poses)
    sh = fig["specific_force_share"]
    assert 0.1 < sh["x"] < 1 and 0.1 < sh["y"] < 1
    assert 0.1 < fig["specific_force_share_xy"] < 1
    cue = poses - HOME
    assert fig["workspace_use"]["x"] == pytest.approx(max(cue[:, 0].max() / HI[0], cue[:, 0].min() / LO[0]))
    assert all(0 <= u <= 1 for u in fig["workspace_use"].values())
    assert 0 < fig["leg_stroke_use"] < 1
    # a platform that does nothing reproduces nothing; an ideal one everything
    still = cu.figures(wo, t, f, w, np.tile(HOME, (len(t), 1)))
    assert abs(still["specific_force_share"]["x"]) < 1e-9
    assert still["specific_force_fidelity"]["x"] == pytest.approx(0.0, abs=1e-9)


def test_bad_parameters_and_inputs_are_refused():
    with pytest.raises(ValueError, match="tilt_max"):
        cu.Washout(cu.with_params(tilt_max=2.0))
    with pytest.raises(ValueError, match="dt"):
        cu.Washout(dt=0.0)
    with pytest.raises(ValueError, match="finite"):
        cu.Washout().step([math.nan, 0, G], [0, 0, 0])
    with pytest.raises(ValueError, match="apart"):
        cu.Washout().run([0.0, 0.002], np.zeros((2, 3)), np.zeros((2, 3)))


def test_cli_cueing(tmp_path, capsys):
    tel, out, png, js = (tmp_path / n for n in ("drive.csv", "poses.csv", "drive.png", "fig.json"))
    rc = cli.main(["cueing", "--synthetic", "--duration", "20", "--in", str(tel), "--out", str(out),
                   "--plot", str(png), "--figures", str(js)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "specific force reproduced below 1 Hz" in text and "workspace use" in text
    rows = out.read_text().splitlines()
    assert rows[0] == "t,x,y,z,roll,pitch,yaw" and len(rows) == 20001 + 1
    first = [float(v) for v in rows[1].split(",")]
    assert first == pytest.approx([0.0] + list(HOME))
    assert png.stat().st_size > 10000
    assert json.loads(js.read_text())["clipped"]["x"] == 0
    # the same telemetry at 100 Hz is resampled to 1 kHz
    t, f, w = cu.read_telemetry(tel)
    cu.write_telemetry(tmp_path / "slow.csv", t[::10], f[::10], w[::10])
    assert cli.main(["cueing", "--in", str(tmp_path / "slow.csv"), "--out", str(out)]) == 0
    assert len(out.read_text().splitlines()) == 20001 + 1


@pytest.mark.parametrize("content, message", [
    ("t,fx,fy\n0,1,2\n", "header lacks column"),
    ("t,fx,fy,fz,wx,wy,wz\n0,0,0,9.8,0,0,0\n0.001,x,0,9.8,0,0,0\n", "line 3"),
    ("t,fx,fy,fz,wx,wy,wz\n0,0,0,9.8,0,0,0\n0,0,0,9.8,0,0,0\n", "does not increase"),
    ("", "empty"),
])
def test_cli_cueing_bad_telemetry(tmp_path, capsys, content, message):
    tel = tmp_path / "bad.csv"
    tel.write_text(content)
    rc = cli.main(["cueing", "--in", str(tel), "--out", str(tmp_path / "p.csv")])
    assert rc == 2
    assert message in capsys.readouterr().err
