# SPDX-License-Identifier: Apache-2.0
"""``stewart calc`` and ``stewart fk`` over CSV files: the fixed-point core
behind a command line, with bad rows reported in place."""

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from stewart import cli, model
from stewart import config as cfg

REPO_ROOT = Path(__file__).resolve().parents[2]

CONFIG = str(REPO_ROOT / "config" / "platform_default.json")


def write(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def platform():
    return cfg.load(CONFIG)


def test_calc_columns_any_order_missing_are_zero(tmp_path, platform):
    home = platform.home
    src = tmp_path / "in.csv"
    # columns in another order, most omitted (zero), plus an extra column kept as is
    write(src, ["note", "z", "x", "ax"], [["a", home[2], 0.05, 1.5], ["b", home[2] + 0.1, -0.05, 0.0]])
    out = tmp_path / "out.csv"
    assert cli.main(["calc", "--config", CONFIG, "--input", str(src), "--output", str(out)]) == 0
    rows = read(out)
    assert [r["note"] for r in rows] == ["a", "b"]
    for r, (z, x, ax) in zip(rows, [(home[2], 0.05, 1.5), (home[2] + 0.1, -0.05, 0.0)]):
        assert r["status"] == "ok"
        pose = np.array([x, 0, z, 0, 0, 0], dtype=float)
        ik = model.inverse_kinematics(platform, pose)
        f = model.inverse_dynamics(platform, pose, [0, 0, 0], [0, 0, 0], [ax, 0, 0], [0, 0, 0])
        for i in range(6):
            assert abs(float(r[f"l{i + 1}"]) - ik.lengths[i]) < 1e-6
            assert abs(float(r[f"F{i + 1}"]) - f[i]) < 0.05
        assert float(r["y"]) == 0.0  # missing column written as zero


def test_calc_bad_rows_get_a_status_and_the_rest_runs(tmp_path, platform):
    home = platform.home
    src = tmp_path / "in.csv"
    write(src, ["x", "z"], [
        [0.0, home[2]],          # fine
        ["abc", home[2]],        # not a number
        [0.0, "nan"],            # not finite
        [0.0, home[2] + 2.0],    # 2 m up: legs beyond their stroke
        [0.0, home[2]],          # fine again
    ])
    out = tmp_path / "out.csv"
    assert cli.main(["calc", "--config", CONFIG, "--input", str(src), "--output", str(out)]) == 1
    st = [r["status"] for r in read(out)]
    assert st[0] == "ok" and st[4] == "ok"
    assert st[1].startswith("bad-input") and st[2].startswith("bad-input")
    assert st[3] == "out-of-range"


def test_calc_bad_config_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    src = tmp_path / "in.csv"
    write(src, ["x"], [[0]])
    rc = cli.main(["calc", "--config", str(bad), "--input", str(src), "--output", str(tmp_path / "o.csv")])
    assert rc == 2
    assert "bad.json" in capsys.readouterr().err


def test_fk_recovers_poses_warm_and_cold(tmp_path, platform):
    rng = np.random.default_rng(3)
    home = np.array(platform.home, dtype=float)
    # a smooth path: successive rows one 1 kHz tick apart, warm-started
    t = np.arange(0, 0.5, 0.001)
    poses = [home + np.array([0.09 * math.sin(math.pi * s), 0, 0, 0, 0, 0.09 * math.sin(math.pi * s)]) for s in t]
    rows = [list(model.inverse_kinematics(platform, p).lengths) for p in poses]
    src = tmp_path / "legs.csv"
    write(src, [f"l{i}" for i in range(1, 7)], rows)
    out = tmp_path / "pose.csv"
    assert cli.main(["fk", "--config", CONFIG, "--input", str(src), "--output", str(out)]) == 0
    res = read(out)
    for r, p in zip(res, poses):
        assert r["status"] == "ok"
        got = [float(r[c]) for c in ("x", "y", "z", "roll", "pitch", "yaw")]
        assert max(abs(a - b) for a, b in zip(got[:3], p[:3])) < 1e-6
        assert max(abs(a - b) for a, b in zip(got[3:], p[3:])) < 5e-6
        assert int(r["iterations"]) <= 3
    # random far poses, each solved cold from home
    far = [home + rng.uniform([-0.2, -0.2, -0.15, -0.26, -0.26, -0.26], [0.2, 0.2, 0.15, 0.26, 0.26, 0.26])
           for _ in range(50)]
    write(src, [f"l{i}" for i in range(1, 7)], [list(model.inverse_kinematics(platform, p).lengths) for p in far])
    assert cli.main(["fk", "--config", CONFIG, "--input", str(src), "--output", str(out), "--cold"]) == 0
    for r, p in zip(read(out), far):
        got = [float(r[c]) for c in ("x", "y", "z", "roll", "pitch", "yaw")]
        assert max(abs(a - b) for a, b in zip(got, p)) < 5e-6


def test_fk_bad_rows(tmp_path, platform):
    home = np.array(platform.home, dtype=float)
    good = list(model.inverse_kinematics(platform, home).lengths)
    src = tmp_path / "legs.csv"
    write(src, [f"l{i}" for i in range(1, 7)], [good, good[:5] + ["x"], [v + 1.0 for v in good[:1]] + good[1:], good])
    out = tmp_path / "pose.csv"
    assert cli.main(["fk", "--config", CONFIG, "--input", str(src), "--output", str(out)]) == 1
    st = [r["status"] for r in read(out)]
    assert st[0] == "ok" and st[3] == "ok"
    assert st[1].startswith("bad-input")
    assert st[2] in ("no-convergence", "discontinuity", "singular", "out-of-range")
