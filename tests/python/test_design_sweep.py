# SPDX-License-Identifier: Apache-2.0
"""``stewart design --sweep``: candidates ranked by the duty's margins on
local processes and on a Dask LocalCluster, with the same results."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from stewart import cli
from stewart import config as cfg
from stewart.design import duty as duty_mod
from stewart.design import sweep

REPO_ROOT = Path(__file__).resolve().parents[2]
CONFIG = REPO_ROOT / "config" / "platform_default.json"
DUTY = {"payload": {"mass_max": 300},
        "envelope": {"excursion_min": [-0.1, -0.1, -0.08, -0.05, -0.05, -0.1],
                     "excursion_max": [0.1, 0.1, 0.08, 0.05, 0.05, 0.1],
                     "velocity": [0.1] * 6, "acceleration": [1.0] * 6},
        "requirements": {"bandwidth_hz": 2.0}}
SPEC = {"base_radius": [1.5, 1.7, 2], "bore": [0.09, 0.11, 2], "home_height": 2.55}


def test_pattern_rebuilds_the_default_platform():
    p = cfg.load(CONFIG)
    base, plat = sweep.joints(sweep.of_platform(p), 0.0, -0.25)
    assert np.allclose(base, p.base_joints, atol=1e-6)
    assert np.allclose(plat, p.platform_joints, atol=1e-6)


def test_sweep_local_and_on_a_local_cluster(tmp_path):
    distributed = pytest.importorskip("distributed")
    (tmp_path / "duty.json").write_text(json.dumps(DUTY))
    (tmp_path / "spec.json").write_text(json.dumps(SPEC))
    args = ["design", str(CONFIG), "--duty", str(tmp_path / "duty.json"), "--sweep", str(tmp_path / "spec.json")]
    assert cli.main(args + ["--out", str(tmp_path / "local"), "--workers", "2"]) in (0, 1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        assert cli.main(args + ["--out", str(tmp_path / "dask"), "--scheduler", cluster.scheduler_address]) in (0, 1)
    local = list(csv.DictReader(open(tmp_path / "local" / "sweep.csv")))
    dask = list(csv.DictReader(open(tmp_path / "dask" / "sweep.csv")))
    assert len(local) == 4 and local == dask
    scores = [float(r["score"]) for r in local if r["failed"] == "0"]
    assert scores == sorted(scores, reverse=True)
    # A candidate's row is the analysis of that geometry.
    best = local[0]
    p = cfg.load(CONFIG)
    d = duty_mod.from_dict(DUTY)
    row = sweep.evaluate(p, d, {k: float(best[k]) for k in sweep.PARAMS}, 2)
    assert float(best["score"]) == pytest.approx(row["score"], rel=1e-5)


def test_candidate_outside_the_stroke_is_ranked_last(tmp_path):
    p = cfg.load(CONFIG)
    d = duty_mod.from_dict(DUTY)
    good = sweep.of_platform(p)
    bad = dict(good, home_height=3.5)
    rows = sweep.rank(sweep.run_local(p, d, [bad, good], 2, workers=1))
    assert rows[-1]["home_height"] == 3.5 and rows[-1]["failed"] == -1
    assert "stroke" in rows[-1]["limit"]


def test_sweep_spec_unknown_key(tmp_path, capsys):
    (tmp_path / "duty.json").write_text(json.dumps(DUTY))
    (tmp_path / "spec.json").write_text(json.dumps({"base_radus": 1.5}))
    assert cli.main(["design", str(CONFIG), "--duty", str(tmp_path / "duty.json"), "--sweep",
                     str(tmp_path / "spec.json"), "--out", str(tmp_path / "o")]) == 2
    assert "base_radus: unknown key" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
