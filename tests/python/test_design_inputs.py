# SPDX-License-Identifier: Apache-2.0
"""``stewart design`` on bad input: refused naming the key, row or pose,
with nothing written; a trajectory beyond the strokes reported by row."""

import json
from pathlib import Path

import numpy as np
import pytest

from stewart import cli
from stewart import config as cfg

REPO_ROOT = Path(__file__).resolve().parents[2]
CONFIG = REPO_ROOT / "config" / "platform_default.json"
QUICK = {"workspace": {"position_step": 0.15, "angle_step": 0.15, "envelope_points": 2}}


def run(tmp_path, duty: dict, config=CONFIG):
    (tmp_path / "duty.json").write_text(json.dumps(duty))
    out = tmp_path / "out"
    status = cli.main(["design", str(config), "--duty", str(tmp_path / "duty.json"), "--out", str(out)])
    return status, out


@pytest.mark.parametrize("duty, message", [
    ({"payload": {"mas_max": 10}}, "payload.mas_max: unknown key"),
    ({"paylod": {}}, "paylod: unknown key"),
    ({"envelope": {"combined": {"speed": 1}}}, "envelope.combined.speed: unknown key"),
    ({"payload": {"mass_min": -5}}, "payload.mass_min: -5 is below 0"),
    ({"payload": {"mass_min": 200, "mass_max": 100}}, "payload.mass_min: 200 is above mass_max 100"),
    ({"envelope": {"excursion_min": [0, 0, 0.1, 0, 0, 0], "excursion_max": [0] * 6}},
     "envelope.excursion_min[2]: 0.1 is above excursion_max[2] 0"),
    ({"envelope": {"velocity": [0.1] * 5}}, "envelope.velocity: expected a list of 6 numbers"),
    ({"trajectories": ["missing.csv"]}, "missing.csv: cannot read"),
])
def test_bad_duty_is_refused_by_name(tmp_path, capsys, duty, message):
    status, out = run(tmp_path, duty)
    assert status == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_bad_trajectory_row_is_named(tmp_path, capsys):
    (tmp_path / "t.csv").write_text("t,x,y,z,roll,pitch,yaw\n0,0,0,2.55,0,0,0\n0.1,0,0,2.55,0,0,0\n"
                                    "0.2,0,zero,2.55,0,0,0\n")
    status, out = run(tmp_path, dict(QUICK, trajectories=["t.csv"]))
    assert status == 2
    assert "row 4: y is not a finite number" in capsys.readouterr().err
    assert not out.exists()


def test_trajectory_beyond_the_strokes_fails_naming_the_row(tmp_path, capsys):
    t = np.arange(0, 1.0, 0.01)
    z = 2.55 + 0.9 * t  # leaves the upper end stop on the way
    rows = "\n".join(f"{a:.2f},0,0,{b:.4f},0,0,0" for a, b in zip(t, z))
    (tmp_path / "t.csv").write_text("t,x,y,z,roll,pitch,yaw\n" + rows + "\n")
    status, out = run(tmp_path, dict(QUICK, trajectories=["t.csv"]))
    text = capsys.readouterr().out
    assert status == 1
    line = next(x for x in text.splitlines() if "t.csv inside the workspace" in x)
    assert line.startswith("FAIL") and "stroke (leg_length_max" in line and "at row 101" in line
    r = json.loads((out / "report.json").read_text())
    assert not next(v for v in r["verdict"] if "t.csv inside" in v["requirement"])["pass"]


@pytest.mark.parametrize("drop, message", [
    ("joints", "joints.base_cone_max: missing"),
    ("cylinder_outer_diameter", "hydraulic.cylinder_outer_diameter: missing"),
    ("hydraulic", "hydraulic.piston_diameter: missing"),
])
def test_config_without_a_needed_key(tmp_path, capsys, drop, message):
    d = json.loads(CONFIG.read_text())
    if drop == "cylinder_outer_diameter":
        del d["hydraulic"][drop]
    else:
        del d[drop]
    (tmp_path / "c.json").write_text(json.dumps(d))
    status, out = run(tmp_path, QUICK, tmp_path / "c.json")
    assert status == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["joints"].update(base_cone=0.5), "joints.base_cone: unknown key"),
    (lambda d: d["joints"].update(platform_cone_max=2.0), "joints.platform_cone_max: 2 is above"),
    (lambda d: d["hydraulic"].update(cylinder_outer_diameter=0.09),
     "hydraulic.cylinder_outer_diameter: must exceed piston_diameter"),
])
def test_new_config_keys_are_validated(edit, message):
    d = json.loads(CONFIG.read_text())
    edit(d)
    with pytest.raises(cfg.ConfigError, match=message):
        cfg.from_dict(d)


def test_the_example_duty_and_sweep_are_valid():
    from stewart.design import duty as duty_mod
    from stewart.design import sweep

    d = duty_mod.load(REPO_ROOT / "config" / "duty_example.json")
    assert d.mass_max == 600 and len(d.trajectories) == 1 and d.trajectories[0].t.size == 201
    assert len(sweep.read_spec(REPO_ROOT / "config" / "sweep_example.json", cfg.load(CONFIG))) == 720
